"""The world service: the one process that knows ground truth (terrain, poses, obstacles, radio)."""
