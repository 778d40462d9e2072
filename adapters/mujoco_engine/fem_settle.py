"""The settle of the fem group's "steady" (MuJoCo has no static solve): damped dynamics from the
initial state to the equilibrium, by MuJoCo's Euler (kick then drift) with mass-proportional
damping -alpha m v on every free dof (a damping tendon per slide) and no Rayleigh damping.

Parameters, from the free dofs' stiffness K of refsim's assembly of the same StVK law and the
lumped masses M (used only to choose them): omega_min the lowest angular frequency of M^-1 K
at rest, omega_max the highest at rest or at the initial positions, whichever is higher (an
imposed boundary field strains the elements next to it most at the start: at 16 x 16 cells
the patch test's start has 5.7 x the rest's omega_max^2); alpha = 2 omega_min, so the
slowest mode is critically damped and every faster one decays at the same rate alpha / 2 =
omega_min (its damping ratio omega_min / omega < 1); timestep h the root of
(h omega_max)^2 + 2 h alpha = LIMIT_FRACTION x 4 (Euler with an explicit damping force is
stable for (h omega)^2 + 2 h alpha < 4 and h alpha < 2, from the trace and determinant of its
step matrix), so h omega_max <= sqrt(2) and a mode may stiffen by a factor of 2 in omega^2
before the step goes unstable.

Stop rule, checked every `check_every` steps (a quarter of the slowest mode's e-folding time)
on MuJoCo's own forces after its forward pass: the residual r = elastic + external force
(qfrc_spring + loads + gravity, i.e. qfrc_smooth - qfrc_damper) on the free dofs and the
damping force alpha m v (qfrc_damper) both at most max(RTOL x the force scale, the forces'
rounding); the force scale the larger of the external forces and the elastic forces on the
free dofs (reactions at pinned nodes are not dofs in MuJoCo, so not counted: a stricter stop
than refsim's Newton), the rounding ROUNDING_TERMS eps lambda_max(K) max|x| as in the static
cases' bound. Or, whichever first, after MAX_EFOLDS e-folding times of the slowest mode
(stopped "at the cap": the state is judged as it is).
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from refsim.models.fem.assembly import Assembler
from refsim.models.fem.model import ElasticBody

RTOL = 1e-12  # of the force scale: the in-house static solve's stop (newton_rtol)
ROUNDING_TERMS = 64  # products summed into one nodal force (the static cases' bound's count)
LIMIT_FRACTION = 0.5  # of Euler's damped stability limit (module docstring)
MAX_EFOLDS = 120.0  # cap: e^-120 = 8e-53 of the slowest mode's start, far below round-off
CHECKS_PER_EFOLD = 4
DENSE_MAX = 1500  # free dofs up to which the eigenvalues are found densely
EPS = float(np.finfo(float).eps)


def _extremes(k: sp.spmatrix) -> tuple[float, float]:
    if k.shape[0] <= DENSE_MAX:
        eig = np.linalg.eigvalsh(k.toarray())
        return float(eig[0]), float(eig[-1])
    from scipy.sparse.linalg import eigsh
    top = eigsh(k, k=1, which="LA", return_eigenvectors=False)[0]
    low = eigsh(k.tocsc(), k=1, sigma=0.0, which="LM", return_eigenvectors=False)[0]
    return float(low), float(top)


class SettlePlan:
    def __init__(self, omega_min, omega_max, lambda_max):
        self.omega_min, self.omega_max, self.lambda_max = omega_min, omega_max, lambda_max
        self.alpha = 2.0 * omega_min
        w2, limit = omega_max * omega_max, 4.0 * LIMIT_FRACTION
        self.timestep = (math.sqrt(self.alpha ** 2 + limit * w2) - self.alpha) / w2
        efold = 1.0 / (omega_min * self.timestep)  # steps per e-folding time
        self.check_every = max(1, int(efold / CHECKS_PER_EFOLD))
        self.max_steps = int(math.ceil(MAX_EFOLDS * efold))

    def describe(self) -> dict:
        return {
            "method": "damped dynamics to equilibrium: MuJoCo Euler (kick then drift, "
                      "eulerdamp disabled) from the initial positions at rest",
            "damping": "mass-proportional -alpha m v per free dof (a fixed tendon per slide, "
                       "damping alpha m; MuJoCo takes no joint damping on flex vertex "
                       "bodies); Rayleigh (flex elasticity damping) 0",
            "alpha_per_s": self.alpha, "timestep_s": self.timestep,
            "omega_min_per_s": self.omega_min, "omega_max_per_s": self.omega_max,
            "lambda_max_N_per_m": self.lambda_max,
            "choice": "from refsim's StVK stiffness on the free dofs and the lumped masses "
                      "(omega_min at rest, omega_max the higher of rest and the initial "
                      "positions): alpha = 2 omega_min (slowest mode critically damped, "
                      "every mode decays at rate >= omega_min), h from (h omega_max)^2 + 2 h "
                      f"alpha = {LIMIT_FRACTION:g} x 4 (Euler's damped limit 4)",
            "stop": f"max |residual| and max |alpha m v| on the free dofs <= max({RTOL:g} x "
                    f"force scale, {ROUNDING_TERMS} eps lambda_max max|x|), checked every "
                    f"{self.check_every} steps on MuJoCo's forces (qfrc_smooth - "
                    "qfrc_damper, qfrc_damper); force scale the larger of the external and "
                    "the elastic forces on the free dofs (no reactions); or at the cap",
            "settle_rtol": RTOL, "check_every": self.check_every,
            "max_steps": self.max_steps,
            "cap": f"{MAX_EFOLDS:g} e-folding times of the slowest mode "
                   f"({self.max_steps} steps, {self.max_steps * self.timestep:.4g} s)",
        }


def settle_plan(layout) -> SettlePlan:
    """The settle's parameters for the mesh of `layout` (module docstring)."""
    mesh = layout.mesh
    body = ElasticBody.of(mesh)
    assembler = Assembler(body)
    free = np.repeat(layout.free, body.d)
    scale = sp.diags(1.0 / np.sqrt(np.repeat(layout.masses[layout.free], body.d)))

    def stiffness(x):
        return assembler.stiffness(x).tocsr()[free][:, free]

    k = stiffness(body.elements.rest)
    w2_min, w2_max = _extremes(scale @ k @ scale)
    _, lambda_max = _extremes(k)
    start = body.to_local(mesh.positions)
    if not np.array_equal(start, body.elements.rest):  # an imposed field strains it at start
        w2_max = max(w2_max, _extremes(scale @ stiffness(start) @ scale)[1])
    return SettlePlan(math.sqrt(w2_min), math.sqrt(w2_max), lambda_max)


class Settle:
    """One settle of a MujocoFemSettle sim from its current state."""

    def __init__(self, sim, plan: SettlePlan):
        self.sim, self.plan = sim, plan
        self.steps, self.residual, self.stopped = 0, float("nan"), ""

    def forces(self) -> tuple[float, float, float]:
        """(max |residual|, max |damping force|, stop threshold) on the free dofs, N."""
        sim = self.sim
        m, d = sim.model, sim.data
        sim.mj.mj_forward(m, d)  # flexvert_xpos: every node's position now, pinned included
        spring, damper = d.qfrc_spring, d.qfrc_damper
        residual = d.qfrc_smooth - damper
        scale = max(np.abs(residual - spring).max(), np.abs(spring).max())  # external, elastic
        rounding = ROUNDING_TERMS * EPS * self.plan.lambda_max * np.abs(d.flexvert_xpos).max()
        return (float(np.abs(residual).max()), float(np.abs(damper).max()),
                max(RTOL * scale, rounding))

    def run(self) -> None:
        from .sim import MujocoSim
        plan, sim = self.plan, self.sim
        while True:
            residual, damping, threshold = self.forces()
            self.residual = residual
            if residual <= threshold and damping <= threshold:
                self.stopped = f"residual {residual:.3g} N and damping force {damping:.3g} N " \
                               f"<= {threshold:.3g} N"
                return
            if self.steps >= plan.max_steps:
                self.stopped = f"at the cap ({plan.max_steps} steps): residual " \
                               f"{residual:.3g} N, damping force {damping:.3g} N, " \
                               f"threshold {threshold:.3g} N"
                return
            n = min(plan.check_every, plan.max_steps - self.steps)
            MujocoSim._step_impl(sim, n)
            self.steps += n
            if sim.failure:
                return

    def result(self) -> tuple[float, int, str]:
        return self.residual, self.steps, self.stopped
