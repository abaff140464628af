"""The container image, the Compose file and the Kubernetes manifests, checked without a container engine.

A deployment file is otherwise exercised only when someone deploys it. Here every container's command goes
through the expansion Compose, Kubernetes and the shell would apply (the shell is run for real, with a
``lunarsim`` stand-in on PATH that hands back its arguments) and then through the real argument parser; the
files the commands read must be in the image (mapped back to the repository through the Dockerfile's
COPY lines); and the wiring (router endpoint, rover count, volumes, ids) must agree across the files.
"""

from __future__ import annotations

import functools
import json
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path, PurePosixPath

import pytest
import yaml
import zenoh
from mcap.reader import make_reader
from procs import REPO, free_port, stop, wait_for

from bus.zenoh_config import build_config
from deploy.children import wait_for_port
from deploy.cli import build_parser
from rover_agent.identity import id_from_hostname, parse_id
from schemas.keyspace import PERCEPTION, Keyspace
from schemas.scenario import load_scenario

DEPLOY = REPO / "deploy"
DOCKERFILE = DEPLOY / "Dockerfile"
COMPOSE = DEPLOY / "compose.yaml"
K8S = DEPLOY / "k8s"
IMAGE = "lunarsim:latest"
ROLES = {"router": "router", "world": "world", "lander": "lander", "rover": "rover", "record": "recorder",
         "run": "batch", "batch": "batch", "ros2": "ros2"}
INPUT_FILES = ("scenario", "params")  # argument names that are files a command reads


# --- the Dockerfile -------------------------------------------------------------------------------------

@functools.cache
def dockerfile_stages() -> list[dict]:
    """Stages in order, each with its base, name and instructions (continuations joined, comments dropped)."""
    text = re.sub(r"\\\n", " ", DOCKERFILE.read_text())
    stages: list[dict] = []
    for line in text.splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        word, _, rest = line.strip().partition(" ")
        if word.upper() == "FROM":
            base, _, name = rest.partition(" AS ")
            stages.append({"base": base.strip(), "name": name.strip(), "steps": []})
        else:
            stages[-1]["steps"].append((word.upper(), rest.strip()))
    return stages


def steps(stage: dict, instruction: str) -> list[str]:
    return [rest for word, rest in stage["steps"] if word == instruction]


def copies(stage: dict) -> list[tuple[str | None, list[str], str]]:
    """(--from stage or None, sources, destination) of each COPY, the destination made absolute."""
    workdir, found = "/", []
    for word, rest in stage["steps"]:
        if word == "WORKDIR":
            workdir = str(PurePosixPath(workdir) / rest)
        if word != "COPY":
            continue
        args = json.loads(rest) if rest.startswith("[") else shlex.split(rest)
        source_stage = next((a.split("=", 1)[1] for a in args if a.startswith("--from=")), None)
        paths = [a for a in args if not a.startswith("--")]
        found.append((source_stage, paths[:-1], str(PurePosixPath(workdir) / paths[-1])))
    return found


def final_workdir() -> str:
    return str(PurePosixPath("/", *steps(dockerfile_stages()[-1], "WORKDIR")))


def exec_form(stage: dict, instruction: str) -> list[str]:
    (value,) = steps(stage, instruction)
    return json.loads(value)


def repo_path_in_image(image_path: str) -> Path | None:
    """The repository file a path of the final image comes from, through its COPY lines; None if none."""
    path = PurePosixPath(final_workdir()) / image_path
    for source_stage, sources, dest in copies(dockerfile_stages()[-1]):
        if source_stage is None and len(sources) == 1 and path.is_relative_to(dest):
            return REPO / sources[0] / path.relative_to(dest)
    return None


def dockerignore_excludes(path: str) -> bool:
    """Docker's rule: the last pattern matching the path or one of its parents decides; '!' re-includes."""
    patterns = [p.strip() for p in (DEPLOY / "Dockerfile.dockerignore").read_text().splitlines()]
    parts = PurePosixPath(path).parts
    candidates = ["/".join(parts[:i]) for i in range(1, len(parts) + 1)]
    excluded = False
    for pattern in (p for p in patterns if p and not p.startswith("#")):
        negated, glob = pattern.startswith("!"), pattern.lstrip("!").rstrip("/")
        regex = re.compile(_glob_regex(glob))
        if any(regex.fullmatch(c) for c in candidates):
            excluded = not negated
    return excluded


def package_files() -> list[str]:
    """What ``pip install .`` reads: pyproject, readme, every package's modules and its package data."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())
    setuptools = project["tool"]["setuptools"]
    found = ["pyproject.toml", project["project"]["readme"]]
    for package in setuptools["packages"]:
        folder = REPO / package.replace(".", "/")
        found += [str(p.relative_to(REPO)) for p in folder.glob("*.py")]
        for pattern in setuptools.get("package-data", {}).get(package, []):
            found += [str(p.relative_to(REPO)) for p in folder.glob(pattern)]
    return found


def _glob_regex(glob: str) -> str:
    return "".join(".*" if tok == "**" else "[^/]*" if tok == "*" else "[^/]" if tok == "?" else re.escape(tok)
                   for tok in re.split(r"(\*\*|\*|\?)", glob) if tok)


# --- expanding and running container commands ----------------------------------------------------------

def compose_interpolate(text: str, env: dict[str, str]) -> str:
    """Compose's ${VAR}, ${VAR:-default}, ${VAR-default}, ${VAR:+alt} and $$ (a literal $)."""
    def one(match: re.Match) -> str:
        if match.group(0) == "$$":
            return "$"
        name, op, arg = match.group("name") or match.group("bare"), match.group("op"), match.group("arg")
        value = env.get(name)
        if op in (":-", "-"):
            return arg if value is None or (op == ":-" and value == "") else value
        if op in (":+", "+"):
            return arg if value is not None and (op == "+" or value != "") else ""
        return value or ""

    pattern = r"\$\$|\$\{(?P<name>\w+)(?:(?P<op>:?[-+])(?P<arg>[^}]*))?\}|\$(?P<bare>\w+)"
    return re.sub(pattern, one, text)


def interpolated(value, env: dict[str, str]):
    if isinstance(value, str):
        return compose_interpolate(value, env)
    if isinstance(value, list):
        return [interpolated(v, env) for v in value]
    if isinstance(value, dict):
        return {k: interpolated(v, env) for k, v in value.items()}
    return value


def k8s_expand(text: str, env: dict[str, str]) -> str:
    """Kubernetes' $(VAR) in command and args: defined names are replaced, others kept; $$ is a literal $."""
    out, i = [], 0
    while i < len(text):
        if text[i] == "$" and i + 1 < len(text):
            nxt = text[i + 1]
            if nxt == "$":
                out.append("$")
                i += 2
                continue
            end = text.find(")", i + 2) if nxt == "(" else -1
            if end >= 0:
                name = text[i + 2:end]
                out.append(env.get(name, text[i:end + 1]))
                i = end + 1
                continue
        out.append(text[i])
        i += 1
    return "".join(out)


def lunarsim_argv(argv: list[str], env: dict[str, str], shim: Path, where: str) -> list[str]:
    """The arguments ``lunarsim`` receives from a container's argv, through ``sh -c`` when there is one."""
    if argv[:1] == ["lunarsim"]:
        return argv[1:]
    assert argv[:2] == ["sh", "-c"] and len(argv) == 3, f"{where}: neither lunarsim nor sh -c: {argv}"
    script = argv[2]
    assert re.search(r"(^|&&|;)\s*exec lunarsim ", script), f"{where}: the shell must exec lunarsim (signals)"
    proc = subprocess.run(["sh", "-c", script], env={**env, "PATH": f"{shim}:/usr/bin:/bin"}, capture_output=True,
                          text=True, timeout=10)
    assert proc.returncode == 0 and proc.stdout, f"{where}: {script!r} failed: {proc.stderr}"
    return proc.stdout.split("\0")[:-1]


@functools.cache
def parser():
    return build_parser()


def parse(args: list[str], where: str):
    try:
        return parser().parse_args(args)
    except SystemExit:
        pytest.fail(f"{where}: 'lunarsim {shlex.join(args)}' does not parse (see the usage message above)")


def check_inputs_in_image(parsed, where: str) -> None:
    for name in INPUT_FILES:
        value = getattr(parsed, name, None)
        if value is not None:
            source = repo_path_in_image(str(value))
            assert source is not None, f"{where}: {value} is not copied into the image"
            assert source.is_file(), f"{where}: {value} comes from {source}, which does not exist"


def option(args: list[str], name: str) -> str | None:
    return args[args.index(name) + 1] if name in args else None


# --- Compose -------------------------------------------------------------------------------------------

COMPOSE_ENVS = [{}, {"ROVERS": "8", "SCENARIO": "daisy_chain", "RUNS": "3", "BASE_SEED": "40"}]


def compose_services(env: dict[str, str]) -> dict[str, dict]:
    return interpolated(yaml.safe_load(COMPOSE.read_text())["services"], env)


def compose_container_env(service: dict) -> dict[str, str]:
    environment = service.get("environment") or {}
    if isinstance(environment, list):
        environment = dict(item.split("=", 1) for item in environment)
    return {k: "" if v is None else str(v) for k, v in environment.items()}


def compose_commands(env: dict[str, str], shim: Path) -> dict[str, list[str]]:
    """Per service, the arguments its ``lunarsim`` gets (entrypoint + command, the image's as defaults)."""
    image = dockerfile_stages()[-1]
    found = {}
    for name, service in compose_services(env).items():
        entrypoint = service.get("entrypoint", exec_form(image, "ENTRYPOINT"))
        command = service.get("command", exec_form(image, "CMD"))
        argv = [*_as_list(entrypoint), *_as_list(command)]
        found[name] = lunarsim_argv(argv, compose_container_env(service), shim, f"compose service {name}")
    return found


def _as_list(value) -> list[str]:
    return shlex.split(value) if isinstance(value, str) else list(value)


# --- Kubernetes ----------------------------------------------------------------------------------------

def k8s_objects() -> list[tuple[Path, dict]]:
    return [(path, doc) for path in sorted(K8S.rglob("*.yaml")) for doc in yaml.safe_load_all(path.read_text())
            if doc and doc.get("kind") != "Kustomization"]


def k8s_by_kind(kind: str) -> list[dict]:
    return [doc for _, doc in k8s_objects() if doc["kind"] == kind]


def configmap(name: str) -> dict[str, str]:
    (found,) = [d for d in k8s_by_kind("ConfigMap") if d["metadata"]["name"] == name]
    return found["data"]


def pod_env(obj: dict, container: dict, index: int) -> dict[str, str]:
    """What the container sees: envFrom ConfigMaps, env values, downward API and the pod's own identity."""
    env = {"HOSTNAME": f"{obj['metadata'].get('name', 'pod')}-{index}"}
    if obj["kind"] == "Job" and obj["spec"].get("completionMode") == "Indexed":
        env["JOB_COMPLETION_INDEX"] = str(index)
    for source in container.get("envFrom", []):
        env.update(configmap(source["configMapRef"]["name"]))
    for item in container.get("env", []):
        if "value" in item:
            env[item["name"]] = k8s_expand(item["value"], env)
        elif "fieldRef" in item.get("valueFrom", {}):
            env[item["name"]] = f"downward-{item['name'].lower()}"
        else:
            env[item["name"]] = configmap(item["valueFrom"]["configMapKeyRef"]["name"])[
                item["valueFrom"]["configMapKeyRef"]["key"]]
    return env


def workloads() -> list[tuple[dict, dict]]:
    return [(obj, c) for obj in k8s_objects_of_pods() for c in obj["spec"]["template"]["spec"]["containers"]]


def k8s_objects_of_pods() -> list[dict]:
    return [doc for _, doc in k8s_objects() if doc["kind"] in ("Deployment", "StatefulSet", "Job")]


def k8s_command(obj: dict, container: dict, shim: Path, index: int = 0) -> list[str]:
    """Kubernetes' rule: command replaces ENTRYPOINT and drops CMD; args replace CMD."""
    image = dockerfile_stages()[-1]
    command = container.get("command", exec_form(image, "ENTRYPOINT"))
    args = container.get("args", exec_form(image, "CMD") if "command" not in container else [])
    env = pod_env(obj, container, index)
    argv = [k8s_expand(a, env) for a in [*command, *args]]
    return lunarsim_argv(argv, env, shim, f"{obj['kind']} {obj['metadata'].get('name')}")


def role_of(args: list[str]) -> str:
    return ROLES[args[0]]


def k8s_role(role: str, shim: Path) -> list[tuple[dict, dict, list[str]]]:
    found = [(obj, c, k8s_command(obj, c, shim)) for obj, c in workloads()]
    return [item for item in found if role_of(item[2]) == role]


def scenario_rovers(image_path: str) -> int:
    return len(load_scenario(repo_path_in_image(image_path)).rovers)


# === tests =============================================================================================

def test_every_deployment_yaml_parses_into_objects():
    files = [COMPOSE, *sorted(K8S.rglob("*.yaml"))]
    assert len(files) >= 8
    for path in files:
        docs = [d for d in yaml.safe_load_all(path.read_text()) if d is not None]
        assert docs and all(isinstance(d, dict) for d in docs), f"{path}: no YAML mapping"
    for path, doc in k8s_objects():
        assert doc.get("apiVersion") and doc.get("kind"), f"{path}: an object without apiVersion or kind"
        assert doc["metadata"].get("name") or doc["metadata"].get("generateName"), f"{path}: {doc['kind']} unnamed"


def python_stages() -> list[dict]:
    """Every stage but the front end's, which only runs npm."""
    return [s for s in dockerfile_stages() if s["name"] != "frontend"]


def build_stage() -> dict:
    return next(s for s in dockerfile_stages() if any("pip install ." in r for r in steps(s, "RUN")))


def test_dockerfile_builds_from_slim_python_and_runs_as_non_root():
    stages = python_stages()
    assert all(re.fullmatch(r"python:3\.1[1-9]-slim(-\w+)?", s["base"]) for s in stages), [s["base"] for s in stages]
    (frontend,) = [s for s in dockerfile_stages() if s["name"] == "frontend"]
    assert re.fullmatch(r"node:\d+-\w+-slim", frontend["base"]), frontend["base"]
    users = steps(stages[-1], "USER")
    assert users, "the final stage sets no USER: it would run as root"
    uid = users[-1].split(":")[0]
    assert uid.isdigit() and int(uid) != 0, f"USER {users[-1]}: give a numeric non-root uid (runAsNonRoot)"
    assert exec_form(stages[-1], "ENTRYPOINT") == ["lunarsim"]


def test_dockerfile_installs_every_package_with_pip_from_files_that_exist():
    build, final = build_stage(), dockerfile_stages()[-1]
    project = tomllib.loads((REPO / "pyproject.toml").read_text())
    needed = {p.split(".")[0] for p in project["tool"]["setuptools"]["packages"]} | {"pyproject.toml",
                                                                                  project["project"]["readme"]}
    copied = {src.rstrip("/") for stage, sources, _ in copies(build) if stage is None for src in sources}
    assert needed <= copied, f"the build stage does not copy {sorted(needed - copied)}"
    for stage in (build, final):
        for source_stage, sources, _ in copies(stage):
            assert source_stage is not None or all((REPO / s).exists() for s in sources), sources
    (install,) = [r for r in steps(build, "RUN") if "pip install ." in r]
    venv = install.split("/bin/pip")[0]
    assert any(stage == build["name"] and sources == [venv] for stage, sources, _ in copies(final))
    assert any(e.startswith(f"PATH={venv}/bin:") for e in steps(final, "ENV")), "lunarsim is not on PATH"


def test_dockerignore_sends_what_the_dockerfile_copies_and_leaves_the_rest_out():
    needed = package_files()
    assert len(needed) > 50
    built = {dest for stage, _, dest in copies(build_stage()) if stage == "frontend"}
    assert built == {"/src/web/static/bundle.js"}, built
    left_out = [f for f in needed if dockerignore_excludes(f) and f"/src/{f}" not in built]
    assert not left_out, f"pip install . needs these, the context leaves them out: {left_out[:5]}"
    assert dockerignore_excludes("web/frontend/node_modules/three/package.json")
    for path in (".git/HEAD", "runs/crater/report.json", ".ci-venv/bin/python", "tests/e2e/test_bus.py",
                 "benchmarks/x.py", "schemas/__pycache__/m.cpython-312.pyc", "deploy/compose.yaml",
                 "deploy/k8s/router.yaml", "lunarsim.egg-info/PKG-INFO"):
        assert dockerignore_excludes(path), f"{path} would be sent to the build"


def test_the_image_default_command_runs_a_shipped_scenario(shim):
    image = dockerfile_stages()[-1]
    args = lunarsim_argv([*exec_form(image, "ENTRYPOINT"), *exec_form(image, "CMD")], {}, shim, "Dockerfile")
    parsed = parse(args, "Dockerfile CMD")
    assert args[0] == "run"
    check_inputs_in_image(parsed, "Dockerfile CMD")


@pytest.mark.parametrize("env", COMPOSE_ENVS, ids=["defaults", "overrides"])
def test_compose_commands_parse_and_read_files_in_the_image(env, shim):
    services = compose_services(env)
    for name, args in compose_commands(env, shim).items():
        check_inputs_in_image(parse(args, f"compose {name}"), f"compose {name}")
        assert services[name]["image"] == IMAGE
        build = services[name]["build"]
        assert (COMPOSE.parent / build["context"]).resolve() == REPO
        assert (REPO / build["dockerfile"]).resolve() == DOCKERFILE


def test_compose_covers_every_role_and_connects_to_its_router(shim):
    services, commands = compose_services({}), compose_commands({}, shim)
    roles = {role_of(args): name for name, args in commands.items()}
    assert set(roles) == set(ROLES.values())
    listen = option(commands[roles["router"]], "--listen")
    port = listen.rsplit(":", 1)[1]
    for name, args in commands.items():
        if role_of(args) in ("world", "lander", "rover", "recorder", "ros2"):
            assert option(args, "--connect") == f"tcp/{roles['router']}:{port}", name
            assert services[name]["depends_on"]["router"]["condition"] == "service_healthy", name
    probe = services[roles["router"]]["healthcheck"]["test"]
    assert probe[:3] == ["CMD", "python", "-c"] and f", {port})" in probe[3]
    compile(probe[3], "healthcheck", "exec")


@pytest.mark.parametrize("env", COMPOSE_ENVS, ids=["defaults", "overrides"])
def test_compose_rovers_get_ids_from_the_world_and_match_its_count(env, shim):
    services, commands = compose_services(env), compose_commands(env, shim)
    (rover,) = [n for n, a in commands.items() if role_of(a) == "rover"]
    (world,) = [n for n, a in commands.items() if role_of(a) == "world"]
    assert parse_id(option(commands[rover], "--id")) == "auto"
    assert "container_name" not in services[rover] and "LUNARSIM_ROVER_ID" not in compose_container_env(
        services[rover]), "a fixed name or id would break --scale"
    world_args = commands[world]
    expected = int(option(world_args, "--rovers") or scenario_rovers(world_args[1]))
    assert int(services[rover]["deploy"]["replicas"]) == expected
    assert ("--rovers" in world_args) == ("ROVERS" in env)


def on_loopback(args: list[str], router: str, port: int, mounts: dict[str, Path]) -> list[str]:
    """A container's arguments for a process on this machine: router host, image files and volumes mapped."""
    mapped = []
    for arg in args:
        arg = re.sub(rf"tcp/({re.escape(router)}|0\.0\.0\.0):\d+", f"tcp/127.0.0.1:{port}", arg)
        mount = next((m for m in mounts if arg.startswith(m + "/")), None)
        if mount is not None:
            arg = str(mounts[mount] / arg[len(mount) + 1:])
        elif arg.startswith("/"):
            arg = str(repo_path_in_image(arg) or arg)
        mapped.append(arg)
    return mapped


def start_service(name: str, args: list[str], logs: Path, copy: int = 0) -> subprocess.Popen:
    log = (logs / f"{name}-{copy}.log").open("w")
    return subprocess.Popen([sys.executable, "-m", "deploy.cli", *args], cwd=logs, stdout=log,
                            stderr=subprocess.STDOUT, text=True)


def rovers_heard(session: zenoh.Session, keys: Keyspace) -> set[int]:
    """Rover ids the world has started to send perception to (its clock runs only once every agent is in)."""
    heard: set[int] = set()
    session.declare_subscriber(keys.rovers(PERCEPTION), lambda s: heard.add(keys.parse_rover_key(str(s.key_expr))[0]))
    return heard


@pytest.mark.e2e
def test_compose_services_run_as_processes_give_every_rover_its_own_id(shim, tmp_path):
    """The compose commands themselves, started as processes on loopback (one per rover replica, all with
    --id auto): the world hands out ids 1..N, starts the mission, and the recorder's file holds every rover."""
    services, commands = compose_services({}), compose_commands({}, shim)
    names = {role_of(args): name for name, args in commands.items()}
    port, data = free_port(), tmp_path / "volumes"
    procs: list[subprocess.Popen] = []

    def launch(role: str, copies: int = 1) -> None:
        name = names[role]
        mounts = {v.split(":")[1]: data / v.split(":")[0] for v in services[name].get("volumes", [])}
        args = on_loopback(commands[name], names["router"], port, mounts)
        procs.extend(start_service(name, args, tmp_path, i) for i in range(copies))

    try:
        launch("router")
        assert wait_for_port("127.0.0.1", port, 15, procs[0]), "the router did not listen"
        for role in ("recorder", "world", "lander"):
            launch(role)
        replicas = int(services[names["rover"]]["deploy"]["replicas"])
        launch("rover", replicas)
        with zenoh.open(build_config(connect=[f"tcp/127.0.0.1:{port}"])) as session:
            heard = rovers_heard(session, Keyspace())
            wait_for(lambda: len(heard) == replicas, 60, f"perception for {replicas} rovers")
        assert heard == set(range(1, replicas + 1))
    finally:
        stop(*reversed(procs))
    (session_file,) = (data / "recordings").glob("session-*.mcap")
    with session_file.open("rb") as stream:
        topics = {c.topic for c in make_reader(stream).get_summary().channels.values()}
    assert {Keyspace().rover(i, PERCEPTION) for i in heard} <= topics


def test_compose_recorder_and_batch_write_into_named_volumes(shim):
    document = yaml.safe_load(COMPOSE.read_text())
    services, commands = compose_services({}), compose_commands({}, shim)
    outputs = {"recorder": "-o", "batch": "--out"}
    for name, args in commands.items():
        if role_of(args) in outputs:
            out = PurePosixPath(option(args, outputs[role_of(args)]))
            mounts = dict(v.split(":")[::-1] for v in services[name]["volumes"])
            volume = next(mounts[m] for m in mounts if out.is_relative_to(m))
            assert volume in document["volumes"], f"{name}: {out} is not on a named volume"
    (batch,) = [n for n, a in commands.items() if role_of(a) == "batch"]
    assert services[batch]["profiles"] == ["batch"], "the batch service must not start with 'up'"


def test_k8s_commands_parse_and_read_files_in_the_image(shim):
    assert workloads()
    for obj, container in workloads():
        where = f"{obj['kind']} {obj['metadata'].get('name')}"
        check_inputs_in_image(parse(k8s_command(obj, container, shim), where), where)
        assert container["image"] == IMAGE and container["imagePullPolicy"] == "IfNotPresent", where


def test_k8s_covers_every_role_with_its_kind_of_object(shim):
    kinds = {role: {obj["kind"] for obj, _, _ in k8s_role(role, shim)} for role in set(ROLES.values()) - {"ros2"}}
    assert kinds == {"router": {"Deployment"}, "world": {"Deployment"}, "lander": {"Deployment"},
                     "rover": {"StatefulSet"}, "recorder": {"Deployment"}, "batch": {"Job"}}


def test_k8s_router_service_selects_the_router_and_every_agent_connects_to_it(shim):
    ((router, _, router_args),) = k8s_role("router", shim)
    port = int(option(router_args, "--listen").rsplit(":", 1)[1])
    labels = router["spec"]["template"]["metadata"]["labels"]
    services = [s for s in k8s_by_kind("Service") if s["spec"].get("selector", {}).items() <= labels.items()
                and any(p["port"] == port for p in s["spec"].get("ports", []))]
    assert len(services) == 1, "exactly one Service must lead to the router's port"
    endpoint = f"tcp/{services[0]['metadata']['name']}:{port}"
    for role in ("world", "lander", "rover", "recorder"):
        for obj, _, args in k8s_role(role, shim):
            assert option(args, "--connect") == endpoint, obj["metadata"]["name"]


def test_k8s_rover_ids_come_from_pod_ordinals_one_per_world_rover(shim):
    ((rovers, container, args),) = k8s_role("rover", shim)
    assert parse_id(option(args, "--id")) == "ordinal"
    governing = [s for s in k8s_by_kind("Service") if s["metadata"]["name"] == rovers["spec"]["serviceName"]]
    assert governing and governing[0]["spec"]["clusterIP"] == "None"
    ((_, _, world_args),) = k8s_role("world", shim)
    count = int(option(world_args, "--rovers") or scenario_rovers(world_args[1]))
    replicas = rovers["spec"]["replicas"]
    ids = [id_from_hostname(pod_env(rovers, container, i)["HOSTNAME"]) for i in range(replicas)]
    assert ids == list(range(1, count + 1)), "StatefulSet pods must drive exactly the world's rovers"


def test_k8s_batch_job_runs_one_seeded_mission_per_index(shim):
    ((job, container, _),) = k8s_role("batch", shim)
    assert job["spec"]["completionMode"] == "Indexed" and job["spec"]["completions"] > 1
    assert job["spec"]["template"]["spec"]["restartPolicy"] == "Never"
    runs = [parse(k8s_command(job, container, shim, index), "batch Job") for index in (0, 1, 7)]
    base = int(pod_env(job, container, 0)["BASE_SEED"])
    assert [r.seed for r in runs] == [base, base + 1, base + 7]
    assert len({r.out for r in runs}) == 3 and all(r.lockstep and r.quiet for r in runs)
    mounts = [m["mountPath"] for m in container["volumeMounts"]]
    assert all(any(r.out.is_relative_to(m) for m in mounts) for r in runs), "results must land on the volume"
    for rule in job["spec"]["podFailurePolicy"]["rules"]:
        assert rule.get("onExitCodes", {}).get("containerName", container["name"]) == container["name"]


def test_k8s_recorder_writes_to_a_persistent_volume_claim(shim):
    ((recorder, container, args),) = k8s_role("recorder", shim)
    out = PurePosixPath(option(args, "-o"))
    (mount,) = [m for m in container["volumeMounts"] if out.is_relative_to(m["mountPath"])]
    (volume,) = [v for v in recorder["spec"]["template"]["spec"]["volumes"] if v["name"] == mount["name"]]
    claims = {c["metadata"]["name"] for c in k8s_by_kind("PersistentVolumeClaim")}
    assert volume["persistentVolumeClaim"]["claimName"] in claims
    assert recorder["spec"]["strategy"]["type"] == "Recreate", "a ReadWriteOnce claim cannot be shared in a rollout"


def test_k8s_pods_run_as_the_image_user_without_privileges():
    uid = int(steps(dockerfile_stages()[-1], "USER")[-1].split(":")[0])
    for obj in k8s_objects_of_pods():
        pod = obj["spec"]["template"]["spec"]
        assert pod["securityContext"]["runAsNonRoot"] is True and pod["securityContext"]["runAsUser"] == uid
        for container in pod["containers"]:
            assert container["securityContext"]["allowPrivilegeEscalation"] is False
            assert container["securityContext"]["capabilities"]["drop"] == ["ALL"]


def test_k8s_objects_match_the_api_schemas_strictly():
    validate = pytest.importorskip("kubernetes_validate", reason="pip install kubernetes-validate")
    for path, doc in k8s_objects():
        try:
            validate.validate(doc, "1.29.0", strict=True)
        except validate.ValidationError as exc:
            pytest.fail(f"{path.relative_to(REPO)}: {doc['kind']}: {exc.message}")


@pytest.fixture(scope="module")
def kubectl() -> str:
    found = shutil.which("kubectl")
    if found is None:
        pytest.skip("kubectl is not installed")
    return found


def test_kustomization_builds_every_live_object(kubectl):
    proc = subprocess.run([kubectl, "kustomize", str(K8S)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    built = {(d["kind"], d["metadata"]["name"]) for d in yaml.safe_load_all(proc.stdout)}
    live = {(d["kind"], d["metadata"]["name"]) for path, d in k8s_objects() if path.parent == K8S}
    assert built == live


def test_kubectl_client_dry_run_accepts_every_manifest(kubectl):
    files = [p for p in sorted(K8S.rglob("*.yaml")) if p.name != "kustomization.yaml"]
    for path in files:
        verb = "create" if "generateName" in path.read_text() else "apply"
        proc = subprocess.run([kubectl, verb, "--dry-run=client", "--request-timeout=10s", "-o", "name", "-f",
                               str(path)], capture_output=True, text=True, timeout=60)
        if proc.returncode != 0 and _needs_a_server(proc.stderr):
            pytest.skip(f"kubectl's client dry run needs an API server for discovery here: {proc.stderr.strip()[:200]}")
        assert proc.returncode == 0, f"{path}: {proc.stderr}"
        assert len(proc.stdout.split()) == len([d for d in yaml.safe_load_all(path.read_text()) if d])


def _needs_a_server(stderr: str) -> bool:
    return any(s in stderr for s in ("connection refused", "couldn't get current server", "failed to download "
                                     "openapi", "no such host", "i/o timeout", "Unable to connect to the server"))

