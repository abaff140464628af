"""Where the rover thinks it is, without ground truth: the filter over its pose (``pose_filter``), what perception
shows of the lander, of teammates and of a crater goal's rim (``sightings``), the way by the lander that fixes a
drifted estimate (``lander_fix``), the search for a fix at an unsure goal (``fix_search``), the look back at a
crater's rim on leaving it (``rim_look``), and the agent's part that feeds them all (``estimator``). How an action
moves a pose, dead reckoning, is ``shared.pose``: part of what every behaviour sees."""
