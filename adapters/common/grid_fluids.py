"""What every engine's grid-fluid group shares (refsim.models.grid_fluid's MAC step): the
scene a group claims (one FluidGrid), and the support rule for its integrators: the scheme
names of refsim.integrators.semi_lagrangian for time stepping, "steady" for a scene whose meta
asks one projection (solve = projection). Each engine adds what it alone refuses."""
from __future__ import annotations

from refsim.integrators.semi_lagrangian import SCHEMES, parse_scheme
from refsim.integrators.spec import spec_name
from refsim.scene import FluidGrid


def claims(scene) -> bool:
    return scene.part(FluidGrid) is not None


def projection_only(scene) -> bool:
    return scene.meta.get("solve") == "projection"


def scene_reason(scene, who: str, alone_note: str = "") -> str | None:
    """Why `who`'s group does not run `scene`: a fluid grid alone, in 2D."""
    if scene.part_kinds() != {"fluid_grids"}:
        others = ", ".join(sorted(scene.part_kinds() - {"fluid_grids"}))
        return f"{who}: a fluid grid alone, got also {others}{alone_note}"
    if scene.dim != 2:
        return f"{who}: 2D MAC grids (scene.dim 2), got dim {scene.dim}"
    return None


def integrator_reason(scene, integrator, who: str) -> str | None:
    """Why `integrator` does not run `scene` (None where it does, or where it is None)."""
    if integrator is None:
        return None
    if projection_only(scene):
        return None if integrator == "steady" else (
            f"{who}: the scene asks for one projection (meta solve = projection): integrator "
            f"'steady' only, got {integrator!r}")
    if spec_name(integrator) == "steady":
        return (f"{who}: 'steady' is one projection, for scenes whose meta asks solve = "
                "projection; time stepping offers " + ", ".join(SCHEMES))
    try:
        parse_scheme(integrator)
    except ValueError as exc:
        return f"{who}: {exc}"
    return None
