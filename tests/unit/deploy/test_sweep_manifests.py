"""The batch Job and its collect pod agree without a cluster: each index writes the folder the collector reads, on
the claim the collector mounts, and the collect pod's command parses as kubectl would create it. Read with
``tests/e2e/test_deploy_manifests.py``'s helpers, which expand the manifests as Kubernetes and the shell would."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import PurePosixPath

import pytest
import test_deploy_manifests as manifests
import yaml
from procs import REPO

from deploy.batch import run_folder
from deploy.batch_collect import RUN_FOLDER

BATCH = REPO / "deploy" / "k8s" / "batch"


def _one(name: str) -> tuple[dict, dict]:
    (obj,) = [d for d in yaml.safe_load_all((BATCH / name).read_text()) if d]
    spec = obj["spec"]["template"]["spec"] if obj["kind"] == "Job" else obj["spec"]
    (container,) = spec["containers"]
    return obj, container


def _spec(obj: dict) -> dict:
    return obj["spec"]["template"]["spec"] if obj["kind"] == "Job" else obj["spec"]


def _claim_at(obj: dict, container: dict, path: PurePosixPath) -> tuple[str, str]:
    """(claim, mount path) that ``path`` lies on."""
    (mount,) = [m for m in container["volumeMounts"] if path.is_relative_to(m["mountPath"])]
    (volume,) = [v for v in _spec(obj)["volumes"] if v["name"] == mount["name"]]
    return volume["persistentVolumeClaim"]["claimName"], mount["mountPath"]


@pytest.fixture(scope="module")
def shim(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shim")
    script = folder / "lunarsim"
    script.write_text("#!/bin/sh\nfor a in \"$@\"; do printf '%s\\0' \"$a\"; done\n")
    script.chmod(0o755)
    return folder


def test_each_index_writes_a_run_folder_the_collector_reads(shim):
    job, container = _one("job.yaml")
    base = int(manifests.pod_env(job, container, 0)["BASE_SEED"])
    job_name = manifests.pod_env(job, container, 0)["JOB_NAME"]
    for index in (0, 1, 9, 120):
        args = manifests.parse(manifests.k8s_command(job, container, shim, index), f"Job index {index}")
        out = PurePosixPath(args.out)
        assert out.name == run_folder(index + 1, base + index)
        match = RUN_FOLDER.fullmatch(out.name)
        assert match and (int(match["run"]), int(match["seed"])) == (index + 1, base + index)
        _, mount = _claim_at(job, container, out)
        assert out.parent == PurePosixPath(mount) / job_name, "every index of one Job writes into one folder"


def test_the_collect_pod_reads_the_jobs_folder_on_the_same_claim(shim):
    job, job_container = _one("job.yaml")
    pod, container = _one("collect.yaml")
    assert pod["kind"] == "Pod" and pod["spec"]["restartPolicy"] == "Never"
    args = manifests.parse(manifests.k8s_command(pod, container, shim), "collect pod")
    env = manifests.pod_env(pod, container, 0)
    assert args.run.__module__ == "deploy.commands.collect_batch" and args.runs == job["spec"]["completions"]
    folder = PurePosixPath(args.folder)
    claim, mount = _claim_at(pod, container, folder)
    job_out = PurePosixPath(manifests.parse(manifests.k8s_command(job, job_container, shim, 0), "Job").out)
    assert (claim, mount) == _claim_at(job, job_container, job_out)
    assert folder == PurePosixPath(mount) / env["JOB_NAME"]
    assert container["image"] == job_container["image"] and container["imagePullPolicy"] == "IfNotPresent"
    assert pod["spec"]["securityContext"] == _spec(job)["securityContext"]
    assert container["securityContext"] == job_container["securityContext"]


def test_kubectl_sets_the_job_name_and_run_count_offline(shim, tmp_path):
    """The collect pod's header says to create it through ``kubectl set env --local``: kubectl's own edit."""
    kubectl = shutil.which("kubectl")
    if kubectl is None:
        pytest.skip("kubectl is not installed")
    proc = subprocess.run([kubectl, "set", "env", "--local", "-f", str(BATCH / "collect.yaml"), "-o", "yaml",
                           "JOB_NAME=lunarsim-batch-x7k2p", "RUNS=7"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    pod = yaml.safe_load(proc.stdout)
    (container,) = pod["spec"]["containers"]
    args = manifests.parse(manifests.k8s_command(pod, container, shim), "collect pod from kubectl")
    assert (str(args.folder), args.runs) == ("/results/lunarsim-batch-x7k2p", 7)
    assert "kubectl set env --local -f deploy/k8s/batch/collect.yaml" in (BATCH / "collect.yaml").read_text()
