"""What /proc says of a benchmark's processes: ``ProcessMeter`` reads user+system CPU time (with that of waited-for
children) from /proc/<pid>/stat and Rss/Pss from /proc/<pid>/smaps_rollup, for a process and its descendants."""

from __future__ import annotations

import contextlib
import os
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

CLK_TCK = os.sysconf("SC_CLK_TCK")


def proc_stat(pid: int) -> tuple[str, list[str]]:
    """A process's name and the fields after it in /proc/<pid>/stat (the name may hold spaces): ``fields[1]`` is
    the parent's pid, ``fields[11:15]`` utime, stime, cutime and cstime, ``fields[19]`` the start time in clock ticks
    since boot (fields 4, 14-17 and 22 of stat(5))."""
    stat = Path(f"/proc/{pid}/stat").read_text()
    return stat[stat.index("(") + 1:stat.rindex(")")], stat[stat.rindex(")") + 2:].split()


def stat_cpu_seconds(fields: list[str]) -> float:
    """User + system CPU time from ``proc_stat``'s fields (the process's threads included)."""
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far (its threads included)."""
    return stat_cpu_seconds(proc_stat(pid)[1])


def cpu_and_parent(pid: int) -> tuple[float, int]:
    """CPU seconds of a process and of its children it has waited for (cutime, cstime), and its parent's pid."""
    fields = proc_stat(pid)[1]
    return sum(int(f) for f in fields[11:15]) / CLK_TCK, int(fields[1])


def with_descendants(pid: int) -> list[int]:
    """``pid`` and every process under it (the world's camera process renders photos: its CPU is the world's)."""
    pids, i = [pid], 0
    while i < len(pids):
        try:
            tasks = list(Path(f"/proc/{pids[i]}/task").iterdir())
        except OSError:
            tasks = []
        for task in tasks:
            try:
                pids += [int(c) for c in (task / "children").read_text().split()]
            except OSError:
                continue
        i += 1
    return pids


def memory_kib(pid: int) -> tuple[int, int]:
    """(Rss, Pss) in KiB: resident pages, and resident pages with shared ones split among their sharers."""
    values = {}
    for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
        name, _, rest = line.partition(":")
        if name in ("Rss", "Pss"):
            values[name] = int(rest.split()[0])
    return values["Rss"], values["Pss"]


def _memory_or_none(pid: int) -> tuple[int, int]:
    try:
        return memory_kib(pid)
    except OSError:  # ended since the groups were listed
        return 0, 0


def machine_cpu_seconds() -> tuple[float, float]:
    """(busy, stolen) CPU seconds of the whole machine so far, every core summed (/proc/stat, proc(5))."""
    with open("/proc/stat") as f:
        user, nice, system, _idle, _iowait, irq, softirq, steal = (int(v) for v in f.readline().split()[1:9])
    return (user + nice + system + irq + softirq) / CLK_TCK, steal / CLK_TCK


def every_process_cpu() -> dict[int, tuple[float, str]]:
    """CPU seconds and name of every process on the machine: what 'others' was, when it is large."""
    out = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            with contextlib.suppress(OSError, ValueError, IndexError):  # a process may end while we read
                name, fields = proc_stat(int(entry.name))
                out[int(entry.name)] = (stat_cpu_seconds(fields), name)
    return out


class Mark(NamedTuple):
    wall: float
    per_pid: dict[int, tuple[float, int]]  # pid -> (CPU with waited-for children, parent pid)
    machine: tuple[float, float]
    everyone: dict[int, tuple[float, str]]


@dataclass
class ProcessMeter:
    """CPU and memory of groups of processes (router, world, lander, rovers), between two ``mark`` calls, and the
    machine's whole CPU use over the same time: what is left is other work (other engineers' tests, the system)."""

    groups: dict[str, list[int]]
    _marks: list[Mark] = field(default_factory=list)

    def mark(self) -> None:
        per_pid = {}
        for pid in (pid for pids in self.groups.values() for pid in pids):
            with contextlib.suppress(OSError):  # a helper process (of the world's camera pool) may have ended
                per_pid[pid] = cpu_and_parent(pid)
        self._marks.append(Mark(time.monotonic(), per_pid, machine_cpu_seconds(), every_process_cpu()))

    def cpu(self) -> dict[str, float]:
        """CPU seconds each group used per wall second between the first and the last mark (1.0 = one core).

        A process that ended in between and was waited for by another of its group (the world's camera process,
        closed as the mission ends) counts through its parent's children's time, less what it had used by the
        first mark; one that ended otherwise counts for nothing (its CPU is left to 'others')."""
        a, b = self._marks[0], self._marks[-1]
        return {name: self._group_cpu(pids, a, b) / (b.wall - a.wall) for name, pids in self.groups.items()}

    @staticmethod
    def _group_cpu(pids: list[int], a: Mark, b: Mark) -> float:
        used = 0.0
        for p in pids:
            if p in a.per_pid and p in b.per_pid:
                used += b.per_pid[p][0] - a.per_pid[p][0]
            elif p in a.per_pid and a.per_pid[p][1] in b.per_pid and a.per_pid[p][1] in pids:
                used -= a.per_pid[p][0]  # its parent's children's time now holds its whole life
        return used

    def machine(self) -> dict[str, float]:
        """Busy and stolen (by the hypervisor) cores of the whole machine over the same time."""
        a, b = self._marks[0], self._marks[-1]
        wall = b.wall - a.wall
        return {"busy_cores": (b.machine[0] - a.machine[0]) / wall, "steal_cores": (b.machine[1] - a.machine[1]) / wall}

    def outsiders(self, limit: int = 5) -> dict[str, float]:
        """Cores used by processes in no group (this benchmark's own included), by name, the busiest first; a
        process started between the marks counts whole."""
        a, b = self._marks[0], self._marks[-1]
        ours = {p for pids in self.groups.values() for p in pids}
        by_name: dict[str, float] = defaultdict(float)
        for pid, (cpu, name) in b.everyone.items():
            if pid not in ours:
                by_name[name] += cpu - a.everyone.get(pid, (0.0, name))[0]
        wall = b.wall - a.wall
        return {name: round(cpu / wall, 3) for name, cpu in sorted(by_name.items(), key=lambda kv: -kv[1])[:limit]}

    def memory(self) -> dict[str, dict[str, float]]:
        out = {}
        for name, pids in self.groups.items():
            mem = [_memory_or_none(p) for p in pids]
            out[name] = {"rss_mib": sum(r for r, _ in mem) / 1024, "pss_mib": sum(p for _, p in mem) / 1024}
        return out
