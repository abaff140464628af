"""The ROS 2 commands' arguments: domain ids as ROS 2 reads them, rovers handed to an outside node, and what is
refused in one ``error:`` line with exit code 2 before anything starts."""

from __future__ import annotations

import pytest
from procs import SCENARIOS

from bus.errors import UsageError
from deploy import cli
from deploy.rover_groups import external_ids, groups
from ros2_bridge.commands.ros2 import domain_id


def test_the_domain_comes_from_the_flag_then_ros_domain_id_then_zero():
    assert domain_id(5, {"ROS_DOMAIN_ID": "9"}) == 5
    assert domain_id(None, {"ROS_DOMAIN_ID": " 9 "}) == 9
    assert domain_id(None, {}) == 0
    for given, env in ((233, {}), (-1, {}), (None, {"ROS_DOMAIN_ID": "abc"}), (None, {"ROS_DOMAIN_ID": "400"})):
        with pytest.raises(UsageError):
            domain_id(given, env)


def test_rover_agents_are_grouped_around_the_rovers_a_ros_node_drives():
    assert groups([2, 3, 4, 5], 1) == [(2, 2), (3, 3), (4, 4), (5, 5)]
    assert groups([1, 3, 4, 5, 6], 3) == [(1, 1), (3, 5), (6, 6)]
    assert external_ids("1,3", 5) == {1, 3} and external_ids(None, 5) == frozenset()
    for text in ("0", "x", "6"):
        with pytest.raises(UsageError):
            external_ids(text, 5)


@pytest.mark.parametrize(("args", "said"), [
    (["ros2", "--domain-id", "300"], "domain id must be 0 to 232"),
    (["run", str(SCENARIOS / "crater_observation.yaml"), "--external", "1", "--lockstep"], "does not acknowledge"),
    (["run", str(SCENARIOS / "crater_observation.yaml"), "--external", "7"], "the scenario has 5 rovers"),
])
def test_bad_arguments_exit_2_with_one_line(args, said, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert said in err and err.count("\n") == 1
    assert not (tmp_path / "runs").exists()
