"""The Zenoh plumbing every LunarSim process shares: config layering, the Bus, process main and exit codes,
the world's clock as agents watch it, and CPU priorities. Depends only on ``schemas``."""
