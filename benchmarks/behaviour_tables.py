"""The behaviour suite's figures from its missions' rows (``behaviour_suite.run_one``): reach, collisions,
efficiency, pose error and the estimates' consistency by class and role, why rovers fell short, where their walking
went, relays stranded; and the tables that print them. Apart from the runs, so a saved run (``--table``) is tabled
the same way."""

from __future__ import annotations

import statistics
from collections import Counter

from scenarios.generator import CLASS_VALUES

UNSURE_SIGMAS = 3.0
"""A rover done off its goal "knew it was unsure" when its estimate's error was within this many of its own 1-sigma
position errors (``Localisation.position_std``)."""
NEES_GATES = (9.21, 13.82)
"""Chi-square with 2 degrees of freedom at 99% and 99.9%: a consistent filter's truth lies beyond them one time in
100 and in 1,000 (``estimate_nees``)."""
LOCALISED_AFTER_M = 400.0
"""The localisation figure counts rovers that walked at least this far: dead reckoning's error grows with the
distance walked, so short walks would flatter it."""


def failure_kind(rover: dict) -> str:
    """Why a rover did not reach, the first that applies."""
    if not rover["heard_lander"]:
        return "never heard the lander"
    if rover["state"] == "relay":
        return "relay (daisy chain)"
    if rover["state"] == "stuck":
        return "stuck (said so)"
    if rover["stalled"]:
        return "stalled (world's watchdog)"
    if rover["state"] == "done" and rover["goal_index"] == rover["final_goal_index"]:
        error, std = rover.get("estimate_error_m"), rover.get("estimate_std_m")  # runs saved before have no std
        if error is None or std is None:
            return "done but not at the goal"
        knew = error <= UNSURE_SIGMAS * std
        return f"done but not at the goal, {'knowing it was unsure' if knew else 'sure of a wrong estimate'}"
    if rover["state"] == "done":
        return "done at an earlier goal"
    return f"unfinished ({rover['state']}) at the cap"


def summarise(rows: list[dict]) -> dict:
    """Reach, collisions, stuck, efficiency and pose error of some missions' rovers."""
    rovers = [r for row in rows for r in row["rovers"]]
    reached = [r for r in rovers if r["reached"]]
    errors = sorted(r["goal_error_m"] for r in rovers)
    walked = sorted(r["estimate_error_m"] for r in rovers  # runs saved before the figure have none
                    if r.get("estimate_error_m") is not None and r["distance_covered_m"] >= LOCALISED_AFTER_M)
    efficiencies = [r["efficiency"] for r in reached if r["efficiency"] is not None]
    collisions = sum(row["report"]["rover_collisions"] + row["report"]["obstacle_collisions"] for row in rows)
    sent = [r for r in rovers if r["state"] != "relay"]  # a relay holds its spot for the others: its job
    return {"missions": len(rows), "rovers": len(rovers), "reached": len(reached),
            "reach": round(len(reached) / len(rovers), 4) if rovers else None,
            "relays": len(rovers) - len(sent),
            "reach_sent": round(sum(r["reached"] for r in sent) / len(sent), 4) if sent else None,
            "collisions": collisions, "collisions_per_mission": round(collisions / len(rows), 3) if rows else None,
            "stuck": sum(r["state"] == "stuck" or r["stalled"] for r in rovers),
            "efficiency_reached": round(statistics.fmean(efficiencies), 4) if efficiencies else None,
            "pose_error_median_m": round(statistics.median(errors), 3) if errors else None,
            "pose_error_p90_m": _p90(errors),
            "walked_400m": len(walked),
            "estimate_error_median_m": round(statistics.median(walked), 3) if walked else None,
            "estimate_error_p90_m": _p90(walked),
            **consistency(rovers),
            "complete": sum(row["report"]["complete"] for row in rows),
            "sim_s_mean": round(statistics.fmean(row["report"]["mission_duration_s"] for row in rows), 1)
            if rows else None}


def consistency(rovers: list[dict]) -> dict:
    """Whether the rovers' stated uncertainty is honest at the end (``estimate_nees``, over the rovers standing
    still with any): its mean (2 for a consistent filter; above, the filter is overconfident) and the shares beyond
    ``NEES_GATES`` (1% and 0.1% when consistent). Runs saved before the figure have none."""
    nees = [r["estimate_nees"] for r in rovers if r.get("estimate_nees") is not None]
    if not nees:
        return {"nees_rovers": 0, "nees_mean": None, "nees_beyond_99": None, "nees_beyond_999": None}
    low, high = NEES_GATES
    return {"nees_rovers": len(nees), "nees_mean": round(statistics.fmean(nees), 3),
            "nees_beyond_99": round(sum(v > low for v in nees) / len(nees), 4),
            "nees_beyond_999": round(sum(v > high for v in nees) / len(nees), 4)}


def _p90(ordered: list[float]) -> float | None:
    return round(ordered[min(len(ordered) - 1, int(0.9 * len(ordered)))], 3) if ordered else None


def aggregate(results: list[dict]) -> dict:
    ok = [row for row in results if "error" not in row]
    by_class = {f"{key}={value}": summarise([row for row in ok if row["classes"][key] == value])
                for key, values in CLASS_VALUES.items() for value in values}
    by_role = {}
    for role in ("formation", "in_crater", "out_of_range"):
        rows = [{**row, "rovers": [r for r in row["rovers"] if r["role"] == role]} for row in ok]
        by_role[role] = summarise([row for row in rows if row["rovers"]])
    failures = [{"seed": row["seed"], "classes": row["classes"], **r, "why": failure_kind(r)}
                for row in ok for r in row["rovers"] if not r["reached"]]
    return {"overall": summarise(ok), "by_class": by_class, "by_role": by_role, "errors": len(results) - len(ok),
            "stranded": stranded(ok), "walked": walked_by_cause(ok),
            "failure_kinds": dict(Counter(f["why"] for f in failures).most_common()), "failures": failures}


def walked_by_cause(rows: list[dict]) -> dict:
    """Metres the rovers that reached walked, by what they walked for (``RoverAgent.walked``), beside their ideal
    paths: where path efficiency goes. Runs saved before the figure have none."""
    reached = [r for row in rows for r in row["rovers"] if r["reached"] and "walked_by_cause" in r]
    causes: Counter = Counter()
    for r in reached:
        causes.update(r["walked_by_cause"])
    return {"rovers": len(reached), "ideal_m": round(sum(r["ideal_path_m"] for r in reached), 1),
            "covered_m": round(sum(r["distance_covered_m"] for r in reached), 1),
            "by_cause_m": {k: round(v, 1) for k, v in causes.most_common()},
            "rovers_by_cause": dict(Counter(k for r in reached for k, v in r["walked_by_cause"].items() if v > 0))}


def stranded(rows: list[dict]) -> dict:
    """Relays still holding a daisy chain's spot at the end, over the daisy family's missions: a spot the mission
    no longer needs (at the end nobody needs the route), per mission and the missions with any."""
    daisy = [row for row in rows if row["classes"]["family"] == "daisy"]
    counts = [sum(r["state"] == "relay" for r in row["rovers"]) for row in daisy]
    return {"daisy_missions": len(daisy), "relays": sum(counts), "missions_with_any": sum(c > 0 for c in counts),
            "per_mission": round(sum(counts) / len(daisy), 3) if daisy else None,
            "elsewhere": sum(r["state"] == "relay" for row in rows if row["classes"]["family"] != "daisy"
                             for r in row["rovers"])}


def _fmt(value, spec: str = "") -> str:
    return "-" if value is None else format(value, spec)


def print_table(agg: dict) -> None:
    head = (f"{'class':<24}{'missions':>9}{'rovers':>8}{'reach':>8}{'sent':>8}{'coll/m':>8}{'stuck':>7}{'eff':>7}"
            f"{'err p50':>9}{'err p90':>9}{'est p50':>9}{'est p90':>9}{'complete':>10}")
    print(head)
    print("-" * len(head))
    rows = {"all": agg["overall"], **agg["by_class"], **{f"role={k}": v for k, v in agg["by_role"].items()}}
    for label, s in rows.items():
        if not s["missions"]:
            print(f"{label:<24}{0:>9}")
            continue
        print(f"{label:<24}{s['missions']:>9}{s['rovers']:>8}{_fmt(s['reach'], '.1%'):>8}"
              f"{_fmt(s['reach_sent'], '.1%'):>8}"
              f"{_fmt(s['collisions_per_mission'], '.2f'):>8}{s['stuck']:>7}{_fmt(s['efficiency_reached'], '.2f'):>7}"
              f"{_fmt(s['pose_error_median_m'], '.1f'):>9}{_fmt(s['pose_error_p90_m'], '.1f'):>9}"
              f"{_fmt(s['estimate_error_median_m'], '.1f'):>9}{_fmt(s['estimate_error_p90_m'], '.1f'):>9}"
              f"{s['complete']:>6}/{s['missions']:<3}")
    print(f"err: distance from the final goal at the end; est: distance of each rover's own estimate from the truth "
          f"at the end, over the {agg['overall']['walked_400m']} rovers that walked {LOCALISED_AFTER_M:.0f} m or more")
    if (o := agg["overall"]).get("nees_rovers"):
        noise = ", ".join(f"{label} {s['nees_mean']:.2f} / {s['nees_beyond_99']:.1%} / {s['nees_beyond_999']:.1%}"
                          for label, s in agg["by_class"].items()
                          if label.startswith("noise=") and s.get("nees_rovers"))
        print(f"estimate consistency at the end, {o['nees_rovers']} rovers standing still with an uncertain "
              f"estimate: mean NEES {o['nees_mean']:.2f} (2 if the stated uncertainty is honest), beyond the 99% gate "
              f"{o['nees_beyond_99']:.1%} (1%), beyond 99.9% {o['nees_beyond_999']:.1%} (0.1%); by noise: {noise}")
    if (w := agg.get("walked")) is not None and w["rovers"]:
        causes = ", ".join(f"{k} {v:.0f} m ({w['rovers_by_cause'].get(k, 0)} rovers)"
                           for k, v in w["by_cause_m"].items())
        print(f"walked by the {w['rovers']} rovers that reached: {w['covered_m']:.0f} m for {w['ideal_m']:.0f} m of "
              f"ideal paths; by cause: {causes}")
    if (st := agg.get("stranded")) is not None:  # runs saved before the figure have none
        print(f"relays stranded: {st['relays']} in {st['missions_with_any']} of {st['daisy_missions']} daisy missions "
              f"({_fmt(st['per_mission'], '.2f')} a mission); {st['elsewhere']} in other missions")


def print_failures(agg: dict, shown: int) -> None:
    print(f"\nfailure taxonomy ({len(agg['failures'])} rovers did not reach their final goal):")
    for why, count in agg["failure_kinds"].items():
        print(f"  {count:>5}  {why}")
    for f in agg["failures"][:shown]:
        labels = " ".join(f"{k}={v}" for k, v in f["classes"].items())
        print(f"  seed {f['seed']} rover {f['id']} ({f['role']}): {f['why']}; state {f['state']}, goal "
              f"{f['goal_index']}/{f['final_goal_index']}, {f['goal_error_m']:.1f} m from its final goal, heard the "
              f"lander: {'yes' if f['heard_lander'] else 'no'}; {labels}")
    if len(agg["failures"]) > shown:
        print(f"  ... {len(agg['failures']) - shown} more in --json")
