"""The rover agent: one rover's process. Light (no NumPy, no world service): it runs on the rover's flight computer.

- ``agent``: ``RoverAgent``, the coordinator: one handler a topic, over parts that each own their state;
  ``runtime`` is its Zenoh loop, ``commands.rover`` its command (``lunarsim rover``, ``python -m rover_agent``).
- ``decisions``: what a behaviour sees and may decide (``BaseBehaviour``, the one class to subclass);
  ``behaviour``: the default behaviour; ``examples``: short ones; ``registry``: behaviours found by name.
- ``actions/``: the action in flight; ``estimation/``: where the rover thinks it is; ``mission/``: its goals and
  what it tells the lander; ``restarts/``: what survives a restart; ``rules/``: the default behaviour's rules.
"""

from __future__ import annotations

__all__ = ["BaseBehaviour", "Decision", "Finish", "Goal", "Hold", "MoveTo", "Rotate", "TakePhoto", "View"]
"""What a behaviour is written against (``rover_agent.decisions``): ``from rover_agent import BaseBehaviour,
MoveTo``."""


def __getattr__(name: str) -> object:
    """Loaded on first use, so a command's ``--help`` and a flight computer's start read no more than they need."""
    if name in __all__:
        from rover_agent import decisions

        return getattr(decisions, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
