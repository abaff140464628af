"""What a rover behaviour is to the rover agent: what it sees (``View``), what it may decide, and ``BaseBehaviour``.

Kept apart from the default behaviour so that its rules (``rover_agent.rules``), the agent's parts and user
behaviours build on the interface alone (report 4.4: any behaviour that keeps the interface will do).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from schemas.params import RoverParams
from shared.hit import Hit
from shared.pose import Pose


@dataclass(frozen=True)
class Goal:
    index: int
    total: int
    kind: str
    x: float  # lander frame
    z: float
    station: tuple[float, float] | None = None  # this rover's spot at a shared goal, offset from it
    shared: bool = False  # a waypoint or crater the team shares: the lander gives out stations on request
    relayed: bool = False  # a daisy chain stands for this goal: the radio route runs through relays before it
    rim: tuple[float, float, float] | None = None  # a crater goal's crater: centre (lander frame), terrain's radius

    @property
    def final(self) -> bool:
        return self.index >= self.total - 1

    @property
    def target(self) -> tuple[float, float]:
        """Where to walk: the goal, or this rover's station at it."""
        if self.station is None:
            return self.x, self.z
        return self.x + self.station[0], self.z + self.station[1]


@dataclass(frozen=True)
class View:
    time: float
    pose: Pose
    goal: Goal
    hits: tuple[Hit, ...]
    pitch_deg: float
    battery: float | None = None  # charge as a share of capacity; None: no power sensors (no sun in the world)
    sunlit: bool | None = None  # whether the solar panel is lit
    position_std_m: float = 0.0  # how far off ``pose`` may be: its 1-sigma position error (0 without noise)
    remaining_m: float = 0.0  # asked during a move (``should_cancel``): metres it still has to go, once under way

    def toward(self, x: float, z: float) -> View:
        """This view with its goal swapped for a spot of the rover's own on the way (sunlight, the foot of a crest
        station's spoke, the way out of a crater's bowl): a plain waypoint, which no teammate shares."""
        return replace(self, goal=Goal(self.goal.index, self.goal.total, "waypoint", x, z))


@dataclass(frozen=True)
class MoveTo:
    x: float
    z: float
    slow: bool = field(default=False, repr=False)  # at the lowest speed level: among rovers at close quarters


@dataclass(frozen=True)
class Rotate:
    degrees: float


@dataclass(frozen=True)
class Hold:
    until: float


@dataclass(frozen=True)
class Finish:
    outcome: str  # "reached" | "stuck" | "relay" (holding a daisy-chain spot)
    why: str = field(default="", compare=False)  # for "stuck": what stopped it, shown in the rover's status


@dataclass(frozen=True)
class TakePhoto:
    label: str


Decision = MoveTo | Rotate | Hold | TakePhoto | Finish


class BaseBehaviour:
    """What a rover behaviour is to the agent (report 4.4: any behaviour that keeps the interface will do).

    Write your own by subclassing this and implementing ``decide``; select it by name in the scenario
    (``behaviour: my_package.module:MyBehaviour``) or with ``lunarsim rover --behaviour``, and check it with
    ``lunarsim check-behaviour``. The agent owns all I/O and keeps one action in flight:

    - ``decide(view)`` is called with fresh sensor data whenever no action is running. Return ``MoveTo``
      (rover-relative, in view and within the perception radius), ``Rotate``, ``TakePhoto``, ``Hold`` (do
      nothing until a time) or ``Finish("reached" | "stuck")`` for the current goal.
    - ``should_cancel(view)`` is asked on every perception while a move runs.
    - the event hooks below say what happened to the last action; the defaults ignore them.
    ``state`` is shown to the ground (one of the ``RoverState`` names of schemas.messages).
    """

    name = "base"

    def __init__(self, rover_id: int, params: RoverParams) -> None:
        self.rover_id = rover_id
        self.params = params
        self.state = "waiting"

    def decide(self, view: View) -> Decision:
        raise NotImplementedError

    def should_cancel(self, view: View) -> bool:
        return False

    def start_goal(self, goal: Goal) -> None:
        self.state = "migration"

    def moved(self, distance: float) -> None:
        """A move ended (completed or cut short) after ``distance`` metres."""

    def rejected(self, relative_angle: float) -> None:
        """The rover refused a move in this direction (blocked, out of view or range)."""

    def cancelled(self, now: float) -> None:
        """A move this behaviour cancelled has come to a stop."""
