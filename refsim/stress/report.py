"""What `refsim stress` writes and prints: the limits against theory, the stiffness sweep's
failure taxonomy, and their CSV files."""
from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from refsim.store import results as store
from refsim.integrators import get_integrator
from refsim.stress.search import Criterion, finite_time, theory

# --------------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------------
def atomic_csv(path: Path, table: pd.DataFrame) -> None:
    store.atomic_write(path, table.to_csv(index=False, na_rep="nan"))


def f_reason(crit: Criterion) -> str:
    rk4 = get_integrator("rk4")
    ft, _ = finite_time(rk4, theory(rk4), crit)
    return (f"F = {crit.factor:g} because from rest symplectic Euler's bounded energy peaks at "
            f"E0 / (1 - y/2), which puts its finite-time limit at 2 - 2/F = "
            f"{2 - 2 / crit.factor:g}, while P = {crit.periods} periods give geometric growth "
            f"past a limit time to reach F E0 (RK4 by y = {ft:.6f}, 2 sqrt 2 + "
            f"{ft - 2 * math.sqrt(2):.1e}; dopri5's |R(iy)|^2 - 1 ~ 1e-3 (y - 0.99719) is too "
            "slow for any affordable P, so its row is criterion-limited).")


def print_report(opts, spring, limits, sweep) -> None:
    from refsim.stress import sweep as stress  # the sweep's constants
    crit = opts["criterion"]
    if not opts.get("sweep", True):
        print_case_report(opts, spring, limits)
        return
    print(f"Stability limits, y = omega dt. Criterion: {crit.text()}; "
          f"k = {spring.p['stiffness']:g} N/m, m = {spring.p['mass']:g} kg, rest length "
          f"{spring.p['rest_length']:g} m, A = {spring.p['amplitude']:g} m (the case's 0.1 m "
          "lowered so that the mass never reaches the anchor: the spring stays linear at every "
          "y searched).")
    print(f_reason(crit))
    print(f"Bisection tolerance {opts['tol']:g} x max(1, y); agrees: |measured - theory| <= "
          "resolution (finite-time, from the exact step map) + that tolerance.")
    if len(limits):
        print(limits_text(limits))
    print(f"\nStiffness sweep: dt = {opts['dt']:g} s, m = 1 kg, y = sqrt(k) dt, runs of "
          f"min({stress.SWEEP_PERIODS} periods, {opts['span']:g} s), every step observed. "
          "Legend:")
    for name, text in stress.LEGEND.items():
        print(f"  {name}: {text}")
    if len(sweep):
        print(sweep_pivot(sweep).to_string())


def print_case_report(opts, probe, limits) -> None:
    """The limits of a case other than the probe case (no stiffness sweep)."""
    spec, crit = probe.spec, opts["criterion"]
    overrides = ", ".join(f"{k} = {v}" for k, v in probe.overrides.items())
    print(f"Stability limits of {probe.case.name} ({overrides or 'default parameters'}), "
          f"y = {spec.name}, dt = y x {spec.dt_unit:.6g} s. Criterion: {crit.text()}.")
    print(f"Theory: {spec.source}.")
    if spec.resolution_reason:
        print(f"Resolution: {spec.resolution_reason}.")
    print(f"Bisection tolerance {opts['tol']:g} x max(1, y); agrees: |measured - theory| <= "
          "resolution + that tolerance.")
    if len(limits):
        shown = limits.drop(columns=[c for c in ("theory_reason",) if c in limits])
        print(limits_text(shown))
        reasons = dict.fromkeys(limits.get("theory_reason", pd.Series(dtype=str)).dropna())
        for reason in reasons:
            print(f"  theory: {reason}")


def sweep_pivot(sweep: pd.DataFrame) -> pd.DataFrame:
    """failure by (engine, integrator) x k, "-" for none."""
    labels = [f"k={_power(k)} y={y:.3g}" for k, y in zip(sweep.k, sweep.y)]
    table = sweep.assign(col=labels, label=sweep.failure.replace("none", "-"))
    pivot = table.pivot_table(index=["engine", "integrator"], columns="col", values="label",
                              aggfunc="first", sort=False)[list(dict.fromkeys(labels))]
    pivot.columns.name = None
    return pivot


def _power(k: float) -> str:
    exponent = round(math.log10(k))
    return f"1e{exponent}" if k == 10.0 ** exponent else f"{k:.2g}"


FORMATS = {"measured": "{:.7g}", "theory": "{:.7g}", "finite_time": "{:.7g}",
           "resolution": "{:.2e}", "seconds": "{:.1f}"}


def limits_text(limits: pd.DataFrame) -> str:
    formatters = {c: f.format for c, f in FORMATS.items() if c in limits}
    return limits.to_string(index=False, formatters=formatters)
