"""What several LunarSim processes share that is not the wire contract: pure code, light (no NumPy), carried by the
flight wheel with the rover agent.

- ``pose``: a pose in the lander's or the map's frame, and where an action done from it ends;
- ``hit``: one perceived thing, as a rover's behaviour and a hardware driver see it;
- ``mission``: each rover's list of goals and how ground commands change it (the lander's plan, the world's judge);
- ``lockstep``: an agent's answer to a lockstep tick;
- ``png``: the PNG codec of the photos and the traverse map.
"""
