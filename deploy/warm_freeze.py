"""Imported last by the warm fork server (``deploy.warm_start``), once the agents' code is loaded: the only way
to run code in the standard library's fork server before it forks.

It takes the loaded modules out of the garbage collector's scans before the agents are forked from them, so
neither the agents' collections nor their own start-up freeze (``process.freeze_start_up_heap``) write to those
pages: they stay shared between the server and every agent instead of being copied into each."""

from __future__ import annotations

import gc

gc.collect()
gc.freeze()
