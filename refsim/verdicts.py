"""The two verdicts of a results row, named for the user's two questions.

*Reaches the target* (`reaches_target`): the row's error (the case's tolerance column) is
within the case's accuracy target, its declared "good enough" (`Case.target_error`, or the
user's `--target-error`). It says whether this configuration is accurate enough to use.

*Consistent with its method* (`consistency`): the row behaves as the method it names — rk4 as
RK4, velocity Verlet as velocity Verlet — at that dt. One of
- CONSISTENT: the error is within the bound a correct implementation of the named method
  must meet at this dt (`Case.tolerance` for the named method: its exact discrete solution
  where the case has one, else its error constant times the case's sensitivity, one safety
  factor <= 3, plus round-off), and the state at t = 0 is the reference's to the error floor;
  across the dt sweep the fitted order (where the case declares orders meaningful) is not
  below the method's nominal order by more than ORDER_SLACK (`runner.with_orders`); for a
  symplectic method on a scene whose exact flow conserves energy (`Case.energy_period`),
  the energy error stays bounded (`energy_reason`: read even where the bound is unresolved);
- INCONSISTENT: one of those fails; `consistency_reason` says which, with the numbers;
- UNRESOLVED: the method's bound at this dt is not below half the motion itself (an answer
  wrong by half the motion would meet it), or the case states none (an infinite bound: an
  experimental reference whose error is the model's at any dt): no verdict at this dt;
- NO_REFERENCE: the integrator is an engine's own scheme (MuJoCo's implicitfast, ...), not a
  method refsim defines: only the target question is answered.
The nominal order is always the named method's, never an engine's self-declared one (kept
apart as `declared_order`, shown beside the verdict).

Runs stored before these columns existed carry `within_tol` (and `unresolved`): their
bound came from the order the engine declared for itself. `upgrade_table` reads them as
`consistency` (within_tol True: consistent, False: inconsistent, unresolved: unresolved),
with `consistency_reason` saying they were judged by the old rule.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

CONSISTENT, INCONSISTENT = "consistent", "inconsistent"
UNRESOLVED, NO_REFERENCE = "unresolved", "no method reference"
CONSISTENCY = (CONSISTENT, INCONSISTENT, UNRESOLVED, NO_REFERENCE)
# a fitted order more than this below the named method's nominal order is inconsistent
# (the 0.2: a fit's standard error over a decade of clean points is ~0.02-0.05)
ORDER_SLACK = 0.2
# a bound at or above this fraction of the motion decides nothing: an engine off by half the
# motion (a wrong phase, a mode damped away) would meet it
UNRESOLVED_FRACTION = 0.5
OLD_RULE = ("stored before the two verdicts: within_tol read as the consistency verdict, its "
            "bound from the order the engine declared for itself")


def _truthy(value) -> bool:
    return value in (True, "True", "true", 1, "1") or (
        isinstance(value, (bool, np.bool_)) and bool(value))


def initial_check(err_initial: float, floor: float) -> str | None:
    """Why the state at t = 0 disqualifies the row (None when it does not): the engine must
    report the scene's own initial state, to the error floor."""
    if math.isfinite(err_initial) and err_initial > floor:
        return (f"the state at t = 0 is off by {err_initial:.3g} (error floor {floor:.3g}): "
                "the engine does not report the scene's initial state")
    return None


def judge(error: float, bound: float, why: str, scale: float, err_initial: float,
          floor: float) -> dict:
    """consistency, its reason and `tolerance` of one ok row whose integrator names a method
    with bound `bound` (reason `why`)."""
    if math.isinf(bound):  # the case states no bound on the method's error at all
        return {"tolerance": bound, "consistency": UNRESOLVED, "tol_reason": why,
                "consistency_reason": f"unresolved: {why}"}
    if not bound < UNRESOLVED_FRACTION * scale:
        return {"tolerance": bound, "consistency": UNRESOLVED,
                "tol_reason": f"{why}; that bound ({bound:.3g}) is not below half the motion "
                              f"({scale:.3g}): unresolved, no verdict at this dt",
                "consistency_reason": f"unresolved: the method's bound {bound:.3g} is not "
                                      f"below half the motion {scale:.3g}"}
    out = {"tolerance": bound, "tol_reason": why}
    initial = initial_check(err_initial, floor)
    if initial is not None:
        return {**out, "consistency": INCONSISTENT, "consistency_reason": initial}
    if not error <= bound:
        return {**out, "consistency": INCONSISTENT,
                "consistency_reason": f"error {error:.3g} above the method's bound "
                                      f"{bound:.3g} ({error / bound:.3g}x)"}
    return {**out, "consistency": CONSISTENT, "consistency_reason": ""}


def order_reason(fitted: float, stderr: float, dt_lo: float, dt_hi: float,
                 nominal: float) -> str | None:
    """Why a fitted order disqualifies its rows (None when it does not)."""
    if math.isfinite(fitted) and math.isfinite(nominal) and fitted < nominal - ORDER_SLACK:
        return (f"fitted order {fitted:.2f} +- {stderr:.2f} over dt {dt_lo:.3g}..{dt_hi:.3g} "
                f"s, below the method's order {nominal:g}")
    return None


def declared_reason(declared: float, nominal: float) -> str | None:
    """An engine that declares a lower order than the method it names says itself that it is
    not that method (None when it does not)."""
    if math.isfinite(declared) and math.isfinite(nominal) and declared < nominal - ORDER_SLACK:
        return (f"the engine declares order {declared:g} for it, the method's order is "
                f"{nominal:g}")
    return None


# a symplectic method's energy error on a conservative scene stays bounded: its largest value
# over the run's last quarter may exceed the first quarter's by at most this factor (each
# quarter spans at least one period of the oscillating energy error, whose maxima then agree
# up to the sampling of ~400 observations, <1 %; a steady drift D over the run gives 4, so
# any drift above twice the oscillation's amplitude is caught)
ENERGY_GROWTH = 2.0
# round-off: one rounding of the state per step moves the energy by a few eps of its scale
ENERGY_ROUNDOFF_EPS = 8.0
# observations per period needed to read the maxima (20: the sampled maximum of the energy
# error, which oscillates at up to twice the motion's frequency, is within cos(pi / 10) = 95 %
# of the true one; 4 per period, as 400 samples of a 100-period run, alias)
ENERGY_SAMPLES = 20


def energy_reason(t, energy, e_scale: float, period: float, steps: int) -> str | None:
    """Why the energy's behaviour disqualifies a row of a symplectic method on a scene whose
    exact flow conserves energy (`Case.energy_period`), None when it does not or cannot be
    judged (a quarter of the run shorter than the period P, or fewer than ENERGY_SAMPLES
    observations per period): the energy error's largest value over the last quarter of the
    run is above ENERGY_GROWTH times the first quarter's plus round-off (ENERGY_ROUNDOFF_EPS eps per step of the energy scale). A bounded
    oscillation passes whatever its size; hidden damping or a non-symplectic stepper drifts."""
    t, energy = np.asarray(t, float), np.asarray(energy, float)
    span = t[-1] - t[0]
    if not (len(t) > 8 and period > 0 and span / 4 >= period and np.isfinite(energy).all()
            and np.max(np.diff(t)) <= period / ENERGY_SAMPLES):
        return None
    err = np.abs(energy - energy[0])
    first = float(err[t <= t[0] + span / 4].max())
    last = float(err[t >= t[-1] - span / 4].max())
    roundoff = ENERGY_ROUNDOFF_EPS * np.finfo(float).eps * steps * e_scale
    if last > ENERGY_GROWTH * first + roundoff:
        return (f"energy error grew from {first:.3g} (first quarter of the run) to {last:.3g} "
                f"(last quarter): a symplectic method's energy error stays bounded on this "
                f"conservative scene (period {period:.3g} s)")
    return None


def reaches(error: float, target: float) -> bool:
    return bool(math.isfinite(error) and math.isfinite(target) and error <= target)


def upgrade_table(table: pd.DataFrame) -> pd.DataFrame:
    """A stored table with the two verdict columns (old runs: see the module docstring)."""
    if "consistency" in table or "within_tol" not in table:
        return table
    table = table.copy()
    unresolved = (table["unresolved"].map(_truthy) if "unresolved" in table
                  else pd.Series(False, index=table.index))
    within = table["within_tol"].map(_truthy)
    ok = table["status"] == "ok"
    table["consistency"] = np.where(~ok, "", np.where(unresolved, UNRESOLVED, np.where(
        within, CONSISTENT, INCONSISTENT)))
    table["consistency_reason"] = np.where(ok, OLD_RULE, "")
    return table
