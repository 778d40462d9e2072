"""`refsim stress` as an ordinary stored run (refsim.store.figures): results rows and case
definitions beside stress_limits.csv and stress_sweep.csv, so `report` and `compare` read it.

Rows (case: the probe case's name, engine_variant "", KEY unique):
- variant "stability_limit", one per (engine, integrator) searched, dt nan (the limit is a
  y, not a step): err_max = |measured - theory| in y = omega dt (0 when both are unbounded,
  inf when one is, nan where no theory is known); tolerance = the agreement bound `agrees`
  uses, resolution + bisection tolerance x max(1, theory) (0 for an unbounded theory: both must
  be unbounded; nan where no theory is known), tol_reason saying so; consistency: the
  measured limit agrees with the method's theory (consistent) or not (inconsistent), "no
  method reference" where no theory is known;
  status ok, or failed with the search's error. Extra columns: measured, theory, finite_time,
  resolution, as, evals, batched, search_s, note.
- variant "k=1e4" (one per stiffness of the sweep, `sweep_variant`), one per (engine,
  integrator), dt the sweep step: status ok when the failure label is "none", failed for
  "error" (the run raised), else diverged with the label as reason; energy_drift =
  |E_end / E0 - 1| (the last finite energy ratio, not a maximum over the run); no tolerance.
  Extra columns: k, y, failure, at_step, energy_ratio, detail.
`params` holds what the figure depends on beyond KEY (the spring's overrides and the search or
sweep settings), so compare refuses rows measured under another criterion.
"""
from __future__ import annotations

import json
import math

import pandas as pd

from refsim.store.figures import base_row, definition, store_rows
from refsim.stress.report import _power
from refsim.stress.search import Y_MAX

LIMIT_VARIANT = "stability_limit"
UNITS = "y = omega dt"  # the probe case's; another case's spec names its own


def probe_overrides(opts) -> dict:
    """The case parameters the search overrides (the spec's params), {} without a probe."""
    probe = opts.get("probe")
    return dict(probe.overrides) if probe is not None else {}


def units(opts) -> str:
    probe = opts.get("probe")
    return UNITS if probe is None or probe.spec.name == "omega dt" else f"y = {probe.spec.name}"
SWEEP_NO_TOLERANCE = "no tolerance: the failure label (column failure) is the result"


def sweep_variant(k: float) -> str:
    """The sweep row's variant: "k=1e4" for powers of ten, else k to 12 digits."""
    power = _power(k)
    return f"k={power if power.startswith('1e') else format(k, '.12g')}"


def limit_params(opts) -> str:
    return json.dumps({**probe_overrides(opts), "periods": opts["criterion"].periods,
                       "bisection_tol": opts["tol"]})


def sweep_params(opts, k: float) -> str:
    return json.dumps({**probe_overrides(opts), "stiffness": float(k), "span_s": opts["span"]})


# --------------------------------------------------------------------------------------------
# Rows
# --------------------------------------------------------------------------------------------
def limit_error(measured: float, th: float) -> float:
    """|measured - theory| in y; 0 when both are unbounded, nan where no theory is known."""
    if math.isnan(th) or math.isnan(measured):
        return math.nan
    if math.isinf(th) or math.isinf(measured):
        return 0.0 if measured == th else math.inf
    return abs(measured - th)


def limit_tolerance(th: float, res: float, tol: float) -> tuple[float, str]:
    """The bound stress.agrees applies, with its reason."""
    if math.isnan(th):
        return math.nan, "no tolerance: no theory for this integrator (no refsim equivalent " \
                         "with a known family or tableau)"
    if math.isinf(th):
        return 0.0, f"theory unbounded: agrees only when the search is stable to Y_MAX = " \
                    f"{Y_MAX:g} too"
    return res + tol * max(1.0, th), (
        f"finite-time resolution {res:.2e} (|finite_time - theory| + overshoot allowance, "
        f"from the method's exact step map) + bisection tolerance {tol:g} x max(1, theory)")


def stored_limit_row(limit: dict, opts, case: str, run_id: str, versions: dict) -> dict:
    measured, th = float(limit.get("measured", math.nan)), float(limit["theory"])
    tolerance, why = limit_tolerance(th, float(limit["resolution"]), opts["tol"])
    row = base_row(run_id, case, LIMIT_VARIANT, limit["engine"], limit["integrator"],
                   engine_variant=str(limit.get("engine_variant", "") or ""),
                   params=limit_params(opts))
    note = str(limit.get("note", ""))
    failed = note.startswith("error: ")
    row.update(engine_version=versions.get(limit["engine"], ""),
               status="failed" if failed else "ok", reason=note[7:] if failed else "",
               err_max=limit_error(measured, th), tolerance=tolerance, tol_reason=why,
               consistency=("" if failed else "no method reference" if math.isnan(th) else
                            "consistent" if str(limit.get("agrees")) == "True"
                            else "inconsistent"),
               measured=measured, theory=th,
               finite_time=float(limit["finite_time"]),
               resolution=float(limit["resolution"]), note=note,
               search_s=float(limit.get("seconds", math.nan)),
               **{c: limit[c] for c in ("as", "evals", "batched", "theory_reason")
                  if c in limit})
    return row


def sweep_status(failure: str, detail: str, at_step) -> tuple[str, str]:
    if failure == "none":
        return "ok", ""
    if failure == "error":
        return "failed", detail
    where = f" at step {int(at_step)}" if at_step is not None and not pd.isna(at_step) else ""
    return "diverged", f"{failure}{where}" + (f": {detail}" if detail else "")


def stored_sweep_row(run: dict, opts, case: str, run_id: str, versions: dict) -> dict:
    k, dt = float(run["k"]), float(run["dt"])
    row = base_row(run_id, case, sweep_variant(k), run["engine"], run["integrator"], dt,
                   params=sweep_params(opts, k))
    at_step = None if pd.isna(run.get("at_step")) else int(run["at_step"])
    status, reason = sweep_status(run["failure"], str(run.get("detail", "")), at_step)
    ratio = float(run["energy_ratio"])
    row.update(engine_version=versions.get(run["engine"], ""), status=status, reason=reason,
               steps=int(run["steps"]), t_end=int(run["steps"]) * dt,
               energy_drift=abs(ratio - 1.0), tol_reason=SWEEP_NO_TOLERANCE, k=k,
               y=float(run["y"]), failure=run["failure"], at_step=at_step,
               energy_ratio=ratio, detail=str(run.get("detail", "")))
    return row


# --------------------------------------------------------------------------------------------
# Definitions
# --------------------------------------------------------------------------------------------
def limit_definition(opts, spring) -> dict:
    crit, spec = opts["criterion"], spring.spec
    overrides = ", ".join(f"{k} = {v}" for k, v in spring.overrides.items())
    return definition(
        spring.case.name, LIMIT_VARIANT,
        f"largest stable y = {spec.name} of each fixed-step integrator on {spring.case.name} "
        f"({overrides or 'default parameters'}), by bisection, against the theory: "
        f"{spec.source}; {crit.text()}",
        "|measured - theory| of the largest stable y", units(opts), spring.case.source_hash(),
        limit_params(opts), params={**spring.p, "periods": crit.periods,
                                    "bisection_tol": opts["tol"]},
        report_columns=["measured", "theory", "finite_time", "note"],
        figures=[{"kind": "stability_limits", "x_label": f"largest stable {units(opts)}",
                  "title": "largest stable step, measured against theory"}])


def sweep_definition(opts, spring, k: float) -> dict:
    from refsim.stress import sweep as stress  # the sweep's constants
    return definition(
        spring.case.name, sweep_variant(k),
        f"stiffness sweep at k = {k:g} N/m (m = {spring.p['mass']:g} kg, y = sqrt(k) dt), "
        f"dt = {opts['dt']:g} s, a run of min({stress.SWEEP_PERIODS} periods, "
        f"{opts['span']:g} s) observed every step: status ok when no failure is found, else "
        f"diverged (failed when the run raised) with the failure label as reason: "
        + "; ".join(f"{name}: {text}" for name, text in stress.LEGEND.items()),
        "", UNITS, spring.case.source_hash(), sweep_params(opts, k),
        params={**spring.p, "stiffness": float(k), "span_s": opts["span"]},
        report_columns=["y", "failure", "at_step", "energy_ratio"])


def store_run(st, opts, spring, limits: pd.DataFrame, sweep: pd.DataFrame) -> None:
    """The limits and the sweep as results rows with their definitions in run `st`."""
    run_id, versions, case = st.manifest["run_id"], st.manifest["engines"], spring.case.name
    rows = [stored_limit_row(r, opts, case, run_id, versions) for r in limits.to_dict("records")]
    rows += [stored_sweep_row(r, opts, case, run_id, versions) for r in sweep.to_dict("records")]
    definitions = [limit_definition(opts, spring)] if len(limits) else []
    ks = list(dict.fromkeys(sweep["k"])) if len(sweep) else []
    definitions += [sweep_definition(opts, spring, k) for k in ks]
    store_rows(st, rows, definitions)
