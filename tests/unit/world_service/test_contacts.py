"""Collisions: the plain-Python test that clears movers before the exact one never changes what is found."""

from __future__ import annotations

import math

import numpy as np
import pytest

from schemas.scenario import parse_scenario
from world_service.actuation import contacts as c
from world_service.actuation.navigation import RoverBody
from world_service.scene import Scene

RADIUS = 0.5
ROCK = (4.0, 3.0, 1.2)  # x, z, radius


def _scene(walls=()) -> Scene:
    return Scene.from_scenario(parse_scenario({
        "name": "contacts", "lander": {"x": -50.0, "z": -50.0}, "rovers": [{"x": 0.0, "z": 0.0}],
        "obstacles": {"rocks": [{"x": ROCK[0], "z": ROCK[1], "radius_m": ROCK[2]}],
                      "walls": [{"points": list(w), "thickness_m": 1.0} for w in walls]},
        "mission": [{"x": 0.0, "z": 100.0}]}))


def _exact(moved, bodies, scene, monkeypatch):
    with monkeypatch.context() as patch:
        patch.setattr(c, "_clear", lambda *_: False)
        return c.contacts(moved, bodies, scene, RADIUS)


def _found(result: c.Contacts) -> tuple:
    return sorted(b.id for b in result.hit), result.obstacle, result.rover_pairs


@pytest.mark.parametrize("scale", [1 - 1e-12, 1 - 1e-15, 1.0, 1 + 1e-15, 1 + 1e-12, 1.5])
def test_movers_at_the_contact_distance_are_found_as_the_exact_test_finds_them(scale, monkeypatch):
    scene = _scene()
    touch = (ROCK[2] + RADIUS) * scale
    at_rock = RoverBody(1, ROCK[0] + touch * math.sin(0.7), ROCK[1] + touch * math.cos(0.7), 0.0)
    pair = [RoverBody(2, 20.0, 20.0, 0.0), RoverBody(3, 20.0 + 2 * RADIUS * scale, 20.0, 0.0)]
    far = RoverBody(4, -20.0, 10.0, 0.0)
    bodies = [at_rock, *pair, far]
    for moved in ([at_rock], pair, [far], bodies):
        assert _found(c.contacts(moved, bodies, scene, RADIUS)) == _found(_exact(moved, bodies, scene, monkeypatch))
    if abs(scale - 1) >= 1e-12:  # nearer than that, where the rover stands is rounding's choice
        assert bool(c.contacts([at_rock], bodies, scene, RADIUS).hit) == (scale < 1)
        assert bool(c.contacts(pair, bodies, scene, RADIUS).hit) == (scale < 1)


def test_random_crowds_find_what_the_exact_test_finds(monkeypatch):
    rng = np.random.default_rng(7)
    scene = _scene()
    for _ in range(300):
        bodies = [RoverBody(i, *rng.uniform(0.0, 8.0, 2), 0.0) for i in range(1, 7)]
        moved = [b for b in bodies if rng.random() < 0.6]
        assert _found(c.contacts(moved, bodies, scene, RADIUS)) == _found(_exact(moved, bodies, scene, monkeypatch))


def test_walls_and_crowds_go_to_the_exact_test():
    body = RoverBody(1, 0.0, 0.0, 0.0)
    assert not c._clear([body], [body], _scene(walls=[[(-5.0, 30.0), (5.0, 30.0)]]), RADIUS)
    many = [RoverBody(i, 100.0 * i, 0.0, 0.0) for i in range(1, 200)]
    assert not c._clear(many, many, _scene(), RADIUS)
    assert c._clear([body], [body], _scene(), RADIUS)
