"""Who gives way when the world shares a machine's cores with the processes it serves.

In real time the world's clock is the simulation: a tick that goes out late reaches every rover late, and
the next tick starts late too. On hardware each agent has its own flight computer; co-hosted, a hundred agents
woken by one tick's samples all want the cores at once, and the kernel's fair scheduler lets them take turns
with the world while it is still publishing that tick. Measured with 100 rover processes on 2 cores, the
world's main thread waited a median 13 ms a tick for a core (11 ms with the agents at nice 10), and 158-691
sampled sensor samples of a 30 s window went out more than a period behind the world's schedule. Lowered below
the world, the agents run on what it leaves, and an agent that falls behind shows it as its own lag, as a slow
flight computer would.

Lowered to nice 19 under ``SCHED_BATCH`` (``low``), not to the idle class: the kernel still runs the world first
(a nice-19 task weighs 15 against its 1,024) but never leaves the agents nothing. In the idle class, 1,000 agents
sharing four processes fell seconds behind in three 40 s windows of four (lag p99 1.98-3.37 s), the world then
taking more of a core (0.81-0.88 against 0.68); at ``low`` they kept up in three of three (0.58-0.87 s), the
world's samples going out as late as with the idle class. With 100 rover processes the world's samples went out
a median 3.8 ms behind its schedule at ``low`` and 3.0 ms in the idle class (p99 14.8 and 11.6 ms), none more
than a period behind either way.

In lockstep the world waits for the agents' acks, so it gains nothing by going first: there they keep the
world's priority (idle agents made the crater mission 11 % slower).

A few agents take little from the world, and lowered they would also give way to whatever else the machine runs
(a build, another simulation): beside two CPU-bound processes an idle-class agent, or the camera, gets almost no
CPU at all, and a mission waits on photos and moves that never come. So ``auto`` lowers them only in a crowd
(``CROWD`` agents or more), where the measurements above hold, and the camera with them.

Only lowering: it needs no privilege. Threads inherit their creator's policy, so lowering a process's first
thread before it opens its Zenoh session lowers Zenoh's threads as well.
"""

from __future__ import annotations

import os
from typing import Literal

Priority = Literal["equal", "low", "idle"]
CHOICES = ("auto", "equal", "low", "idle")
HELP = ("CPU priority of the agents against the world on this machine: 'low' at nice 19 without preempting it "
        "(SCHED_BATCH), 'idle' only on what the world leaves (the kernel's SCHED_IDLE), 'equal' as the kernel "
        "shares by default; 'auto' (default): low in real time with 20 or more rovers, else equal")
LOWEST_NICE = 19


CROWD = 20
"""Co-hosted rovers from which ``auto`` lowers the agents of a real-time world (the module's docstring says why)."""


def for_mode(choice: str, lockstep: bool, rovers: int = CROWD) -> Priority:
    """``auto`` resolved: a crowd of agents yields to a real-time world; a few agents, and any in lockstep, keep
    its priority."""
    if choice not in CHOICES:
        raise ValueError(f"unknown priority {choice!r}: expected one of {', '.join(CHOICES)}")
    if choice == "auto":
        return "low" if not lockstep and rovers >= CROWD else "equal"
    return choice  # type: ignore[return-value]


def for_camera(lockstep: bool, rovers: int) -> Priority:
    """The world's camera process: out of the world's way when a crowd keeps it rendering in real time, as
    ``auto`` lowers the agents, and never ``idle`` whatever the agents are given, so other work on the machine
    cannot starve it of the photos a mission waits for."""
    return for_mode("auto", lockstep, rovers)


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

