"""How the world answers a rover's actions (report 10.2): a move, rotate, cancel, speed, photo or radio sample from
an agent, checked against what the rover can do and where it stands, started, answered or refused.

A mixin of ``world_service.sim.World`` (its state: bodies, params, the action ledger...), kept apart so the
world's own module stays about time: how a tick moves every body and what it publishes.
"""

from __future__ import annotations

import logging
import math
from typing import ClassVar

import numpy as np

from schemas import keyspace as ks
from schemas import messages as m
from world_service import navigation as nav
from world_service.actions import REFUSED_KINDS, ActionRecord
from world_service.photos import PhotoJob
from world_service.scene import in_view

Out = tuple[str, m.Message]
log = logging.getLogger("lunarsim.world")
ACTION_ID_PROBLEMS = {"stale": "older than the rover's latest action",
                      "out_of_sequence": "beyond any id its agent can have taken by now"}


class ActionInputs:
    def _on_move(self, rid: int, msg: m.MoveAction) -> list[Out]:
        if (record := self.actions.known(rid, msg.action_id, self.sim_time)) is not None:
            return self._again(rid, record, "move")
        body = self.bodies[rid]
        reason = self._power_problem(rid) or self._move_problem(body, msg)
        if reason:
            return self._refuse(rid, "move", msg.action_id, *reason)
        slip, turn = self._noise(msg.x, msg.z)
        body.start_move(msg.x, msg.z, slip, turn)
        self.actions.start(rid, msg.action_id, "move", self.tick)
        return [self._nav_status(body, "move")]

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
        return self.energy.refusal(rid) if self.energy is not None else None

    def _noise(self, x: float, z: float) -> tuple[tuple[float, float], float]:
        """How a move goes wrong (seeded): the ground slips it by a share of its length, the heading drifts."""
        nav_p = self.params.navigation
        sigma = nav_p.slip_std * math.hypot(x, z)
        turn = self.rng.normal(0.0, nav_p.heading_noise_std_deg) if nav_p.heading_noise_std_deg > 0 else 0.0
        slip = (self.rng.normal(0.0, sigma), self.rng.normal(0.0, sigma)) if sigma > 0 else (0.0, 0.0)
        return slip, turn

    def _move_problem(self, body: nav.RoverBody, msg: m.MoveAction) -> tuple[str, str] | None:
        p = self.params
        if body.busy:
            return "action_in_progress", "a move or rotate is still running"
        if not in_view(msg.x, msg.z, p.perception.field_of_view_degrees):
            return "out_of_view", f"({msg.x:.2f}, {msg.z:.2f}) is outside the field of view"
        limit = p.perception.perception_radius * (1 + p.navigation.move_action_tolerance_factor)
        if math.hypot(msg.x, msg.z) > limit:
            return "out_of_range", f"{math.hypot(msg.x, msg.z):.2f} m is beyond the {limit:.2f} m perception range"
        gx, gz = nav.to_world(body.x, body.z, body.heading, msg.x, msg.z)
        radius = p.behaviour.rover_radius
        clearance = radius if p.navigation.strict_line_of_sight else 0.0
        ox, oz = self._other_positions(body.id)
        if self.scene.line_blocked(body.x, body.z, gx, gz, clearance, ox, oz, radius):
            return "blocked", "the line to the goal is not clear"
        if self._too_steep(body.x, body.z, gx, gz):
            return "blocked", f"the ground on the way is steeper than {p.navigation.max_slope_deg:g} degrees"
        return None

    def _too_steep(self, x0: float, z0: float, x1: float, z1: float) -> bool:
        length = math.hypot(x1 - x0, z1 - z0)
        if length < 1e-9:
            return False
        f = np.linspace(0.0, 1.0, max(2, math.ceil(length / 0.5) + 1))
        pitch = self.terrain.pitch_deg(x0 + f * (x1 - x0), z0 + f * (z1 - z0), np.degrees(np.arctan2(x1 - x0, z1 - z0)))
        return bool(np.any(pitch > self.params.navigation.max_slope_deg))

    def _on_rotate(self, rid: int, msg: m.RotateAction) -> list[Out]:
        if (record := self.actions.known(rid, msg.action_id, self.sim_time)) is not None:
            return self._again(rid, record, "rotate")
        body = self.bodies[rid]
        if body.busy:
            return self._refuse(rid, "rotate", msg.action_id, "action_in_progress",
                                 "a move or rotate is still running")
        if reason := self._power_problem(rid):
            return self._refuse(rid, "rotate", msg.action_id, *reason)
        noise = self.params.navigation.heading_noise_std_deg
        body.start_rotate(msg.degrees + (self.rng.normal(0.0, noise) if noise > 0 else 0.0))
        self.actions.start(rid, msg.action_id, "rotate", self.tick)
        return [self._nav_status(body, "rotate")]

    def _on_cancel(self, rid: int, msg: m.CancelAction) -> list[Out]:
        """Cancel the running action; a cancel naming an action that has already ended gets that end again."""
        body = self.bodies[rid]
        running = self.actions.running_id(rid)
        if body.busy and msg.action_id in (0, running):
            body.cancel()
            return []
        record = self.actions.started.get(rid)
        if msg.action_id and record is not None and record.action_id == msg.action_id and record.answer:
            return list(record.answer)
        self.actions.cancelled_unseen(rid, msg.action_id, self.sim_time)
        return [self._reject(rid, "cancel", "no_action", "nothing to cancel", msg.action_id)]

    def _on_speed(self, rid: int, msg: m.SpeedAction) -> list[Out]:
        self.bodies[rid].speed_level = msg.level
        return []

    def _on_comm_out(self, rid: int, msg: m.OutboundComm) -> list[Out]:
        return self._radio(rid, msg, from_lander=False)

    def _on_photo_action(self, rid: int, msg: m.PhotoAction) -> list[Out]:
        """Queue a photo of what the rover sees now; rendering is slow, so the service decides when."""
        if (record := self.actions.known(rid, msg.action_id, self.sim_time)) is not None:
            # taken already: the photo is on its way (or lost, and the agent gives up on it in time)
            return self._again(rid, record, "photo") if record.kind in REFUSED_KINDS else []
        body = self.bodies[rid]
        if reason := self._power_problem(rid):
            return self._refuse(rid, "photo", msg.action_id, *reason)
        capture_ticks = max(1, round(self.params.camera.capture_time_s / self.dt))
        if self.tick < self.camera_free_at.get(rid, 0):
            # one camera, one photo at a time: a flood of photo actions must not queue renders without end
            return self._refuse(rid, "photo", msg.action_id, "action_in_progress",
                                "the camera is still taking the last photo")
        self.camera_free_at[rid] = self.tick + capture_ticks
        self.actions.start(rid, msg.action_id, "photo", self.tick)
        if self.energy is not None:
            self.energy.spend(rid, self.params.power.photo_j)
        others = [b for b in self.bodies.values() if b.id != rid]
        due = self.tick + capture_ticks
        self.photo_jobs.append(PhotoJob(rid, self.sim_time, msg.label, due, body.x, body.z, body.heading,
                                        np.array([b.x for b in others]), np.array([b.z for b in others])))
        return []

    def _on_status(self, rid: int, msg: m.RoverStatus) -> list[Out]:
        before = self.status[rid]
        if (msg.state, msg.goal_index) != (before.state, before.goal_index):  # the mission's story, for the log
            log.info("t = %.1f s: rover %d %s, goal %d%s", self.sim_time, rid, msg.state, msg.goal_index + 1,
                     f" ({msg.detail})" if msg.detail else "")
        self.status[rid] = msg
        self.actions.note_heard(rid, msg.action_id)
        return []

    def _reject(self, rid: int, action: str, reason: str, detail: str, action_id: int = 0) -> Out:
        return self.keys.rover(rid, ks.ACTION_REJECTED), m.ActionRejected(action=action, reason=reason, detail=detail,
                                                                          action_id=action_id)

    def _refuse(self, rid: int, action: str, action_id: int, reason: str, detail: str) -> list[Out]:
        """A refusal the ledger keeps, so the same action sent again gets the same answer; answered at most once
        a tick per rover, so a client flooding a rover's actions is not answered at its own rate (an agent whose
        answer this holds back asks again and gets it from the ledger)."""
        answer = self._reject(rid, action, reason, detail, action_id)
        self.actions.refuse(rid, action_id, action, answer)
        if self._refused_on.get(rid) == self.tick:
            self.refusals_held += 1
            return []
        self._refused_on[rid] = self.tick
        return [answer]

    def _other_positions(self, rid: int) -> tuple[np.ndarray, np.ndarray]:
        """Every other rover's position; the arrays are built once per tick, however many moves are checked."""
        if self._positions is None:
            self._positions = (np.array(list(self.bodies)), np.array([b.x for b in self.bodies.values()]),
                               np.array([b.z for b in self.bodies.values()]))
        ids, xs, zs = self._positions
        others = ids != rid
        return xs[others], zs[others]

    _handlers: ClassVar[dict] = {
        ks.MOVE_ACTION: _on_move,
        ks.ROTATE_ACTION: _on_rotate,
        ks.CANCEL_ACTION: _on_cancel,
        ks.SPEED_ACTION: _on_speed,
        ks.COMM_OUT: _on_comm_out,
        ks.STATUS: _on_status,
        ks.PHOTO_ACTION: _on_photo_action,
    }
    INPUT_TOPICS = tuple(_handlers)
