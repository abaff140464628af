"""``lunarsim check-behaviour NAME``: does a rover behaviour keep the contract? (report 4.4)

Two parts. Scripted views, no world: every decision is one of the allowed kinds; moves stay in view
and within the perception radius; the same inputs give the same decisions; a goal behind is turned
towards; a goal in view is finished. Then a short mission in one process (no router) on a scenario,
reporting what a run reports. Problems are listed one per line; the exit status is 1 if there is any.

A ``package.module:Class`` is found as ``python -m`` finds modules: from the folder the command runs in
first (``lunarsim check-behaviour my_rovers.slow:Slow`` in a project's folder), then the installed packages.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import process
from deploy.behaviour_check import DEFAULT_SCENARIO

SHORTEST_CHECK_S = 10.0
"""A shorter mission ends before the rovers have driven, and a check of what they did would pass on nothing."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("behaviour", help="default, straight, an installed plugin, or package.module:Class")
    parser.add_argument("--scenario", type=Path, default=DEFAULT_SCENARIO, help="for the short mission")
    parser.add_argument("--rovers", type=int, default=2, metavar="N", help="rovers in the short mission")
    parser.add_argument("--max-sim-time", type=float, default=300.0, metavar="S",
                        help=f"simulated seconds each checking mission may last (default 300, at least "
                             f"{SHORTEST_CHECK_S:g})")


def run(args: argparse.Namespace) -> int:
    from deploy.behaviour_check import behaviour_problem, scripted_problems
    from harness.loopback import run_mission
    from rover_agent.registry import UnknownBehaviour, load_behaviour
    from schemas.scenario import load_scenario

    process.check_range("--max-sim-time", args.max_sim_time, SHORTEST_CHECK_S, process.AT_MOST["max_sim_time"])
    problem = behaviour_problem(args.behaviour)
    if problem is not None:
        raise process.UsageError(problem)
    try:
        cls = load_behaviour(args.behaviour)  # what the check above found, from the same folders
    except UnknownBehaviour as exc:
        raise process.UsageError(str(exc)) from None
    scenario = load_scenario(args.scenario).with_overrides(rovers=args.rovers)
    problems = scripted_problems(cls, scenario.rover_params)
    for line in problems:
        print(f"problem: {line}")
    report = run_mission(scenario, args.max_sim_time, behaviour=cls).report()
    print(f"mission {scenario.name} with {args.rovers} rovers: {report.rovers_reached_final_goal}/"
          f"{report.rovers_total} reached, {report.rover_collisions + report.obstacle_collisions} collisions, "
          f"{report.rovers_stuck} stuck, efficiency {report.average_path_efficiency:.3f}, "
          f"{'complete' if report.complete else 'not complete'} after {report.mission_duration_s:.1f} s")
    if report.power_budget_efficiency is not None:
        print(f"power: budget efficiency {report.power_budget_efficiency:.3f}, {report.energy_used_wh:.4f} Wh drawn, "
              f"{report.power_shutdowns} battery and {report.cold_shutdowns} cold shutdown(s)")
    print("contract: ok" if not problems else f"contract: {len(problems)} problem(s)")
    return 1 if problems else 0
