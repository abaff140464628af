"""The lander agent: holds the mission plan and tells each rover, over the radio, where to go.

Its shape is every process's: a pure core (``lander.Lander``, over the plan in ``mission``, the ``archive`` of photos
and the traverse map of ``mapping``), its Zenoh loop (``runtime``) and its command (``commands.lander``,
``lunarsim lander``, ``python -m lander_agent``).
"""
