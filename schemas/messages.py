"""Message models of the rover interface (report section 10) and of the LunarSim additions.

One model per key; the key names the type (see ``TOPIC_MODELS``). Ground truth and the mission statistics,
which no agent ever receives, are defined in ``schemas.truth``, the lander's and the ground's messages in
``schemas.ground`` (both importable from here). Conventions follow
the report: metres, an x/z ground plane, headings in degrees with 0 = +z and 90 = +x, positive rotation to the
right. Rover-relative coordinates: +z straight ahead, +x to the right. Times are simulation seconds.
"""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta

from schemas import keyspace as ks
from schemas.base import HIT_KINDS, DirectionKind, GoalKind, HitKind, Message, RoverState
from schemas.estimate import EstimatedPose
from schemas.ground import (
    MISSION_COMMANDS,
    PLAYBACK_COMMANDS,
    RECORDER_COMMANDS,
    CommandResult,
    GroundCommand,
    LanderMap,
    LanderStatus,
)
from schemas.truth import MissionReport, RoverTruth, WorldCounters, WorldState, WorldStats
from schemas.wire_limits import (
    INDEX_LIMIT,
    MAX_PNG_BYTES,
    MAX_RADIO_PAYLOAD,
    MAX_RAYS,
    ActionId,
    Coordinate,
    Count,
    Degrees,
    Distance,
    Finite,
    GoalCount,
    GoalIndex,
    Label,
    Metres,
    RoverId,
    RoverIds,
    Seconds,
    Stamp,
    Text,
    Tick,
    finite,
)

__all__ = ["HIT_KINDS", "MISSION_COMMANDS", "PLAYBACK_COMMANDS", "RECORDER_COMMANDS", "CommandResult", "DirectionKind",
           "EstimatedPose", "GoalKind", "GroundCommand", "HitKind", "LanderMap", "LanderStatus", "Message",
           "MissionReport", "RoverState", "RoverTruth", "WorldCounters", "WorldState", "WorldStats"]
"""Re-exported: every payload is ``schemas.messages.X`` to its users, wherever it is defined."""

Out = tuple[str, Message]
"""One sample a process publishes: its key and its message. What every pure core (world, lander, rover agent)
returns for its loop to publish."""

# ---- perception, navigation, gyroscope (report 10.1-10.3) ----


class Perception(Message, kw_only=True):
    """PerceptionData: one scan of rays; columns rather than a list of hit objects to keep decoding cheap."""

    stamp: Seconds
    angles_deg: Annotated[list[Degrees], Meta(max_length=MAX_RAYS, description="angle of each hit relative to the "
                                              "rover, negative left")]
    distances_m: Annotated[list[Metres], Meta(max_length=MAX_RAYS)]
    kinds: Annotated[list[HitKind], Meta(max_length=MAX_RAYS)]

    def __post_init__(self) -> None:
        if not len(self.angles_deg) == len(self.distances_m) == len(self.kinds):
            raise ValueError("angles_deg, distances_m and kinds must have the same length")


AgentActionId = Annotated[ActionId, Meta(description="the agent's id of the action (0: none): the world answers a "
                                         "repeated id with how that action stands instead of starting it again, so "
                                         "a lost sample is recovered by sending the same action again")]


class MoveAction(Message, kw_only=True):
    """Move to a point relative to the rover (+x right, +z ahead); must be in view."""

    x: Metres
    z: Metres
    action_id: AgentActionId = 0


class RotateAction(Message, kw_only=True):
    """Rotate in place; negative is left, positive right."""

    degrees: Degrees
    action_id: AgentActionId = 0


class NavigationStatus(Message, kw_only=True):
    """Metres (move) or degrees (rotate) still to go; the last one of an action has remaining 0."""

    stamp: Seconds
    action: Literal["move", "rotate"]
    remaining: Metres
    outcome: Literal["running", "completed", "cancelled", "collided"] = "running"
    action_id: AgentActionId = 0


class CancelAction(Message, kw_only=True):
    """Cancel the move in progress (empty in the report; ``action_id`` names it, 0 whichever is running)."""

    action_id: AgentActionId = 0


class CancelResult(Message, kw_only=True):
    """Where the rover stopped, relative to the start of the move that ended early."""

    x: Metres
    z: Metres
    angle_deg: Degrees
    reason: Literal["cancelled", "collided"] = "cancelled"
    action_id: AgentActionId = 0


class SpeedAction(Message, kw_only=True):
    level: Annotated[int, Meta(ge=1, le=3)]


class ActionRejected(Message, kw_only=True):
    """New in LunarSim: why an action was refused, so a behaviour never waits for nothing."""

    action: Literal["move", "rotate", "cancel", "speed", "photo"]
    reason: Literal["out_of_view", "out_of_range", "blocked", "action_in_progress", "no_action", "collided",
                    "no_power", "too_cold", "stale", "out_of_sequence"]
    detail: Text = ""
    action_id: AgentActionId = 0


class Gyroscope(Message, kw_only=True):
    """The rover's inertial sensors: pitch, and with a sun sensor (``PerceptionParams.sun_sensor``) the heading."""

    stamp: Seconds
    pitch_deg: Annotated[Degrees, Meta(description="positive nose up")]
    heading_deg: Annotated[Degrees | None, Meta(description="the sun sensor's heading in the lander frame (0 = +z, "
                                                "90 = +x), with its noise; none without a sun sensor")] = None


# ---- power (report 7.1.2, needs N9 and N10) ----


class Battery(Message, kw_only=True):
    """The rover's battery monitor. ``empty``: the rover is off until it has recharged above its threshold."""

    stamp: Seconds
    charge_wh: Annotated[float, finite(ge=0)]
    capacity_wh: Annotated[float, finite(gt=0)]
    solar_w: Annotated[float, finite(ge=0, description="what the panel delivers now")] = 0.0
    empty: bool = False

    @property
    def fraction(self) -> float:
        return self.charge_wh / self.capacity_wh


class Temperature(Message, kw_only=True):
    """The rover's internal temperature. ``shutdown``: below its operating minimum, off until warm again (N9)."""

    stamp: Seconds
    celsius: Finite
    shutdown: bool = False


class Sunlight(Message, kw_only=True):
    """Whether the rover's solar panel is lit (its sun sensor)."""

    stamp: Seconds
    lit: bool


# ---- radio (report 10.4) ----

RadioChannel = Literal["comm_in", "mission_direction", "calibration"]


class OutboundComm(Message, kw_only=True):
    """A radio transmission. ``channel`` says which key of the target it lands on; the payload is opaque."""

    targets: RoverIds
    payload: Annotated[bytes, Meta(max_length=MAX_RADIO_PAYLOAD)]
    channel: RadioChannel = "comm_in"


class InboundComm(Message, kw_only=True):
    sender: RoverId
    payload: Annotated[bytes, Meta(max_length=MAX_RADIO_PAYLOAD)]


class CommPartners(Message, kw_only=True):
    """Ids in direct radio range and line of sight (0 is the lander)."""

    ids: RoverIds


class GoalPlace(Message, kw_only=True):
    """A goal's kind and place, as a mission direction gives them: bearing and distance from the lander."""

    kind: GoalKind
    bearing_deg: Degrees
    distance_m: Distance


class MissionDirection(Message, kw_only=True):
    """Where the lander sends a rover now: bearing and distance from the lander (report 10.4.3).

    Usually the rover's current mission goal; ``kind == "relay"`` sends it to hold a daisy-chain spot. At a
    waypoint or crater the team shares (``shared``), the rover asks for its own spot there when it comes near
    (``radio.StationRequest``), and the lander's answer carries it in ``station`` (``lander_agent.stations``):
    in formation round a waypoint, on the crest round a crater.
    """

    goal_index: GoalIndex
    goals_total: GoalCount
    kind: DirectionKind
    bearing_deg: Degrees
    distance_m: Distance
    station: Annotated[tuple[Metres, Metres] | None, Meta(
        description="offset (x, z) in metres from the goal, lander axes, of this rover's spot at it")] = None
    shared: Annotated[bool, Meta(description="a waypoint or crater the team shares: ask the lander for a station "
                                 "near it")] = False
    relayed: Annotated[bool, Meta(description="a daisy chain stands for this goal: the rover's radio route to the "
                                  "lander runs through relays holding on the way to it")] = False
    relay_for: Annotated[GoalPlace | None, Meta(description="for a relay: the goal it holds the route for, which it "
                                                "walks on to at the last goal once cut off from the lander")] = None
    rim: Annotated[tuple[Metres, Metres, Distance] | None, Meta(
        description="at a crater goal, the crater as the mission plan has it: its centre's offset (x, z) in metres "
        "from the goal, lander axes, and the radius at which its terrain begins (the outer foot of the rim)")] = None


class Calibration(Message, kw_only=True):
    """Where the lander set the rover down (dispatch), relative to the lander: the origin of dead reckoning."""

    x: Coordinate
    z: Coordinate
    heading_deg: Degrees


# ---- observation (report 10.5) ----


class PhotoAction(Message, kw_only=True):
    label: Label = ""
    action_id: AgentActionId = 0


class Photo(Message, kw_only=True):
    stamp: Seconds
    label: Label = ""
    png: Annotated[bytes, Meta(max_length=MAX_PNG_BYTES)]


# ---- agent telemetry and the world's clock (the lander's and the ground's: ``schemas.ground``) ----



class RoverStatus(Message, kw_only=True):
    """Agent telemetry for the ground and viewers: what the behaviour is doing."""

    stamp: Seconds
    state: RoverState
    goal_index: Annotated[int, Meta(ge=-1, lt=INDEX_LIMIT)] = -1
    detail: Text = ""
    photos_pending: Annotated[Count, Meta(description="photos taken but not yet acknowledged by the lander")] = 0
    action_id: Annotated[ActionId, Meta(description="the last action whose end the agent has heard: the world "
                                        "re-sends that end until it shows here")] = 0
    lost: Annotated[bool, Meta(description="the agent does not know where it is (restarted without a saved pose of "
                               "this run, or the world began a new run under it), so it does not drive")] = False
    rejected: Annotated[Count, Meta(description="samples the agent has rejected since it started (malformed, "
                                    "unknown topic)")] = 0


class Clock(Message, kw_only=True):
    tick: Tick
    sim_time: Stamp
    time_scale: Annotated[float, Meta(ge=0, le=1e6)]
    running: bool = True
    lockstep: bool = False
    run: Annotated[Label, Meta(description="names this run of the world: a restarted agent resumes only a state "
                               "saved in the same run")] = ""
    acks: Annotated[RoverIds | None, Meta(description="lockstep: the agents whose ack this tick waits for (rover "
                                          "ids, 0 the lander); None: every agent's")] = None


class Telemetry(Message, kw_only=True):
    """A real rover's own estimate of its pose (wheel odometry and IMU heading), relative to where its driver
    started: the driver bridge publishes it and the world service in twin mode places it on the map from the
    scenario's start pose. Rover agents never read it: they dead-reckon, as in simulation."""

    stamp: Seconds
    x: Coordinate
    z: Coordinate
    heading_deg: Degrees
    pitch_deg: Degrees = 0.0
    moving: bool = False


class RoverIdGrant(Message, kw_only=True):
    """The world's answer to ``--id auto``: the lowest scenario rover id no running agent holds, or why none."""

    id: RoverId | None
    detail: Text = ""


class Ack(Message, kw_only=True):
    """Lockstep: everything up to and including this tick has been handled (and answered)."""

    tick: Tick
    wake: Annotated[Seconds | None, Meta(description="simulated time at which the agent will next act on its own "
                                         "timers; None: it may act on any tick")] = None


TOPIC_MODELS: dict[str, type[Message]] = {
    ks.PERCEPTION: Perception,
    ks.MOVE_ACTION: MoveAction,
    ks.ROTATE_ACTION: RotateAction,
    ks.NAVIGATION_STATUS: NavigationStatus,
    ks.CANCEL_ACTION: CancelAction,
    ks.CANCEL_RESULT: CancelResult,
    ks.SPEED_ACTION: SpeedAction,
    ks.ACTION_REJECTED: ActionRejected,
    ks.GYROSCOPE: Gyroscope,
    ks.COMM_OUT: OutboundComm,
    ks.COMM_IN: InboundComm,
    ks.COMM_PARTNERS: CommPartners,
    ks.MISSION_DIRECTION: MissionDirection,
    ks.CALIBRATION: Calibration,
    ks.PHOTO_ACTION: PhotoAction,
    ks.PHOTO: Photo,
    ks.STATUS: RoverStatus,
    ks.ACK: Ack,
    ks.TELEMETRY: Telemetry,
    ks.POSE_ESTIMATE: EstimatedPose,
    ks.BATTERY: Battery,
    ks.TEMPERATURE: Temperature,
    ks.SUN: Sunlight,
}
"""Rover topic -> payload model: the one table that says which type travels on which key."""

RADIO_CHANNEL_MODELS: dict[str, type[Message]] = {
    "mission_direction": MissionDirection,
    "calibration": Calibration,
}
"""Radio channels other than comm_in carry an encoded message of a fixed type, checked by the radio."""

LANDER_TOPIC_MODELS: dict[str, type[Message]] = {
    ks.COMM_OUT: OutboundComm,
    ks.COMM_IN: InboundComm,
    ks.COMM_PARTNERS: CommPartners,
    ks.STATUS: LanderStatus,
    ks.ACK: Ack,
    ks.MAP: LanderMap,
}
WORLD_TOPIC_MODELS: dict[str, type[Message]] = {ks.CLOCK: Clock, ks.STATE: WorldState, ks.STATS: WorldStats,
                                                 ks.ROVER_IDS: RoverIdGrant}
GROUND_TOPIC_MODELS: dict[str, type[Message]] = {ks.COMMAND: GroundCommand, ks.COMMAND_RESULT: CommandResult}
_AREA_MODELS = {"lander": LANDER_TOPIC_MODELS, "world": WORLD_TOPIC_MODELS, "ground": GROUND_TOPIC_MODELS}


def model_for_key(key: str) -> type[Message] | None:
    """The payload model of any key ``lunar/<world>/...``; None for keys that carry no message (liveliness)."""
    parts = key.split("/")
    if len(parts) == 5 and parts[0] == ks.ROOT and parts[2] == "rover":
        return TOPIC_MODELS.get(parts[4])
    if len(parts) == 4 and parts[0] == ks.ROOT:
        return _AREA_MODELS.get(parts[2], {}).get(parts[3])
    return None
