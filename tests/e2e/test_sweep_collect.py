"""A seed sweep on Kubernetes, run on this machine: the batch Job's own command, one real process per index (with
the JOB_COMPLETION_INDEX Kubernetes would set) writing into one folder as the pods write onto their shared claim,
then the collect pod's own command as a real process. Its batch.json and table must be those ``lunarsim batch``
gives for the same seeds, and a sweep with a failed pod, a corrupt report or a seed twice must be told, not
crash. The manifests are read as ``tests/e2e/test_deploy_manifests.py`` reads them (its helpers expand them), so
what runs here is what the cluster would run, but for the results path (a folder here) and each run's port
(pods have a network each; processes here share one).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
import test_deploy_manifests as manifests
import yaml
from procs import REPO, SCENARIOS, free_port, lunarsim, stop

from deploy.batch import aggregate

JOB_FILE = REPO / "deploy" / "k8s" / "batch" / "job.yaml"
COLLECT_FILE = REPO / "deploy" / "k8s" / "batch" / "collect.yaml"
RESULTS = "/results"
BASE_SEED = 21
INDEXES = 3
JOB_NAME = "lunarsim-batch-local"
RUN_TIMEOUT_S = 300


def _load(path: Path) -> dict:
    (doc,) = [d for d in yaml.safe_load_all(path.read_text()) if d]
    return doc


def _job(scenario: Path) -> tuple[dict, dict]:
    """The Job as a user would set it for this sweep: its SCENARIO and BASE_SEED changed, nothing else."""
    job = _load(JOB_FILE)
    (container,) = job["spec"]["template"]["spec"]["containers"]
    values = {"SCENARIO": str(scenario), "BASE_SEED": str(BASE_SEED)}
    for item in container["env"]:
        if item["name"] in values:
            item["value"] = values[item["name"]]
        elif item["name"] == "JOB_NAME":  # Kubernetes fills it from the Job's name label
            item.pop("valueFrom")
            item["value"] = JOB_NAME
    return job, container


def _collect_pod(job_name: str = JOB_NAME, runs: int = INDEXES) -> tuple[dict, dict]:
    """The collect pod as ``kubectl set env --local ... JOB_NAME=... RUNS=...`` makes it."""
    pod = _load(COLLECT_FILE)
    (container,) = pod["spec"]["containers"]
    for item in container["env"]:
        item["value"] = {"JOB_NAME": job_name, "RUNS": str(runs)}.get(item["name"], item["value"])
    return pod, container


def _here(args: list[str], volume: Path) -> list[str]:
    """A container's arguments for a process on this machine: the results claim is the folder ``volume``."""
    return manifests.on_loopback(args, "-", 0, {RESULTS: volume})


def _run_index(job: dict, container: dict, index: int, volume: Path, shim: Path) -> subprocess.Popen:
    args = _here(manifests.k8s_command(job, container, shim, index), volume)
    return lunarsim(*args, "--port", str(free_port()), env={**os.environ, "JOB_COMPLETION_INDEX": str(index)})


def _finish(proc: subprocess.Popen, what: str) -> tuple[str, str]:
    try:
        stdout, stderr = proc.communicate(timeout=RUN_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        stop(proc)
        raise AssertionError(f"{what} did not end within {RUN_TIMEOUT_S} s") from None
    return stdout, stderr


def _collect(folder: Path, *extra: str, shim: Path | None = None) -> tuple[int, str, str]:
    """The collect pod's command (through its manifest when ``shim`` is given), as a real process."""
    if shim is not None:
        pod, container = _collect_pod()
        args = _here(manifests.k8s_command(pod, container, shim), folder.parent)
    else:
        args = ["collect-batch", str(folder), *extra]
    proc = lunarsim(*args)
    stdout, stderr = _finish(proc, "lunarsim collect-batch")
    assert "Traceback" not in stdout + stderr
    return proc.returncode, stdout, stderr


@pytest.fixture(scope="module")
def sweep(tmp_path_factory, shim) -> dict:
    """The Job's indexes, all at once as real processes into one results folder, and ``lunarsim batch`` of the
    same scenario and seeds afterwards, in process (two at a time, as on this 2-core machine): the reports of
    ``--lockstep``, which tests/e2e/test_batch_in_process.py holds it to."""
    root = tmp_path_factory.mktemp("sweep")
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rovers"] = data["rovers"][:2]  # short: two rovers round the rim
    scenario = root / "two_rovers.yaml"
    scenario.write_text(yaml.safe_dump(data))
    job, container = _job(scenario)
    volume = root / "results"
    procs = [_run_index(job, container, index, volume, shim) for index in range(INDEXES)]
    try:
        for index, proc in enumerate(procs):
            stdout, stderr = _finish(proc, f"Job index {index}")
            assert proc.returncode == 0, f"index {index}: {stdout}{stderr}"
    finally:
        stop(*procs)
    out = root / "batch"
    max_sim_time = manifests.pod_env(job, container, 0)["MAX_SIM_TIME"]
    proc = lunarsim("batch", str(scenario), "--runs", str(INDEXES), "--seed", str(BASE_SEED), "--in-process",
                    "--jobs", "2", "--max-sim-time", max_sim_time, "--out", str(out))
    batch_stdout, stderr = _finish(proc, "lunarsim batch")
    assert proc.returncode == 0, batch_stdout + stderr
    return {"folder": volume / JOB_NAME, "batch": json.loads((out / "batch.json").read_text()),
            "batch_stdout": batch_stdout}


def _copy(sweep: dict, tmp_path: Path) -> Path:
    """The sweep's runs, to break (only what the collector reads: the reports, the photo index, the recording)."""
    folder = tmp_path / JOB_NAME
    shutil.copytree(sweep["folder"], folder, ignore=shutil.ignore_patterns("photos", "logs", "state", "*.png",
                                                                         "map.npz", "batch.json"))
    return folder


def _without_wall_time(runs: list[dict]) -> list[dict]:
    return [{k: v for k, v in run.items() if k != "wall_time_s"} for run in runs]


def _table(stdout: str) -> str:
    """The printed Table 2: from its title to its bottom border."""
    match = re.search(r"^\S+: \d+ runs\s*\n.*?^└[^\n]*$", stdout, re.M | re.S)
    assert match, stdout
    return match.group(0)


@pytest.mark.e2e
def test_collecting_the_job_indexes_gives_what_lunarsim_batch_gives_for_the_same_seeds(sweep, shim):
    folders = sorted(p.name for p in sweep["folder"].iterdir())
    assert folders == [f"run-{i + 1:03d}-seed{BASE_SEED + i}" for i in range(INDEXES)]
    code, stdout, stderr = _collect(sweep["folder"], shim=shim)
    assert code == 0, stdout + stderr
    collected, batch = json.loads((sweep["folder"] / "batch.json").read_text()), sweep["batch"]
    assert _without_wall_time(collected["runs"]) == _without_wall_time(batch["runs"])
    assert collected["aggregate"] == batch["aggregate"]
    same = ("scenario", "rovers", "lockstep", "failed")
    assert {k: collected[k] for k in same} == {k: batch[k] for k in same}
    assert batch["lockstep"] is True and batch["aggregate"]["runs"] == INDEXES
    assert len({run["total_distance_covered_m"] for run in batch["runs"]}) == INDEXES, "seeds should differ"
    assert (collected["missing"], collected["unreadable"], collected["duplicate_seeds"]) == ([], [], [])
    assert _table(stdout) == _table(sweep["batch_stdout"])
    assert f"{INDEXES} of {INDEXES} runs in the aggregate" in stdout


@pytest.mark.e2e
def test_a_failed_pod_and_a_pod_that_never_ran_are_named_and_the_rest_aggregated(sweep, tmp_path):
    folder = _copy(sweep, tmp_path)
    shutil.rmtree(folder / f"run-002-seed{BASE_SEED + 1}")  # never scheduled: no folder
    (folder / f"run-003-seed{BASE_SEED + 2}" / "report.json").unlink()  # started, then killed
    code, stdout, _ = _collect(folder, "--runs", str(INDEXES + 1))  # the last index left nothing either
    assert code == 0, stdout
    collected = json.loads((folder / "batch.json").read_text())
    assert collected["missing"] == [2, 3, 4]
    assert [(f["run"], f["seed"]) for f in collected["failed"]] == [(r, BASE_SEED + r - 1) for r in (2, 3, 4)]
    assert "never started" in collected["failed"][0]["error"] and "did not finish" in collected["failed"][1]["error"]
    first = sweep["batch"]["runs"][0]
    assert _without_wall_time(collected["runs"]) == _without_wall_time([first])
    assert collected["aggregate"] == aggregate([first])
    assert "1 of 4 runs in the aggregate" in stdout and "3 run(s) missing (2, 3, 4)" in stdout
    assert f"run 4 (Job index 3, seed {BASE_SEED + 3}): no run folder" in stdout


@pytest.mark.e2e
def test_corrupt_reports_are_counted_and_named_not_a_traceback(sweep, tmp_path):
    folder = _copy(sweep, tmp_path)
    cut = folder / f"run-002-seed{BASE_SEED + 1}" / "report.json"
    cut.write_text(cut.read_text()[:200])  # a copy cut short
    (folder / f"run-003-seed{BASE_SEED + 2}" / "report.json").write_text(json.dumps({"seed": BASE_SEED + 2}))
    code, stdout, _ = _collect(folder)
    assert code == 0, stdout
    collected = json.loads((folder / "batch.json").read_text())
    names = [f"run-002-seed{BASE_SEED + 1}", f"run-003-seed{BASE_SEED + 2}"]
    assert collected["unreadable"] == names and collected["aggregate"]["runs"] == 1
    assert "report.json unreadable: scenario: required field missing" in collected["failed"][1]["error"]
    assert f"2 report(s) unreadable ({', '.join(names)})" in stdout

    for path in folder.glob("run-*/report.json"):
        path.write_bytes(b"\xff\xfe not json")
    code, stdout, _ = _collect(folder)
    assert code == 1 and "0 of 3 runs in the aggregate" in stdout
    assert json.loads((folder / "batch.json").read_text())["aggregate"] == {}


@pytest.mark.e2e
def test_a_seed_twice_counts_once(sweep, tmp_path):
    folder = _copy(sweep, tmp_path)
    shutil.copytree(folder / f"run-001-seed{BASE_SEED}", folder / f"run-004-seed{BASE_SEED}")  # an index re-run
    code, stdout, _ = _collect(folder)
    assert code == 0, stdout
    collected = json.loads((folder / "batch.json").read_text())
    assert collected["duplicate_seeds"] == [{"seed": BASE_SEED, "kept": f"run-001-seed{BASE_SEED}",
                                             "left_out": [f"run-004-seed{BASE_SEED}"]}]
    assert collected["aggregate"] == sweep["batch"]["aggregate"]
    assert f"seed {BASE_SEED} came twice" in stdout


@pytest.mark.e2e
def test_bad_input_exits_2_with_one_line(sweep, tmp_path):
    folder = _copy(sweep, tmp_path)
    cases = [((str(tmp_path / "nowhere"),), "no such folder"), ((str(tmp_path),), "holds no run folders"),
             ((str(folder), "--runs", "0"), "--runs must be between 1 and"),
             ((str(folder), "--out", str(tmp_path / "no" / "batch.json")), "no/batch.json: No such file")]
    for args, message in cases:
        _exits_2(args, message)
    other = folder / f"run-002-seed{BASE_SEED + 1}" / "report.json"
    other.write_text(other.read_text().replace('"scenario": "crater_observation"', '"scenario": "maze"'))
    _exits_2((str(folder),), "holds runs of different missions: crater_observation (2 rovers), maze (2 rovers)")


def _exits_2(args: tuple[str, ...], message: str) -> None:
    code, stdout, stderr = _collect(Path(args[0]), *args[1:])
    assert code == 2 and message in stderr and stderr.count("\n") == 1, (args, stdout, stderr)
