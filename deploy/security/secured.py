"""The files of a secured router (``lunarsim acl``): its config with access control for each role, the
user/password dictionary, and one client config per role. The secrets are written readable by their owner only."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from deploy.security import acl, configs
from schemas.keyspace import Keyspace


def write_secured(output: Path, certs: Path, credentials: Path, clients: Path, roles: Sequence[acl.Role],
                  keys: Keyspace, existing: dict[str, str], listen: Sequence[str], connect: Sequence[str],
                  header: str) -> list[str]:
    """Write the router's config to ``output``, the dictionary to ``credentials`` (passwords in ``existing`` kept)
    and each role's client config into ``clients``; the role names, in order."""
    names = [r.name for r in roles]
    passwords = configs.passwords_for(names, existing)
    router = configs.router_config(certs, credentials, listen, acl.access_control(roles, keys))
    _write(output, configs.json5_text(router, header), secret=False)
    _write(credentials, configs.credentials_text(passwords), secret=True)
    for name in names:
        client = configs.client_config(name, passwords[name], certs, connect)
        _write(clients / f"{name}.json5", configs.json5_text(client, f"{header}\nRole: {name}"), secret=True)
    return names


def _write(path: Path, text: str, secret: bool) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    if secret:
        os.chmod(path, 0o600)
    print(f"wrote {path}")
