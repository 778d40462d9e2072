"""A `TetMesh` of the stable Neo-Hookean law as pybullet's own deformable body
(loadSoftBody of a .vtk, useNeoHookean=1), and the facts that decide what it computes.

Read in bullet3 (commit 6c888f4, January 2025, the date of the pybullet 3.2.7 wheel's build:
src/BulletSoftBody/btDeformableNeoHookeanForce.h, btDeformableBodySolver.cpp,
btDeformableBackwardEulerObjective.cpp, btConjugateResidual.h, btSoftBody.cpp;
examples/SharedMemory/PhysicsServerCommandProcessor.cpp; examples/pybullet/pybullet.c) and
measured here (tests/engines/pybullet/test_pybullet_fem.py):
- energy density (btDeformableNeoHookeanForce::elasticEnergyDensity) mu/2 (I_C - 3) +
  lam/2 (J - 1 - 3 mu / (4 lam))^2 - mu/2 log(I_C + 1), stress P = mu (1 - 1/(I_C + 1)) F +
  (lam (J - 1) - 3 mu / 4) cof F: refsim's "neo_hookean" law (Smith et al. 2018) with the same
  mu, lam, up to refsim's constant rest energy (forces identical). refsim's law takes Smith's
  reparametrisation of the material's Lame pair (mu = 4/3 mu_L, lam = lam_L + 5/6 mu_L, so that
  it linearises to E, nu at rest); the adapter passes those two numbers as NeoHookeanMu and
  NeoHookeanLambda. Passing the plain Lame pair instead would make the material 25 % softer in
  shear than E, nu say (the law's shear modulus at rest is 3/4 of its mu).
- damping: NeoHookeanDamping b (s) adds the viscous stress b (mu (dF + dF^T) + lam tr(dF) I),
  dF = (velocity differences) Dm^-1, i.e. stiffness-proportional (Rayleigh beta = b) damping
  with the linear-elastic stiffness of (mu, lam) at the rest shape. It is solved implicitly,
  (M + h D) dv = -h D v*, by conjugate residual preconditioned by the node masses alone (the
  Neo-Hookean force adds no damping diagonal: KKTPreconditioner), stopping at an
  absolute 1e-8 (m/s, the preconditioned residual's norm over all nodes) or 300 iterations: a
  velocity change below 1e-8 m/s is not applied at all (the solve returns at once).
- step (setImplicit(false), the deformable world's default): v* = v + h (gravity + elastic
  force at x_n) / m; the damping solve; x_{n+1} = x_n + h v_{n+1}. Without damping this is
  symplectic Euler (kick, drift) exactly.
- masses: loadSoftBody's `mass` spread evenly over the nodes (btSoftBody::setTotalMass: mass / n
  per node, not rho V / 4 per element node as refsim's lumped mass); there is no per-node mass
  in the API. A world anchor (createSoftBodyAnchor(body, node, -1, -1)) sets its node's mass to
  0: the node never moves (measured: bit-identical).
- node forces: none. applyExternalForce on a soft-body node adds to btSoftBody::Node::m_f,
  which only the old soft-body world reads (btSoftBody::predictMotion); the deformable world's
  solver never does (measured: the motion is bit-identical with and without the force).
- clamps: |v*| <= (bounding-box diagonal) / h per node before the damping solve
  (btDeformableBodySolver::predictDeformableMotion), each velocity component <= 1000 m / h
  after it (btSoftBodyWorldInfo::m_maxDisplacement); btSoftBody's m_maxStress (a clamp on the
  principal stresses) is 0, off.
- sleeping: a body whose fastest node stays below 0.04 m/s for 2 s freezes; the adapter
  disables it (changeDynamics activationState=ACTIVATION_STATE_DISABLE_SLEEPING).
- velocities: the Python API reads and writes node positions only (getMeshData's velocity flag
  is not passed through by pybullet.c); initial velocities cannot be set.
"""
from __future__ import annotations

import os
import tempfile

import numpy as np

from refsim.models.fem.laws import law_of
from refsim.scene.meshes import tetrahedron_volumes

from .fem_vtk import write_vtk
from .runtime import c_stdout_silenced

CR_TOLERANCE, CR_MAX_ITERATIONS = 1e-8, 300  # btConjugateResidual: absolute, m/s
MAX_DISPLACEMENT = 1000.0  # m: btSoftBodyWorldInfo::m_maxDisplacement (per-component clamp)


def neo_hookean_coefficients(material) -> tuple[float, float]:
    """(NeoHookeanMu, NeoHookeanLambda) in Pa: refsim's neo_hookean law's (mu, lam) for E, nu."""
    law = law_of(material, 3)
    return law.mu, law.lam


class TetFile:
    """The mesh's .vtk in a temporary directory that lives as long as this object."""

    def __init__(self, mesh):
        self._dir = tempfile.TemporaryDirectory(prefix="refsim_pb_fem_")
        self.path = os.path.join(self._dir.name, "mesh.vtk")
        write_vtk(self.path, mesh.vertices, mesh.tetrahedra)

    def cleanup(self):
        self._dir.cleanup()


def total_mass(mesh) -> float:
    """rho x the mesh's volume (kg): what loadSoftBody spreads evenly over the nodes."""
    return float(mesh.material.density * tetrahedron_volumes(mesh.vertices, mesh.tetrahedra).sum())


def node_masses(mesh) -> np.ndarray:
    """pybullet's node masses (kg): total mass / n, 0 on anchored nodes."""
    out = np.full(len(mesh), total_mass(mesh) / len(mesh))
    out[mesh.pinned] = 0.0
    return out


def load_mesh(p, cid, mesh, tet_file, damping, gravity, positions=None) -> int:
    """A fresh deformable world holding the mesh (rest shape: its vertices), its pinned nodes
    anchored, every node at `positions` (the mesh's initial positions when None) at rest, under
    `gravity`, sleeping off. Returns the body id."""
    p.resetSimulation(p.RESET_USE_DEFORMABLE_WORLD, physicsClientId=cid)
    p.setGravity(*gravity, physicsClientId=cid)  # before the body: its gravity force is made at load
    mu, lam = neo_hookean_coefficients(mesh.material)
    with c_stdout_silenced():  # the .vtk reader prints its node, link, face and tet counts
        body = p.loadSoftBody(
            tet_file.path, mass=total_mass(mesh), useNeoHookean=1, NeoHookeanMu=mu,
            NeoHookeanLambda=lam, NeoHookeanDamping=float(damping), useMassSpring=0,
            useSelfCollision=0, useFaceContact=0, frictionCoeff=0.0, physicsClientId=cid)
    count = p.getMeshData(body, -1, flags=p.MESH_DATA_SIMULATION_MESH, physicsClientId=cid)[0]
    if count != len(mesh):
        raise RuntimeError(f"pybullet made {count} soft-body nodes of {len(mesh)} mesh nodes")
    for node in mesh.pinned.tolist():
        p.createSoftBodyAnchor(body, node, -1, -1, physicsClientId=cid)
    start = mesh.positions if positions is None else positions
    p.resetMeshData(body, np.asarray(start, float).tolist(), physicsClientId=cid)
    p.changeDynamics(body, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                     physicsClientId=cid)
    return body


def softbody_settings(mesh) -> dict:
    """The settings every pybullet FEM Sim states."""
    mu, lam = neo_hookean_coefficients(mesh.material)
    return {
        "world": "RESET_USE_DEFORMABLE_WORLD", "connection": "DIRECT", "dtype": "float64",
        "threads": 1, "law": "stable Neo-Hookean (btDeformableNeoHookeanForce, Smith et al. "
                             "2018): refsim's neo_hookean with the same mu, lam",
        "NeoHookeanMu_Pa": mu, "NeoHookeanLambda_Pa": lam,
        "lame_mapping": "Smith et al.'s: mu = 4/3 mu_L, lam = lam_L + 5/6 mu_L of E, nu",
        "mesh": ".vtk written to a temporary directory (POINTS in node order, CELLS '4 a b c "
                "d', CELL_TYPES 10), every tetrahedron positively oriented (checked)",
        "mass_total_kg": total_mass(mesh),
        "node_mass": "total / n on every node (setTotalMass), not refsim's rho V / 4 per "
                     "element node; anchored nodes mass 0",
        "pinned": "createSoftBodyAnchor to the world (node mass 0: exact)",
        "self_collision": "off", "contacts": "none (no other body in the world)",
        "stress_clamp": "off (m_maxStress = 0)",
        "sleeping": "disabled (ACTIVATION_STATE_DISABLE_SLEEPING)",
        "damping_solve": (f"conjugate residual, absolute tolerance {CR_TOLERANCE:g} m/s, at "
                          f"most {CR_MAX_ITERATIONS} iterations"),
        "velocity_clamp": "|v| <= bounding-box diagonal / h per node before the damping solve; "
                          f"each component <= {MAX_DISPLACEMENT:g} m / h after it",
    }
