"""The world service: the one process that knows ground truth (terrain, poses, obstacles, radio).

Its shape: a pure core that does no I/O (``sim.World``, a coordinator over its parts, and ``twin.world.TwinWorld``,
both ``served.ServedWorld``), the Zenoh loop that drives it (``service``, with ``lockstep``'s schedule and
``presence``'s view of the agents), and the command (``commands.world``). The parts are subpackages, each owning
its state: ``actuation``, ``radio``, ``sensors``, ``camera``, ``power``, ``outcome`` and ``terrain``; ``clock``,
``scene`` and ``geometry`` are what they share.
"""
