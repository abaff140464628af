"""``--quick`` for the benchmarks: the same code path end to end at small sizes, in seconds, so a test can run every
benchmark on every change (``tests/e2e/test_benchmarks.py``) and none of them rots between the runs that measure."""

from __future__ import annotations

import argparse
from collections.abc import Sequence


def parse_args(parser: argparse.ArgumentParser, quick: dict[str, object],
               argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Parse with a ``--quick`` flag whose sizes (``quick``, by argument name) replace the full defaults; a size
    given on the command line wins over both."""
    shown = ", ".join(f"--{key.replace('_', '-')} {_shown(value)}" for key, value in quick.items())
    parser.add_argument("--quick", action="store_true", help=f"a smoke check in seconds, the same path at small "
                        f"sizes: {shown}")
    first, _ = parser.parse_known_args(argv)
    if first.quick:
        parser.set_defaults(**quick)
    return parser.parse_args(argv)


def _shown(value: object) -> str:
    if isinstance(value, list | tuple):
        return " ".join(map(str, value))
    if isinstance(value, range):
        return f"{value.start}-{value.stop - 1}"
    return str(value)
