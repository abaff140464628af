"""The world's memory of each rover's last action: what makes the action protocol survive lost samples.

An action's answer (how it ended, or why it was refused) is one sample, and a link may lose it. So each action
carries the agent's id (``action_id``), and the world keeps, per rover, the last action it started and the last it
refused with their answers:
- an agent that hears nothing of its action sends it again with the same id; the world answers how that action
  stands (its running status, its end, its refusal) instead of starting it again;
- the world re-sends an action's end every ``resend_period`` ticks until the agent's status says it has heard it
  (``RoverStatus.action_id``), so neither a lost end nor a lost query leaves an agent waiting.

Id 0 means "no id" (tools and drivers that send none): such actions are answered once.
"""

from __future__ import annotations

from dataclasses import dataclass

from schemas.messages import Out
from schemas.wire_limits import highest_action_id

STALE = "stale"
FUTURE = "out_of_sequence"
REFUSED_KINDS = (STALE, FUTURE)


@dataclass
class ActionRecord:
    action_id: int
    kind: str  # "move" | "rotate" | "photo"
    answer: list[Out] | None = None  # how it ended (navigation status, cancel result) or why it was refused
    started_tick: int = 0


class ActionLedger:
    def __init__(self, resend_period: int) -> None:
        self.resend_period = resend_period
        self.started: dict[int, ActionRecord] = {}  # rover -> the last move or rotate the world started
        self.photos: dict[int, ActionRecord] = {}  # rover -> the last photo it started: apart, as the camera works
        # while the rover moves, and the move's status and end must still name the move
        self.refused: dict[int, ActionRecord] = {}  # rover -> the last action the world refused
        self.heard: dict[int, int] = {}  # rover -> the last action id whose end its agent says it has heard
        self.floor: dict[int, int] = {}  # rover -> the lowest action id it may still start: its latest, or one past
        # an id cancelled before the world had it
        self.repeats = 0  # actions sent again by their agent (a query after a lost sample)
        self.resent = 0  # ends sent again because the agent had not heard them
        self.stale = 0  # actions below their rover's floor, refused

    def known(self, rover: int, action_id: int, sim_time: float) -> ActionRecord | None:
        """The record of an action the world has already had, if ``action_id`` names one; a ``STALE`` record for
        an id below the rover's floor (a late duplicate), which must never start; a ``FUTURE`` record for an id no
        agent can have taken by ``sim_time`` (``schemas.wire_limits.highest_action_id``), which must never raise
        the floor: it would refuse every action of the rover's own agent as stale."""
        if action_id == 0:
            return None
        if action_id > highest_action_id(sim_time):
            return ActionRecord(action_id, FUTURE)
        for record in (self.started.get(rover), self.refused.get(rover), self.photos.get(rover)):
            if record is not None and record.action_id == action_id:
                self.repeats += 1
                return record
        if action_id < self.floor.get(rover, 0):
            self.stale += 1
            return ActionRecord(action_id, STALE)
        self.floor[rover] = action_id
        return None

    def cancelled_unseen(self, rover: int, action_id: int, sim_time: float) -> None:
        """A cancel naming an action the world never had: its agent, told so, settles where it stood, so the action
        must never start if a copy of it comes after all (a link delivers late as well as loses): started then,
        the rover would drive where its agent does not watch, towards whatever it had cancelled for."""
        if action_id and action_id <= highest_action_id(sim_time):
            self.floor[rover] = max(self.floor.get(rover, 0), action_id + 1)

    def start(self, rover: int, action_id: int, kind: str, tick: int) -> None:
        records = self.photos if kind == "photo" else self.started
        records[rover] = ActionRecord(action_id, kind, started_tick=tick)

    def refuse(self, rover: int, action_id: int, kind: str, answer: Out) -> None:
        if action_id:
            self.refused[rover] = ActionRecord(action_id, kind, [answer])

    def running_id(self, rover: int) -> int:
        record = self.started.get(rover)
        return record.action_id if record is not None and record.answer is None else 0

    def end(self, rover: int, answer: list[Out]) -> None:
        record = self.started.get(rover)
        if record is not None and record.answer is None:
            record.answer = answer

    def note_heard(self, rover: int, action_id: int) -> None:
        self.heard[rover] = max(self.heard.get(rover, 0), action_id)

    def unheard_end(self, rover: int) -> list[Out]:
        """The end of the rover's last action if its agent has not said it heard it (ids only)."""
        record = self.started.get(rover)
        if record is None or record.answer is None or record.action_id == 0:
            return []
        if self.heard.get(rover, 0) >= record.action_id:
            return []
        return record.answer

    def resend_due(self, tick: int, alive: dict[int, bool]) -> list[Out]:
        """Ends to send again on this tick: each rover's once every ``resend_period`` ticks, rovers staggered,
        while its agent is alive (an agent away hears nothing; once back it is told)."""
        out: list[Out] = []
        for rover, is_alive in alive.items():
            if is_alive and (tick + rover) % self.resend_period == 0:
                again = self.unheard_end(rover)
                self.resent += bool(again)
                out += again
        return out
