"""The fault-injected link (``bus.loss``): a seeded share of samples lost, each decided by itself, so a lockstep run
with losses repeats whatever other samples went out and however often its clock was sent again."""

from __future__ import annotations

from bus.loss import SeededLoss


def _fates(loss: SeededLoss, samples: list[tuple[str, bytes]]) -> list[bool]:
    return [loss.drops(key, payload) for key, payload in samples]


PERCEPTIONS = [("w/rover/1/perception", f"scan {i}".encode()) for i in range(4000)]


def test_the_share_lost_is_the_share_asked_for_and_the_seed_decides_which():
    lost = _fates(SeededLoss(0.2, seed=7), PERCEPTIONS)
    assert 0.18 < sum(lost) / len(lost) < 0.22
    assert lost == _fates(SeededLoss(0.2, seed=7), PERCEPTIONS)
    assert lost != _fates(SeededLoss(0.2, seed=8), PERCEPTIONS)


def test_a_sample_s_fate_does_not_depend_on_what_else_went_out_or_how_often_a_clock_was_resent():
    alone = _fates(SeededLoss(0.2, seed=3), PERCEPTIONS)
    loss = SeededLoss(0.2, seed=3)
    interleaved = []
    for i, sample in enumerate(PERCEPTIONS):
        for _ in range(i % 4):  # a clock sent again a varying number of times, as timing has it
            loss.drops("w/world/clock", f"tick {i}".encode())
        loss.drops("w/rover/2/gyroscope", f"gyro {i}".encode())
        interleaved += _fates(loss, [sample])
    assert interleaved == alone


def test_samples_resent_in_turn_on_one_key_each_get_through_in_the_end():
    """An action's end, a refusal and a photo's end, resent each second on one key until heard: a link that lost
    one of them for good would hold the rover's mission for ever."""
    loss = SeededLoss(0.5, seed=1)
    ends = [b"moved", b"refused", b"photo taken"]
    heard = set()
    for _ in range(40):
        heard |= {end for end in ends if not loss.drops("w/rover/1/action_end", end)}
    assert heard == set(ends)
