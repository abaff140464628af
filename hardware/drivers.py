"""Which driver a URL names (``lunarsim bridge --driver``, ``lunarsim check-driver``): ``serial://PORT?...`` for the
reference serial driver, or ``package.module:Class?...`` for a user's. Apart from the driver contract
(``hardware.driver``) so that the contract does not import its own implementations."""

from __future__ import annotations

import importlib
from urllib.parse import parse_qsl, urlsplit

from hardware.driver import Driver
from hardware.serial_driver import SerialDriver
from schemas.errors import LunarSimError


class UnknownDriver(LunarSimError, ValueError):
    """A driver URL that names nothing usable; the message says what was wrong."""


def load_driver(url: str) -> Driver:
    """Build (and so connect) the driver a URL names: ``serial://PORT?...`` or ``package.module:Class?...``."""
    parts = urlsplit(url)
    params = dict(parse_qsl(parts.query, keep_blank_values=True))
    if parts.scheme == "serial":
        port = parts.path or parts.netloc
        if not port:
            raise UnknownDriver(f"driver URL {url!r} names no serial port (serial:///dev/ttyUSB0?baud=115200)")
        return SerialDriver.from_params({"port": port, **params})
    target = url.split("?", 1)[0]
    module_name, _, attr = target.partition(":")
    if not attr or "/" in module_name:
        raise UnknownDriver(f"unknown driver {url!r}: use serial:///dev/PORT?baud=115200 or package.module:Class")
    try:
        cls = getattr(importlib.import_module(module_name), attr)
    except (ImportError, AttributeError) as exc:
        raise UnknownDriver(f"driver {target!r} cannot be loaded: {exc}") from None
    if not (isinstance(cls, type) and issubclass(cls, Driver)):
        raise UnknownDriver(f"driver {target!r} is not a subclass of hardware.driver.Driver")
    factory = getattr(cls, "from_params", None)
    try:
        return factory(params) if factory is not None else cls(**params)
    except TypeError as exc:
        raise UnknownDriver(f"driver {target!r} does not take {sorted(params)}: {exc}") from None
