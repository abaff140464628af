"""The documentation: the site builds with MkDocs in strict mode (a broken link or anchor fails it), every page is
in its navigation, and the README stays a short user's guide that points into it."""

from __future__ import annotations

import os
import subprocess
import sys

import yaml
from procs import REPO

DOCS = REPO / "docs"
README_MAX_LINES = 200


def test_the_site_builds_in_strict_mode(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=REPO, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert done.returncode == 0, done.stdout + done.stderr
    assert (tmp_path / "site" / "getting-started" / "index.html").is_file()


def _pages(nav: list) -> set[str]:
    found: set[str] = set()
    for entry in nav:
        for value in entry.values():
            found |= _pages(value) if isinstance(value, list) else {value}
    return found


def test_every_page_is_in_the_navigation():
    nav = yaml.safe_load((REPO / "mkdocs.yml").read_text())["nav"]
    assert _pages(nav) == {str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md")}


def test_the_reference_pages_are_what_the_code_generates():
    """Keys, messages, scenario fields and command help come from the code: regenerate them with
    ``python -m deploy.reference docs`` after changing any of those."""
    from deploy.reference import pages

    stale = [name for name, content in pages(DOCS).items() if (DOCS / name).read_text() != content]
    assert not stale, f"regenerate with 'python -m deploy.reference docs': {stale}"


def test_the_readme_is_short_and_every_link_into_the_docs_resolves():
    text = (REPO / "README.md").read_text()
    assert len(text.splitlines()) <= README_MAX_LINES
    assert "pip install . && lunarsim run crater_observation" in text
    assert "pip install '.[test]' && pytest" in text
    for target in {part.split(")")[0] for part in text.split("](docs/")[1:]}:
        assert (DOCS / target.split("#")[0]).is_file(), target
