"""Sunlight, power and heat: where the sun is (``sun``), which panels it reaches (``shadows``), how batteries charge
and drain (``battery``), how rovers warm and cool (``thermal``), and the part the world steps with them all and
whose sensors it publishes (``energy``)."""
