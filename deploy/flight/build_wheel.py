"""Build ``lunarsim-rover``: the wheel a rover's flight computer installs.

It holds only what runs on the rover: the rover agent, the hardware driver bridge and its drivers, the message
schemas, and the Zenoh plumbing and pure code (``shared``) they share. No world service, no rendering, no NumPy or
trimesh: its dependencies are Zenoh and msgspec, and pydantic and PyYAML for a ``--params`` file (pyserial with
the ``serial`` extra, for the reference driver). The modules are the project's own files, staged into a temporary
project and built with pip, so there is one copy of every line; ``FLIGHT_PACKAGES`` is the whole list, and tests
check that nothing in it imports anything outside it.

    python -m deploy.flight.build_wheel -o dist/     # from the checkout
    pip install dist/lunarsim_rover-*.whl            # then: lunarsim-rover --id 3 --connect tcp/...:7447
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
"""The source tree; an installed copy of this module is given the checkout explicitly (``source=``)."""
DIST_NAME = "lunarsim-rover"
FLIGHT_PACKAGES = ("schemas", "bus", "shared", "rover_agent", "hardware")
"""The packages the rover carries, whole, with their subpackages: the layout keeps ground-side code out of them
(``tests/project/test_layout.py``)."""
DEPENDENCIES = ("eclipse-zenoh>=1.10,<2", "msgspec>=0.19", "pydantic>=2.6,<3", "pyyaml>=6")
EXTRAS = {"serial": ("pyserial>=3.5",)}
SCRIPTS = {"lunarsim-rover": "rover_agent.commands.rover:main", "lunarsim-bridge": "hardware.commands.bridge:main"}
DATA = {"share/lunarsim": ("deploy/zenoh/client.json5",),
        "share/lunarsim/systemd": ("deploy/systemd/lunarsim-rover@.service", "deploy/systemd/lunarsim-bridge@.service")}
"""Installed under the environment's prefix: the client config and the systemd units to copy into place."""


def project_version(source: Path = REPO) -> str:
    found = re.search(r'^version = "([^"]+)"', (source / "pyproject.toml").read_text(), re.MULTILINE)
    if found is None:
        raise RuntimeError("no version in pyproject.toml")
    return found.group(1)


def staged_files(source: Path = REPO) -> list[Path]:
    """Every source file of the wheel, relative to the repository: each package's modules and those of its
    subpackages (folders with an ``__init__.py``, all the way down)."""
    files: list[Path] = []
    for package in FLIGHT_PACKAGES:
        top = source / package.replace(".", "/")
        files += [p.relative_to(source) for p in sorted(top.rglob("*.py")) if _importable(p.parent, top)]
    return files


def _importable(folder: Path, top: Path) -> bool:
    """Whether ``folder``, under the package folder ``top``, is a subpackage, and so is every folder between."""
    return all((f / "__init__.py").is_file() for f in (folder, *folder.parents) if f != top and top in f.parents)


def package_names(source: Path = REPO) -> list[str]:
    """The wheel's packages, subpackages included: setuptools installs only those it is told of."""
    return sorted({".".join(rel.parent.parts) for rel in staged_files(source) if rel.name == "__init__.py"})


def _pyproject(version: str, packages: list[str]) -> str:
    """TOML by hand: its arrays of strings are JSON's, and the standard library writes no TOML."""
    extras = "\n".join(f"{name} = {json.dumps(list(deps))}" for name, deps in EXTRAS.items())
    scripts = "\n".join(f"{name} = {json.dumps(target)}" for name, target in SCRIPTS.items())
    data = "\n".join(f"{json.dumps(dest)} = {json.dumps(list(sources))}" for dest, sources in DATA.items())
    return f"""[build-system]
requires = ["setuptools>=68", "wheel"]
build-backend = "setuptools.build_meta"

[project]
name = "{DIST_NAME}"
version = "{version}"
description = "LunarSim on a rover's flight computer: the rover agent and the hardware driver bridge"
requires-python = ">=3.11"
license = {{ text = "Apache-2.0" }}
dependencies = {json.dumps(list(DEPENDENCIES))}

[project.optional-dependencies]
{extras}

[project.scripts]
{scripts}

[tool.setuptools]
packages = {json.dumps(packages)}

[tool.setuptools.data-files]
{data}
"""


def stage(into: Path, source: Path = REPO) -> Path:
    for rel in staged_files(source):
        target = into / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source / rel, target)
    for src in (src for sources in DATA.values() for src in sources):
        (into / src).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source / src, into / src)
    (into / "pyproject.toml").write_text(_pyproject(project_version(source), package_names(source)))
    return into


def build(out_dir: Path, source: Path = REPO) -> Path:
    """Build the wheel from the checkout at ``source`` into ``out_dir``; returns the wheel's path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="lunarsim-rover-") as tmp:
        project = stage(Path(tmp) / "project", source)
        subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet",
                        "--wheel-dir", str(out_dir), str(project)], check=True)
    wheels = sorted(out_dir.glob("lunarsim_rover-*.whl"), key=lambda p: p.stat().st_mtime)
    if not wheels:
        raise RuntimeError(f"pip built no lunarsim_rover wheel in {out_dir}")
    return wheels[-1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-o", "--out", type=Path, default=Path("dist"), help="folder for the wheel (default dist/)")
    parser.add_argument("--source", type=Path, default=REPO, help="the LunarSim checkout (default: this one)")
    args = parser.parse_args(argv)
    wheel = build(args.out, args.source)
    print(f"built {wheel} ({wheel.stat().st_size / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
