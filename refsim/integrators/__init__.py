"""Every time stepper of the course slides, each declaring its order and family.

One module per family: `tableaux` (Butcher tableaux as data) and `explicit_rk` (the one
stepper that runs them), `adaptive` (Dormand-Prince with error control), `symplectic`
(symplectic Euler, Stormer-Verlet, velocity Verlet, leapfrog), `implicit` (implicit Euler,
Baraff-Witkin). `base` holds the contract every stepper follows (read it before writing one)
and the configuration-update hook: a system may define `shift(x, dx)` (jax-md's `shift_fn`,
e.g. the exponential map of the unit quaternions) and every stepper then moves x through it.

`get_integrator(spec)` builds one by name: 'rk4', 'rk2:0.5' (alpha), 'dopri5_adaptive:1e-8'.
"""
from __future__ import annotations

from .adaptive import AdaptiveDormandPrince
from .base import Integrator, StepFailure, configuration_update
from .explicit_rk import ExplicitRK
from .implicit import BaraffWitkin, ImplicitEuler
from .implicit_midpoint import ImplicitMidpoint
from .spec import IntegratorSpec, spec_name
from .symplectic import (
    Leapfrog,
    StormerVerlet,
    SymplecticEulerDK,
    SymplecticEulerKD,
    VelocityVerlet,
)
from .tableaux import DOPRI5, EULER, HEUN, MIDPOINT, RK4, Tableau, rk2_tableau

__all__ = [
    "DOPRI5",
    "EULER",
    "HEUN",
    "INTEGRATORS",
    "MIDPOINT",
    "PARAMETRISED",
    "RK4",
    "AdaptiveDormandPrince",
    "BaraffWitkin",
    "ExplicitRK",
    "ImplicitEuler",
    "ImplicitMidpoint",
    "Integrator",
    "Leapfrog",
    "StepFailure",
    "StormerVerlet",
    "SymplecticEulerDK",
    "SymplecticEulerKD",
    "Tableau",
    "VelocityVerlet",
    "configuration_update",
    "get_integrator",
    "rk2_tableau",
]

_FACTORIES = {
    "explicit_euler": lambda: ExplicitRK("explicit_euler", EULER),
    "implicit_euler": ImplicitEuler,
    "symplectic_euler": SymplecticEulerKD,
    "symplectic_euler_dk": SymplecticEulerDK,
    "midpoint": lambda: ExplicitRK("midpoint", MIDPOINT),
    "heun": lambda: ExplicitRK("heun", HEUN),
    "rk2": lambda: ExplicitRK("rk2", rk2_tableau(2.0 / 3.0)),
    "rk4": lambda: ExplicitRK("rk4", RK4),
    "dopri5": lambda: ExplicitRK("dopri5", DOPRI5),
    "dopri5_adaptive": AdaptiveDormandPrince,
    "stormer_verlet": StormerVerlet,
    "velocity_verlet": VelocityVerlet,
    "leapfrog": Leapfrog,
    "baraff_witkin": BaraffWitkin,
    "implicit_midpoint": ImplicitMidpoint,
}
INTEGRATORS = tuple(_FACTORIES)
PARAMETRISED = {"rk2": "alpha in (0, 1], default 2/3 (Ralston)",
                "dopri5_adaptive": "rtol > 0, default 1e-9 (atol = rtol * 1e-3)"}


def get_integrator(spec: str) -> Integrator:
    """'rk4', 'rk2:0.5' (alpha), 'dopri5_adaptive:1e-8' (rtol)."""
    parsed = IntegratorSpec.parse(spec)
    name = parsed.name
    if name not in _FACTORIES:
        raise ValueError(f"integrator must be one of {list(_FACTORIES)}, got {spec!r}")
    if not parsed.arg:
        return _FACTORIES[name]()
    if name not in PARAMETRISED:
        raise ValueError(f"integrator {name!r} takes no parameter, got {spec!r}")
    value = parsed.number(PARAMETRISED[name])
    if name == "rk2":
        return ExplicitRK(f"rk2:{value:g}", rk2_tableau(value))
    return AdaptiveDormandPrince(rtol=value, atol=value * 1e-3)


STATIC_SOLVE = {"steady": {"name": "steady", "order": 0.0, "symplectic": False,
                           "implicit": True, "adaptive": False},
                # a query case's one answer of its batch (refsim.query): no time stepping
                "query": {"name": "query", "order": 0.0, "symplectic": False,
                          "implicit": False, "adaptive": False}}


def method_info(spec: str) -> dict | None:
    """The method an integrator spec names, as refsim defines it: {name, order, symplectic,
    implicit, adaptive}, or None for a name refsim does not define (an engine's own scheme,
    e.g. MuJoCo's implicitfast). Covers the second-order steppers (`get_integrator`), the
    sparse first-order theta methods of the grid models (crank_nicolson), the static solve
    ("steady", order 0: one complete solve to the solver's tolerance; "query", a query case's
    one answer of its batch) and the grid-fluid
    schemes ("sl_linear:rk2", refsim.integrators.semi_lagrangian) and particle-grid transfers
    ("apic_quadratic_bspline", refsim.models.grid_fluid.transfer.transfer_info)."""
    from refsim.models.grid_fluid.transfer import transfer_info

    from .semi_lagrangian import scheme_info
    from .sparse_linear import first_order_implicit
    name = spec_name(spec)
    if name in STATIC_SOLVE:
        return dict(STATIC_SOLVE[name])
    for info in (scheme_info(spec), transfer_info(spec)):
        if info is not None:
            return {k: info[k] for k in ("name", "order", "symplectic", "implicit", "adaptive")}
    try:
        method = get_integrator(spec)
    except ValueError:
        try:
            method = first_order_implicit(name)
        except ValueError:
            return None
    return {"name": method.name, "order": float(method.order),
            "symplectic": bool(method.symplectic), "implicit": not method.explicit,
            "adaptive": bool(getattr(method, "adaptive", False))}
