"""The rover topics each way are the ones ``schemas.keyspace`` names: the agents' outputs (``ROVER_OUTPUTS``), which
their Zenoh loop declares before the world starts the clock, and what the world sends them (``ROVER_INPUTS``), which
they subscribe to. An output missing there is declared on first use, in the middle of the mission, where in a
process of many agents each declaration holds up every sample behind it."""

from __future__ import annotations

from pathlib import Path

from harness.loopback import answer, rover_agents
from harness.rounds import Rounds
from schemas import keyspace as ks
from schemas.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"


def test_a_whole_mission_uses_only_the_rover_topics_declared_up_front():
    rounds = Rounds(load_scenario(SCENARIOS / "crater_observation.yaml"), max_sim_time=120.0, strict=True)
    agents = rover_agents(rounds.scenario, rounds.keys, rounds.rover_ids)
    published: set[str] = set()
    heard_topics: set[str] = set()
    heard = rounds.advance({})
    while heard:
        heard_topics |= {topic for samples in heard.values() for topic, _ in samples if topic != ks.CLOCK}
        answers = {rid: answer(agents[rid], samples) for rid, samples in heard.items()}
        for rid, out in answers.items():
            own = rounds.keys.rover(rid, "")
            assert all(key.startswith(own) for key, _ in out), out  # an agent publishes on its own rover's keys
            published |= {key[len(own):] for key, _ in out}
        heard = rounds.advance(answers)
    assert published <= set(ks.ROVER_OUTPUTS), published - set(ks.ROVER_OUTPUTS)
    assert heard_topics <= set(ks.ROVER_INPUTS), heard_topics - set(ks.ROVER_INPUTS)
    # the mission went far enough to use the main topics each way
    assert {ks.MOVE_ACTION, ks.ROTATE_ACTION, ks.STATUS, ks.POSE_ESTIMATE, ks.COMM_OUT, ks.PHOTO_ACTION,
            ks.ACK} <= published
    assert {ks.PERCEPTION, ks.GYROSCOPE, ks.NAVIGATION_STATUS, ks.COMM_IN, ks.CALIBRATION, ks.MISSION_DIRECTION,
            ks.PHOTO} <= heard_topics
