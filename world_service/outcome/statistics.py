"""Mission statistics of report 3.4.7, computed from ground truth.

They are computed from the world's published ``world/state`` stream (and the ground's mission commands)
and nothing else, by ``MissionStats``: the live world feeds it each state it publishes, ``lunarsim report``
feeds it the states of a recording, so the two reports agree to the last digit.

"Reached" follows the report: the rover finished its final goal *and* stands at the correct final
location. For a crater goal that is on the rim: within ``RIM_TOLERANCE`` x radius of the crest. For a
waypoint it is having the goal in view: within the perception radius.

Power budget efficiency (the literature study's first fitness criterion, 6.3.3: "the rate between the current
situation to the optimal situation"), reported only when the scenario has a sun: the energy the rovers' goal
progress would have needed at best, divided by the energy they drew. "At best" is walking the ideal path
(``relative_path_length``) at the speed level with the least energy per metre, drawing nothing else;
progress is how much shorter the rover's remaining ideal path (from where it stands through its remaining
goals) is than its whole one. Energy is chosen over distance per Wh so the figure stays in 0..1 like path
efficiency, and progress rather than distance so walking the wrong way, detours and standing still (charging
included) all lower it. A rover that is off (battery empty or too cold) or stuck is credited no progress: what
it walked bought the mission nothing, while the energy it drew still counts. So a rover that spends energy on
charging and arrives scores above one that saves it and dies half way.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from schemas import codec
from schemas.messages import MISSION_COMMANDS, GroundCommand, MissionReport, WorldCounters, WorldState
from schemas.scenario import Goal, Scenario
from shared.mission import CommandRefused, RoverMissions

RIM_TOLERANCE = 0.15


def relative_path_length(scenario: Scenario, start: tuple[float, float]) -> float:
    """Crow-flies length from a start through every goal in order, to where each goal is reached.

    A crater goal is reached on its crest, so its leg ends at the crest point nearest the leg's start
    (the report measured to the goal marker in the crater, which rewards stopping short of it).
    """
    return remaining_path(scenario, scenario.mission, *start)


def arrival_point(scenario: Scenario, goal: Goal, here: tuple[float, float]) -> tuple[float, float]:
    crater = scenario.crater_of(goal) if goal.kind == "crater" else None
    if crater is None:
        return goal.x, goal.z
    d = math.hypot(here[0] - crater.x, here[1] - crater.z)
    if d < 1e-9:
        return crater.x, crater.z + crater.radius_m
    scale = crater.radius_m / d
    return crater.x + (here[0] - crater.x) * scale, crater.z + (here[1] - crater.z) * scale


def mission_path_length(scenario: Scenario) -> float:
    """The report's relative path length: the mean over rovers of each one's ideal path."""
    lengths = [relative_path_length(scenario, (r.x, r.z)) for r in scenario.rovers]
    return sum(lengths) / len(lengths)


def distance_to_goal(scenario: Scenario, goal: Goal, x: float, z: float) -> float:
    """How far a rover is from being at a goal: from the crater's crest, or from the waypoint."""
    crater = scenario.crater_of(goal) if goal.kind == "crater" else None
    if crater is not None:
        return abs(math.hypot(x - crater.x, z - crater.z) - crater.radius_m)
    return math.hypot(x - goal.x, z - goal.z)


def at_goal(scenario: Scenario, goal: Goal, x: float, z: float) -> bool:
    crater = scenario.crater_of(goal) if goal.kind == "crater" else None
    if crater is not None:
        return distance_to_goal(scenario, goal, x, z) <= RIM_TOLERANCE * crater.radius_m
    return distance_to_goal(scenario, goal, x, z) <= scenario.rover_params.perception.perception_radius


def energy_per_metre_wh(scenario: Scenario) -> float:
    """The least energy a rover can walk a metre on: its whole draw over its speed, at the best speed level."""
    p = scenario.rover_params
    base = p.power.idle_w + p.power.perception_w
    return min((base + p.power.move_power(level)) / p.navigation.speed(level) for level in (1, 2, 3)) / 3600.0


def remaining_path(scenario: Scenario, goals: Sequence[Goal], x: float, z: float) -> float:
    """Crow-flies length from (x, z) through the goals still ahead, to where each is reached."""
    length, here = 0.0, (x, z)
    for goal in goals:
        there = arrival_point(scenario, goal, here)
        length += math.dist(here, there)
        here = there
    return length


def build_report(
    scenario: Scenario,
    distances: Sequence[float],
    reached: int,
    stuck: int,
    rover_collisions: int,
    obstacle_collisions: int,
    duration_s: float,
    complete: bool,
    rejected_messages: int = 0,
    links: LinkStats | None = None,
    radio_dropped: int = 0,
    radio_lost: int = 0,
    power: dict | None = None,
    stalled: int = 0,
    counters: WorldCounters | None = None,
    reached_efficiencies: Sequence[float] = (),
    relay_rovers: int = 0,
) -> MissionReport:
    total = float(sum(distances))
    average = total / len(distances) if distances else 0.0
    path = mission_path_length(scenario)
    return codec.checked(MissionReport(  # checked: the figures come from NumPy and integer sums, a report holds floats
        scenario=scenario.name,
        seed=scenario.seed,
        relative_path_length_m=round(path, 4),
        average_distance_covered_m=round(average, 4),
        average_path_efficiency=round(path / average, 6) if average > 0 else 0.0,
        reached_path_efficiency=(round(sum(reached_efficiencies) / len(reached_efficiencies), 6)
                                 if reached_efficiencies else None),
        total_distance_covered_m=round(total, 4),
        rovers_reached_final_goal=reached,
        rovers_total=len(distances),
        rover_collisions=rover_collisions,
        obstacle_collisions=obstacle_collisions,
        rovers_stuck=stuck,
        rovers_stalled=stalled,
        rovers_holding_relay_spots=relay_rovers,
        mission_duration_s=round(duration_s, 4),
        complete=complete,
        rejected_messages=rejected_messages,
        radio_dropped=radio_dropped,
        radio_lost=radio_lost,
        **({"agent_rejected_messages": counters.agent_rejected, "dropped_messages": counters.dropped_messages,
            "world_resumes": counters.world_resumes, "rovers_lost": counters.rovers_lost,
            "lander_map_lost": counters.lander_map_lost}
           if counters is not None else {}),
        **(links.as_fields() if links else {}),
        **(power or {}),
    ))


@dataclass
class LinkStats:
    """The literature study's fitness list (6.3.3) for communication, accumulated as the graph changes."""

    connected: dict[int, bool] = field(default_factory=dict)
    losses: int = 0
    disconnected_s: float = 0.0
    disconnected_by_rover: dict[int, float] = field(default_factory=dict)
    elapsed_s: float = 0.0
    max_relays: int = 0

    def update(self, connected: dict[int, bool], relays: int, elapsed_s: float) -> None:
        self.losses += sum(1 for rid, now in connected.items() if self.connected.get(rid, True) and not now)
        self.disconnected_s += elapsed_s * sum(1 for now in connected.values() if not now)
        self.elapsed_s += elapsed_s
        for rid, now in connected.items():
            self.disconnected_by_rover[rid] = self.disconnected_by_rover.get(rid, 0.0) + (0.0 if now else elapsed_s)
        self.max_relays = max(self.max_relays, relays)
        self.connected = connected

    def as_fields(self) -> dict:
        worst = max(self.disconnected_by_rover.values(), default=0.0)
        connected = 1.0 - worst / self.elapsed_s if self.elapsed_s > 0 else 1.0
        return {"lander_connection_losses": self.losses, "disconnected_time_s": round(self.disconnected_s, 4),
                "worst_rover_connected_fraction": round(connected, 4),
                "max_rovers_in_daisy_chain": self.max_relays}


def lander_component(state: WorldState) -> set[int]:
    """Node ids with a radio route to the lander (0), from the state's links."""
    neighbours: dict[int, list[int]] = {}
    for a, b in state.comm_links:
        neighbours.setdefault(a, []).append(b)
        neighbours.setdefault(b, []).append(a)
    seen, frontier = {0}, {0}
    while frontier:  # a set: a node reached from two of the frontier's enters the next once, not once a path
        frontier = {n for node in frontier for n in neighbours.get(node, ()) if n not in seen}
        seen |= frontier
    return seen


@dataclass
class MissionStats:
    """Report 3.4.7 from the stream of world states: the one computation, live and replayed."""

    scenario: Scenario
    missions: RoverMissions
    links: LinkStats = field(default_factory=LinkStats)
    last: WorldState | None = None
    relayed: set[int] = field(default_factory=set)
    """Rovers that have held a daisy-chain spot (state ``relay``): sent there instead of along their goals."""
    turned: dict[int, list[tuple[int, int, float, float]]] = field(default_factory=dict)
    """Per rover, where the ground sent it elsewhere before it finished a goal: (that goal's index, the new goal's
    index, x, z)."""

    def command(self, command: GroundCommand) -> None:
        """Follow the ground's changes to the mission, so each rover is judged at its real final goal."""
        if command.command in MISSION_COMMANDS:
            with contextlib.suppress(CommandRefused):  # the lander answers the ground; a refusal changes nothing
                self._turn(self.missions.apply(command) if command.command != "stop" else [])

    def _turn(self, rovers: Sequence[int]) -> None:
        """Rovers given a new goal: one not done with its last goal turned where it stood. The goal it was on is
        the one its status names (the rover's word), if that comes before the new one; else its first."""
        latest = {r.id: r for r in self.last.rovers} if self.last is not None else {}
        for rid in rovers:
            r = latest.get(rid)
            if r is None or r.state != "done":
                new = self.missions.final_index(rid)
                index = r.goal_index if r is not None and 0 <= r.goal_index < new else 0
                x, z = (r.x, r.z) if r is not None else (self.scenario.rovers[rid - 1].x,
                                                          self.scenario.rovers[rid - 1].z)
                self.turned.setdefault(rid, []).append((index, new, x, z))

    def ideal_goals(self, rid: int) -> list[Goal]:
        """The goals a rover was asked to walk through: its mission's, up to the point where the ground sent it
        elsewhere (that point stands in for the goals left unfinished), then the new ones. Each turn leads on to
        a later goal, so the walk through them ends (a rover that claimed a goal beyond its plan once sent it
        round in a circle for ever, the world with it)."""
        instead = {index: (new, Goal(x=x, z=z, kind="waypoint"))
                   for index, new, x, z in self.turned.get(rid, []) if new > index}
        goals, i = [], 0
        while i <= self.missions.final_index(rid):
            if i in instead:  # goals i .. new - 1 left unfinished: the point where the rover turned
                i, turn = instead[i]
                goals.append(turn)
            goals.append(self.missions.goal(rid, i))
            i += 1
        return goals

    def observe(self, state: WorldState) -> None:
        elapsed = state.stamp - self.last.stamp if self.last is not None else 0.0
        reach = lander_component(state)
        self.links.update({r.id: r.id in reach for r in state.rovers if r.alive}, len(state.relays), elapsed)
        self.relayed.update(r.id for r in state.rovers if r.state == "relay")
        self.last = state

    def reached(self, state: WorldState) -> list[int]:
        """Ids of the rovers that finished their final goal and stand at it."""
        ids = []
        for r in state.rovers:
            final = self.missions.final_index(r.id)
            if (r.state == "done" and r.goal_index == final
                    and at_goal(self.scenario, self.missions.goal(r.id, final), r.x, r.z)):
                ids.append(r.id)
        return ids

    def path_efficiencies(self, state: WorldState, ids: Sequence[int]) -> list[float]:
        """Each listed rover's ideal path (from its start through its own goals) over the distance it covered:
        the efficiency of a rover that got there, which stopping short cannot inflate. Relays are left out: the
        lander sent them to a chain spot instead of along their goals, so their ideal path is not theirs."""
        rovers = {r.id: r for r in state.rovers}
        result = []
        for rid in (i for i in ids if i not in self.relayed):
            r, spawn = rovers[rid], self.scenario.rovers[rid - 1]
            if r.distance_covered_m > 0:
                ideal = remaining_path(self.scenario, self.ideal_goals(rid), spawn.x, spawn.z)
                result.append(ideal / r.distance_covered_m)
        return result

    def power_fields(self, state: WorldState) -> dict | None:
        """Power budget efficiency, energy and shutdowns; None when the world has no power model."""
        if any(r.energy_used_wh is None for r in state.rovers) or not state.rovers:
            return None
        useful = 0.0
        for r in state.rovers:
            spawn = self.scenario.rovers[r.id - 1] if r.id <= len(self.scenario.rovers) else None
            if spawn is None or r.powered is False or r.state == "stuck" or r.stalled:
                continue  # stranded: its progress bought nothing
            final = self.missions.final_index(r.id)
            goals = [self.missions.goal(r.id, i) for i in range(max(r.goal_index, 0), final + 1)]
            whole = remaining_path(self.scenario, [self.missions.goal(r.id, i) for i in range(final + 1)],
                                   spawn.x, spawn.z)
            useful += max(0.0, whole - remaining_path(self.scenario, goals, r.x, r.z))
        used = sum(r.energy_used_wh for r in state.rovers)
        best = useful * energy_per_metre_wh(self.scenario)
        c = state.counters
        return {"power_budget_efficiency": round(best / used, 6) if used > 0 else 0.0,
                "energy_used_wh": round(used, 6), "power_shutdowns": c.power_shutdowns,
                "cold_shutdowns": c.cold_shutdowns}

    def report(self) -> MissionReport:
        state = self.last
        if state is None:
            raise ValueError("no world state observed yet: nothing to report")
        c = state.counters
        reached = self.reached(state)
        return build_report(
            self.scenario,
            distances=[r.distance_covered_m for r in state.rovers],
            reached=len(reached),
            reached_efficiencies=self.path_efficiencies(state, reached),
            relay_rovers=sum(r.state == "relay" for r in state.rovers),
            stuck=sum(r.state == "stuck" or r.stalled for r in state.rovers),
            stalled=sum(r.stalled and r.state != "stuck" for r in state.rovers),
            rover_collisions=c.rover_collisions,
            obstacle_collisions=c.obstacle_collisions,
            duration_s=state.completed_at if state.completed_at is not None else state.stamp,
            complete=state.completed_at is not None,
            rejected_messages=c.rejected_messages,
            links=self.links,
            radio_dropped=c.radio_dropped,
            radio_lost=c.radio_lost,
            power=self.power_fields(state),
            counters=c,
        )
