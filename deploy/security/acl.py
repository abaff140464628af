"""Who may do what on a world's keyspace, and the router's Zenoh ``access_control`` section that enforces it.

Each process of a deployment has a role: ``world``, ``lander``, ``ground``, ``recorder``, ``view``, one ``rover-<id>``
per rover agent and one ``bridge-<id>`` per real rover's driver bridge. A role is the set of keys it
publishes, subscribes to, holds liveliness tokens on, watches tokens on, answers queries on and queries,
taken from what the programs do:

- a rover agent publishes only its own inputs to the world (``World.INPUT_TOPICS``: actions, radio output,
  status), its lockstep ``ack`` and its ``pose_estimate`` (which the ground may read, the world not), and
  subscribes only to its own sensors and radio input (``keyspace.ROVER_INPUTS``) and the clock; it holds
  ``alive/rover/<id>`` and may ask the world for a free id;
- the world publishes the sensors of the simulated rovers (every rover's ``keyspace.ROVER_INPUTS``, the lander's
  radio input), the clock, ``world/state`` and ``world/stats``;
- a real rover's bridge (``hardware.bridge``) takes the world's place for that rover only: it alone
  publishes the rover's sensors and its driver's ``telemetry``, subscribes to the rover's actions and radio
  output (``AGENT_TOPICS``, ``comm_out``) and the clock, and watches its own agent's token. The world keeps
  no right to publish a bridged rover's sensors; it follows the bridged rovers as a twin instead
  (``TwinWorld.INPUT_TOPICS``, as ``service.declare_io`` subscribes for it). On a bench without a world one
  bridge may be the clock (``bridge_clock``);
- the ground alone publishes ``ground/command``; the lander answers it on ``ground/command_result``;
- the recorder reads the whole world and writes nothing; it and the ground watch a replay's token (``alive/replay``),
  which tells a viewer that what it shows is a recording;
- the web view (``view``, ``lunarsim view``) reads what the recorder reads and has the ground's say: it publishes
  only ground commands, and watches a replay's token;
- the ROS 2 bridge (``ros2``, ``lunarsim ros2``) has the ground's say and reads what it bridges: it publishes only
  ground commands, and reads the rovers' sensors, the world's answers to their actions, their radio deliveries and
  pose estimates, the clock and the lander's map; ``world/state`` only when the deployment grants it ground truth.
  For the rovers ROS 2 drives (``--drive``) it takes their agent's place (their actions, status, estimate and
  liveliness token). On the ROS side it owns its domain's data keys and graph tokens (``@ros2_lv/<domain>``),
  which the ROS 2 nodes (``ros2-nodes``) share, and where those nodes may do nothing else: no LunarSim key.

Everything else is denied (``default_permission: deny``). Two Zenoh facts shape the rules (checked on a
real router, see tests/e2e/test_security.py): a declared publisher sends only when it has learnt of a matching
subscriber, so a publishing role must be allowed to *see* subscriber declarations (egress
``declare_subscriber``: it reveals which keys are subscribed, no data); and a rule matches a message only if
the rule's key expression includes the message's, so a wildcard subscription needs a rule at least as wide.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from schemas import keyspace as ks

WORLD, LANDER, GROUND, RECORDER, VIEW = "world", "lander", "ground", "recorder", "view"
ROS2, ROS2_NODES = "ros2", "ros2-nodes"
PUBLICATION = ("put", "delete")


def rover_role(rover_id: int) -> str:
    """The role name of one rover: its certificate's common name and its user name."""
    return f"rover-{rover_id}"


def bridge_role(rover_id: int) -> str:
    """The role name of one real rover's driver bridge (``lunarsim bridge --id <id>``)."""
    return f"bridge-{rover_id}"


@dataclass(frozen=True)
class Role:
    """What one process may do, as key expressions per kind of operation."""

    name: str
    publishes: tuple[str, ...] = ()
    subscribes: tuple[str, ...] = ()
    tokens: tuple[str, ...] = ()
    """Liveliness tokens it holds."""
    watches: tuple[str, ...] = ()
    """Liveliness tokens it subscribes to (or queries)."""
    serves: tuple[str, ...] = ()
    """Queryables it declares and answers."""
    queries: tuple[str, ...] = ()


def _rover_inputs() -> tuple[str, ...]:
    """Topics a rover agent sends: what the world accepts from rovers, plus lockstep acks."""
    from world_service.sim import World

    return (*World.INPUT_TOPICS, ks.ACK)


def _bridge_inputs() -> tuple[str, ...]:
    """Topics a bridge takes from its agent (``bridge.input_topics`` with a radio)."""
    from hardware.bridge import AGENT_TOPICS

    return (*AGENT_TOPICS, ks.COMM_OUT)


def _bridge_outputs() -> tuple[str, ...]:
    """Topics a bridge publishes: every sensor its agent reads, in the world's place, and the driver's pose."""
    return (*ks.ROVER_INPUTS, ks.TELEMETRY)


def _twin_inputs() -> tuple[str, ...]:
    """Rover topics the world follows in twin mode (``TwinWorld.input_keys``)."""
    from world_service.twin.world import TwinWorld

    return TwinWorld.INPUT_TOPICS


def world_role(keys: ks.Keyspace, simulated: Iterable[int] | None = None, bridged: Iterable[int] = (),
               clock: bool = True) -> Role:
    """The world simulating ``simulated`` (None: every rover, by wildcard) and following ``bridged`` as a twin.

    It may publish the sensors of the simulated rovers only (and the lander's radio input while it simulates
    any), so it cannot speak for a real rover; it publishes the clock unless a bridge is the clock (a bench).
    """
    bridged = tuple(bridged)
    sensors = [keys.rovers(t) for t in ks.ROVER_INPUTS] if simulated is None else [
        keys.rover(rid, t) for rid in simulated for t in ks.ROVER_INPUTS]
    publishes: list[str] = []
    subscribes: list[str] = []
    if sensors:
        publishes += [*sensors, keys.lander(ks.COMM_IN), keys.lander(ks.COMM_PARTNERS)]
        subscribes += [*(keys.rovers(t) for t in _rover_inputs()), keys.lander(ks.COMM_OUT), keys.lander(ks.ACK),
                       keys.lander(ks.STATUS)]  # the lander's count of rejected samples, for the report
    if bridged:
        subscribes += [*(keys.rovers(t) for t in _twin_inputs()), keys.lander(ks.COMM_PARTNERS)]
    publishes += [keys.clock] if clock else []
    return Role(
        WORLD,
        publishes=(*publishes, keys.state, keys.stats),
        subscribes=(*dict.fromkeys(subscribes), keys.ground_command),
        watches=(keys.alive_rovers, keys.alive_lander),
        serves=(keys.rover_ids,),
    )


def lander_role(keys: ks.Keyspace) -> Role:
    return Role(
        LANDER,
        publishes=(keys.lander(ks.COMM_OUT), keys.lander(ks.STATUS), keys.lander(ks.ACK), keys.ground_command_result,
                   keys.lander(ks.MAP)),
        subscribes=(keys.clock, keys.lander(ks.COMM_IN), keys.lander(ks.COMM_PARTNERS), keys.ground_command),
        tokens=(keys.alive_lander,),
    )


def ground_role(keys: ks.Keyspace) -> Role:
    return Role(GROUND, publishes=(keys.ground_command,),
                subscribes=(keys.ground_command_result, keys.lander(ks.STATUS), keys.rovers(ks.POSE_ESTIMATE)),
                watches=(keys.alive_replays,))


def recorder_role(keys: ks.Keyspace) -> Role:
    return Role(RECORDER, subscribes=(keys.all,), watches=(keys.alive_replays,))


def view_role(keys: ks.Keyspace) -> Role:
    """The recorder's reading and the ground's say: the view shows everything and sends the operator's commands."""
    recorder, ground = recorder_role(keys), ground_role(keys)
    return Role(VIEW, publishes=ground.publishes, subscribes=recorder.subscribes, watches=recorder.watches)


def rover_agent_role(keys: ks.Keyspace, rover_id: int) -> Role:
    return Role(
        rover_role(rover_id),
        publishes=tuple(keys.rover(rover_id, t) for t in ks.ROVER_OUTPUTS),
        subscribes=(*(keys.rover(rover_id, t) for t in ks.ROVER_INPUTS), keys.clock),
        tokens=(keys.alive_rover(rover_id),),
        queries=(keys.rover_ids,),
    )


def driver_bridge_role(keys: ks.Keyspace, rover_id: int, clock: bool = False) -> Role:
    """A real rover's bridge: that rover's sensors and telemetry out, its actions and radio output in, its agent's
    token watched (to stop the rover without it); the clock read, or published with ``clock`` (``--clock``)."""
    return Role(
        bridge_role(rover_id),
        publishes=(*(keys.rover(rover_id, t) for t in _bridge_outputs()), *((keys.clock,) if clock else ())),
        subscribes=(*(keys.rover(rover_id, t) for t in _bridge_inputs()), *(() if clock else (keys.clock,))),
        watches=(keys.alive_rover(rover_id),),
    )


@dataclass(frozen=True)
class Ros2Access:
    """What a deployment grants the ROS 2 bridge: its ROS domain, ground truth (``lunarsim ros2 --truth``) and the
    rovers ROS 2 nodes drive in their agent's place (``--drive``)."""

    domain: int = 0
    truth: bool = False
    driven: tuple[int, ...] = ()


def ros2_graph(domain: int) -> tuple[str, str, str]:
    """The ROS 2 domain's data keys, its graph tokens (rmw_zenoh: ``<domain>/...``, ``@ros2_lv/<domain>/...``) and
    the keys of its transient-local publishers' caches (``<topic key>/@adv/...``: a verbatim chunk, which ``**``
    does not cross)."""
    return f"{domain}/**", f"@ros2_lv/{domain}/**", f"{domain}/**/@adv/**"


def ros2_bridge_role(keys: ks.Keyspace, access: Ros2Access) -> Role:
    from ros2_bridge.translator import ROVER_SOURCES

    data, graph, cache = ros2_graph(access.domain)
    driven = sorted(set(access.driven))
    return Role(
        ROS2,
        publishes=(keys.ground_command, *(keys.rover(rid, t) for rid in driven
                                          for t in ks.ROVER_OUTPUTS), data, cache),
        subscribes=(*(keys.rovers(t) for t in ROVER_SOURCES), keys.clock, keys.lander(ks.MAP),
                    *((keys.state,) if access.truth else ()), data),
        tokens=(*(keys.alive_rover(rid) for rid in driven), graph, cache),
        watches=(keys.alive_rovers, graph),
        serves=(cache,),
    )


def ros2_nodes_role(access: Ros2Access) -> Role:
    """ROS 2 nodes on rmw_zenoh: their domain's topics and graph, and no LunarSim key."""
    data, graph, cache = ros2_graph(access.domain)
    return Role(ROS2_NODES, publishes=(data, cache), subscribes=(data, cache), tokens=(graph, cache),
                watches=(graph, cache), serves=(cache,), queries=(cache,))


def roles(keys: ks.Keyspace, rover_ids: Iterable[int], bridged: Iterable[int] = (),
          bridge_clock: bool = False, ros2: Ros2Access | None = None) -> list[Role]:
    """Every role of a world with these rovers, of which ``bridged`` are real ones behind a driver bridge.

    ``bridge_clock``: the one bridge publishes the clock (``lunarsim bridge --clock``, a bench without a world)
    and the world may not. ``ros2``: a ROS 2 bridge and its nodes join, with what it grants them.
    """
    ids = sorted(set(rover_ids))
    if not ids or ids[0] < 1:
        raise ValueError(f"rover ids must be 1 or more (as rover1, rover2 in the report), got {ids}")
    real = sorted(set(bridged))
    strangers = [rid for rid in real if rid not in ids]
    if strangers:
        raise ValueError(f"bridged rovers {strangers} are not rovers of this world (its rovers: "
                         f"{', '.join(map(str, ids))})")
    if bridge_clock and len(real) != 1:
        raise ValueError(f"the clock can be one bridge's only (one rover on a bench, no world), got bridges {real}")
    simulated = None if not real else [rid for rid in ids if rid not in real]
    fixed = [world_role(keys, simulated, real, clock=not bridge_clock), lander_role(keys), ground_role(keys),
             recorder_role(keys), view_role(keys)]
    if ros2 is not None and (strangers := [rid for rid in ros2.driven if rid not in ids]):
        raise ValueError(f"rovers {strangers} driven from ROS 2 are not rovers of this world")
    extra = [] if ros2 is None else [ros2_bridge_role(keys, ros2), ros2_nodes_role(ros2)]
    return (fixed + [rover_agent_role(keys, rid) for rid in ids]
            + [driver_bridge_role(keys, rid, bridge_clock) for rid in real] + extra)


def _rule(rule_id: str, messages: Iterable[str], flow: str, key_exprs: Iterable[str]) -> dict:
    return {"id": rule_id, "permission": "allow", "messages": list(messages), "flows": [flow],
            "key_exprs": list(key_exprs)}


def rules_of(role: Role, keys: ks.Keyspace) -> list[dict]:
    """The allow rules of one role, each named ``<role> <what>``; kinds the role does not use give none."""
    n = role.name
    wanted = [
        (f"{n} publish", PUBLICATION, "ingress", role.publishes),
        (f"{n} sees subscribers", ["declare_subscriber"], "egress", _seen(role, keys)),
        (f"{n} subscribe", ["declare_subscriber"], "ingress", role.subscribes),
        (f"{n} receive", PUBLICATION, "egress", role.subscribes),
        (f"{n} hold token", ["liveliness_token"], "ingress", role.tokens),
        (f"{n} watch tokens", ["declare_liveliness_subscriber", "liveliness_query"], "ingress", role.watches),
        (f"{n} see tokens", ["liveliness_token"], "egress", role.watches),
        (f"{n} serve", ["declare_queryable", "reply"], "ingress", role.serves),
        (f"{n} take queries", ["query"], "egress", role.serves),
        (f"{n} query", ["query"], "ingress", role.queries),
        (f"{n} get replies", ["reply", "declare_queryable"], "egress", role.queries),
    ]
    return [_rule(rule_id, messages, flow, key_exprs) for rule_id, messages, flow, key_exprs in wanted if key_exprs]


def _seen(role: Role, keys: ks.Keyspace) -> tuple[str, ...]:
    """Where a publishing role sees subscribers: the world's keys, and any others it publishes on (ROS 2's)."""
    if not role.publishes:
        return ()
    return (keys.all, *(k for k in role.publishes if not k.startswith(keys.prefix + "/")))


def access_control(all_roles: Iterable[Role], keys: ks.Keyspace) -> dict:
    """The router's ``access_control`` section: deny by default, then each role's rules for its subject.

    A subject is matched by both its TLS certificate's common name and its user name (a Cartesian product
    in Zenoh: both must hold), so a stolen password without the key, or the reverse, matches no role.
    """
    all_roles = list(all_roles)
    names = [r.name for r in all_roles]
    if len(set(names)) != len(names):
        raise ValueError(f"role names must be unique, got {names}")
    rules, subjects, policies = [], [], []
    for role in all_roles:
        own = rules_of(role, keys)
        rules += own
        subjects.append({"id": role.name, "cert_common_names": [role.name], "usernames": [role.name]})
        policies.append({"id": role.name, "rules": [r["id"] for r in own], "subjects": [role.name]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}
