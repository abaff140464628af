"""In-process wiring of the world, the lander and rover agents, with no router: the harness of the tests, the
behaviour checker and the behaviour benchmarks. It gives the same report as ``lunarsim run --lockstep``."""
