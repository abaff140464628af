"""Every command block of the README and the hand-written docs runs as a reader would copy it.

Which blocks are commands: in ``README.md`` and ``docs/**/*.md`` (not ``docs/reference/`` nor ``docs/index.md``,
which ``python -m deploy.reference docs`` generates), every indented code block and every fenced block tagged
``bash``, ``sh``, ``shell`` or ``console`` (of a console block, the lines after ``$``). Other fences (``text``,
``yaml``, ``python``) are not run. An indented block that is not meant to be typed says so with a marker, so no
block is left out by a guess.

How they run: page by page, each page's blocks in order, with ``bash`` (``set -e -o pipefail``: every command
must succeed; a failure names the block, the command and its output). The scratch folder stands for a clone's
root: it holds copies of the folders commands name (``scenarios/``, ``deploy/``, ``tests/data/``), so whatever a
command writes lands in it. ``lunarsim`` is the one installed in the test's virtual environment. ``HOME`` is a
scratch folder too, with no ``XDG_*``, ``ZENOH_*`` or ``LUNARSIM_*`` variables: a page that leaves anything in
it but caches fails, as does one that leaves a new file at the repository's root. ``<folder>`` in a command
becomes the newest run folder under ``runs/`` that the page's earlier blocks made. A Python block whose first
line is a comment naming a ``.py`` file (``# my_rovers/slow.py``) is written to that file, as a reader saves it.

Markers: an HTML comment on its own line just before a block (with a blank line between it and an indented
block, which Markdown needs), invisible on the site and on GitHub. A block may carry several.

- ``<!-- docs-test: skip: REASON -->``: not run; reported as a skipped test with the page, line and reason. For
  what needs hardware, other machines, a cluster, a second terminal, or installs the package.
- ``<!-- docs-test: omit `PREFIX`: REASON -->``: the block's lines that start with PREFIX are not run; each is
  reported as a skipped test (a server that runs until Ctrl-C, a command for a live mission, a duplicate).
- ``<!-- docs-test: replace `OLD` with `NEW`: REASON -->``: the test runs NEW where the block says OLD: a shorter
  run of the same command (``--max-sim-time``, fewer ``--runs``), never another command.
- ``<!-- docs-test: expect `TEXT` -->``: the block's output (stdout and stderr) contains TEXT.
- ``<!-- docs-test: output -->`` (on a ``text`` block): each of its lines is in the output of the page's previous
  command block.
- ``<!-- docs-test: example: WHAT -->``: what differs from run to run or machine to machine (a host name, a
  token, wall times); neither run nor checked, and the prose says "for example".

Output is compared with table borders dropped and blanks collapsed, from a 160-column terminal, so a table row
is one line. A figure in the prose comes from a block checked with ``expect`` or ``output``, or is an example.

Long missions, case by case. Lockstep missions run whole where a page quotes their figures (the crater mission,
the daisy chain, the polar pair, the maze's traverse map: each a deterministic report, 10-30 s). A real-time
mission takes its simulated time in wall time (the crater mission about 80 s): it is skipped where a lockstep
line beside it runs the same mission, or cut to 10 simulated seconds. Batches run two 5-second missions instead
of ten or twenty. A knob in the product (an environment variable capping every run) would change what users'
commands do, so there is none: shortening lives in the markers, where a reader of the source sees it. The
module takes about two and a half minutes of CPU time.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from docs_blocks import FOLDER, Block, MarkerError, blocks, normalise, omitted, pages, script
from procs import REPO, USES_DEFAULT_PORT

CLONE = ("scenarios", "deploy", "tests/data")
"""The folders of a clone's root that commands name. Whole packages, code too: a child started with
``python -m`` has the current folder first on its path, and in a clone finds the packages there."""
HOME_CACHES = (".cache", ".config/matplotlib")
BLOCK_TIMEOUT_S = 240.0
PRELUDE = "set -e -o pipefail\ntrap 'echo \"docs-test: failed: $BASH_COMMAND\" >&2' ERR\n"

BLOCKS: dict[str, list[Block]] = {page: blocks(path, page) for page, path in pages(REPO)}
RUN = [page for page, found in BLOCKS.items() if any(b.kind == "shell" and not b.skip for b in found)]
NOT_RUN = [(b.where, b.skip) for found in BLOCKS.values() for b in found if b.kind == "shell" and b.skip] + [
    (f"{b.where} {line.split('#')[0].strip()}", reason)
    for found in BLOCKS.values() for b in found if b.kind == "shell" and not b.skip for line, reason in omitted(b)]


@pytest.fixture(scope="module")
def home(tmp_path_factory) -> Path:
    """One home for the module, so caches (matplotlib's fonts) are built once."""
    return tmp_path_factory.mktemp("home")


def clone_root(work: Path) -> Path:
    for name in CLONE:
        shutil.copytree(REPO / name, work / name, ignore=shutil.ignore_patterns("__pycache__"))
    return work


def environment(home: Path) -> dict[str, str]:
    """The user's environment less anything that points a command elsewhere (state folders, a Zenoh config)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("XDG_", "ZENOH_", "LUNARSIM_"))}
    env.update(PATH=f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}", HOME=str(home),
               COLUMNS="160")
    return env


def with_run_folder(block: Block, text: str, work: Path) -> str:
    if FOLDER not in text:
        return text
    made = sorted((work / "runs").glob("*/session.mcap"), key=lambda p: p.stat().st_mtime)
    assert made, f"{block.where}: {FOLDER} needs a run folder, and no earlier block of the page made one"
    return text.replace(FOLDER, made[-1].parent.name)


def run(block: Block, text: str, work: Path, env: dict[str, str]) -> str:
    """Output of the block's commands, stdout and stderr together; fails naming the block and the command."""
    __tracebackhide__ = True  # the message says it all; the frame would show the environment
    proc = subprocess.Popen(["bash", "-c", PRELUDE + text], cwd=work, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=BLOCK_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        pytest.fail(f"{block.where}: still running after {BLOCK_TIMEOUT_S:.0f} s:\n{text}\n{out[-3000:]}")
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)  # whatever the block left in the background
    assert proc.returncode == 0, f"{block.where}: exit {proc.returncode}:\n{text}\n{out[-3000:]}"
    return out


def check_output(block: Block, previous: str | None) -> None:
    assert previous is not None, f"{block.where}: an output block must follow a command block that runs"
    printed = normalise(previous)
    missing = [line for line in normalise(block.text).splitlines() if line not in printed]
    assert not missing, f"{block.where}: not printed now: {missing}\nprinted:\n{printed[-3000:]}"


def run_page(page: str, work: Path, env: dict[str, str]) -> None:
    __tracebackhide__ = True
    previous: str | None = None
    for block in BLOCKS[page]:
        if block.kind == "file":
            target = work / block.text.splitlines()[0].lstrip("# ").strip()
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(block.text + "\n")
        elif block.kind == "output":
            check_output(block, previous)
        elif block.kind == "shell" and not block.skip:
            previous = run(block, with_run_folder(block, script(block), work), work, env)
            for text in block.expect:
                assert normalise(text) in normalise(previous), f"{block.where}: no `{text}` in:\n{previous[-3000:]}"


def left_in(home: Path) -> list[str]:
    caches = [home / name for name in HOME_CACHES]
    return [str(p.relative_to(home)) for p in home.rglob("*")
            if p.is_file() and not any(p.is_relative_to(cache) for cache in caches)]


@pytest.mark.e2e
@USES_DEFAULT_PORT
@pytest.mark.parametrize("page", RUN)
def test_commands_run_as_copied(page, tmp_path, home):
    work = clone_root(tmp_path / "work")
    repo_before, home_before = set(os.listdir(REPO)), set(left_in(home))
    run_page(page, work, environment(home))
    into_home = sorted(set(left_in(home)) - home_before)
    assert not into_home, f"{page}: written into the user's home: {into_home}"
    into_repo = {name for name in set(os.listdir(REPO)) - repo_before if (work / name).exists()}
    assert not into_repo, f"{page}: written into the repository: {sorted(into_repo)}"


@pytest.mark.parametrize(("where", "reason"), NOT_RUN, ids=[where for where, _ in NOT_RUN])
def test_marked_command_says_why_it_is_not_run(where, reason):
    assert reason.strip()
    pytest.skip(f"{where}: {reason}")


SAMPLE = """Text.

<!-- docs-test: omit `lunarsim view`: serves until Ctrl-C -->
<!-- docs-test: replace `--runs 10` with `--runs 2`: shorter -->
<!-- docs-test: expect `5/5` -->

    lunarsim view --scenario maze      # a comment
    lunarsim batch maze --runs 10 \\
        --lockstep

<!-- docs-test: output -->
```text
a   │   5/5
```

<!-- docs-test: skip: needs a rover -->

```bash
lunarsim bridge --id 1
```

```python
# pkg/mod.py
X = 1
```
"""


def test_markers_say_what_runs(tmp_path):
    """The marking scheme on a small page: what is run, what is left out and why, what is checked."""
    page = tmp_path / "page.md"
    page.write_text(SAMPLE)
    shell, output, skipped, saved = blocks(page, "page.md")
    assert script(shell) == "lunarsim batch maze --runs 2 \\\n    --lockstep\n"
    assert omitted(shell) == [("lunarsim view --scenario maze      # a comment", "serves until Ctrl-C")]
    assert shell.expect == ["5/5"] and shell.line == 7
    assert output.kind == "output" and normalise(output.text) == "a 5/5"
    assert skipped.skip == "needs a rover" and skipped.text == "lunarsim bridge --id 1"
    assert saved.kind == "file" and saved.text.startswith("# pkg/mod.py")


@pytest.mark.parametrize("broken", ["<!-- docs-test: skip: why -->\nprose, not a block\n",
                                    "<!-- docs-test: maybe -->\n\n    lunarsim run maze\n",
                                    "<!-- docs-test: replace `--runs 9` with `--runs 1`: short -->\n\n    lunarsim\n"])
def test_a_marker_that_names_nothing_is_refused(tmp_path, broken):
    page = tmp_path / "page.md"
    page.write_text(broken)
    with pytest.raises(MarkerError):
        for block in blocks(page, "page.md"):
            script(block)


def test_every_marker_of_the_docs_names_something_in_its_block():
    """Checked without running anything, so a marker gone stale fails fast."""
    for found in BLOCKS.values():
        for block in found:
            if block.kind == "shell" and not block.skip:
                assert script(block).strip(), f"{block.where}: every line omitted: skip the block instead"
