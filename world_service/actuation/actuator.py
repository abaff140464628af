"""The rovers' bodies and what their agents ask of them (report 10.2): a move, rotate, cancel, speed or photo
action checked against what the rover can do and where it stands, then started, answered or refused; every busy
body stepped each tick, stopped short where it would touch something, and its action's end told to its agent.

The action ledger (``ledger``) makes the protocol survive lost samples; the checks and the noise are ``checks``,
collisions ``contacts``, the kinematics ``navigation``.
"""

from __future__ import annotations

import logging
from typing import Protocol

import numpy as np

from bus.rejections import Rejections
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from world_service.actuation import checks
from world_service.actuation import navigation as nav
from world_service.actuation.contacts import contacts
from world_service.actuation.ledger import REFUSED_KINDS, ActionLedger, ActionRecord
from world_service.camera.shutter import Shutter
from world_service.clock import Clock
from world_service.scene import Scene
from world_service.terrain.heightmap import Heightmap
from world_service.terrain.pitch import RoverPitch

log = logging.getLogger("lunarsim.world")
ACTION_RESEND_S = 1.0
"""How often the world re-sends the end of a rover's last action until its agent's status says it has heard it."""
ACTION_ID_PROBLEMS = {"stale": "older than the rover's latest action",
                      "out_of_sequence": "beyond any id its agent can have taken by now"}


class PowerGate(Protocol):
    """What actuation asks of the rovers' power (``power.energy.Energy``): whether a rover may act, and the energy
    a photo costs."""

    def refusal(self, rid: int) -> tuple[str, str] | None: ...

    def spend(self, rid: int, joules: float) -> None: ...


def action_name(body: nav.RoverBody) -> str:
    """What the rover is doing, as ground truth says it."""
    if isinstance(body.action, nav.Move):
        return "cancel" if body.action.cancelling else "move"
    return "rotate" if isinstance(body.action, nav.Rotate) else "idle"


class Actuator:
    """Owns the bodies, whether each rover's agent is there (``alive``), the action ledger and the contact counts.

    ``rng`` is the world's own generator, shared with the sensors: the order of all draws is part of a run.
    """

    def __init__(self, scenario: Scenario, keys: ks.Keyspace, clock: Clock, terrain: Heightmap, scene: Scene,
                 rng: np.random.Generator, rejected: Rejections, shutter: Shutter, power: PowerGate | None,
                 pitch: RoverPitch) -> None:
        self.keys, self.clock, self.rng, self.rejected = keys, clock, rng, rejected
        self.pitch = pitch  # shared with the gyroscopes, which ask about the same poses
        self.params = p = scenario.rover_params
        self.terrain, self.scene = terrain, scene
        self.shutter, self.power = shutter, power
        self.status_period = clock.period(p.navigation.publish_frequency)  # a busy rover's navigation status
        self.bodies = {i + 1: nav.RoverBody(i + 1, r.x, r.z, r.heading_deg % 360.0)
                       for i, r in enumerate(scenario.rovers)}
        self.alive = dict.fromkeys(self.bodies, True)
        self.ledger = ActionLedger(clock.period(1.0 / ACTION_RESEND_S))
        self.rover_collisions = 0
        self.obstacle_collisions = 0
        self.refusals_held = 0
        self._refused_on: dict[int, int] = {}  # rover -> the tick its last refusal was answered on
        self._positions: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    # ---- the agents' actions ----

    def move(self, rid: int, msg: m.MoveAction) -> list[Out]:
        if (record := self.ledger.known(rid, msg.action_id, self.clock.sim_time)) is not None:
            return self._again(rid, record, "move")
        body = self.bodies[rid]
        reason = self._power_problem(rid) or checks.move_problem(body, msg, self.params, self.scene, self.terrain,
                                                                 self._other_positions)
        if reason:
            return self._refuse(rid, "move", msg.action_id, *reason)
        slip, turn = checks.move_noise(self.rng, self.params.navigation, msg.x, msg.z)
        body.start_move(msg.x, msg.z, slip, turn)
        self.ledger.start(rid, msg.action_id, "move", self.clock.tick)
        return [self._nav_status(body, "move")]

    def rotate(self, rid: int, msg: m.RotateAction) -> list[Out]:
        if (record := self.ledger.known(rid, msg.action_id, self.clock.sim_time)) is not None:
            return self._again(rid, record, "rotate")
        body = self.bodies[rid]
        if body.busy:
            return self._refuse(rid, "rotate", msg.action_id, "action_in_progress",
                                "a move or rotate is still running")
        if reason := self._power_problem(rid):
            return self._refuse(rid, "rotate", msg.action_id, *reason)
        body.start_rotate(msg.degrees + checks.rotation_noise(self.rng, self.params.navigation))
        self.ledger.start(rid, msg.action_id, "rotate", self.clock.tick)
        return [self._nav_status(body, "rotate")]

    def cancel(self, rid: int, msg: m.CancelAction) -> list[Out]:
        """Cancel the running action; a cancel naming an action that has already ended gets that end again."""
        body = self.bodies[rid]
        if body.busy and msg.action_id in (0, self.ledger.running_id(rid)):
            body.cancel()
            return []
        record = self.ledger.started.get(rid)
        if msg.action_id and record is not None and record.action_id == msg.action_id and record.answer:
            return list(record.answer)
        self.ledger.cancelled_unseen(rid, msg.action_id, self.clock.sim_time)
        return [self._reject(rid, "cancel", "no_action", "nothing to cancel", msg.action_id)]

    def speed(self, rid: int, msg: m.SpeedAction) -> list[Out]:
        self.bodies[rid].speed_level = msg.level
        return []

    def photo(self, rid: int, msg: m.PhotoAction) -> list[Out]:
        """Queue a photo of what the rover sees now (``Shutter``)."""
        clock = self.clock
        if (record := self.ledger.known(rid, msg.action_id, clock.sim_time)) is not None:
            # taken already: the photo is on its way (or lost, and the agent gives up on it in time)
            return self._again(rid, record, "photo") if record.kind in REFUSED_KINDS else []
        if reason := self._power_problem(rid):
            return self._refuse(rid, "photo", msg.action_id, *reason)
        if self.shutter.busy(rid, clock.tick):
            return self._refuse(rid, "photo", msg.action_id, "action_in_progress",
                                "the camera is still taking the last photo")
        body = self.bodies[rid]
        self.ledger.start(rid, msg.action_id, "photo", clock.tick)
        if self.power is not None:
            self.power.spend(rid, self.params.power.photo_j)
        others = [b for b in self.bodies.values() if b.id != rid]
        self.shutter.shoot(rid, msg.label, clock.tick, clock.sim_time, (body.x, body.z, body.heading),
                           np.array([b.x for b in others]), np.array([b.z for b in others]))
        return []

    def _again(self, rid: int, record: ActionRecord, action: str) -> list[Out]:
        """An action sent again (its agent heard nothing of it): how it stands, never a second start. One whose id
        is stale or from the future is refused, and counted as any other rejected sample."""
        if record.kind in REFUSED_KINDS:
            detail = ACTION_ID_PROBLEMS[record.kind]
            self.rejected.count(f"{action}_action", f"action id {record.action_id}: {detail}")
            return [self._reject(rid, action, record.kind, detail, record.action_id)]
        if record.answer is not None:
            return list(record.answer)
        body = self.bodies[rid]
        return [self._nav_status(body, record.kind)] if body.busy and record.kind != "photo" else []

    def _power_problem(self, rid: int) -> tuple[str, str] | None:
        return self.power.refusal(rid) if self.power is not None else None

    def _reject(self, rid: int, action: str, reason: str, detail: str, action_id: int = 0) -> Out:
        return self.keys.rover(rid, ks.ACTION_REJECTED), m.ActionRejected(action=action, reason=reason, detail=detail,
                                                                          action_id=action_id)

    def _refuse(self, rid: int, action: str, action_id: int, reason: str, detail: str) -> list[Out]:
        """A refusal the ledger keeps, so the same action sent again gets the same answer; answered at most once
        a tick per rover, so a client flooding a rover's actions is not answered at its own rate (an agent whose
        answer this holds back asks again and gets it from the ledger)."""
        answer = self._reject(rid, action, reason, detail, action_id)
        self.ledger.refuse(rid, action_id, action, answer)
        if self._refused_on.get(rid) == self.clock.tick:
            self.refusals_held += 1
            return []
        self._refused_on[rid] = self.clock.tick
        return [answer]

    def _other_positions(self, rid: int) -> tuple[np.ndarray, np.ndarray]:
        """Every other rover's position; the arrays are built once per tick, however many moves are checked."""
        if self._positions is None:
            self._positions = (np.array(list(self.bodies)), np.array([b.x for b in self.bodies.values()]),
                               np.array([b.z for b in self.bodies.values()]))
        ids, xs, zs = self._positions
        others = ids != rid
        return xs[others], zs[others]

    # ---- the agents' presence ----

    def set_alive(self, rid: int, alive: bool) -> None:
        """A rover whose agent is gone stops where it is. When it comes back, the ledger re-sends how its action
        ended until it has heard."""
        self.alive[rid] = alive
        if not alive:
            self.bodies[rid].cancel()

    def resumed(self) -> None:
        """Loaded from a saved state: every agent counts as gone until its liveliness token shows again."""
        self.alive = dict.fromkeys(self.bodies, False)
        self._positions = None

    def stop(self, rid: int) -> None:
        """The rover has lost its power: its action ends where it stands."""
        self.bodies[rid].cancel()

    def note_heard(self, rid: int, action_id: int) -> None:
        self.ledger.note_heard(rid, action_id)

    # ---- time ----

    def step(self) -> list[Out]:
        """Step every busy rover, then stop short, as one batch, those that would touch something."""
        active = [b for b in self.bodies.values() if b.busy]
        if not active:
            return []
        factors = self._slope_factors([b for b in active if isinstance(b.action, nav.Move)])
        before = {b.id: (b.x, b.z, b.distance_covered) for b in active}
        dt, navigation = self.clock.dt, self.params.navigation
        ended = {b.id: nav.step(b, dt, navigation, factors.get(b.id, 1.0)) for b in active}
        moved = [b for b in active if (b.x, b.z) != before[b.id][:2]]
        touching = contacts(moved, list(self.bodies.values()), self.scene, self.params.behaviour.rover_radius)
        self.obstacle_collisions += touching.obstacle
        self.rover_collisions += touching.rover_pairs
        for body in touching.hit:
            body.x, body.z, body.distance_covered = before[body.id]
            # a move may have ended on this very step: its start is then in its end, and the agent needs the
            # CancelResult built from it (a "collided" status without one would leave the agent waiting for ever)
            done = ended[body.id]
            start = body.action.start if body.action is not None else done.start if done else None
            body.action, body.velocity = None, 0.0
            ended[body.id] = nav.Ended("move", "collided", start)
        self._positions = None
        return [o for b in active if ended[b.id] for o in self._ended(b, ended[b.id])]

    def _slope_factors(self, moving: list[nav.RoverBody]) -> dict[int, float]:
        if not moving:
            return {}
        pitch = self.pitch.pitch_deg([b.id for b in moving],
                                     *(np.array([getattr(b, a) for b in moving]) for a in ("x", "z", "heading")))
        return dict(zip((b.id for b in moving), nav.slope_factor(pitch, self.params.navigation).tolist(),
                        strict=True))

    def _ended(self, body: nav.RoverBody, ended: nav.Ended) -> list[Out]:
        rid = body.id
        action_id = self.ledger.running_id(rid)
        status = m.NavigationStatus(stamp=self.clock.sim_time, action=ended.action, remaining=0.0,
                                    outcome=ended.outcome, action_id=action_id)
        out: list[Out] = [(self.keys.rover(rid, ks.NAVIGATION_STATUS), status)]
        if ended.outcome != "completed" and ended.start is not None:
            x, z, angle = body.relative_to_start(ended.start)
            out.append((self.keys.rover(rid, ks.CANCEL_RESULT),
                        m.CancelResult(x=x, z=z, angle_deg=angle, reason=ended.outcome, action_id=action_id)))
        self.ledger.end(rid, out)
        return out

    def statuses(self) -> list[Out]:
        """Every busy rover's navigation status, at the navigation rate."""
        if self.clock.tick % self.status_period:
            return []
        return [self._nav_status(b, "move" if isinstance(b.action, nav.Move) else "rotate")
                for b in self.bodies.values() if b.busy]

    def resend_due(self) -> list[Out]:
        return self.ledger.resend_due(self.clock.tick, self.alive)

    def _nav_status(self, body: nav.RoverBody, action: str) -> Out:
        status = m.NavigationStatus(stamp=self.clock.sim_time, action=action, remaining=round(body.remaining(), 4),
                                    action_id=self.ledger.running_id(body.id))
        return self.keys.rover(body.id, ks.NAVIGATION_STATUS), status

    def moving(self) -> dict[int, bool]:
        return {b.id: b.busy for b in self.bodies.values()}
