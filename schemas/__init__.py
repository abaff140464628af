"""The contract between LunarSim processes: key expressions, message models, codec, scenarios.

Kept free of NumPy and other heavy imports so that a rover agent importing it starts fast.
"""
