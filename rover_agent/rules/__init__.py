"""The default behaviour's rules (``rover_agent.behaviour`` walks and asks them): at a crater (``crater``, ``rim``),
among rovers (``crowd``, ``crossing``), in sunlight (``sunlight``); where its body can go from one scan
(``free_space``), its map of what it has seen (``occupancy``) and the routes planned on it (``planner``); the
thresholds they share (``tuning``) and what the rules ask of the walking (``walking``)."""
