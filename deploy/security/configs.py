"""Router and per-role client Zenoh configs for a secured deployment, rendered from the json5 templates.

The templates beside this module (``router.json5``, ``client.json5``) are the one place that says how
TLS, mTLS and user/password authentication are set; the functions here keep their settings and fill in
only what a user would edit: endpoints, certificate and key paths, user names, passwords and the router's
access control. Paths are written absolute, so a process finds them from any working folder.
"""

from __future__ import annotations

import json
import secrets
from collections.abc import Iterable, Sequence
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROUTER_TEMPLATE = HERE / "router.json5"
CLIENT_TEMPLATE = HERE / "client.json5"
FROM_TEMPLATE = ("mode", "scouting/multicast/enabled", "transport/shared_memory/enabled", "transport/link/protocols",
                 "transport/link/tls")
"""What a rendered config takes from its template (all the rest is filled in here)."""
CA, ROUTER = "ca", "router"


def cert_files(certs: Path, name: str) -> tuple[Path, Path]:
    """(certificate, private key) of ``name`` in a folder made by ``make-dev-certs.sh``."""
    return certs / f"{name}.pem", certs / f"{name}.key"


def missing_cert_files(certs: Path, names: Iterable[str]) -> list[Path]:
    wanted = [certs / f"{CA}.pem"] + [f for name in names for f in cert_files(certs, name)]
    return [f for f in wanted if not f.is_file()]


def _drop_nulls(value):
    if isinstance(value, dict):
        return {k: _drop_nulls(v) for k, v in value.items() if v is not None}
    return value


def from_template(template: Path) -> dict:
    """The settings of a template that rendered configs keep, read through Zenoh's own parser."""
    import zenoh

    conf = zenoh.Config.from_file(str(template))
    tree: dict = {}
    for key in FROM_TEMPLATE:
        *parents, leaf = key.split("/")
        node = tree
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = _drop_nulls(json.loads(conf.get_json(key)))
    return tree


def router_config(certs: Path, credentials: Path, listen: Sequence[str], access_control: dict | None,
                  template: Path = ROUTER_TEMPLATE) -> dict:
    conf = from_template(template)
    cert, key = cert_files(certs.resolve(), ROUTER)
    conf["transport"]["link"]["tls"].update(root_ca_certificate=str(certs.resolve() / f"{CA}.pem"),
                                            listen_certificate=str(cert), listen_private_key=str(key))
    conf["transport"]["auth"] = {"usrpwd": {"dictionary_file": str(credentials.resolve())}}
    conf["listen"] = {"endpoints": list(listen)}
    if access_control is not None:
        conf["access_control"] = access_control
    return conf


def client_config(role: str, password: str, certs: Path, connect: Sequence[str],
                  template: Path = CLIENT_TEMPLATE) -> dict:
    conf = from_template(template)
    cert, key = cert_files(certs.resolve(), role)
    conf["transport"]["link"]["tls"].update(root_ca_certificate=str(certs.resolve() / f"{CA}.pem"),
                                            connect_certificate=str(cert), connect_private_key=str(key))
    conf["transport"]["auth"] = {"usrpwd": {"user": role, "password": password}}
    conf["connect"] = {"endpoints": list(connect)}
    return conf


def parse_credentials(text: str) -> dict[str, str]:
    """A usrpwd dictionary file (``user:password`` per line) as {user: password}."""
    users = {}
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        user, sep, password = line.partition(":")
        if not sep or not user or not password:
            raise ValueError(f"credentials line {number}: expected user:password, got {line!r}")
        users[user] = password
    return users


def credentials_text(passwords: dict[str, str]) -> str:
    return "".join(f"{user}:{password}\n" for user, password in passwords.items())


def passwords_for(role_names: Iterable[str], existing: dict[str, str]) -> dict[str, str]:
    """A password per role: kept from ``existing`` (clients already deployed keep working), else a new one."""
    return {name: existing.get(name) or secrets.token_urlsafe(18) for name in role_names}


def json5_text(conf: dict, header: str) -> str:
    """JSON is json5; the header says where the file came from, as a comment."""
    comment = "".join(f"// {line}\n" for line in header.splitlines())
    return comment + json.dumps(conf, indent=2) + "\n"
