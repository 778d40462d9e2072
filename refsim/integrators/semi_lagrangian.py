"""The grid-fluid time-stepping schemes by name (issue 27; the physics is
refsim.models.grid_fluid): "sl_<interpolant>[:<backtrace>]", a semi-Lagrangian advection whose
characteristic is traced back by an explicit Runge-Kutta `backtrace` and whose departure value
is read by `interpolant`, followed by body force, viscosity and a pressure projection
(operator splitting).

Orders, stated once here and read by every engine and case:
- in dt: 1 for every scheme (`SPLITTING_ORDER`): the advection, viscous and pressure substeps
  do not commute (Chorin's projection method);
- the backtrace along a characteristic: euler 1, rk2 (explicit midpoint) 2, rk3 (Ralston's
  third-order tableau) 3 (`BACKTRACES`);
- the interpolant in h, max norm on smooth data: linear (bilinear) 2, cubic (Catmull-Rom) 3,
  cubic_clamped 2 (the clamp cuts a smooth extremum's h^2 bulge) (`INTERPOLANTS`); over a unit
  time the interpolation error is O(h^order / dt): SL has no convergence order in dt at a
  fixed h.
"""
from __future__ import annotations

from .spec import IntegratorSpec

BACKTRACES = {"euler": 1, "rk2": 2, "rk3": 3}
INTERPOLANTS = {"linear": 2, "cubic": 3, "cubic_clamped": 2}
SCHEMES = tuple(f"sl_{name}" for name in INTERPOLANTS)
DEFAULT_BACKTRACE = "rk2"
SPLITTING_ORDER = 1


def parse_scheme(spec) -> tuple[str, str]:
    """'sl_linear:rk3' -> ('linear', 'rk3'); the backtrace defaults to rk2."""
    parsed = IntegratorSpec.parse(spec)
    if parsed.name not in SCHEMES:
        raise ValueError(f"grid-fluid scheme must be one of {list(SCHEMES)} (optionally "
                         f":euler, :rk2 or :rk3), got {spec!r}")
    backtrace = parsed.arg or DEFAULT_BACKTRACE
    if (parsed.colon and not parsed.arg) or backtrace not in BACKTRACES:
        raise ValueError(f"grid-fluid scheme {parsed.name!r} backtrace must be one of "
                         f"{list(BACKTRACES)}, got {spec!r}")
    return parsed.name[3:], backtrace


def scheme_info(spec) -> dict | None:
    """{name, order (in dt: the splitting's), symplectic, implicit, adaptive, family,
    backtrace_order, interpolant_order_h} of a scheme spec; None for another name."""
    try:
        interpolant, backtrace = parse_scheme(spec)
    except ValueError:
        return None
    return {"name": f"sl_{interpolant}:{backtrace}", "order": float(SPLITTING_ORDER),
            "symplectic": False, "implicit": False, "adaptive": False,
            "family": "semi-Lagrangian projection (operator splitting)",
            "backtrace_order": BACKTRACES[backtrace],
            "interpolant_order_h": INTERPOLANTS[interpolant]}
