"""Newton's cradle: a striker hits a row of four touching spheres at rest; what every correct
engine must keep is momentum and, at e = 1, kinetic energy.

No gravity, no strings: a striker at (-0.5, 0, 0) moving at +v into 4 touching spheres at rest
from x = 0.5 (five equal spheres, e = 1). Ideal outcome: the striker and the first three stop,
the last sphere leaves at v (pairwise impacts one after another). An engine that treats the
simultaneous contacts as one system departs (a rigid block of 4 m: -0.6 v, 0.4 v x 4; a spring
chain: the pulse spreads); err_* report that departure. Whichever way an engine resolves the
simultaneous contacts, elastic impulses conserve momentum and kinetic energy (Herrmann &
Seitz, "How does the ball-chain work?", Am. J. Phys. 50, 977 (1982)): the tolerance bounds
`conservation_err`, the larger of the momentum drift and the relative kinetic-energy change
after the impacts. Other observables and metrics: see `refsim_cases.spheres._impact`.
"""
from __future__ import annotations

import numpy as np

from refsim_cases.spheres._impact import SPHERE_PARAMS, SingleImpactCase, kinetic_energy
from refsim.case import Param
from refsim.engine import ContactInfo

SPHERES = 5


class NewtonsCradle(SingleImpactCase):
    name = "newtons_cradle"
    description = "Newton's cradle: a striker into four touching spheres; momentum and energy"
    tags = ("contacts", "rigid", "exact")
    # r = 1/8: centres 2r apart are exact in binary, so the resting spheres touch exactly
    # (with r = 0.1 round-off makes some pairs overlap by 6e-17 m and others gap)
    params = {**SPHERE_PARAMS, "radius": Param(0.125, 0.0, 10.0, "r (m)", low_inclusive=False)}
    variants = {"cradle": {}}
    quick_variants = ("cradle",)
    tolerance_norm = "conservation_err"

    def initial_state(self, p):
        x = np.zeros((SPHERES, 3))
        x[0, 0] = -0.5
        x[1:, 0] = 0.5 + 2 * p["radius"] * np.arange(SPHERES - 1)
        velocity = np.zeros((SPHERES, 3))
        velocity[0, 0] = p["speed"]
        return x, velocity, np.full(SPHERES, p["mass"]), np.zeros_like(x)

    def contact_time(self, p):
        return (1.0 - 2 * p["radius"]) / p["speed"]

    def outcome(self, p):
        """The ideal cradle's (velocities, angular velocities): the striker's velocity passes
        to the last sphere, the others rest."""
        x0, v0, m, w0 = self.initial_state(p)
        v1 = v0.copy()
        v1[0], v1[-1] = v0[-1], v0[0]
        return v1, w0.copy()

    def extra_metrics(self, p, obs, observed, reference):
        out = super().extra_metrics(p, obs, observed, reference)
        energy = kinetic_energy(self.initial_state(p)[2], p["radius"], obs)
        post = self.post_impact(p, obs["t"])
        change = float(np.max(np.abs(energy[post] - energy[0])) / energy[0])
        out["conservation_err"] = max(out["momentum_drift"], change)
        return out

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        contact = ContactInfo.of(settings)
        if contact.soft:
            residual = contact.restitution_residual
            return 8 * residual + 1e-8, (
                f"momentum and energy conserved up to the soft contact's restitution error: "
                f"4 impacts in turn, each carrying the whole energy, each with |e - 1| <= "
                f"{residual:.2g} (the engine's calibration residual), change it by at most "
                f"8 x that")
        return 1e-8, ("momentum and kinetic energy conserved (e = 1): any resolution of the "
                      "simultaneous contacts by elastic impulses keeps both; 1e-8 covers "
                      "iterative solvers' residuals")


CASE = NewtonsCradle()
