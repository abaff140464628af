"""What loading a scenario leaves to the processes that use it, tried at once (``lunarsim scenario check``): its
terrain mesh is read and made into triangles as the world will, its behaviour imported as each rover agent will."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from schemas.scenario import Scenario


def check_files(path: Path, scenario: Scenario) -> None:
    """A ``ScenarioError`` or ``UsageError`` naming ``path`` when the scenario's mesh or behaviour would fail the
    processes; the behaviour is imported in a child process."""
    from deploy.behaviour_check import require_behaviour
    from schemas.scenario import ScenarioError
    from schemas.scenario_limits import clip

    mesh = scenario.terrain.mesh if scenario.terrain is not None else None
    if mesh is not None:
        from world_service.terrain.mesh import load_vertices_faces

        try:
            load_vertices_faces(mesh, scenario.terrain.mesh_scale, scenario.terrain.mesh_offset)
        except ScenarioError as exc:
            raise ScenarioError(f"{path}: terrain.mesh: {exc}") from None
        except Exception as exc:  # trimesh raises many kinds; all mean a file it cannot make triangles of
            raise ScenarioError(f"{path}: terrain.mesh: {clip(mesh)}: not a mesh the world can load: "
                                f"{clip(str(exc).removeprefix(f'{mesh}: ') or type(exc).__name__)}") from None
    require_behaviour(scenario.behaviour, str(path))
