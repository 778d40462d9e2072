"""The observation contract: what `Sim.observe()` returns, by scene part, in one table.

`Sim.observe()` returns a dict of named arrays (SI units, float64). OBSERVABLES below is the one
list of every name: the part it belongs to, its shape, units and meaning, and whether an engine
must report it. Shape symbols: n = bodies of the moving part, k = joints, f = fluid particles
(`FluidBlock.particle_count`), N = nodes of all networks (or all meshes) together, in the
order the scene lists them; "grid.shape" = the shape of the grid holding the field; nx, ny =
the cells of a `FluidGrid` (MAC grid: u on the vertical faces, v on the horizontal ones, p at
the cell centres).

The moving-kind rule: "x" and "v" (and "w") belong to the scene's one kind of moving bodies,
`Scene.moving_kind()`: particles, the SPH fluid, rigid bodies, spring-network nodes or mesh
nodes (a scene that mixes two is rejected when built). Grids move nothing: each field is
reported by name as "grid.<field>". Names an engine adds beyond the table are engine extras:
allowed, unchecked. Optional names are checked whenever an engine reports them.

`check_observation(obs, scene)` lists what breaks the contract (missing names, wrong shapes);
`contract_markdown()` renders the table for the documentation.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsim.scene import (MOVING_KINDS, FluidBlock, FluidGrid, Grid, Joints, Particles,
                          RigidBodies, SpringNetwork, TetMesh, TriangleMesh)


@dataclass(frozen=True)
class Observable:
    name: str
    part: str  # a scene part kind (refsim.scene.PART_KINDS) or "scene"
    shape: str
    units: str
    meaning: str
    required: bool = True


OBSERVABLES: tuple[Observable, ...] = (
    Observable("t", "scene", "()", "s", "simulated time, steps x dt"),
    Observable("x", "particles", "(n, 3)", "m", "body (sphere) centres"),
    Observable("v", "particles", "(n, 3)", "m/s", "body velocities"),
    Observable("w", "particles", "(n, 3)", "rad/s", "sphere spin, world frame, where the engine "
               "reports it (engines simulating contacts do)", required=False),
    Observable("constraint", "joints", "(k,)", "m", "rod length error |x_body - anchor| - "
               "length per joint (zeros where the engine uses generalized coordinates)",
               required=False),
    Observable("wall_impulse", "walls", "(3,)", "N s", "impulse the walls gave the spheres, "
               "accumulated since t = 0 (momentum balance of contact scenes)", required=False),
    Observable("x", "fluid", "(f, 2)", "m", "fluid particle positions in the block's plane "
               "(x, y of a 2D scene; x, z of a 3D one), wall particles excluded"),
    Observable("v", "fluid", "(f, 2)", "m/s", "fluid particle velocities in that plane"),
    Observable("rho", "fluid", "(f,)", "kg/m^3", "fluid particle densities"),
    Observable("mass", "fluid", "(f,)", "kg", "fluid particle masses"),
    Observable("x", "rigid", "(n, 3)", "m", "centres of mass"),
    Observable("v", "rigid", "(n, 3)", "m/s", "velocities of the centres of mass"),
    Observable("q", "rigid", "(n, 4)", "1", "orientations, unit quaternions (w, x, y, z), "
               "scalar first, body to world"),
    Observable("w", "rigid", "(n, 3)", "rad/s", "angular velocities, world frame"),
    Observable("orientation_defect", "rigid", "(n,)", "1", "how far the stored orientation "
               "left the rotations: |q|^2 - 1, the squared norm removed by renormalising "
               "(cumulative), or max |R^T R - I|; as the formulation defines it", required=False),
    Observable("angular_momentum", "rigid", "(n, 3)", "kg m^2/s", "world angular momentum of "
               "each body about its centre of mass, or about its pivot when it has one "
               "(RigidPivots)", required=False),
    Observable("x", "networks", "(N, 3)", "m", "node positions, every network's nodes in "
               "scene order"),
    Observable("v", "networks", "(N, 3)", "m/s", "node velocities"),
    Observable("x", "meshes", "(N, 3)", "m", "mesh node (vertex) positions, every mesh's "
               "nodes in scene order"),
    Observable("v", "meshes", "(N, 3)", "m/s", "mesh node velocities"),
    Observable("grid.<field>", "grids", "grid.shape", "the field's", "each grid field by "
               "name, at the grid points"),
    Observable("grid.u", "fluid_grids", "(nx + 1, ny)", "m/s", "x-velocity on the MAC grid's "
               "vertical faces, at (i h, (j + 1/2) h)"),
    Observable("grid.v", "fluid_grids", "(nx, ny + 1)", "m/s", "y-velocity on the MAC grid's "
               "horizontal faces, at ((i + 1/2) h, j h)"),
    Observable("grid.p", "fluid_grids", "(nx, ny)", "m^2/s^2", "kinematic pressure p / rho "
               "of the last projection at the cell centres (0 before any step)"),
)


def _counts(scene) -> dict[str, int]:
    networks = sum(len(n) for n in scene.parts_of(SpringNetwork))
    meshes = sum(len(m) for m in scene.parts_of(TriangleMesh) + scene.parts_of(TetMesh))
    rigid, particles = scene.part(RigidBodies), scene.part(Particles)
    joints, fluid = scene.part(Joints), scene.part(FluidBlock)
    mac = scene.part(FluidGrid)
    return {"n": len(rigid) if rigid is not None else len(particles or ()),
            "k": len(joints or ()),
            "f": fluid.particle_count if fluid is not None else 0,
            "N": networks or meshes,
            "nx": mac.nx if mac is not None else 0, "ny": mac.ny if mac is not None else 0}


def _shape(text: str, counts: dict[str, int]) -> tuple[int, ...]:
    dims = [d.strip() for d in text.strip("()").split(",") if d.strip()]
    return tuple(sum(counts[t] if t in counts else int(t) for t in map(str.strip, d.split("+")))
                 for d in dims)


def expected(scene) -> dict[str, tuple[tuple[int, ...], bool]]:
    """{name: (shape, required)} of the observables that apply to `scene`."""
    kinds, moving = scene.part_kinds(), scene.moving_kind()
    counts, out = _counts(scene), {}
    for o in OBSERVABLES:
        if o.part in MOVING_KINDS and o.part != moving:
            continue
        if o.part == "grids":
            out.update({f"grid.{name}": (g.shape, True) for g in scene.parts_of(Grid)
                        for name in g.fields})
            continue
        if o.part == "fluid_grids" and o.part not in kinds:
            continue
        required = o.required and (o.part == "scene" or o.part in kinds)
        out[o.name] = (_shape(o.shape, counts), required)
    return out


def check_observation(obs: dict, scene) -> list[str]:
    """The problems of one `observe()` result against the contract for `scene`: a required
    name missing, or a name of the table with the wrong shape. [] when it conforms."""
    problems = []
    for name, (shape, required) in expected(scene).items():
        if name not in obs:
            if required:
                problems.append(f"missing {name!r} (shape {shape})")
            continue
        got = np.shape(obs[name])
        if got != shape:
            problems.append(f"{name!r} has shape {got}, expected {shape}")
    return problems


def contract_markdown() -> str:
    """OBSERVABLES as a Markdown table (name, part, shape, units, meaning, required)."""
    rows = ["| name | part | shape | units | meaning | required |",
            "|---|---|---|---|---|---|"]
    rows += [f"| `{o.name}` | {o.part} | {o.shape} | {o.units} | {o.meaning} | "
             f"{'yes' if o.required else 'where reported'} |" for o in OBSERVABLES]
    return "\n".join(rows)
