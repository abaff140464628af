"""The world's radio (report 10.4): transmissions delivered along the communication graph of ranges and lines of
sight, lost or delayed as the scenario says, counted when they cannot arrive; each sender within its airtime.

The graph is rebuilt from where the rovers stand at the partners rate (``rebuild``); ``graph`` holds how it is
built, ``airtime`` the senders' capacity.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable
from typing import Protocol

import numpy as np

from bus.rejections import Rejections
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from world_service.radio.airtime import Airtime
from world_service.radio.graph import CommGraph, build_graph, line_of_sight
from world_service.scene import Scene
from world_service.terrain.heightmap import Heightmap


class EnergyAccount(Protocol):
    """What a transmission costs a rover's battery (``power.energy.Energy``)."""

    def spend(self, rid: int, joules: float) -> None: ...


class Positioned(Protocol):
    """A rover as the graph needs it: where it stands."""

    id: int
    x: float
    z: float


class RadioLink:
    """Owns the graph, the airtime, the deliveries still in flight, the loss generator and the radio's counts.

    ``rovers``: the scenario's rovers where they start; their ids are the only targets a transmission may name
    besides the lander.
    """

    def __init__(self, scenario: Scenario, keys: ks.Keyspace, dt: float, terrain: Heightmap, scene: Scene,
                 rovers: Collection[Positioned], rejected: Rejections, power: EnergyAccount | None) -> None:
        self.keys, self.dt, self.terrain, self.scene = keys, dt, terrain, scene
        self.params = scenario.rover_params.communication
        self.transmit_j = scenario.rover_params.power.radio_transmit_j
        self.lander_xz = (scenario.lander.x, scenario.lander.z)
        self.rovers = frozenset(r.id for r in rovers)
        self.rejected, self.power = rejected, power
        self.rng = np.random.default_rng([scenario.seed, 1])  # its own stream: traffic never shifts the noise
        self.dropped = 0  # deliveries to a target out of reach
        self.lost = 0  # deliveries lost on the way (``loss_probability``)
        self.in_flight: list[tuple[int, Out]] = []  # (due tick, delivery) with latency
        self.graph: CommGraph = self._graph(list(rovers))
        self.airtime = Airtime(len(self.rovers) + 1, dt)

    def transmit(self, sender: int, msg: m.OutboundComm, from_lander: bool, tick: int) -> list[Out]:
        """Deliveries of one transmission due now; those with latency go in flight. ValueError: refused whole."""
        if msg.channel != "comm_in" and not from_lander:
            raise ValueError(f"only the lander may transmit on channel {msg.channel!r}")
        model = m.RADIO_CHANNEL_MODELS.get(msg.channel)
        inner = codec.decode(model, msg.payload) if model else None
        if not self.airtime.take(sender, len(msg.targets), tick):
            raise ValueError(f"{sender} is over its airtime ({len(msg.targets)} deliveries)")
        if self.power is not None and not from_lander:
            self.power.spend(sender, self.transmit_j)
        out: list[Out] = []
        for target in msg.targets:
            if target != ks.LANDER_ID and target not in self.rovers:
                self.rejected.count("radio target", f"no rover {target} in the scenario")
                continue
            if not self.graph.connected(sender, target):
                self.dropped += 1
                continue
            c = self.params
            if c.loss_probability > 0 and self.rng.random() < c.loss_probability:
                self.lost += 1
                continue
            delivery = self._delivery(target, sender, msg, inner)
            if c.latency_s > 0:
                self.in_flight.append((tick + max(1, round(c.latency_s / self.dt)), delivery))
            else:
                out.append(delivery)
        return out

    def due(self, tick: int) -> list[Out]:
        """Deliveries in flight that arrive on ``tick``."""
        due = [d for t, d in self.in_flight if t <= tick]
        self.in_flight = [(t, d) for t, d in self.in_flight if t > tick]
        return due

    def _delivery(self, target: int, sender: int, msg: m.OutboundComm, inner: m.Message | None) -> Out:
        if inner is not None:
            return self.keys.rover(target, msg.channel), inner
        key = self.keys.lander(ks.COMM_IN) if target == ks.LANDER_ID else self.keys.rover(target, ks.COMM_IN)
        return key, m.InboundComm(sender=sender, payload=msg.payload)

    def rebuild(self, rovers: Iterable[Positioned]) -> None:
        """The graph of where the rovers stand now."""
        self.graph = self._graph(list(rovers))

    def _graph(self, rovers: list[Positioned]) -> CommGraph:
        ids = np.array([ks.LANDER_ID, *(r.id for r in rovers)], int)
        x = np.array([self.lander_xz[0]] + [r.x for r in rovers])
        z = np.array([self.lander_xz[1]] + [r.z for r in rovers])
        c = self.params
        sight = None
        if c.line_of_sight:
            antenna = np.full(len(ids), c.antenna_height_m)
            antenna[0] = c.lander_antenna_height_m

            def sight(i, j):
                return line_of_sight(self.terrain, self.scene.edges, self.scene.edge_height, x, z, antenna, i, j)
        return build_graph(ids, x, z, c.comm_range, c.lander_comm_range, sight)

    def partners(self) -> list[Out]:
        """Every rover's and the lander's partners in direct range and line of sight."""
        out: list[Out] = [(self.keys.rover(rid, ks.COMM_PARTNERS), m.CommPartners(ids=self.graph.partners(rid)))
                          for rid in self.graph.ids.tolist() if rid != ks.LANDER_ID]
        out.append((self.keys.lander(ks.COMM_PARTNERS), m.CommPartners(ids=self.graph.partners(ks.LANDER_ID))))
        return out

    def reaches_lander(self) -> dict[int, bool]:
        """Node id -> whether a route of links joins it to the lander."""
        return dict(zip(self.graph.ids.tolist(), self.graph.connected_to_lander().tolist(), strict=True))
