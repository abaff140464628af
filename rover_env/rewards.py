"""Rewards from the report's evaluation criteria (3.4.7), per rover and round.

- **Reached its final goal** (``reached``, once): the report's "rovers that reached final goal", judged as the
  mission statistics judge it (``MissionStats.reached``: the rover says it is done with its final goal, and it
  truly stands at it);
- **collisions** (``collision``, each): a move of this rover that ended ``collided`` (with a rover or an
  obstacle), the report's "amount of rover collisions" extended to rocks and walls;
- **distance** (``distance``, per metre over the rover's ideal path): the report's path efficiency, so a rover
  that reaches its goal along its ideal path earns ``reached + distance`` in all (1 - 0.1 by default) and one that
  wanders earns less;
- **mission duration** is not rewarded per step: an episode that ends sooner simply has fewer steps to lose on.

Rewards read the world's truth (the environment is the judge); observations never do.
"""

from __future__ import annotations

from dataclasses import dataclass

from schemas import keyspace as ks
from schemas import messages as m
from world_service.outcome import statistics as stats
from world_service.sim import World


@dataclass(frozen=True)
class RewardWeights:
    reached: float = 1.0
    collision: float = -1.0
    distance: float = -0.1
    """Per ideal path length walked: -0.1 for a rover that walks exactly its ideal path."""


class Rewards:
    def __init__(self, world: World, weights: RewardWeights) -> None:
        self.world, self.weights = world, weights
        missions = world.referee.missions
        scenario = world.scenario
        self.ideal = {}
        for rid in world.rover_ids:
            spawn = scenario.rovers[rid - 1]
            goals = [missions.goal(rid, i) for i in range(missions.final_index(rid) + 1)]
            self.ideal[rid] = max(stats.remaining_path(scenario, goals, spawn.x, spawn.z), 1.0)
        self.covered = dict.fromkeys(world.rover_ids, 0.0)
        self.reached: set[int] = set()
        self.collided: dict[int, set[int]] = {rid: set() for rid in world.rover_ids}

    def round(self, rid: int, heard: list[tuple[str, m.Message | None]]) -> float:
        """The reward of rover ``rid`` for the round in which it heard ``heard`` (topic, decoded message)."""
        body, w = self.world.actuator.bodies[rid], self.weights
        reward = w.distance * (body.distance_covered - self.covered[rid]) / self.ideal[rid]
        self.covered[rid] = body.distance_covered
        collided = {msg.action_id for topic, msg in heard if topic == ks.NAVIGATION_STATUS
                    and isinstance(msg, m.NavigationStatus) and msg.outcome == "collided"}
        reward += w.collision * len(collided - self.collided[rid])  # an end the world re-sends is one collision
        self.collided[rid] |= collided
        if rid not in self.reached and self._at_final_goal(rid):
            self.reached.add(rid)
            reward += w.reached
        return reward

    def _at_final_goal(self, rid: int) -> bool:
        status, missions = self.world.referee.status[rid], self.world.referee.missions
        final = missions.final_index(rid)
        body = self.world.actuator.bodies[rid]
        return (status.state == "done" and status.goal_index == final
                and stats.at_goal(self.world.scenario, missions.goal(rid, final), body.x, body.z))
