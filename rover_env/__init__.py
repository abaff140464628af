"""LunarSim for behaviour research: a PettingZoo environment over the in-process lockstep world."""
