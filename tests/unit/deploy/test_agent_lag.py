"""The launcher's judgement of whether the agents keep up with the world's clock (``deploy.agent_lag``)."""

from __future__ import annotations

from deploy.agent_lag import AgentLag


def test_an_agent_behind_the_world_is_reported_once_with_the_most_it_lagged() -> None:
    lag = AgentLag(limit_s=2.0)
    assert not lag.status(3, 0.0)  # the world's time is not known yet
    lag.world(10.0)
    assert not lag.status(3, 8.5) and lag.summary() is None  # within the limit
    assert lag.status(3, 7.0)  # the first agent found behind: the moment to warn
    assert not lag.status(5, 6.0)  # later ones are counted, not warned about again
    lag.world(9.0)  # statistics never move the world's time back
    assert not lag.status(3, 4.0)
    assert lag.worst == {3: 6.0, 5: 4.0}
    assert lag.summary() == "2 rover agent(s) fell more than 2 s behind the world's clock (rover 3, 5; up to 6.0 s)"


def test_the_summary_names_ten_rovers_and_counts_the_rest() -> None:
    lag = AgentLag(limit_s=1.0)
    lag.world(100.0)
    for rid in range(1, 13):
        lag.status(rid, 90.0)
    assert "(rover 1, 2, 3, 4, 5, 6, 7, 8, 9, 10 and 2 more; up to 10.0 s)" in lag.summary()
