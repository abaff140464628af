"""Building what a rover flight computer installs."""
