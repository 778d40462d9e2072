"""One P1 mesh as a MuJoCo 4 flex (mujoco 4.0.0), for the fem group (groups/fem.py).

The flex: `<flexcomp type="direct">` with the mesh's rest vertices as `point` and its elements
as `element`: triangles dim="2" dof="2d" (each free vertex a body with slides along x and y:
plane motion), tetrahedra dim="3" dof="full" (slides x, y, z); `<pin id>` for pinned nodes
(vertices on the world body, no joints); `<elasticity young poisson [thickness elastic2d=
"stretch"] damping>` (MuJoCo's StVK on P1 elements: energy mu tr(E^2) + lambda/2 tr(E)^2 of the
Green strain E, in 2D times the thickness with the plane-stress lambda* = E nu / (1 - nu^2);
`damping` is Rayleigh, in time units: the damping force -damping K v; `yield` the plastic
yield strain of fem_yield when the material is plastic); contacts off. Plane
strain is passed as the plane-stress constants of the same in-plane law (`flex_constants`);
MuJoCo takes Poisson ratios in [0, 0.5) only (`constants_reason`).

What the adapter sets after flexcomp expands it (MjSpec, then the compiled model):
- masses: flexcomp spreads its `mass` equally over the vertices (pinned ones included); each
  free vertex body gets refsim's lumped mass rho V / (d + 1) summed over its elements instead
  (`lumped_masses`), inertia POINT_INERTIA (slides only: it never enters);
- pinned vertices: the flex's reference (rest) shape is computed from `point` at compile time;
  a pinned node held away from its rest vertex (an imposed boundary field) gets its position
  written into the compiled `flex_vert` (its position on the world body) afterwards, so the rest
  shape stays the mesh's;
- free vertices start at the mesh's positions through qpos (displacements from the rest vertex
  along the world axes), velocities through qvel;
- mass-proportional damping (the settle of groups/fem.py, "steady"): a fixed tendon per slide
  with damping alpha m (force -alpha m v on that dof), because MuJoCo takes no joint damping on
  flex vertex bodies.
The compiler's warning that such a flex "is not rigid and has no ... passive forces" (damping
0) is spurious (its elastic forces act) and silenced. Loads go through
`d.xfrc_applied[m.flex_vertbodyid[v], :3]` (constant), gravity through the option. Triangle
meshes must lie in a z = const plane (dof="2d" moves in x and y).
"""
from __future__ import annotations

import warnings

import numpy as np

from refsim.models.fem.assembly import lumped_masses
from refsim.models.fem.model import ElasticBody
from refsim.scene import TriangleMesh, single_mesh

from .mjcf import xml_floats
from .fem_yield import yield_strain
from .network_mjcf import SOLVER_ITERATIONS, SOLVER_TOLERANCE
from .point_masses import POINT_INERTIA

FLEX_NAME = "mesh"
# mujoco 4.0.0's compiler warns this of a flex whose elasticity has damping 0 although its
# StVK forces act (measured: the stretch root reached to 1e-13): silenced at compile
SPURIOUS_WARNING = "flex .* is not rigid and has no equality constraints or passive forces"
FLEX_RADIUS = 1e-3  # m: the flex's collision radius (contacts off: it enters nothing)


def mesh_of(scene):
    """The scene's one TriangleMesh or TetMesh, None when there is not exactly one."""
    return single_mesh(scene)


def plane_reason(mesh) -> str | None:
    """Why a triangle mesh cannot be a dof="2d" flex (None when it can)."""
    if isinstance(mesh, TriangleMesh) and not np.all(mesh.vertices[:, 2] == mesh.vertices[0, 2]):
        return ("mujoco fem: a triangle mesh must lie in a z = const plane (flexcomp "
                "dof=\"2d\" moves its vertices in x and y only)")
    return None


class FemLayout:
    """The mesh's data as the flex needs it: free mask, lumped masses, dofs per vertex."""

    def __init__(self, mesh):
        self.mesh = mesh
        self.triangles = isinstance(mesh, TriangleMesh)
        self.dof = 2 if self.triangles else 3
        self.free = np.ones(len(mesh), bool)
        self.free[mesh.pinned] = False
        body = ElasticBody.of(mesh)
        self.masses = lumped_masses(body.elements, mesh.material.density)
        self.equal_split = float(np.sum(self.masses)) / len(mesh)  # flexcomp's own split

    def mass_comparison(self) -> dict:
        """flexcomp's equal split against the lumped masses set on the free vertices."""
        lumped = self.masses[self.free]
        ratio = self.equal_split / lumped
        return {"flexcomp_split": "total mass / vertices, equal (pinned vertices included)",
                "flexcomp_split_kg": self.equal_split,
                "lumped_kg_min": float(lumped.min()), "lumped_kg_max": float(lumped.max()),
                "split_over_lumped_min": float(ratio.min()),
                "split_over_lumped_max": float(ratio.max())}


def flex_constants(mesh) -> tuple[float, float]:
    """(young, poisson) for the flex. Plane strain on a 2-D flex, which is plane stress: the
    in-plane law of (E, nu) in plane strain is the plane-stress law of E' = E / (1 - nu^2),
    nu' = nu / (1 - nu) (the same mu = E / (2 (1 + nu)) and lambda* = E' nu' / (1 - nu'^2) =
    E nu / ((1 + nu)(1 - 2 nu)), the 3-D lambda), exactly for StVK since E_zz = 0."""
    e, nu = mesh.material.youngs_modulus, mesh.material.poisson_ratio
    if isinstance(mesh, TriangleMesh) and mesh.plane == "strain":
        return e / (1.0 - nu * nu), nu / (1.0 - nu)
    return e, nu


def constants_reason(mesh) -> str | None:
    """Why MuJoCo cannot take the material's Poisson ratio (None when it can)."""
    _, poisson = flex_constants(mesh)
    if 0.0 <= poisson < 0.5:
        return None
    nu = mesh.material.poisson_ratio
    if poisson != nu:
        return (f"mujoco fem: plane strain maps to MuJoCo's plane-stress flex with poisson "
                f"nu / (1 - nu) = {poisson:.6g}, outside MuJoCo's [0, 0.5) (nu >= 1/3)")
    return f"mujoco fem: MuJoCo's flex takes a Poisson ratio in [0, 0.5), got {nu:g}"


def _elasticity_xml(mesh, damping: float) -> str:
    young, poisson = flex_constants(mesh)
    out = (f'<elasticity young="{young!r}" poisson="{poisson!r}" '
           f'damping="{float(damping)!r}"')
    if mesh.material.plasticity is not None:  # fem_yield: refused unless it maps
        out += f' yield="{yield_strain(mesh)!r}"'

    if isinstance(mesh, TriangleMesh):
        out += f' thickness="{mesh.thickness!r}" elastic2d="stretch"'
    return out + "/>"


def fem_xml(layout, gravity, timestep, integrator_xml, damping=0.0) -> str:
    mesh = layout.mesh
    pins = " ".join(str(int(i)) for i in mesh.pinned)
    pin = f'<pin id="{pins}"/>' if len(mesh.pinned) else ""
    dim, dof = ("2", "2d") if layout.triangles else ("3", "full")
    return (f'<mujoco model="refsim_fem"><compiler inertiafromgeom="false"/>'
            f'<option timestep="{xml_floats(timestep)}" gravity="{xml_floats(gravity)}" '
            f'integrator="{integrator_xml}" density="0" viscosity="0" wind="0 0 0" '
            f'solver="Newton" tolerance="{SOLVER_TOLERANCE!r}" '
            f'iterations="{SOLVER_ITERATIONS}">'
            f'<flag contact="disable" eulerdamp="disable" autoreset="disable"/></option>'
            f'<worldbody><flexcomp name="{FLEX_NAME}" type="direct" dim="{dim}" dof="{dof}" '
            f'point="{xml_floats(mesh.vertices.ravel())}" '
            f'element="{" ".join(map(str, mesh.elements.ravel()))}" '
            f'mass="{float(np.sum(layout.masses))!r}" radius="{FLEX_RADIUS!r}">{pin}'
            f'{_elasticity_xml(mesh, damping)}<edge stiffness="0" damping="0"/>'
            f'<contact contype="0" conaffinity="0"/></flexcomp></worldbody></mujoco>')


def _edit_vertex_bodies(spec, layout, alpha: float):
    """Lumped mass and point inertia on every free vertex body; with alpha > 0 a damping
    tendon per slide (alpha m). One call per node, at build time."""
    for i in np.flatnonzero(layout.free):
        body = spec.body(f"{FLEX_NAME}_{i}")
        body.mass, body.inertia = float(layout.masses[i]), [POINT_INERTIA] * 3
        body.explicitinertial = True
        for k, joint in enumerate(body.joints):
            joint.name = f"v{i}_{k}"
            if alpha > 0:
                spec.add_tendon(name=f"damp{i}_{k}",
                                damping=float(alpha * layout.masses[i])).wrap_joint(joint.name,
                                                                                    1.0)


def fem_model(layout, gravity, timestep, integrator_xml, rayleigh=0.0, alpha=0.0):
    """The compiled MjModel: lumped masses, pinned vertices at the mesh's positions."""
    import mujoco
    spec = mujoco.MjSpec.from_string(fem_xml(layout, gravity, timestep, integrator_xml,
                                             rayleigh))
    _edit_vertex_bodies(spec, layout, alpha)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=SPURIOUS_WARNING)
        model = spec.compile()
    pinned = layout.mesh.pinned
    model.flex_vert[model.flex_vertadr[0] + pinned] = layout.mesh.positions[pinned]
    return model


def vertex_dofs(model, layout) -> tuple[np.ndarray, np.ndarray]:
    """(n_free, dof) qpos and qvel addresses of each free vertex's slides, in node order."""
    bodies = model.flex_vertbodyid[model.flex_vertadr[0]:][layout.free]
    joints = np.argsort(model.jnt_bodyid, kind="stable")
    joints = joints[np.isin(model.jnt_bodyid[joints], bodies)].reshape(-1, layout.dof)
    order = np.argsort(np.argsort(bodies))  # rows of `joints` follow body ids
    joints = joints[order]
    return model.jnt_qposadr[joints], model.jnt_dofadr[joints]


def check_model(model, layout, rayleigh: float, alpha: float) -> None:
    """The compiled flex is the one asked for: one flex of the mesh's dimension, the lumped
    masses on the free vertex bodies, slides along the world axes, pinned vertices on the
    world body at their positions, the damping asked and no other."""
    mesh, free = layout.mesh, layout.free
    verts = model.flex_vertbodyid[model.flex_vertadr[0]:][:len(mesh)]
    qadr, dadr = vertex_dofs(model, layout)
    axes = model.jnt_axis[model.dof_jntid[dadr]]
    n_tendons = int(free.sum()) * layout.dof if alpha > 0 else 0
    same = (model.nflex == 1 and model.flex_dim[0] == layout.dof and
            model.flex_vertnum[0] == len(mesh) and model.nv == layout.dof * int(free.sum()) and
            np.array_equal(model.body_mass[verts[free]], layout.masses[free]) and
            np.all(verts[~free] == 0) and
            np.array_equal(model.flex_vert[model.flex_vertadr[0] + mesh.pinned],
                           mesh.positions[mesh.pinned]) and
            np.array_equal(axes, np.broadcast_to(np.eye(3)[:layout.dof], axes.shape)) and
            model.flex_damping[0] == rayleigh and not model.dof_damping.any() and
            np.array_equal(model.flex_yield[0], [yield_strain(mesh), 0.0]) and
            model.flex_edgestiffness[0] == 0 and model.flex_edgedamping[0] == 0 and
            not model.dof_armature.any() and model.ntendon == n_tendons and
            not model.tendon_stiffness.any() and
            np.array_equal(model.tendon_damping, alpha * np.repeat(layout.masses[free],
                                                                   layout.dof)[:n_tendons]))
    if not same:
        raise RuntimeError("mujoco compiled another flex/masses/damping than the mesh's")
