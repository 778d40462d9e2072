"""MuJoCo behind refsim's engine contract (measured on mujoco 4.0.0).

Each scene becomes an MJCF model with one MuJoCo body per scene body, no geoms and contacts off:
- a free point mass: three slide joints (x, y, z), so the mass matrix is m I exactly;
- a mass on a spring to a fixed anchor: one slide joint along the anchor-body line with
  `stiffness` k, `springref` at the rest length and `damping` c (the spring's own damping);
- a mass on a rod: one hinge joint through the anchor (generalized coordinate, no constraint).
Linear drag f = -b v is joint damping: b on each slide, b L^2 on a hinge (exact for a point mass).
The body's reference pose (qpos = 0) is the scene's initial pose, so refsim's positions need no
sign or offset conventions and MuJoCo's own reset target is the initial state.

Facts applied (docs/engine_notes.md#mujoco, mujoco 4.0.0), each reported in `Sim.settings()`:
- gravity and timestep are set explicitly (MuJoCo defaults: -9.81 z, 0.002 s);
- a point mass gets an explicit `<inertial>` with diaginertia 1e-12 (1e-9 showed a 1e-8 error
  under RK4), never inertia from geoms;
- `Euler` treats joint damping implicitly unless the `eulerdamp` flag is disabled (mujoco 4.0.0
  docs, Numerical integration): it is disabled, so "symplectic_euler" is refsim's kick-drift
  step with every force explicit; `implicit`/`implicitfast` keep damping implicit, their method;
- on NaN/Inf/huge values MuJoCo warns, resets to the initial pose and writes MUJOCO_LOG.TXT in
  the working directory: auto-reset is disabled, the bad-qpos/qvel/qacc warning counters are read
  after every `step(n)` and set `Sim.failure`, and MuJoCo's warnings go to a callback while
  stepping (no log file, no console output).

Sphere scenes (features "contacts", "walls") are described in `spheres` (the MJCF and the
contact parameters) and `restitution` (the calibration of the contact damping).

Every scene runs through a model group (`groups/`, one module each): "particles" (point masses,
springs, rods, drag), "spheres" (spheres under a contact model, walls), "gravity_pairs",
"rigid", "pivots", "contact_rolling", "spring_network" and "fem" (one P1 mesh as a flex);
`engine` only declares who the engine is and why it refuses what no group runs (`refusals`:
grids, SPH fluid, several meshes, emitter).

Modules, one per concern:
- `methods`: the MuJoCo integrators as refsim declares them;
- `body_plan`: one scene body as a MuJoCo body (`BodyPlan`), built by `point_masses`
  (particles, springs, hinges) and `spheres` (free spheres, contacts, walls) for the groups;
- `contact_params`, `restitution`: contact stiffness, friction damping, restitution calibration;
- `mjcf`: the MJCF text of a plan;
- `sim`: stepping, failure detection, observation and settings; `engine`: the Engine.
"""
from __future__ import annotations

from .engine import MujocoEngine
from .sim import MujocoSim

__all__ = ["MujocoEngine", "MujocoSim"]
