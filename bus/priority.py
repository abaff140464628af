"""Who gives way when the world shares a machine's cores with the processes it serves.

In real time the world's clock is the simulation: a tick that goes out late reaches every rover late, and
the next tick starts late too. On hardware each agent has its own flight computer; co-hosted, a hundred agents
woken by one tick's samples all want the cores at once, and the kernel's fair scheduler lets them take turns
with the world while it is still publishing that tick. Measured with 100 rover processes on 2 cores, the
world's main thread waited a median 13 ms a tick for a core (11 ms with the agents at nice 10), and 158-691
sampled sensor samples of a 30 s window went out more than a period behind the world's schedule. With the
agents in the idle class it waited 2 ms and 0-10 samples did (0-92 on a busier day): the agents run on what the
world leaves, and an agent that falls behind shows it as its own lag, as a slow flight computer would.

In lockstep the world waits for the agents' acks, so it gains nothing by going first: there they keep the
world's priority (idle agents made the crater mission 11 % slower).

A few agents take little from the world, and lowered they would also give way to whatever else the machine runs
(a build, another simulation): beside two CPU-bound processes an idle-class agent, or the camera, gets almost no
CPU at all, and a mission waits on photos and moves that never come. So ``auto`` lowers them only in a crowd
(``CROWD`` agents or more), where the measurement above holds, and the camera then runs ``low`` rather than
``idle``: slowly, but never starved.

Only lowering: it needs no privilege. Threads inherit their creator's policy, so lowering a process's first
thread before it opens its Zenoh session lowers Zenoh's threads as well.
"""

from __future__ import annotations

import os
from typing import Literal

Priority = Literal["equal", "low", "idle"]
CHOICES = ("auto", "equal", "low", "idle")
HELP = ("CPU priority of the agents against the world on this machine: 'idle' runs them on what the world leaves "
        "(the kernel's SCHED_IDLE), 'low' at nice 19 without preempting it (SCHED_BATCH), 'equal' as the kernel "
        "shares by default; 'auto' (default): idle in real time with 20 or more rovers, else equal")
LOWEST_NICE = 19


CROWD = 20
"""Co-hosted rovers from which ``auto`` lowers the agents of a real-time world (the module's docstring says why)."""


def for_mode(choice: str, lockstep: bool, rovers: int = CROWD) -> Priority:
    """``auto`` resolved: a crowd of agents yields to a real-time world; a few agents, and any in lockstep, keep
    its priority."""
    if choice not in CHOICES:
        raise ValueError(f"unknown priority {choice!r}: expected one of {', '.join(CHOICES)}")
    if choice == "auto":
        return "idle" if not lockstep and rovers >= CROWD else "equal"
    return choice  # type: ignore[return-value]


def for_camera(lockstep: bool, rovers: int) -> Priority:
    """The world's camera process: out of the world's way when a crowd keeps it rendering in real time, but
    ``low``, not ``idle``, so other work on the machine cannot starve it of the photos a mission waits for."""
    return "low" if for_mode("auto", lockstep, rovers) == "idle" else "equal"


def lower(priority: Priority) -> bool:
    """Lower the calling thread, and every thread it starts from now on, to ``priority``; False where it could
    not (no scheduling policies, as off Linux, or a sandbox that forbids the call): it then runs as it was, which
    costs the world's schedule, not the run."""
    if priority == "equal":
        return True
    try:
        if priority == "idle":
            os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
        else:
            os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
            os.setpriority(os.PRIO_PROCESS, 0, LOWEST_NICE)  # on Linux: this thread, inherited by its new ones
    except (AttributeError, OSError):
        return False
    return True

