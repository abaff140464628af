"""The world's radio (report 10.4): transmissions delivered along the communication graph of ranges and lines of
sight, lost or delayed as the scenario says, counted when they cannot arrive.

A mixin of ``world_service.sim.World`` (its bodies, params, terrain and scene), kept apart from the world's
stepping.
"""

from __future__ import annotations

import numpy as np

from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from world_service.radio import CommGraph, build_graph, line_of_sight

Out = tuple[str, m.Message]


class RadioLink:
    def _radio(self, sender: int, msg: m.OutboundComm, from_lander: bool) -> list[Out]:
        if msg.channel != "comm_in" and not from_lander:
            raise ValueError(f"only the lander may transmit on channel {msg.channel!r}")
        model = m.RADIO_CHANNEL_MODELS.get(msg.channel)
        inner = codec.decode(model, msg.payload) if model else None
        if not self.airtime.take(sender, len(msg.targets), self.tick):
            raise ValueError(f"{sender} is over its airtime ({len(msg.targets)} deliveries)")
        if self.energy is not None and not from_lander:
            self.energy.spend(sender, self.params.power.radio_transmit_j)
        out: list[Out] = []
        for target in msg.targets:
            if target != ks.LANDER_ID and target not in self.bodies:
                self.rejected.count("radio target", f"no rover {target} in the scenario")
                continue
            if not self.graph.connected(sender, target):
                self.radio_dropped += 1
                continue
            c = self.params.communication
            if c.loss_probability > 0 and self.radio_rng.random() < c.loss_probability:
                self.radio_lost += 1
                continue
            delivery = self._deliver(sender, target, msg, inner)
            if c.latency_s > 0:
                self._in_flight_radio.append((self.tick + max(1, round(c.latency_s / self.dt)), delivery))
            else:
                out.append(delivery)
        return out

    def _due_radio(self) -> list[Out]:
        due = [d for t, d in self._in_flight_radio if t <= self.tick]
        self._in_flight_radio = [(t, d) for t, d in self._in_flight_radio if t > self.tick]
        return due

    def _deliver(self, sender: int, target: int, msg: m.OutboundComm, inner: m.Message | None) -> Out:
        if inner is not None:
            return self.keys.rover(target, msg.channel), inner
        key = self.keys.lander(ks.COMM_IN) if target == ks.LANDER_ID else self.keys.rover(target, ks.COMM_IN)
        return key, m.InboundComm(sender=sender, payload=msg.payload)

    def _build_graph(self) -> CommGraph:
        ids = np.array([ks.LANDER_ID, *self.bodies], int)
        x = np.array([self.scenario.lander.x] + [b.x for b in self.bodies.values()])
        z = np.array([self.scenario.lander.z] + [b.z for b in self.bodies.values()])
        c = self.params.communication
        sight = None
        if c.line_of_sight:
            antenna = np.full(len(ids), c.antenna_height_m)
            antenna[0] = c.lander_antenna_height_m

            def sight(i, j):
                return line_of_sight(self.terrain, self.scene.edges, self.scene.edge_height, x, z, antenna, i, j)
        return build_graph(ids, x, z, c.comm_range, c.lander_comm_range, sight)
