"""Ground truth and the mission statistics: what the world publishes for viewers, the recorder and the statistics
(``world/state``, ``world/stats``), and never sends to an agent (report 9.1)."""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta, field

from schemas.base import Message, RoverState
from schemas.scenario_limits import MAX_ROVERS
from schemas.wire_limits import MAX_TARGETS, Finite, RoverId, Seconds, Tally


class RoverTruth(Message, kw_only=True):
    """Ground truth of one rover: for viewers, recorder and statistics, never for agents."""

    id: RoverId
    x: Finite
    z: Finite
    heading_deg: Finite
    action: Literal["idle", "move", "rotate", "cancel"]
    state: RoverState
    goal_index: int
    distance_to_goal_m: Finite
    distance_covered_m: Finite
    alive: bool
    telemetry_stale: Annotated[bool, Meta(
        description="twin mode: the rover's driver has gone quiet; this is its last known pose")] = False
    battery_wh: Annotated[Finite | None, Meta(
        description="charge; None when the scenario has no sun (no power model)")] = None
    temperature_c: Finite | None = None
    sunlit: bool | None = None
    energy_used_wh: Annotated[Finite | None, Meta(description="drawn from the battery since the start")] = None
    powered: Annotated[bool | None, Meta(description="False while off: battery empty or too cold")] = None
    stalled: Annotated[bool, Meta(
        description="no closer to its goal for the stall time: counted stuck, whatever its agent says "
                    "(world_service.outcome.progress)")] = False


class WorldCounters(Message, kw_only=True):
    """Events the world has counted since the start: ground truth a recording must carry for its statistics."""

    rover_collisions: Tally = 0
    obstacle_collisions: Tally = 0
    rejected_messages: Tally = 0
    radio_dropped: Tally = 0
    radio_lost: Tally = 0
    power_shutdowns: Annotated[Tally, Meta(description="times a rover's battery ran empty")] = 0
    cold_shutdowns: Annotated[Tally, Meta(description="times a rover fell below its operating temperature (N9)")] = 0
    agent_rejected: Annotated[Tally, Meta(
        description="samples the rover agents and the lander rejected, as their statuses last said")] = 0
    dropped_messages: Annotated[Tally, Meta(
        description="samples the world dropped unread: over its inbox's bound for their key (a flood)")] = 0
    world_resumes: Annotated[Tally, Meta(
        description="times the world service was restarted and resumed this run from its saved state "
                    "(``world_service.resume``)")] = 0
    rovers_lost: Annotated[Tally, Meta(description="rovers whose agents say they do not know where they are")] = 0
    lander_map_lost: Annotated[bool, Meta(
        description="the lander joined the run under way without its saved state")] = False


class WorldState(Message, kw_only=True):
    """Ground truth at the perception rate; the mission statistics are computed from this stream alone
    (``world_service.outcome.statistics.MissionStats``), live and from a recording alike."""

    stamp: Seconds
    rovers: Annotated[list[RoverTruth], Meta(max_length=MAX_ROVERS)]
    comm_links: Annotated[list[tuple[RoverId, RoverId]], Meta(max_length=MAX_TARGETS ** 2 // 2)] = field(
        default_factory=list)
    relays: Annotated[list[RoverId], Meta(
        max_length=MAX_TARGETS, description="rovers relaying for others: the daisy chain")] = field(
        default_factory=list)
    counters: WorldCounters = field(default_factory=WorldCounters)
    completed_at: Annotated[Finite | None, Meta(description="when every rover had finished, if they have")] = None


class MissionReport(Message, kw_only=True):
    """Statistics of report 3.4.7: the fields of ``report.json``."""

    scenario: str
    seed: int
    relative_path_length_m: Finite
    average_distance_covered_m: Finite
    average_path_efficiency: Annotated[Finite, Meta(
        description="the report's: relative path length over the average distance covered, over every rover; "
                    "above 1 when rovers stopped short")]
    reached_path_efficiency: Annotated[Finite | None, Meta(
        description="mean over the rovers that reached their final goal, relays aside, of each one's ideal "
                    "path over the distance it covered (at most about 1); None when none did")] = None
    total_distance_covered_m: Finite
    rovers_reached_final_goal: int
    rovers_total: int
    rover_collisions: int
    obstacle_collisions: int
    rovers_stuck: int
    rovers_holding_relay_spots: Annotated[int, Meta(
        description="rovers on a daisy-chain spot at the end: the lander sent them there instead of to the "
                    "final goal, so they count as not reached")] = 0
    rovers_stalled: Annotated[int, Meta(
        description="of rovers_stuck: those the world counted stuck because they made no progress, while "
                    "their agents did not say so")] = 0
    mission_duration_s: Finite
    wall_time_s: Annotated[Finite | None, Meta(
        description="wall-clock seconds of the run by the launcher's stopwatch; null in a report rebuilt from "
                    "a recording, which has no wall clock")] = None
    complete: bool = False
    rejected_messages: int = 0
    agent_rejected_messages: Annotated[int, Meta(description="samples the agents and the lander rejected")] = 0
    dropped_messages: Annotated[int, Meta(description="samples the world dropped unread (over its inbox's bound)")] = 0
    world_resumes: Annotated[int, Meta(
        description="times the world was restarted mid-mission and resumed this run from its saved state; "
                    "rovers may have lost up to a second of motion each time")] = 0
    rovers_lost: Annotated[int, Meta(
        description="rovers whose agents said at the end that they did not know where they were (restarted "
                    "without their state, or the world began a new run under them)")] = 0
    lander_map_lost: Annotated[bool, Meta(
        description="the lander was restarted mid-mission without its saved state: its plan and traverse map "
                    "began again, and the map figures miss what came before")] = False
    lander_connection_losses: Annotated[int, Meta(description="times a rover lost its route to the lander (6.3.3)")] = 0
    disconnected_time_s: Annotated[Finite, Meta(description="rover-seconds without a route to the lander")] = 0.0
    worst_rover_connected_fraction: Annotated[Finite, Meta(
        description="share of the mission the least connected rover had a route to the lander")] = 1.0
    max_rovers_in_daisy_chain: Annotated[int, Meta(description="most rovers relaying for others at one time")] = 0
    radio_dropped: Annotated[int, Meta(description="transmissions whose target was out of reach")] = 0
    radio_lost: Annotated[int, Meta(description="transmissions lost to the configured loss probability")] = 0
    map_corridor_mapped: Annotated[Finite | None, Meta(
        description="share of the A-B corridor's cells the lander's map knows "
                    "(world_service.outcome.map_truth); None: no map")] = None
    map_obstacles_found: Annotated[Finite | None, Meta(
        description="share of the corridor's obstacle cells the map marks as obstacle (within the match "
                    "tolerance)")] = None
    map_obstacle_precision: Annotated[Finite | None, Meta(
        description="share of the map's obstacle cells that are obstacles in truth (within the match "
                    "tolerance)")] = None
    power_budget_efficiency: Annotated[Finite | None, Meta(
        description="energy the goal progress made needed at best / energy drawn (6.3.3); None without sun")] = None
    energy_used_wh: Annotated[Finite | None, Meta(description="drawn from every battery together")] = None
    power_shutdowns: Annotated[int | None, Meta(description="times a battery ran empty (None without sun)")] = None
    cold_shutdowns: Annotated[int | None, Meta(
        description="times a rover got too cold to run (None without sun)")] = None


class WorldStats(Message, kw_only=True):
    stamp: Finite
    report: MissionReport
    final: bool = False
