"""How the mission is judged: the world's part that keeps the agents' statuses and calls stalls and the end
(``referee``), when a rover has stopped making progress (``progress``), when the mission is over (``completion``),
the mission's statistics (``statistics``), and the lander's map scored against ground truth (``map_truth``)."""
