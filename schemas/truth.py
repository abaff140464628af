"""Ground truth and the mission statistics: what the world publishes for viewers, the recorder and the statistics
(``world/state``, ``world/stats``), and never sends to an agent (report 9.1)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from schemas.base import Message, RoverState
from schemas.scenario_limits import MAX_ROVERS
from schemas.wire_limits import MAX_TARGETS, RoverId, Seconds, Tally


class RoverTruth(Message):
    """Ground truth of one rover: for viewers, recorder and statistics, never for agents."""

    id: RoverId
    x: float
    z: float
    heading_deg: float
    action: Literal["idle", "move", "rotate", "cancel"]
    state: RoverState
    goal_index: int
    distance_to_goal_m: float
    distance_covered_m: float
    alive: bool
    telemetry_stale: bool = Field(False, description="twin mode: the rover's driver has gone quiet; this is its "
                                                     "last known pose")
    battery_wh: float | None = Field(None, description="charge; None when the scenario has no sun (no power model)")
    temperature_c: float | None = None
    sunlit: bool | None = None
    energy_used_wh: float | None = Field(None, description="drawn from the battery since the start")
    powered: bool | None = Field(None, description="False while off: battery empty or too cold")
    stalled: bool = Field(False, description="no closer to its goal for the stall time: counted stuck, whatever its "
                          "agent says (world_service.outcome.progress)")


class WorldCounters(Message):
    """Events the world has counted since the start: ground truth a recording must carry for its statistics."""

    rover_collisions: Tally = 0
    obstacle_collisions: Tally = 0
    rejected_messages: Tally = 0
    radio_dropped: Tally = 0
    radio_lost: Tally = 0
    power_shutdowns: Tally = Field(0, description="times a rover's battery ran empty")
    cold_shutdowns: Tally = Field(0, description="times a rover fell below its operating temperature (N9)")
    agent_rejected: Tally = Field(0, description="samples the rover agents and the lander rejected, as their statuses "
                                "last said")
    dropped_messages: Tally = Field(0, description="samples the world dropped unread: over its inbox's bound for "
                                  "their key (a flood)")
    world_resumes: Tally = Field(0, description="times the world service was restarted and resumed this run from "
                                 "its saved state (``world_service.resume``)")
    rovers_lost: Tally = Field(0, description="rovers whose agents say they do not know where they are")
    lander_map_lost: bool = Field(False, description="the lander joined the run under way without its saved state")


class WorldState(Message):
    """Ground truth at the perception rate; the mission statistics are computed from this stream alone
    (``world_service.outcome.statistics.MissionStats``), live and from a recording alike."""

    stamp: Seconds
    rovers: list[RoverTruth] = Field(max_length=MAX_ROVERS)
    comm_links: list[tuple[RoverId, RoverId]] = Field(default_factory=list, max_length=MAX_TARGETS ** 2 // 2)
    relays: list[RoverId] = Field(default_factory=list, max_length=MAX_TARGETS,
                                  description="rovers relaying for others: the daisy chain")
    counters: WorldCounters = WorldCounters()
    completed_at: float | None = Field(None, description="when every rover had finished, if they have")


class MissionReport(Message):
    """Statistics of report 3.4.7: the fields of ``report.json``."""

    scenario: str
    seed: int
    relative_path_length_m: float
    average_distance_covered_m: float
    average_path_efficiency: float = Field(description="the report's: relative path length over the average "
                                           "distance covered, over every rover; above 1 when rovers stopped short")
    reached_path_efficiency: float | None = Field(None, description="mean over the rovers that reached their final "
                                                  "goal, relays aside, of each one's ideal path over the distance "
                                                  "it covered (at most about 1); None when none did")
    total_distance_covered_m: float
    rovers_reached_final_goal: int
    rovers_total: int
    rover_collisions: int
    obstacle_collisions: int
    rovers_stuck: int
    rovers_holding_relay_spots: int = Field(0, description="rovers on a daisy-chain spot at the end: the lander sent "
                                            "them there instead of to the final goal, so they count as not reached")
    rovers_stalled: int = Field(0, description="of rovers_stuck: those the world counted stuck because they made "
                                "no progress, while their agents did not say so")
    mission_duration_s: float
    wall_time_s: float | None = Field(None, description="wall-clock seconds of the run by the launcher's stopwatch; "
                                      "null in a report rebuilt from a recording, which has no wall clock")
    complete: bool = False
    rejected_messages: int = 0
    agent_rejected_messages: int = Field(0, description="samples the agents and the lander rejected")
    dropped_messages: int = Field(0, description="samples the world dropped unread (over its inbox's bound)")
    world_resumes: int = Field(0, description="times the world was restarted mid-mission and resumed this run from "
                               "its saved state; rovers may have lost up to a second of motion each time")
    rovers_lost: int = Field(0, description="rovers whose agents said at the end that they did not know where they "
                             "were (restarted without their state, or the world began a new run under them)")
    lander_map_lost: bool = Field(False, description="the lander was restarted mid-mission without its saved state: "
                                  "its plan and traverse map began again, and the map figures miss what came before")
    lander_connection_losses: int = Field(0, description="times a rover lost its route to the lander (6.3.3)")
    disconnected_time_s: float = Field(0.0, description="rover-seconds without a route to the lander")
    worst_rover_connected_fraction: float = Field(1.0, description="share of the mission the least connected "
                                                                   "rover had a route to the lander")
    max_rovers_in_daisy_chain: int = Field(0, description="most rovers relaying for others at one time")
    radio_dropped: int = Field(0, description="transmissions whose target was out of reach")
    radio_lost: int = Field(0, description="transmissions lost to the configured loss probability")
    map_corridor_mapped: float | None = Field(None, description="share of the A-B corridor's cells the lander's "
                                              "map knows (world_service.outcome.map_truth); None: no map")
    map_obstacles_found: float | None = Field(None, description="share of the corridor's obstacle cells the map "
                                              "marks as obstacle (within the match tolerance)")
    map_obstacle_precision: float | None = Field(None, description="share of the map's obstacle cells that are "
                                                 "obstacles in truth (within the match tolerance)")
    power_budget_efficiency: float | None = Field(
        None, description="energy the goal progress made needed at best / energy drawn (6.3.3); None without sun")
    energy_used_wh: float | None = Field(None, description="drawn from every battery together")
    power_shutdowns: int | None = Field(None, description="times a battery ran empty (None without sun)")
    cold_shutdowns: int | None = Field(None, description="times a rover got too cold to run (None without sun)")


class WorldStats(Message):
    stamp: float
    report: MissionReport
    final: bool = False
