"""Packaging hook: build the web front end (three.js, bundled by esbuild) before the Python package is built.

``pip install .`` runs ``npm ci && npm run build`` in ``web/frontend`` when the bundle is missing or
older than its sources, so the wheel carries ``web/static/bundle.js`` and the page needs no CDN.
Everything else about the package is in pyproject.toml.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

FRONTEND = Path(__file__).resolve().parent / "web" / "frontend"
BUNDLE = FRONTEND.parent / "static" / "bundle.js"


def _stale() -> bool:
    if not BUNDLE.is_file():
        return True
    sources = [*FRONTEND.glob("src/*.js"), FRONTEND / "package.json", FRONTEND / "package-lock.json"]
    return max(p.stat().st_mtime for p in sources) > BUNDLE.stat().st_mtime


def build_frontend() -> None:
    if not _stale():
        return
    npm = shutil.which("npm")
    if npm is None:
        raise SystemExit("building lunarsim needs npm (Node.js 18 or newer) to bundle the web front end in "
                         f"{FRONTEND}: install nodejs and npm (Debian: apt-get install -y nodejs npm) and retry")
    subprocess.run([npm, "ci", "--no-audit", "--no-fund"], cwd=FRONTEND, check=True)
    subprocess.run([npm, "run", "build"], cwd=FRONTEND, check=True)


class BuildPyWithFrontend(build_py):
    def run(self) -> None:
        build_frontend()
        super().run()


setup(cmdclass={"build_py": BuildPyWithFrontend})
