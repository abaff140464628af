"""The scale benchmark's output: the table, delivery per topic, cost against rover count (the slope), targets.

Works on the JSON document ``scale.py`` builds (rows of plain dicts), so a saved ``--json`` file can be printed
again: ``python benchmarks/scale_report.py FILE``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from host import line as host_line

RTF_TOLERANCE = 0.005
"""The world paces itself to real time and never runs ahead, so a run that keeps up measures 1.000 give or take
the clock samples at the window's ends; a factor within this of 1.0 holds real time."""
AGENT_LAG_LIMIT_MS = 1000.0
"""A shared-process count holds real time only if the sampled agents also keep up: their status no later than
this (p99) after the world's tick it answers. Below the world's priority (``bus.priority``) agents that cannot
keep up no longer slow the world's clock, so its factor alone would call a run whose agents fall behind holding."""
LOCKSTEP_TARGET = 20.0
STARTUP_TARGET_S = 20.0
SATURATED = 0.9
"""Share of the machine's cores above which a run's CPU figures are capped by the machine, not by its needs."""

REFINE_STEP = 50
"""Then it narrows the gap between the count that held and the lowest that did not, to this many rovers."""
MIN_SHARED = 50
"""The shared series halves its last count until one holds real time, down to this."""


def print_report(doc: dict) -> None:
    rows = doc["rows"]
    print(f"\nScale benchmark, {doc['scenario']}: {doc['cpus']} CPUs, Python {doc['python']}, zenoh {doc['zenoh']}")
    if "host" in doc:
        print(host_line(doc["host"]))
    code = doc.get("code", {})
    if code:
        dirty = code["uncommitted_changes"]
        print(f"code: commit {code['commit']}" + (f", with uncommitted changes to {', '.join(dirty)}" if dirty else ""))
    print(f"load average (1, 5, 15 min) at start {_load(doc['load_at_start'])}, at end "
          f"{_load(doc.get('load_at_end', doc['load_at_start']))} (it counts this benchmark's own threads too); "
          "'others' below: CPU used outside the benchmark during each window (/proc/stat), other work's noise")
    routing = doc.get("settings", {}).get("routing", "process")
    if doc.get("settings", {}).get("two_hosts"):
        routing = "two_hosts"
    print({"two_hosts": "routing: two hosts (network namespaces of this machine, sharing its cores): the world and "
                        "the lander behind one router process, the rovers behind another joined to it ('router' "
                        "below: both)",
           "world": "routing: the world is the Zenoh router in every series (its routing CPU is in 'world')",
           "process": "routing: a Zenoh router process that every process joins ('router' below)",
           "auto": "routing: the world is the Zenoh router (as in lunarsim run; its routing CPU is in 'world'), "
                   "except in the shared-process real-time series: a router process there ('router' below)"}
          [routing])
    priorities = sorted({f"{r['mode']} {r['agent_priority']}" for r in rows if "agent_priority" in r})
    if priorities:
        print(f"the agents' CPU priority against the world (bus/priority.py): {', '.join(priorities)}; a shared "
              f"count holds real time if the world keeps pace and the sampled agents' lag p99 is at most "
              f"{AGENT_LAG_LIMIT_MS:g} ms")
    if rows:
        done = [r for r in rows if "sampled_rovers" in r]
        sampled = max(done, key=lambda r: r["rovers"])["sampled_rovers"] if done else None
        print("sensor delivery measured on up to 10 rovers spread over the ids"
              + (f" (at the largest count: {sampled})" if sampled else "")
              + "; latency = arrival minus the publisher's Zenoh timestamp; agent lag = world clock tick to the "
              "agent's status stamped with it")
        print_table(rows)
        print_repeats(rows)
        print_delivery(rows)
        print_schedule(rows)
    print_witness(rows)
    print_slopes(doc.get("slopes", []))
    for note in doc.get("notes", []):
        print(f"note: {note}")
    if "highest_shared_holding" in doc:
        h = doc["highest_shared_holding"]
        print(f"highest shared-process rover count holding real time: {h if h is not None else 'none measured'}")
    for t in doc.get("targets", []):
        verdict = "not measured" if t["pass"] is None else ("PASS" if t["pass"] else "FAIL")
        print(f"target: {t['target']}: {t['measured']}  {verdict}")


def _load(load: list[float]) -> str:
    return " ".join(f"{x:.2f}" for x in load)


HEADER = (f"{'mode':9}{'rovers':>7}{'procs':>6}{'RTF':>8}{'CPU/rover':>10}{'rovers':>8}{'world':>7}{'router':>7}"
          f"{'total':>7}{'RSS/rover':>10}{'PSS/rover':>10}{'RSS all':>9}{'lat p50':>8}{'p99':>7}{'>period':>8}"
          f"{'dropped':>8}{'clk miss':>9}{'lag p99':>8}{'start-up':>9}{'others':>7}")
UNITS = (f"{'':30}{'% core':>10}{'cores':>8}{'cores':>7}{'cores':>7}{'cores':>7}{'MiB':>10}{'MiB':>10}{'MiB':>9}"
         f"{'ms':>8}{'ms':>7}{'':25}{'ms':>8}{'s':>9}{'cores':>7}")


def print_repeats(rows: list[dict]) -> None:
    """Every run behind a lockstep row that is the median of several, in run order."""
    for r in rows:
        if len(r.get("repeats", [])) > 1:
            runs = ", ".join(f"{f:.2f}" if f is not None else "failed" for f in r["repeats"])
            print(f"  {r['mode']} {r['rovers']} rovers in {r['processes']} process(es): median of runs {runs}")


def print_schedule(rows: list[dict]) -> None:
    """Real time against the world's schedule (see ``scale_observe.schedule_lateness``)."""
    shown = [r for r in rows if r.get("schedule")]
    if not shown:
        return
    print("\nagainst the world's schedule (sampled perception and gyroscope, real time): how far behind its best the "
          "world published a sample, and how late it arrived by that schedule")
    for r in shown:
        print(f"  {r['rovers']} rovers in {r['processes']} process(es): {_behind(r['schedule'])}")
        witness = (r.get("witness") or {}).get("schedule")
        if witness:
            agents = r.get("agent_priority", "equal")
            print(f"    at the witness, at the agents' priority ({agents}): {_behind(witness)}")


def _behind(schedule: dict) -> str:
    slip, arrival = schedule["slip_ms"], schedule["arrival_ms"]
    return (f"published behind p50 {slip['p50_ms']:.1f} p99 {slip['p99_ms']:.1f} max {slip['max_ms']:.1f} ms; "
            f"arrived behind p99 {arrival['p99_ms']:.1f} max {arrival['max_ms']:.1f} ms; later than one period: "
            f"{schedule['over_one_period']}")


def print_table(rows: list[dict]) -> None:
    print()
    print(HEADER)
    print(UNITS)
    for r in rows:
        head = f"{r['mode']:9}{r['rovers']:>7}{r['processes']:>6}"
        if "error" in r:
            print(f"{head}  failed: {r['error'].splitlines()[0]}")
            continue
        c, mem, lat, lag = r["cpu_cores"], r["memory_mib"], r["latency_ms"] or {}, r["agent_lag_ms"] or {}
        over, dropped = _sum(r, "over_one_period"), _sum(r, "dropped")
        print(f"{head}{r['real_time_factor']:>8.3f}{r['cpu_per_rover_pct']:>10.2f}{c['rovers']:>8.2f}{c['world']:>7.2f}"
              f"{c['router']:>7.2f}{c['total']:>7.2f}{r['memory_per_rover_mib']['rss_mib']:>10.1f}"
              f"{r['memory_per_rover_mib']['pss_mib']:>10.1f}{mem['total']['rss_mib']:>9.0f}"
              f"{_num(lat.get('p50_ms'), 2):>8}{_num(lat.get('p99_ms'), 1):>7}{_num(over, 0):>8}{_num(dropped, 0):>8}"
              f"{_dash(r['clock_samples_missing']):>9}{_num(lag.get('p99_ms'), 0):>8}{r['startup_s']:>9.1f}"
              f"{r['machine_cores']['other_cores']:>7.2f}")


def _sum(row: dict, field: str) -> int | None:
    values = [d[field] for d in row["delivery"].values() if d[field] is not None]
    return sum(values) if values else None


def _num(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def print_delivery(rows: list[dict]) -> None:
    print(f"\n{'mode':9}{'rovers':>7}{'procs':>6}  {'topic':18}{'period s':>9}{'received':>9}{'p50 ms':>8}"
          f"{'p99 ms':>8}{'max ms':>8}{'>period':>8}{'dropped':>8}{'reorder':>8}")
    for r in rows:
        if "error" in r:
            continue
        for topic, d in r["delivery"].items():
            lat = d["latency_ms"] or {}
            print(f"{r['mode']:9}{r['rovers']:>7}{r['processes']:>6}  {topic:18}{d['period_s']:>9.2f}"
                  f"{d['received']:>9}{_num(lat.get('p50_ms'), 2):>8}{_num(lat.get('p99_ms'), 1):>8}"
                  f"{_num(lat.get('max_ms'), 1):>8}{_num(d['over_one_period'], 0):>8}{_num(d['dropped'], 0):>8}"
                  f"{_num(d['out_of_order'], 0):>8}")


def print_witness(rows: list[dict]) -> None:
    """Where lost samples were lost: before the router's per-subscriber queues (agents too) or on one link."""
    for r in rows:
        w, ours = r.get("witness"), _sum(r, "dropped") if "delivery" in r else None
        if w is None or not (ours or w["dropped"] or w["clock_samples_missing"] or r["clock_samples_missing"]):
            continue
        print(f"{r['mode']} {r['rovers']} rovers: samples missing at the benchmark {ours}, at the witness process "
              f"{w['dropped']}, at both {w['dropped_at_both']} (lost before the router's per-subscriber queues: "
              f"the agents lose them too); world clock samples missing {r['clock_samples_missing']} and "
              f"{w['clock_samples_missing']}")


# ---- cost against rover count ----


def fit(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """Least-squares line: (slope, intercept)."""
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sxx
    return slope, my - slope * mx


def saturated(row: dict, cpus: int) -> bool:
    """The machine, not the run's needs, set its CPU figures: it fell behind real time or the cores were full."""
    return (row["real_time_factor"] < 1.0 - RTF_TOLERANCE
            or row["machine_cores"]["busy_cores"] > SATURATED * cpus)


def slopes(rows: list[dict], cpus: int) -> list[dict]:
    """Per series (real time, same agents per process, at least two counts): marginal and fixed cost. CPU is in
    CPU seconds per simulated second, so a run that fell behind real time is costed for the work it did."""
    out = []
    done = [r for r in rows if r["mode"] == "realtime" and "error" not in r]
    for k in sorted({r["agents_per_process"] for r in done}):
        series = sorted((r for r in done if r["agents_per_process"] == k), key=lambda r: r["rovers"])
        if len({r["rovers"] for r in series}) < 2:
            continue
        xs = [r["rovers"] for r in series]
        entry = {"agents_per_process": k, "rovers": xs,
                 "saturated": [r["rovers"] for r in series if saturated(r, cpus)]}
        for name in ("total", "rovers", "world", "router"):
            slope, fixed = fit(xs, [r["cpu_seconds_per_sim_second"][name] for r in series])
            entry[f"cpu_{name}"] = {"per_rover_pct": round(100 * slope, 3), "fixed_pct": round(100 * fixed, 1)}
        for name in ("rss_mib", "pss_mib"):
            slope, fixed = fit(xs, [r["memory_mib"]["total"][name] for r in series])
            entry[name] = {"per_rover": round(slope, 2), "fixed": round(fixed, 1)}
        out.append(entry)
    return out


def print_slopes(entries: list[dict]) -> None:
    for e in entries:
        share = "one process per rover" if e["agents_per_process"] == 1 else f"{e['agents_per_process']} per process"
        c, w, ro, rt = e["cpu_total"], e["cpu_world"], e["cpu_router"], e["cpu_rovers"]
        print(f"\ncost against rover count, real time, {share} (fit over {e['rovers']} rovers):")
        print(f"  CPU per simulated second: each more rover +{c['per_rover_pct']:.2f} % of a core (rover agents "
              f"{rt['per_rover_pct']:.2f}, world {w['per_rover_pct']:.2f}, router {ro['per_rover_pct']:.2f}); "
              f"fixed {c['fixed_pct']:.0f} %")
        print(f"  memory: each more rover +{e['rss_mib']['per_rover']:.1f} MiB RSS, "
              f"+{e['pss_mib']['per_rover']:.1f} MiB PSS; fixed {e['rss_mib']['fixed']:.0f} MiB RSS")
        if e["saturated"]:
            print(f"  (runs with {e['saturated']} rovers fell behind real time or filled the cores: their cost is "
                  "what a starved machine spent, so the line bends there)")


# ---- targets ----


def _row(rows: list[dict], mode: str, rovers: int, per_process: int = 1) -> dict | None:
    return next((r for r in rows if r["mode"] == mode and r["rovers"] == rovers
                 and r["agents_per_process"] == per_process), None)


def _dash(value: object) -> object:
    return "-" if value is None else value


def targets(doc: dict) -> list[dict]:
    rows = doc["rows"]
    rt = _row(rows, "realtime", 100)
    lock = _row(rows, "lockstep", 5)
    out = [_realtime_target(rt), _startup_target(rt)]
    out.append(_thousand_target(doc))
    ok = lock is not None and "error" not in lock
    runs = [f"{f:.2f}" if f is not None else "failed" for f in lock.get("repeats", [])] if ok else []
    of = f" (median of {len(runs)} runs: {', '.join(runs)})" if len(runs) > 1 else ""
    out.append({"target": f"5-rover lockstep at least {LOCKSTEP_TARGET:g} x real time",
                "measured": f"{lock['real_time_factor']:.2f} x{of}" if ok else "not run",
                "pass": lock["real_time_factor"] >= LOCKSTEP_TARGET if ok else None})
    return out


def holds(row: dict) -> bool:
    """A real-time run that kept the world's pace, with its sampled agents keeping up (``AGENT_LAG_LIMIT_MS``)."""
    if "error" in row or row["real_time_factor"] < 1.0 - RTF_TOLERANCE:
        return False
    lag = row.get("agent_lag_ms")
    return lag is None or lag["p99_ms"] <= AGENT_LAG_LIMIT_MS


def _thousand_target(doc: dict) -> dict:
    name = "1,000 rovers (sharing processes) hold a real-time factor of at least 1.0"
    if "highest_shared_holding" not in doc:
        return {"target": name, "measured": "not run", "pass": None}
    highest = doc["highest_shared_holding"]
    measured = f"highest count holding: {highest} (tried {doc['shared_counts_tried']})"
    if highest is not None and highest >= 1000:
        return {"target": name, "measured": measured, "pass": True}
    reached = max(doc["shared_counts_tried"], default=0) >= 1000
    return {"target": name, "measured": measured, "pass": False if reached else None}


def _realtime_target(rt: dict | None) -> dict:
    name = "100 rover processes hold real time, no sensor sample dropped or later than one period"
    if rt is None or "error" in rt:
        return {"target": name, "measured": rt["error"].splitlines()[0] if rt else "not run",
                "pass": False if rt else None}
    over, dropped = _sum(rt, "over_one_period") or 0, _sum(rt, "dropped") or 0
    behind = (rt.get("schedule") or {}).get("over_one_period", 0)
    measured = (f"factor {rt['real_time_factor']:.3f}, {over} later than a period after publication, {behind} later "
                f"than a period by the world's schedule, {dropped} dropped")
    late = over + behind + dropped
    witness = rt.get("witness") or {}
    if "over_one_period" in witness:  # what an agent's own thread sees, at the agents' priority
        agent = (witness["over_one_period"], (witness.get("schedule") or {}).get("over_one_period", 0),
                 witness["dropped"])
        measured += (f"; at the agents' priority ({rt.get('agent_priority', 'equal')}) {agent[0]}, {agent[1]} and "
                     f"{agent[2]}")
        late += sum(agent)
    return {"target": name, "measured": measured,
            "pass": rt["real_time_factor"] >= 1.0 - RTF_TOLERANCE and late == 0}


def _startup_target(rt: dict | None) -> dict:
    name = f"100 rover processes all connected within {STARTUP_TARGET_S:g} s"
    if rt is None or "startup_s" not in rt:
        return {"target": name, "measured": "not run" if rt is None else "did not connect", "pass": None
                if rt is None else False}
    cpu = rt.get("startup_cpu_s_per_process")
    detail = f" ({cpu:.2f} CPU s per rover process by then)" if cpu is not None else ""
    return {"target": name, "measured": f"{rt['startup_s']:.1f} s{detail}", "pass": rt["startup_s"] <= STARTUP_TARGET_S}


def median_run(rows: list[dict]) -> dict:
    """The run of median real-time factor (the lower middle of an even number), with every run's factor in run
    order (None for one that failed) under ``repeats``; the first failure if every run failed."""
    ok = sorted((r for r in rows if "error" not in r), key=lambda r: r["real_time_factor"])
    if not ok:
        return rows[0]
    return {**ok[(len(ok) - 1) // 2], "repeats": [r.get("real_time_factor") for r in rows]}


def highest_holding(counts: list[int], held, step_down: bool = True) -> int | None:
    """The highest count that holds, trying ``counts`` largest first until one does (``held(n)`` measures n); then
    between it and the lowest that did not, by halving the gap to ``REFINE_STEP``. After the counts asked for, the
    last one is halved until a count holds or it is below ``MIN_SHARED``. None if no count holds. Without
    ``step_down``: the counts asked for and no others, the first that holds being the answer."""
    counts = sorted(counts, reverse=True)
    failed = None
    while counts:
        n = counts.pop(0)
        if held(n):
            return refine(n, failed, held) if step_down else n
        failed = n
        if not counts and n // 2 >= MIN_SHARED and step_down:
            counts.append(n // 2)
    return None


def refine(holding: int, failed: int | None, held) -> int:
    """The highest count that holds, between ``holding`` (holds) and ``failed`` (does not), to REFINE_STEP."""
    while failed is not None and failed - holding > REFINE_STEP:
        middle = round((holding + failed) / 2 / REFINE_STEP) * REFINE_STEP
        if middle in (holding, failed):
            break
        if held(middle):
            holding = middle
        else:
            failed = middle
    return holding


if __name__ == "__main__":
    print_report(json.loads(Path(sys.argv[1]).read_text()))
