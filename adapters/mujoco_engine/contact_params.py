"""Sphere contact parameters (mujoco 4.0.0): stiffness, impedance per formulation, solver, friction.

Contacts are MuJoCo's soft contacts in the direct form solref = (-K, -B) with a flat impedance
d (solimp dmin = dmax); see `spheres` for the model and `restitution` for how B is found."""
from __future__ import annotations

import math

CONTACT_STEPS = 10  # an undamped contact lasts this many steps: K = (pi / (N dt))^2. Shorter
# contacts spread e over the contact phase (+-8.7 % at 3 steps, +-0.2 % at 10: cubic in 1/N);
# longer ones turn the normal of an oblique impact during the contact (4.6 % of v at 10 steps
# of 1 ms, linear in N dt): 10 steps balances the two (MuJoCo's own default is solref
# timeconst 0.02 s at its 0.002 s step, also 10 steps)

# Flat impedance d (solimp dmin = dmax) per engine variant. An isolated contact is the same
# at any d; simultaneous contacts and resting ones are not: the solver returns
# f = (A + R)^-1 (aref - a0), R = (1 - d)/d diag(A), aref = -(B vel + K pos)/d.
IMPEDANCE = {
    # d = mjMINIMP: R = 1e4 A dominates, f_k = -(K pos_k + B vel_k) / A_kk to 1e-4: a linear
    # spring-dashpot per contact with the pair's reduced mass (the DEM soft-sphere model).
    # Measured: the cradle keeps its energy (+1 %), a ball rests on a floor at g/K overlap
    "": 1e-4,
    # d = mjMAXIMP: R = 1e-4 A, all contacts solved as one coupled system, each one's relative
    # acceleration held at -K pos - B vel while (1 - d) of the external acceleration passes:
    # resting contacts transmit force at once (the cradle's chain acts as one block, +13 %
    # energy) and a ball on a floor under gravity chatters (overlap (1-d) g/K << g dt^2)
    "coupled": 0.9999,
}
VARIANT_NOTES = {
    "": "solimp flat at d = 1e-4 (mjMINIMP): R = 1e4 A dominates the solve, so each contact "
        "force is mu_k (K pos + B vel), mu_k the pair's reduced mass (1/A_kk), independent of "
        "the other contacts to 1e-4: the linear spring-dashpot (DEM) model",
    "coupled": "solimp flat at d = 0.9999 (mjMAXIMP): the contacts are solved as one coupled "
               "system, each contact's relative normal acceleration held at -K pos - B vel; "
               "resting contacts transmit force at once (a chain acts as a near-rigid block); "
               "isolated impacts are identical to the default variant",
}

SOLVER_TOLERANCE = 1e-10  # Newton solver (MuJoCo default 1e-8)
SOLVER_ITERATIONS = 100  # MuJoCo default; a lone contact converges in 1-2 Newton iterations
MAX_FRICTION_SPHERES = 200  # frictional scenes list every pair explicitly (O(n^2) pairs)


def contact_stiffness(dt: float) -> float:
    """K (1/s^2, relative normal acceleration per metre of overlap): an undamped contact is
    half a period of w = sqrt(K), i.e. CONTACT_STEPS steps."""
    return (math.pi / (CONTACT_STEPS * dt)) ** 2


def friction_damping(dt: float) -> float:
    """Bf (1/s) of the friction rows (solreffriction, direct form): critical damping at the
    contact frequency, 2 sqrt(K), as MuJoCo's default dampratio 1 gives its friction rows."""
    return 2.0 * math.sqrt(contact_stiffness(dt))
