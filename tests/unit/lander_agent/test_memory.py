"""The lander's state file (``lander_agent.resume.LanderMemory``): written once its answer to the clock is out, not
before the ack the lockstep world waits for, and holding what it held when the clock was handled."""

from __future__ import annotations

import logging
from pathlib import Path

from bus import snapshot
from lander_agent.lander import Lander
from lander_agent.mission import MissionPlan
from lander_agent.resume import FILE_NAME, LanderMemory, Saved
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"
KEYS = ks.Keyspace("w")


def _lander(folder: Path) -> Lander:
    plan = MissionPlan(load_scenario(SCENARIOS / "crater_observation.yaml"))
    return Lander(plan, KEYS, memory=LanderMemory(folder / FILE_NAME))


def _clock(tick: int) -> bytes:
    return codec.encode(m.Clock(tick=tick, sim_time=tick * 0.05, time_scale=0.0, run="r1", lockstep=True,
                                acks=[ks.LANDER_ID]))


def _saved(folder: Path) -> Saved | None:
    return snapshot.load(folder / FILE_NAME, logging.getLogger("test"))  # type: ignore[return-value]


def test_the_state_is_written_after_the_answer_to_the_clock_not_before_its_ack(tmp_path):
    lander = _lander(tmp_path)
    out = lander.handle(KEYS.clock, _clock(1))
    assert out[-1][0] == KEYS.lander(ks.ACK)  # the answer, ack last, is ready to go out
    assert _saved(tmp_path) is None  # and nothing was written on its way
    lander.catch_up()  # what the runtime does once it has published the answer
    saved = _saved(tmp_path)
    assert isinstance(saved, Saved) and saved.run == "r1" and saved.plan.scenario == lander.plan.scenario
    assert (saved.map.classes() == lander.map.classes()).all()
    (tmp_path / FILE_NAME).unlink()
    lander.catch_up()  # nothing more is due until the next clock
    assert not (tmp_path / FILE_NAME).exists()


def test_a_save_left_due_is_made_before_the_next_sample_is_handled(tmp_path):
    """A loop that does not call ``catch_up`` after publishing still gets the file, holding the state as the clock
    left it: the map report handled after the clock is not in it."""
    lander = _lander(tmp_path)
    lander.handle(KEYS.clock, _clock(1))
    report = radio.MapReport.build(0, 0.5, 0.0, 0.0, [(1, 2, 0), (3, 4, 1)])
    lander.handle(KEYS.lander(ks.COMM_IN), codec.encode(m.InboundComm(sender=1, payload=radio.pack(report))))
    assert lander.map.folded.get(1) == {0}  # handled
    saved = _saved(tmp_path)
    assert isinstance(saved, Saved) and saved.run == "r1" and not saved.map.folded.get(1)  # saved before it
