"""What ``lunarsim X --help`` shows a new user: every option explained, examples kept on their own lines, no reST
markup; and a mission report rebuilt from a recording does not claim a wall time of 0."""

from __future__ import annotations

import argparse
import importlib

import pytest

from deploy.cli import COMMANDS, build_parsers, command_module
from schemas import messages as m
from sessions.summary import summary_table

COMMAND_PARSERS = build_parsers().commands


def test_every_command_is_there():
    assert set(COMMANDS) <= set(COMMAND_PARSERS)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_is_a_module_of_one_shape(name):
    """``<package>/commands/<command>.py``: its docstring is the description, ``add_arguments`` and ``run``."""
    module = importlib.import_module(command_module(name))
    assert module.__name__.split(".")[1:] == ["commands", name.replace("-", "_")]
    assert module.__doc__ and callable(module.add_arguments) and callable(module.run)


@pytest.mark.parametrize("name", sorted(COMMAND_PARSERS))
def test_every_option_has_help_and_no_rest_markup(name):
    parser = COMMAND_PARSERS[name]
    silent = [a.option_strings or a.dest for a in parser._actions
              if a.help is None and not isinstance(a, argparse._SubParsersAction)]
    assert not silent, f"lunarsim {name}: options without help: {silent}"
    assert "``" not in parser.format_help()


def test_examples_in_a_description_stay_on_their_own_lines():
    text = COMMAND_PARSERS["command"].format_help()
    assert "\n    lunarsim command stop --rover 3\n" in text


def _report(**fields) -> m.MissionReport:
    base = dict(scenario="s", seed=1, relative_path_length_m=1.0, average_distance_covered_m=1.0,
                average_path_efficiency=1.0, total_distance_covered_m=1.0, rovers_reached_final_goal=4,
                rovers_total=8, rover_collisions=0, obstacle_collisions=0, rovers_stuck=0, mission_duration_s=1.0)
    return m.MissionReport(**{**base, **fields})


def _rows(report: m.MissionReport) -> dict[str, str]:
    table = summary_table(report)
    names, values = table.columns[0]._cells, table.columns[1]._cells
    return dict(zip(names, values, strict=True))


def test_a_report_from_a_recording_does_not_claim_a_wall_time_of_zero():
    assert _rows(_report(wall_time_s=None))["wall time (s)"] == "- (from a recording)"
    assert _rows(_report(wall_time_s=12.5))["wall time (s)"] == "12.5"


def test_the_reached_count_says_when_rovers_held_daisy_chain_spots():
    assert _rows(_report(rovers_holding_relay_spots=4))["rovers that reached final goal"] == (
        "4/8 (4 held daisy-chain spots instead)")
    assert _rows(_report(max_rovers_in_daisy_chain=4))["rovers that reached final goal"] == "4/8"  # forwarding only
    assert _rows(_report())["rovers that reached final goal"] == "4/8"
