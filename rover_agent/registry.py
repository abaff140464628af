"""Finding a rover behaviour by name: built-ins, installed plugins, or ``package.module:Class``.

Installed packages register behaviours under the ``lunarsim.behaviours`` entry-point group, so a team's
own behaviour is selected by name without touching LunarSim.
"""

from __future__ import annotations

import importlib
import os
import sys
from typing import TYPE_CHECKING

from rover_agent.decisions import BaseBehaviour
from schemas.errors import LunarSimError

BUILT_IN = {
    "default": "rover_agent.behaviour:DefaultBehaviour",
    "straight": "rover_agent.examples:StraightLine",
    "sun_ignoring": "rover_agent.examples:SunIgnoring",
}
ENTRY_POINT_GROUP = "lunarsim.behaviours"

if TYPE_CHECKING:
    from importlib.metadata import EntryPoint


class UnknownBehaviour(LunarSimError, ValueError):
    """A behaviour name that resolves to nothing usable; the message lists what is known."""


def known_names() -> list[str]:
    return sorted(set(BUILT_IN) | set(_plugins()))


def load_behaviour(name: str) -> type[BaseBehaviour]:
    target = BUILT_IN.get(name)
    if target is None:
        plugins = _plugins()
        if name in plugins:
            return _check(name, plugins[name].load())
        target = name
    module_name, _, attr = target.partition(":")
    if not attr:
        raise UnknownBehaviour(f"unknown behaviour {name!r}: use one of {', '.join(known_names())} "
                               "or 'package.module:Class'")
    with_current_folder()
    try:
        return _check(name, getattr(importlib.import_module(module_name), attr))
    except (ImportError, AttributeError) as exc:
        raise UnknownBehaviour(f"behaviour {name!r} cannot be loaded: {exc}") from None


def _plugins() -> dict[str, EntryPoint]:
    """The installed behaviours by name. ``importlib.metadata`` (several MiB with the modules it pulls in) is
    imported here, when a name is not built in, not by every agent that runs a built-in behaviour."""
    from importlib.metadata import entry_points

    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def with_current_folder() -> None:
    """A team's behaviour module is found in the folder the command runs in, as ``python -m`` finds it; last on the
    path, so no folder there can hide an installed package (LunarSim's processes start with ``python -P``)."""
    if os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())


def _check(name: str, cls: object) -> type[BaseBehaviour]:
    if not (isinstance(cls, type) and issubclass(cls, BaseBehaviour)):
        raise UnknownBehaviour(f"behaviour {name!r} is not a subclass of rover_agent.behaviour.BaseBehaviour")
    return cls
