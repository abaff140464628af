"""Files a user names: only a regular file within its size bound is read, each key once, aliases bounded; a terrain
mesh is a mesh file, looked for from the scenario's folder."""

from __future__ import annotations

import copy
import os
from pathlib import Path

import pytest
import yaml

from schemas import scenario_limits as limits
from schemas.scenario import ScenarioError, load_rover_params, load_scenario, parse_scenario

BASE = {
    "name": "tiny",
    "lander": {"x": 0.0, "z": 0.0},
    "rovers": [{"x": 5.0, "z": 5.0}],
    "mission": [{"x": 30.0, "z": 10.0}],
}


def _data(**changes) -> dict:
    return {**copy.deepcopy(BASE), **copy.deepcopy(changes)}


def _terrain(**changes) -> dict:
    return {"origin": [-100.0, -100.0], "size_m": [200.0, 200.0], **changes}


# ---- YAML files ----


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "test.yaml"
    path.write_text(text)
    return path


def _file_error(path: Path) -> str:
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    return str(info.value)


@pytest.mark.parametrize(("text", "where", "key", "first"), [
    ("name: a\nseed: 1\nname: b\n", "line 3, column 1", "'name'", 1),
    ("name: a\nlander: {x: 0.0, z: 1.0, x: 2.0}\n", "line 2, column 26", "'x'", 2),
    ("name: a\nrover_params:\n  navigation:\n    slip_std: 0.1\n\n    slip_std: 0.2\n", "line 6, column 5",
     "'slip_std'", 4),
    ("name: a\nyes: 1\ntrue: 2\n", "line 3, column 1", "True", 2),  # two spellings of one key
])
def test_a_key_given_twice_is_refused_with_its_line(tmp_path, text, where, key, first):
    path = _file(tmp_path, text)
    assert _file_error(path) == (f"{path}: cannot read scenario: not valid YAML at {where}: duplicate key {key} "
                                 f"(first given at line {first})")


def test_a_key_given_twice_in_a_parameter_file_is_refused(tmp_path):
    path = _file(tmp_path, "navigation: {slip_std: 0.1}\nnavigation: {slip_std: 0.2}\n")
    with pytest.raises(ScenarioError, match=r"rover parameters: not valid YAML at line 2, column 1: duplicate key"):
        load_rover_params(path)


def test_a_merge_key_may_be_overridden(tmp_path):
    """``<<: *anchor`` followed by one of its keys is how YAML overrides a merged value, not a key given twice."""
    rest = yaml.safe_dump({k: v for k, v in _data().items() if k not in ("lander", "rovers")})
    path = _file(tmp_path, rest + "rovers: [&spot {x: 5.0, z: 5.0}]\nlander: {<<: *spot, x: 1.0}\n")
    scenario = load_scenario(path)
    assert (scenario.lander.x, scenario.lander.z, scenario.rovers[0].x) == (1.0, 5.0, 5.0)


def test_aliases_that_expand_beyond_the_bound_are_refused_at_once(tmp_path):
    levels = "".join(f"  l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]\n" for i in range(1, 10))
    path = _file(tmp_path, "name: x\nbomb:\n  l0: &l0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + levels)
    assert _file_error(path) == (f"{path}: cannot read scenario: not valid YAML: aliases expand it to more than "
                                 f"{limits.MAX_YAML_NODES:,} values")


def test_a_value_holding_itself_is_refused(tmp_path):
    path = _file(tmp_path, "name: x\nrovers: &r [*r]\n")
    assert "an alias refers to a value that holds it" in _file_error(path)


def test_a_file_over_the_size_bound_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "big.yaml"
    with path.open("wb") as f:
        f.truncate(limits.MAX_SCENARIO_BYTES + 1)  # sparse: its size is what is checked
    assert _file_error(path) == (f"{path}: cannot read scenario: {limits.MAX_SCENARIO_BYTES + 1:,} bytes, more than "
                                 "the 1 MiB allowed")


def test_a_device_is_refused_as_scenario_and_parameters(tmp_path):
    assert _file_error(Path("/dev/zero")) == "/dev/zero: cannot read scenario: not a regular file (a character device)"
    (tmp_path / "link.yaml").symlink_to("/dev/urandom")
    with pytest.raises(ScenarioError, match=r"link\.yaml: cannot read rover parameters: not a regular file"):
        load_rover_params(tmp_path / "link.yaml")


# ---- a terrain mesh ----


def _mesh_error(tmp_path: Path, mesh: str) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(_data(terrain=_terrain(mesh=mesh)), "test.yaml", tmp_path)
    return str(info.value)


def test_a_mesh_must_be_a_mesh_file_of_bounded_size(tmp_path):
    formats = ", ".join(limits.MESH_SUFFIXES)
    assert _mesh_error(tmp_path, "/dev/zero") == (f"test.yaml: terrain.mesh: '/dev/zero' is not a mesh file: its "
                                                  f"name must end in {formats}")
    assert "'/etc/passwd' is not a mesh file" in _mesh_error(tmp_path, "/etc/passwd")
    (tmp_path / "zero.stl").symlink_to("/dev/zero")
    assert _mesh_error(tmp_path, "zero.stl") == ("test.yaml: terrain.mesh: /dev/zero: not a regular file (a "
                                                 "character device)")
    os.mkfifo(tmp_path / "pipe.obj")
    assert "pipe.obj: not a regular file (a FIFO)" in _mesh_error(tmp_path, "pipe.obj")
    (tmp_path / "folder.ply").mkdir()
    assert "folder.ply: Is a directory" in _mesh_error(tmp_path, "folder.ply")
    assert "missing.glb: No such file or directory" in _mesh_error(tmp_path, "missing.glb")
    with (tmp_path / "huge.glb").open("wb") as f:
        f.truncate(limits.MAX_MESH_BYTES + 1)
    assert f"huge.glb: {limits.MAX_MESH_BYTES + 1:,} bytes, more than the 256 MiB allowed" in _mesh_error(
        tmp_path, "huge.glb")


def test_a_mesh_is_made_absolute_from_the_scenario_folder_and_not_looked_for_without_one(tmp_path):
    (tmp_path / "ground.ply").write_bytes(b"ply\n")
    scenario = parse_scenario(_data(terrain=_terrain(mesh="ground.ply")), "test.yaml", tmp_path)
    assert scenario.terrain.mesh == str(tmp_path / "ground.ply")
    assert parse_scenario(_data(terrain=_terrain(mesh="elsewhere.ply"))).terrain.mesh == "elsewhere.ply"


def test_the_world_reads_a_mesh_as_the_scenario_check_does(tmp_path):
    from world_service.terrain.mesh import load_vertices_faces

    (tmp_path / "zero.stl").symlink_to("/dev/zero")
    with pytest.raises(ScenarioError, match=r"zero\.stl: cannot read terrain mesh: not a regular file"):
        load_vertices_faces(tmp_path / "zero.stl")
