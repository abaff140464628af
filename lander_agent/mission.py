"""The lander's mission plan (report 3.4): dispatch, calibration, then one goal after another per rover.

Pure logic. The lander knows where it set each rover down (dispatch) and each rover's goals, all in
its own frame (lander at the origin, axes as the map's). Each rover is told its deployment pose
(Calibration) and the bearing and distance of its current goal from the lander (MissionDirection);
when a rover reports a goal done, it is given the next one. Ground commands change the goals.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable

from lander_agent.daisy_chain import Chain, in_radio_reach, plan_chain
from lander_agent.stations import fitted_offsets, pick_rim_station, pick_station, rim_offsets
from schemas import messages as m
from schemas.frames import bearing_deg
from schemas.radio import GoalReport, StationRequest
from schemas.scenario import Goal, Scenario
from shared.mission import RoverMissions, calibration

OBSTACLE_GAP_M = 1.0
"""Metres kept between a station and the lander's body."""
STATION_GAP_M = 1.0
"""The least gap between the bodies of rovers at neighbouring stations, where a formation is drawn closer to fit
(``stations.fitted_offsets``): room to walk in between to a station inside."""


class MissionPlan:
    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.calibration = {rid: calibration(scenario, rid) for rid in range(1, len(scenario.rovers) + 1)}
        self.missions = RoverMissions(scenario)
        self.goal_of = dict.fromkeys(self.calibration, 0)
        self.outcome: dict[int, str] = {}
        self.chains: dict[int, Chain] = {}
        self.finished: dict[int, dict[int, bool]] = {}  # goal index -> rover held done there -> its photos are in
        self.stations: dict[tuple[int, Goal], dict[int, tuple[float, float]]] = {}
        self.heard_at: dict[int, float] = {}
        """When the lander last heard each rover by radio (any report); unheard rovers from the mission's start."""
        self._form_chain(0)

    @property
    def rover_ids(self) -> list[int]:
        return list(self.calibration)

    def direction_for(self, rover_id: int) -> m.MissionDirection:
        index = self.goal_of[rover_id]
        goal = self.missions.goal(rover_id, index)
        lx, lz = self.scenario.lander.x, self.scenario.lander.z
        x, z, kind = goal.x - lx, goal.z - lz, goal.kind
        chain, relay_for = self.chains.get(index), None
        if chain and rover_id in chain.spots:
            relay_for = m.GoalPlace(kind=kind, bearing_deg=round(bearing_deg(x, z), 6),
                                    distance_m=round(math.hypot(x, z), 6))
            (x, z), kind = chain.spots[rover_id], "relay"
        shared = kind in ("waypoint", "crater") and len(self._team(rover_id, index)) > 1
        relayed = chain is not None and kind != "relay"
        station = self.stations.get((index, goal), {}).get(rover_id) if shared else None
        crater = self.scenario.crater_of(goal) if kind == "crater" else None
        rim = None if crater is None else (round(crater.x - goal.x, 3), round(crater.z - goal.z, 3),
                                           round(crater.outer_radius, 3))
        return m.MissionDirection(goal_index=index, goals_total=self.missions.final_index(rover_id) + 1,
                                  kind=kind, bearing_deg=round(bearing_deg(x, z), 6),
                                  distance_m=round(math.hypot(x, z), 6), station=station, shared=shared,
                                  relayed=relayed, relay_for=relay_for, rim=rim)

    def _team(self, rover_id: int, index: int) -> list[int]:
        """The rovers that share this rover's goal ``index`` and stand at stations there, in formation at a
        waypoint, round the crest at a crater (none: the report's rule, every rover stops once the waypoint is in
        view, or on the crest wherever it meets it)."""
        goal = self.missions.goal(rover_id, index)
        if goal.kind not in ("waypoint", "crater") or self.scenario.formation.shape == "none":
            return []
        return self.missions.sharing(index, goal)

    def request_station(self, rover_id: int, request: StationRequest) -> bool:
        """A rover near a shared goal asks for its station, so stations go out in the order rovers arrive
        (``stations.pick_station``, ``stations.pick_rim_station``). False: nothing to send (a stale request, or no
        formation here)."""
        index = request.goal_index
        if self.goal_of.get(rover_id) != index or rover_id in self.outcome:
            return False
        if index in self.chains and rover_id in self.chains[index].spots:
            return False
        return self._assign_station(rover_id, index, (request.x, request.z))

    def _assign_station(self, rover_id: int, index: int, here: tuple[float, float]) -> bool:
        """A station at goal ``index`` for a rover ``here`` (in the lander's frame): the free one nearest it."""
        team = self._team(rover_id, index)
        if len(team) < 2:
            return False
        goal = self.missions.goal(rover_id, index)
        taken = self.stations.setdefault((index, goal), {})
        lx, lz = self.scenario.lander.x, self.scenario.lander.z
        near = (here[0] - (goal.x - lx), here[1] - (goal.z - lz))
        crater = self.scenario.crater_of(goal) if goal.kind == "crater" else None
        if goal.kind == "crater" and crater is None:
            return False
        if rover_id in taken:
            return True
        params = self.scenario.rover_params
        least = 2 * params.behaviour.rover_radius + STATION_GAP_M
        if crater is not None:  # offsets from the goal, which need not be the crater's centre
            cx, cz = crater.x - goal.x, crater.z - goal.z
            crest, _ = rim_offsets(len(team), crater.radius_m, self.scenario.formation.spacing_m, least)
            crest = [(round(cx + x, 3), round(cz + z, 3)) for x, z in crest]
            taken[rover_id] = pick_rim_station(crest, taken.values(), near)
        else:
            formation = self.scenario.formation
            offsets, spacing = fitted_offsets(len(team), formation.spacing_m, self._travel_bearing(rover_id, index),
                                              formation.shape, params.perception.perception_radius, least,
                                              self._clear_of_lander(goal))
            taken[rover_id] = pick_station(offsets, taken.values(), near, spacing)
        return True

    def _clear_of_lander(self, goal: Goal) -> Callable[[tuple[float, float]], bool]:
        """Stations a rover can stand on: a waypoint at the lander (``return``) must not put one inside it."""
        lander = self.scenario.lander
        lx, lz = lander.x - goal.x, lander.z - goal.z
        clear = lander.radius_m + self.scenario.rover_params.behaviour.rover_radius + OBSTACLE_GAP_M
        return lambda o: math.hypot(o[0] - lx, o[1] - lz) > clear

    def _travel_bearing(self, rover_id: int, index: int) -> float:
        """From where the team comes to the goal: the previous goal, or the rovers' start."""
        goal = self.missions.goal(rover_id, index)
        if index > 0:
            before = self.missions.goal(rover_id, index - 1)
            return bearing_deg(goal.x - before.x, goal.z - before.z)
        rovers = self.scenario.rovers
        cx, cz = sum(r.x for r in rovers) / len(rovers), sum(r.z for r in rovers) / len(rovers)
        return bearing_deg(goal.x - cx, goal.z - cz)

    def _form_chain(self, index: int) -> None:
        """A daisy chain for goal ``index`` if the lander's radio cannot reach where the rovers are going."""
        rovers = [rid for rid, g in self.goal_of.items() if g == index and rid not in self.outcome]
        if not rovers:
            return
        goal = self.missions.goal(rovers[0], index)
        lx, lz = self.scenario.lander.x, self.scenario.lander.z
        crater = self.scenario.crater_of(goal) if goal.kind == "crater" else None
        reach = math.hypot(goal.x - lx, goal.z - lz) - (crater.radius_m if crater else 0.0)
        c = self.scenario.rover_params.communication
        places = {rid: self._setting_out(rid, index) for rid in rovers}
        heard = in_radio_reach(places, c.lander_comm_range, c.comm_range)
        rovers.sort(key=lambda rid: (rid not in heard, math.dist(places[rid], (goal.x - lx, goal.z - lz))))
        chain = plan_chain((goal.x - lx, goal.z - lz), reach, rovers, c.lander_comm_range, c.comm_range)
        if chain.spots:
            self.chains[index] = chain

    def _setting_out(self, rover_id: int, index: int) -> tuple[float, float]:
        """Where the rover sets out for goal ``index``, in the lander's frame: its start, or the goal before."""
        if index == 0:
            start = self.calibration[rover_id]
            return start.x, start.z
        before = self.missions.goal(rover_id, index - 1)
        return before.x - self.scenario.lander.x, before.z - self.scenario.lander.z

    @property
    def relay_chain(self) -> list[int]:
        """Rovers holding relay spots now, from the lander outwards."""
        return [rid for chain in self.chains.values() for rid in chain.relays
                if self.outcome.get(rid) is None and self.goal_of[rid] in self.chains]

    def directions(self) -> dict[m.MissionDirection, list[int]]:
        """Each distinct direction with the rovers it is for, so one transmission serves them all."""
        grouped: dict[m.MissionDirection, list[int]] = defaultdict(list)
        for rid in self.goal_of:
            grouped[self.direction_for(rid)].append(rid)
        return dict(grouped)

    def on_report(self, rover_id: int, report: GoalReport) -> list[int]:
        """Note a finished goal; returns the rovers that now have a new goal to be told about.

        Without a chain a rover goes on at once. While a chain stands for the goal, finished rovers wait
        (leaving would break the chain's purpose) until every rover that is not a relay is done and has its
        photos in; then all, relays too, go on together and a new chain forms for the next goal (report 6.5.2).
        At the last goal the relays go on to the goal itself: nobody is left who needs the route to the lander.
        """
        index = report.goal_index
        if (rover_id not in self.goal_of or index != self.goal_of[rover_id] or report.outcome == "relay"
                or rover_id in self.outcome):
            return []
        if report.outcome == "stuck" or (index >= self.missions.final_index(rover_id) and index not in self.chains):
            self.outcome[rover_id] = report.outcome
            return []
        if index not in self.chains:
            self.goal_of[rover_id] += 1
            return [rover_id]
        finished = self.finished.setdefault(index, {})
        finished[rover_id] = report.photos_pending == 0
        return self._release(index)

    def heard(self, rover_id: int, now: float) -> None:
        """A report from ``rover_id`` came in by radio: it has a route to the lander now."""
        if rover_id in self.goal_of:
            self.heard_at[rover_id] = max(now, self.heard_at.get(rover_id, now))

    def release_quiet(self, now: float) -> list[int]:
        """Release the chains whose far end has gone quiet: every rover the chain waits for (not a relay, not yet
        done with its photos in) unheard for ``relay_cut_off_s``. A wall between two relay spots cuts a chain; the
        rovers beyond it then never get a report through, and the relays on the lander's side, which still hear
        it, would hold their spots for nobody until the mission's end. A quiet rover goes on as it was: at the
        last goal its report is taken whenever it comes, before it the next goal's direction waits for it.
        Returns the rovers with a new goal."""
        quiet_s = self.scenario.rover_params.communication.relay_cut_off_s
        moving: list[int] = []
        for index in list(self.chains):
            waited = self._waited_for(index)
            if waited and all(now - self.heard_at.get(rid, 0.0) >= quiet_s for rid in waited):
                moving += self._release(index, quiet=set(waited))
        return moving

    def _waited_for(self, index: int) -> list[int]:
        """The rovers the chain of goal ``index`` stands for that are not done there with their photos in."""
        chain, finished = self.chains[index], self.finished.get(index, {})
        return [rid for rid, g in self.goal_of.items()
                if g == index and rid not in self.outcome and rid not in chain.spots and not finished.get(rid, False)]

    def _release(self, index: int, quiet: set[int] = frozenset()) -> list[int]:
        """Every rover of the chain's goal on to what follows it, once the chain waits for nobody but ``quiet``."""
        chain = self.chains[index]
        group = [rid for rid, g in self.goal_of.items() if g == index and rid not in self.outcome]
        if any(rid not in quiet for rid in self._waited_for(index)):
            return []
        del self.chains[index]
        moving, held = [], {}
        for rid in group:
            if index < self.missions.final_index(rid):
                self.goal_of[rid] += 1
                moving.append(rid)
            elif rid in quiet:  # still on its way, out of reach: its report is taken when it comes
                continue
            elif rid in self.finished.setdefault(index, {}):
                self.outcome[rid] = "reached"
            elif self.scenario.rover_params.communication.release_relays:  # free to walk on to the goal
                self._assign_station(rid, index, chain.spots[rid])
                moving.append(rid)
            else:
                self.outcome[rid], held[rid] = "relay", chain.spots[rid]
        if held:  # they keep being told to hold
            self.chains[index] = Chain(held)
        self._form_chain(index + 1)
        return moving

    def on_command(self, command: m.GroundCommand) -> list[int]:
        """Apply a ground command (raises CommandRefused); returns the rovers it concerns."""
        rovers = self.missions.apply(command)
        if command.command != "stop":
            for rid in rovers:
                self.goal_of[rid] = self.missions.final_index(rid)
                self.outcome.pop(rid, None)
        return rovers

    @property
    def phase(self) -> str:
        if len(self.outcome) == len(self.goal_of):
            return "complete"
        observing = any(self.missions.goal(r, g).kind == "crater" and r in self.outcome
                        for r, g in self.goal_of.items())
        return "observation" if observing else "migration"

    def status(self, stamp: float, connected: list[int]) -> m.LanderStatus:
        return m.LanderStatus(stamp=stamp, phase=self.phase, rover_goals=dict(self.goal_of), connected=connected,
                              relay_chain=self.relay_chain)
