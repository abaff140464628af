"""Where the rover thinks it is, without ground truth: the filter over its pose (``pose_filter``), what perception
shows of the lander and of teammates (``sightings``), the way by the lander that fixes a drifted estimate
(``lander_fix``), and the agent's part that feeds them all (``estimator``). How an action moves a pose, dead
reckoning, is ``shared.pose``: part of what every behaviour sees."""
