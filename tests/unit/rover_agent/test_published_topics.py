"""Every key a rover agent publishes on is one its Zenoh loop declares before the world starts the clock
(``rover_agent.agent.PUBLISHED_TOPICS``): a key missing there is declared on first use, in the middle of the
mission, where in a process of many agents each declaration holds up every sample behind it."""

from __future__ import annotations

from pathlib import Path

from harness.loopback import answer, rover_agents
from harness.rounds import Rounds
from rover_agent.agent import PUBLISHED_TOPICS
from schemas import keyspace as ks
from schemas.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"


def test_a_whole_mission_publishes_only_on_the_topics_the_agent_declares_up_front():
    rounds = Rounds(load_scenario(SCENARIOS / "crater_observation.yaml"), max_sim_time=120.0, strict=True)
    agents = rover_agents(rounds.scenario, rounds.keys, rounds.rover_ids)
    published: set[str] = set()
    heard = rounds.advance({})
    while heard:
        answers = {rid: answer(agents[rid], samples) for rid, samples in heard.items()}
        for rid, out in answers.items():
            own = rounds.keys.rover(rid, "")
            assert all(key.startswith(own) for key, _ in out), out  # an agent publishes on its own rover's keys
            published |= {key[len(own):] for key, _ in out}
        heard = rounds.advance(answers)
    assert published <= set(PUBLISHED_TOPICS), published - set(PUBLISHED_TOPICS)
    # the mission went far enough to use the agent's main outputs
    assert {ks.MOVE_ACTION, ks.ROTATE_ACTION, ks.STATUS, ks.POSE_ESTIMATE, ks.COMM_OUT, ks.PHOTO_ACTION,
            ks.ACK} <= published
