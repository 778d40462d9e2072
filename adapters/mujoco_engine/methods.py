"""The MuJoCo integrators as refsim declares them (mujoco 4.0.0)."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Method:
    """One MuJoCo integrator as refsim declares it."""

    native: str  # mjtIntegrator member
    xml: str  # MJCF option value
    order: int
    family: str
    explicit: bool
    symplectic: bool
    note: str


METHODS = {
    "symplectic_euler": Method(
        "mjINT_EULER", "Euler", 1, "symplectic Euler", True, True,
        "semi-implicit Euler, kick then drift (v += h a(x, v); q += h v); eulerdamp disabled, "
        "so joint damping is explicit too"),
    "rk4": Method(
        "mjINT_RK4", "RK4", 4, "explicit Runge-Kutta", True, False,
        "classical 4-stage Runge-Kutta on (q, v)"),
    "implicit": Method(
        "mjINT_IMPLICIT", "implicit", 1, "implicit-in-velocity Euler", False, False,
        "(M + h D) dv = h (f - ...): damping and Coriolis derivatives implicit, stiffness "
        "explicit, so an undamped spring keeps Euler's omega dt < 2 limit; with nothing damped "
        "it is the symplectic_euler step"),
    "implicitfast": Method(
        "mjINT_IMPLICITFAST", "implicitfast", 1, "implicit-in-velocity Euler (no RNE "
        "derivatives)", False, False,
        "as implicit without the Coriolis/centripetal derivatives; here it equals MuJoCo's "
        "default Euler (eulerdamp on): damping implicit, springs explicit"),
    "discrete": Method(
        "mjINT_DISCRETE", "discrete", 1, "linearised backward Euler (heavily damping)", False,
        False,
        "step solved in M + h D + h^2 K: joint stiffness and damping implicit, so springs are "
        "stable at any dt but lose energy by 1/(1 + (omega dt)^2) per step (backward Euler); "
        "gravity stays explicit. Unconditionally stable, misleading as an accuracy figure"),
}

# with contacts: discrete (backward Euler on the contact spring) dissipates and is refused
CONTACT_METHODS = ("symplectic_euler", "implicit", "implicitfast", "rk4")
