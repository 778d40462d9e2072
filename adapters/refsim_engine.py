"""The in-house numpy reference engine, `refsim`, behind the same contract as the others.

Its step is built from `scene.features()` only: gravity, drag, springs and joints become force
or constraint stages; nothing else is assembled, and energy is never evaluated while stepping.
Scenes with rods run in one of three formulations (engine variants): `generalized` (one angle
per rod), `kkt` (maximal coordinates, Lagrange multipliers, Baumgarte stabilisation) and
`penalty` (the rod as a stiff spring).
"""
from __future__ import annotations

import numpy as np

from refsim.engine import Engine, Sim
from refsim.integrators import INTEGRATORS, StepFailure, get_integrator
from refsim.models.forces import SpringSet
from refsim.models.joints import (HingeSystem, RodSet, cartesian_to_hinge, hinge_frame,
                                  hinge_to_cartesian)
from refsim.models.system import ParticleSystem

from .refsim_contacts import CONTACT_VARIANTS, ContactSim
from .refsim_sph import FluidSim

JOINT_VARIANTS = ("generalized", "kkt", "penalty")


class RefsimEngine(Engine):
    name = "refsim"
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls",
                              "fluid"})
    dims = (2, 3)
    integrators = INTEGRATORS

    # Baumgarte rate w = 5 w0 (w0 = sqrt(|g|/L), or 1 rad/s without gravity): a fixed physical
    # rate keeps every stepper's order (a rate tied to 1/dt drops RK4 to second order), and
    # w dt stays far inside every explicit stepper's stability region for the dts used here.
    baumgarte_ratio = 5.0
    # Penalty rod stiffness: rod frequency / pendulum frequency; the rod stretches by about
    # (w0 / w_rod)^2 L, so 100 gives a 1e-4 relative length error.
    penalty_ratio = 100.0

    def version(self) -> str:
        from refsim import __version__
        return __version__

    def variants(self, scene):
        if scene.contact is not None:
            return CONTACT_VARIANTS
        return JOINT_VARIANTS if scene.joints else ("",)

    def supports(self, scene, integrator=None):
        reason = super().supports(scene, integrator)
        if reason:
            return reason
        if scene.contact is not None:
            return _contact_support(scene, integrator)
        if scene.fluid is not None and integrator not in (None, "velocity_verlet"):
            return "refsim fluid scenes step with kick-drift-kick SPH ('velocity_verlet')"
        if not scene.joints:
            return reason
        jointed = {j.body for j in scene.joints}
        if len(jointed) != len(scene.joints) or len(jointed) != len(scene.bodies):
            return "refsim joints: exactly one rod per body"
        if any(s.body in jointed or s.other in jointed for s in scene.springs):
            return "refsim joints: springs on a rod's body are not modelled"
        return None

    def build(self, scene, dt, integrator, variant=""):
        if scene.joints and variant not in JOINT_VARIANTS:
            raise ValueError(f"refsim variant must be one of {list(JOINT_VARIANTS)}, "
                             f"got {variant!r}")
        if scene.contact is not None:
            reason = _contact_support(scene, integrator)
            if reason:
                raise ValueError(reason)
            return ContactSim(scene, dt, variant)
        if scene.fluid is not None:
            if integrator not in (None, "velocity_verlet"):
                raise ValueError("refsim fluid scenes step with kick-drift-kick SPH "
                                 "(integrator 'velocity_verlet')")
            return FluidSim(scene, dt)
        stepper = get_integrator(integrator)
        if scene.joints and variant == "generalized":
            return HingeSim(scene, dt, stepper)
        return ParticleSim(scene, dt, stepper, variant, self)


class _SteppedSim(Sim):
    """Bookkeeping shared by the in-house sims: time, state, failure capture."""

    def __init__(self, dt, stepper, system, q0, qd0):
        self.dt, self.stepper, self.system, self.t = float(dt), stepper, system, 0.0
        self.state = stepper.start(system, 0.0, q0, qd0, self.dt)

    def step(self, n):
        if self.failure:
            return
        try:
            with np.errstate(all="ignore"):
                self.t, self.state = self.stepper.advance(self.system, self.t, self.state,
                                                          self.dt, int(n))
        except (StepFailure, np.linalg.LinAlgError) as exc:
            self.failure = f"{exc} at t={self.t:.6g}"

    def coordinates(self):
        with np.errstate(all="ignore"):
            return self.stepper.output(self.system, self.t, self.state, self.dt)

    def base_settings(self):
        return {"integrator": self.stepper.describe(), "dtype": "float64",
                "stages": self.stages(), "threads": 1}


class ParticleSim(_SteppedSim):
    def __init__(self, scene, dt, stepper, variant, engine):
        self.variant, self.scene = variant, scene
        masses = scene.masses
        springs = list(scene.springs)
        rods, self.extra = None, {}
        if scene.joints and variant == "penalty":
            for j in scene.joints:
                g = np.linalg.norm(scene.gravity)
                w0 = np.sqrt(max(g, 1e-12) / j.length)
                k = masses[j.body] * (engine.penalty_ratio * w0) ** 2
                springs.append(_rod_spring(j, k))
            self.extra = {"penalty_stiffness": [s.stiffness for s in springs[-len(scene.joints):]],
                          "penalty_ratio": engine.penalty_ratio}
        elif scene.joints:
            lengths = np.array([j.length for j in scene.joints])
            g = np.linalg.norm(scene.gravity)
            w = engine.baumgarte_ratio * (np.sqrt(g / lengths.min()) if g > 0 else 1.0)
            rods = RodSet(body=np.array([j.body for j in scene.joints]),
                          anchor=np.array([j.anchor for j in scene.joints]),
                          length=lengths, baumgarte=w)
            self.extra = {"baumgarte_w": w, "baumgarte_w_dt": w * dt}
        spring_set = SpringSet.from_scene(springs) if springs else None
        system = ParticleSystem(masses, scene.gravity, scene.linear_drag, spring_set, rods)
        super().__init__(dt, stepper, system, scene.positions.reshape(-1),
                         scene.velocities.reshape(-1))

    def stages(self):
        stages = self.system.stages()
        if self.variant == "penalty":
            stages = [s if s != "springs" else "penalty_rods" for s in stages]
        return stages + [f"integrate:{self.stepper.name}"]

    def observe(self):
        x, v = self.coordinates()
        out = {"t": self.t, "x": x.reshape(-1, 3), "v": v.reshape(-1, 3)}
        if self.scene.joints:
            out["constraint"] = _rod_error(self.scene, out["x"])
        return out

    def settings(self):
        formulation = {"": "cartesian", "kkt": "maximal coordinates, Lagrange multipliers "
                       "(KKT by its Schur complement) + Baumgarte",
                       "penalty": "maximal coordinates, penalty spring rod"}[self.variant]
        out = {**self.base_settings(), "formulation": formulation, **self.extra}
        if self.variant == "kkt":
            # a symplectic stepper on the Baumgarte-stabilised index-1 ODE is not a symplectic
            # integrator of the constrained system (that would be RATTLE): declare it so
            out["integrator"] = {**out["integrator"], "symplectic": False,
                                 "note": "not symplectic on the index-1 KKT formulation"}
        return out


class HingeSim(_SteppedSim):
    def __init__(self, scene, dt, stepper):
        self.scene = scene
        frames = [hinge_frame(j.axis, scene.gravity) for j in scene.joints]
        self.d = np.array([f[0] for f in frames])
        self.s = np.array([f[1] for f in frames])
        g_plane = np.array([f[2] for f in frames])
        self.bodies = np.array([j.body for j in scene.joints])
        self.anchor = np.array([j.anchor for j in scene.joints])
        self.length = np.array([j.length for j in scene.joints])
        masses = scene.masses[self.bodies]
        x0, v0 = scene.positions[self.bodies], scene.velocities[self.bodies]
        theta0, omega0 = (np.array([cartesian_to_hinge(x0[i], v0[i], self.anchor[i],
                                                       self.length[i], self.d[i], self.s[i])[k]
                                    for i in range(len(self.bodies))]) for k in (0, 1))
        g_over_l, drag_over_m = g_plane / self.length, scene.linear_drag / masses
        self.scalar = len(self.bodies) == 1
        if self.scalar:  # one rod: plain-float state, no numpy overhead per operation
            theta0, omega0, g_over_l, drag_over_m = (float(a[0]) for a in
                                                     (theta0, omega0, g_over_l, drag_over_m))
        system = HingeSystem(g_over_l=g_over_l, drag_over_m=drag_over_m,
                             velocity_dependent=scene.linear_drag > 0)
        super().__init__(dt, stepper, system, theta0, omega0)

    def stages(self):
        stages = ["gravity"] if np.any(self.system.g_over_l) else []
        if self.system.velocity_dependent:
            stages.append("drag")
        return stages + ["hinge_generalized", f"integrate:{self.stepper.name}"]

    def observe(self):
        theta, omega = (np.atleast_1d(c) for c in self.coordinates())
        xb, vb = hinge_to_cartesian(theta, omega, self.anchor, self.length, self.d, self.s)
        x, v = self.scene.positions.copy(), self.scene.velocities.copy()
        x[self.bodies], v[self.bodies] = xb, vb
        return {"t": self.t, "x": x, "v": v, "constraint": np.zeros(len(self.bodies))}

    def settings(self):
        return {**self.base_settings(), "formulation": "generalized coordinate (hinge angle)"}


def _contact_support(scene, integrator):
    if integrator not in (None, "symplectic_euler"):
        return ("refsim contact scenes step with symplectic Euler plus impulses: the contact "
                "solver defines the step")
    if scene.springs or scene.joints or scene.linear_drag:
        return "refsim contact scenes: springs, rods and drag are not combined with contacts"
    if np.any(scene.radii <= 0):
        return "refsim contacts need spheres (radius > 0)"
    return None


def _rod_spring(joint, stiffness):
    from refsim.scene import Spring
    return Spring(body=joint.body, stiffness=stiffness, rest_length=joint.length,
                  anchor=joint.anchor)


def _rod_error(scene, x):
    return np.array([np.linalg.norm(x[j.body] - np.asarray(j.anchor)) - j.length
                     for j in scene.joints])
