"""The documentation's generated pages, so they cannot drift from what they describe: the home page from the
README, and references from the code: every key and the message it carries (``schemas``), every scenario field
with its default and bounds (the models, also as a JSON Schema for editors), every command's help (the
argparse parsers), and the packages' diagram from their imports. ``tests/project/test_docs.py`` fails when the
checked-in pages differ from what this writes.

    python -m deploy.reference docs      # after changing a message, a scenario field, a flag or an import
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import types
import typing
from pathlib import Path
from typing import Annotated, Union, get_args, get_origin

import msgspec
from pydantic import BaseModel

HELP_COLUMNS = "100"
"""argparse wraps help to the terminal: a fixed width keeps the page the same on every machine."""


def pages(docs: Path) -> dict[str, str]:
    """File name (under the ``docs`` folder, beside the README) -> content."""
    return {"index.md": index_page(docs.parent / "README.md"), "reference/keyspace.md": keyspace_page(),
            "reference/scenario.md": scenario_page(), "reference/cli.md": cli_page(), "reference/ros2.md": ros2_page(),
            "scenario.schema.json": scenario_schema(),
            ARCHITECTURE: architecture_page(docs / ARCHITECTURE, docs.parent)}


ARCHITECTURE = "concepts/architecture.md"
GENERATED = ("<!-- generated: python -m deploy.reference docs -->", "<!-- end generated -->")
"""The part of a written page this module draws, between these two lines; the rest is prose kept in the page."""


def architecture_page(page: Path, repo: Path) -> str:
    """The page as written, its diagram and table of the packages drawn again from the imports in the source."""
    from deploy import package_graph as g

    text = page.read_text()
    head, rest = text.split(GENERATED[0] + "\n", 1)
    tail = rest.split(GENERATED[1], 1)[1]
    graph = g.package_imports(repo)
    drawn = ["```text", g.diagram(graph), "```", "", *g.table(graph)]
    return "\n".join([head + GENERATED[0], *drawn, GENERATED[1]]) + tail


def ros2_page() -> str:
    from ros2_bridge.reference import page

    return page()


def index_page(readme: Path) -> str:
    """The site's home page is the README, its links into ``docs/`` made relative: one text, not two to keep."""
    return readme.read_text().replace("](docs/", "](")


# ---- keys and messages ----


def keyspace_page() -> str:
    from schemas import keyspace as ks
    from schemas import messages as m
    from world_service.sim import World

    lines = ["# Keyspace", "", "Every key is `lunar/<world>/...`; rover topics mirror the report's ROS topics "
             "(`roverX/perception` is `lunar/<world>/rover/X/perception`). Every payload is msgpack "
             "`[schema_version, {fields}]` of one model; units: metres, seconds of simulated time, degrees "
             "(heading 0 = +z, 90 = +x).", "", "## Rover keys", "",
             "| key | payload | from | to |", "|---|---|---|---|"]
    # keys the two subscription lists do not tell: the world's service and twin subscribe to these
    elsewhere = {ks.STATUS: ("rover agent", "world, ground, recorder"), ks.ACK: ("rover agent", "world (lockstep)"),
                 ks.TELEMETRY: ("hardware bridge", "world (twin mode)"),
                 ks.POSE_ESTIMATE: ("rover agent", "ground, ROS 2 bridge, recorder")}
    for topic, model in m.TOPIC_MODELS.items():
        sender = "rover agent" if topic in World.INPUT_TOPICS else "world"
        receiver = ", ".join(who for who, yes in (("world", topic in World.INPUT_TOPICS),
                                                  ("rover agent", topic in ks.ROVER_INPUTS)) if yes)
        sender, receiver = elsewhere.get(topic, (sender, receiver))
        lines.append(f"| `rover/<id>/{topic}` | [`{model.__name__}`](#{model.__name__.lower()}) | {sender} | "
                     f"{receiver} |")
    for area, models in (("lander", m.LANDER_TOPIC_MODELS), ("world", m.WORLD_TOPIC_MODELS),
                         ("ground", m.GROUND_TOPIC_MODELS)):
        lines += ["", f"## {area.capitalize()} keys", "", "| key | payload |", "|---|---|"]
        lines += [f"| `{area}/{topic}` | [`{model.__name__}`](#{model.__name__.lower()}) |"
                  for topic, model in models.items()]
    lines += ["", "Liveliness tokens: `alive/rover/<id>` and `alive/lander` (each agent's, while it runs); "
              "`alive/replay/playing` or `alive/replay/paused` (a replay's, while it publishes into the world).", "",
              "## Messages", ""]
    seen: set[str] = set()
    queue = [*m.TOPIC_MODELS.values(), *m.LANDER_TOPIC_MODELS.values(), *m.WORLD_TOPIC_MODELS.values(),
             *m.GROUND_TOPIC_MODELS.values()]
    while queue:  # payloads, then the models nested in them (a state's rovers, the statistics' report)
        model = _described(queue.pop(0))
        if model.__name__ not in seen:
            seen.add(model.__name__)
            lines += _model_section(model, f"### {model.__name__}")
            queue += [inner for info in model.model_fields.values()
                      if (inner := _nested_model(info.annotation)) is not None]
    return "\n".join(lines) + "\n"


# ---- scenario files ----


def scenario_page() -> str:
    from schemas.scenario import Scenario

    lines = ["# Scenario files", "", "A scenario is a YAML file validated by these models; an unknown field, a "
             "value out of bounds or a nan is refused with the field's path. Editors with a YAML language server "
             "complete and check scenario files against [`scenario.schema.json`](../scenario.schema.json) "
             "(add `# yaml-language-server: $schema=<path>/docs/scenario.schema.json` at the top of a file).", ""]
    done: set[type] = set()
    queue: list[tuple[str, type[BaseModel]]] = [("(top level)", Scenario)]
    while queue:
        path, model = queue.pop(0)
        if model in done:
            continue
        done.add(model)
        lines += _model_section(model, f"## `{path}`: {model.__name__}")
        for name, info in model.model_fields.items():
            inner = _nested_model(info.annotation)
            if inner is not None:
                prefix = "" if path == "(top level)" else f"{path}."
                queue.append((f"{prefix}{name}", inner))
    return "\n".join(lines) + "\n"


def scenario_schema() -> str:
    from schemas.scenario import Scenario
    from schemas.scenario_types import StructDefaults

    schema = Scenario.model_json_schema(schema_generator=StructDefaults)
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def _described(model: type) -> type[BaseModel]:
    """The pydantic model whose fields describe ``model``: itself, or a Struct's mirror (``schemas.scenario_types``),
    which reads the Struct's own types, bounds, defaults and descriptions."""
    from schemas.scenario_types import mirror

    return mirror(model) if issubclass(model, msgspec.Struct) else model


def _nested_model(annotation: object) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel | msgspec.Struct):
        return _described(annotation)
    for arg in typing.get_args(annotation):
        found = _nested_model(arg)
        if found is not None:
            return found
    return None


def _model_section(model: type[BaseModel], title: str) -> list[str]:
    doc = (model.__doc__ or "").strip().split("\n\n")[0].replace("\n", " ")
    lines = [title, ""] + ([doc, ""] if doc and not doc.startswith(("!!!", "Usage docs")) else [])
    lines += ["| field | type | default | bounds | meaning |", "|---|---|---|---|---|"]
    for name, info in model.model_fields.items():
        default = "required" if info.is_required() else f"`{_short(info.get_default(call_default_factory=True))}`"
        lines.append(f"| `{name}` | {_type_name(info.annotation)} | {default} | {_bounds(_metadata(info))} | "
                     f"{(info.description or '').replace('|', '/')} |")
    return [*lines, ""]


def _type_name(annotation: object) -> str:
    return f"`{_plain(annotation)}`".replace("|", "&#124;")


def _plain(annotation: object) -> str:
    """``Coordinate | None`` reads ``float | None``: the constrained alias's bounds are in the bounds column."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _plain(args[0])
    if origin in (Union, types.UnionType):
        return " | ".join(_plain(arg) for arg in args)
    if annotation is type(None):
        return "None"
    if origin in (tuple, list, dict, set):
        return f"{origin.__name__}[{', '.join(_plain(arg) for arg in args)}]"
    text = getattr(annotation, "__name__", None) if isinstance(annotation, type) else None
    text = text or str(annotation).replace("typing.", "").replace("schemas.", "")
    for prefix in ("scenario.", "messages.", "params.", "truth.", "base."):
        text = text.replace(prefix, "")
    return text


def _metadata(info) -> list:
    """A field's constraints, also those of an ``Annotated`` alias inside an optional or a tuple (``Coordinate |
    None``, ``tuple[Coordinate, Coordinate]``), each once."""
    found = list(info.metadata)
    for arg in get_args(info.annotation):
        if get_origin(arg) is Annotated:
            found += [item for inner in get_args(arg)[1:] for item in getattr(inner, "metadata", [inner])]
    return list(dict.fromkeys(found))


def _bounds(metadata: list) -> str:
    names = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<", "min_length": "min length", "max_length": "max length"}
    found = [f"{symbol} {_number(getattr(item, name))}" for item in metadata for name, symbol in names.items()
             if getattr(item, name, None) is not None]
    return ", ".join(found)


def _number(value: float) -> str:
    return f"{value:,}" if isinstance(value, int) else f"{value:g}"


def _short(value: object) -> str:
    if isinstance(value, BaseModel | msgspec.Struct):
        return "{...}"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


# ---- commands ----


def cli_page() -> str:
    from deploy.cli import build_parsers

    before = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_COLUMNS
    try:
        return _cli_help(build_parsers())
    finally:
        if before is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = before


def _cli_help(parsers) -> str:
    """Each command's help under ``##``, its own subcommands' under ``###``, in the order ``COMMANDS`` lists them."""
    lines = ["# Commands", "", "Every `lunarsim` command with its `--help` (generated from the parsers).", "",
             "```text", parsers.top.format_help().rstrip(), "```", ""]
    for name, parser in parsers.commands.items():
        level = "###" if " " in name else "##"
        lines += [f"{level} lunarsim {name}", "", "```text", parser.format_help().rstrip(), "```", ""]
    return "\n".join(lines)


def write(folder: Path) -> list[Path]:
    written = []
    for name, content in pages(folder).items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(content)
        written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the docs folder (docs)")
    args = parser.parse_args(argv)
    for path in write(args.folder):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
