"""Who may do what on a world's keyspace, and the router's Zenoh ``access_control`` section that enforces it.

Each process of a deployment has a role: ``world``, ``lander``, ``ground``, ``recorder`` and one
``rover-<id>`` per rover. A role is the set of keys it publishes, subscribes to, holds liveliness tokens on,
watches tokens on, answers queries on and queries, taken from what the programs do:

- a rover publishes only its own inputs to the world (``World.INPUT_TOPICS``: actions, radio output,
  status), its lockstep ``ack`` and its driver's ``telemetry``, and subscribes only to its own sensors and
  radio input (the agent's ``SUBSCRIBED_TOPICS``) and the clock; it holds ``alive/rover/<id>`` and may
  ask the world for a free id;
- the world alone publishes sensors (every rover's ``SUBSCRIBED_TOPICS``, the lander's radio input), the
  clock, ``world/state`` and ``world/stats``;
- the ground alone publishes ``ground/command``; the lander answers it on ``ground/command_result``;
- the recorder reads the whole world and writes nothing.

Everything else is denied (``default_permission: deny``). Two Zenoh facts shape the rules (checked on a
real router, see tests/test_security.py): a declared publisher sends only when it has learnt of a matching
subscriber, so a publishing role must be allowed to *see* subscriber declarations (egress
``declare_subscriber``: it reveals which keys are subscribed, no data); and a rule matches a message only if
the rule's key expression includes the message's, so a wildcard subscription needs a rule at least as wide.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from schemas import keyspace as ks

WORLD, LANDER, GROUND, RECORDER = "world", "lander", "ground", "recorder"
PUBLICATION = ("put", "delete")


def rover_role(rover_id: int) -> str:
    """The role name of one rover: its certificate's common name and its user name."""
    return f"rover-{rover_id}"


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
    """Topics a rover sends: what the world accepts from rovers, plus lockstep acks and driver telemetry."""
    from world_service.sim import World

    return (*World.INPUT_TOPICS, ks.ACK, ks.TELEMETRY)


def _rover_sensors() -> tuple[str, ...]:
    """Topics a rover receives: its sensors and radio input, all of them published by the world."""
    from rover_agent.agent import SUBSCRIBED_TOPICS

    return tuple(SUBSCRIBED_TOPICS)


def world_role(keys: ks.Keyspace) -> Role:
    return Role(
        WORLD,
        publishes=(*(keys.rovers(t) for t in _rover_sensors()), keys.lander(ks.COMM_IN), keys.lander(ks.COMM_PARTNERS),
                   keys.clock, keys.state, keys.stats),
        subscribes=(*(keys.rovers(t) for t in _rover_inputs()), keys.lander(ks.COMM_OUT), keys.lander(ks.ACK),
                    keys.ground_command),
        watches=(keys.alive_rovers, keys.alive_lander),
        serves=(keys.rover_ids,),
    )


def lander_role(keys: ks.Keyspace) -> Role:
    return Role(
        LANDER,
        publishes=(keys.lander(ks.COMM_OUT), keys.lander(ks.STATUS), keys.lander(ks.ACK), keys.ground_command_result),
        subscribes=(keys.clock, keys.lander(ks.COMM_IN), keys.lander(ks.COMM_PARTNERS), keys.ground_command),
        tokens=(keys.alive_lander,),
    )


def ground_role(keys: ks.Keyspace) -> Role:
    return Role(GROUND, publishes=(keys.ground_command,),
                subscribes=(keys.ground_command_result, keys.lander(ks.STATUS)))


def recorder_role(keys: ks.Keyspace) -> Role:
    return Role(RECORDER, subscribes=(keys.all,))


def rover_agent_role(keys: ks.Keyspace, rover_id: int) -> Role:
    return Role(
        rover_role(rover_id),
        publishes=tuple(keys.rover(rover_id, t) for t in _rover_inputs()),
        subscribes=(*(keys.rover(rover_id, t) for t in _rover_sensors()), keys.clock),
        tokens=(keys.alive_rover(rover_id),),
        queries=(keys.rover_ids,),
    )


def roles(keys: ks.Keyspace, rover_ids: Iterable[int]) -> list[Role]:
    """Every role of a world with these rovers."""
    ids = sorted(set(rover_ids))
    if not ids or ids[0] < 1:
        raise ValueError(f"rover ids must be 1 or more (as rover1, rover2 in the report), got {ids}")
    fixed = [world_role(keys), lander_role(keys), ground_role(keys), recorder_role(keys)]
    return fixed + [rover_agent_role(keys, rid) for rid in ids]


def _rule(rule_id: str, messages: Iterable[str], flow: str, key_exprs: Iterable[str]) -> dict:
    return {"id": rule_id, "permission": "allow", "messages": list(messages), "flows": [flow],
            "key_exprs": list(key_exprs)}


def rules_of(role: Role, keys: ks.Keyspace) -> list[dict]:
    """The allow rules of one role, each named ``<role> <what>``; kinds the role does not use give none."""
    n = role.name
    wanted = [
        (f"{n} publish", PUBLICATION, "ingress", role.publishes),
        (f"{n} sees subscribers", ["declare_subscriber"], "egress", (keys.all,) if role.publishes else ()),
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
