"""The rover's part of the mission and what it tells the lander of it: its goals (``goals``), a relay's spot
(``relay``), the search for the lander's word (``contact``), its station at a shared goal (``stations``), its
photos (``photos``) and its share of the traverse map (``traverse_map``)."""
