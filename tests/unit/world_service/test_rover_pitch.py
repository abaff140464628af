"""The rovers' remembered pitch: the terrain's own numbers, computed again only when a rover has moved."""

from __future__ import annotations

import numpy as np

from schemas.scenario import Crater, TerrainSpec
from world_service.terrain.heightmap import Heightmap
from world_service.terrain.pitch import RoverPitch


def _terrain() -> Heightmap:
    spec = TerrainSpec(origin=(-60.0, -60.0), size_m=(120.0, 120.0), resolution_m=0.5, roughness_m=0.4)
    return Heightmap.build(spec, [Crater(x=0.0, z=0.0, radius_m=20.0)], np.random.default_rng(1))


def test_rovers_standing_still_get_the_terrains_pitch_without_sampling_it_again(monkeypatch):
    terrain = _terrain()
    memo = RoverPitch(terrain)
    ids, xs, zs = [1, 2, 3], np.array([19.0, -23.0, 5.5]), np.array([0.5, 4.0, -21.0])
    hs = np.array([270.0, 80.0, 10.0])
    first = memo.pitch_deg(ids, xs, zs, hs)
    assert first.tolist() == terrain.pitch_deg(xs, zs, hs).tolist()
    assert np.all(np.abs(first) > 1.0)  # on the crater's walls: a pitch worth remembering

    calls = []
    direct = terrain.pitch_deg
    monkeypatch.setattr(terrain, "pitch_deg", lambda *a: calls.append(a) or direct(*a))
    assert memo.pitch_deg([3, 1], xs[[2, 0]], zs[[2, 0]], hs[[2, 0]]).tolist() == first[[2, 0]].tolist()
    assert calls == []  # a subset of the rovers, all where they stood

    moved = xs.copy()
    moved[1] += 0.25
    again = memo.pitch_deg(ids, moved, zs, hs)
    assert len(calls) == 1
    assert again.tolist() == direct(moved, zs, hs).tolist()
    assert again[1] != first[1] and again[[0, 2]].tolist() == first[[0, 2]].tolist()


def test_a_rover_never_asked_about_is_computed():
    terrain = _terrain()
    memo = RoverPitch(terrain)
    memo.pitch_deg([1], np.array([10.0]), np.array([10.0]), np.array([0.0]))
    xs, zs, hs = np.array([10.0, 18.0]), np.array([10.0, 3.0]), np.array([0.0, 250.0])
    assert memo.pitch_deg([1, 2], xs, zs, hs).tolist() == terrain.pitch_deg(xs, zs, hs).tolist()
