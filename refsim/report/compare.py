"""`refsim compare RUN_A RUN_B`: row-by-row error and time ratios between two stored runs.

A is the baseline, B the candidate. Rows are matched on the store's KEY (case, variant, engine,
engine_variant, integrator, dt). The rules:

Refused (listed with the reason, never compared):
  - the case's source hash differs between the two manifests, or either manifest lacks it;
  - the two rows ran the case with different parameters (`params`).
Regression (B worse than A), judged only where the row is `ok` in A:
  1. status: `ok` in A, anything else in B (diverged, failed, timeout, unsupported, unavailable);
  2. verdicts: consistent with its method in A, inconsistent in B; or reaching the case's
     target in A, not in B (runs stored before the two verdicts read their within_tol as the
     consistency verdict: refsim.verdicts.upgrade_table);
  3. error: err_B > error_threshold x err_A (default 1.10), unless err_B is at or below the
     round-off floor: the larger of 1e-3 x the row's tolerance (the smaller of A's and B's)
     and the case's error floor (`Case.error_floor`, the round-off level of the order fits).
     Below it errors are round-off and their ratios noise. A finite err_A that becomes nan or
     inf in B is a regression; a non-finite err_A gives no ratio and no verdict on error;
  4. time: us_per_step_B > time_threshold x us_per_step_A (default 1.5, looser than the error
     threshold because timings are noisy: the min of a few repeats moves by tens of per cent
     between runs, and by 2-3x on a loaded machine, where `--no-time` (timings shown, never
     judged) or a larger threshold is the honest gate). Rows without timings (nan
     us_per_step) are not judged on time; a note says when the CPU or thread count differ.
     A stored definition may name another time column in microseconds (`time_column`, e.g.
     a bench figure timing a whole computation whose step count is the method's own).
A row not `ok` in A is never a regression; `ok` in B it is "improved" (fixed). A row `ok` in
both is "improved" too when it became consistent or came to reach the target, or when err_A (above the floor)
exceeds error_threshold x err_B; timings never make a row "improved".

The error compared is the column the case's tolerance bounds (`Case.tolerance_column`: err_max
for most cases, err_rms of the front for a fluid surge, conservation_err for a cradle), read
with the case's error floor from run A's stored case definitions (refsim.store.definitions), never
from today's code (a run stored before definitions were kept falls back to today's, saying so).

Reorganised cases: `--rename OLD=NEW` (a case) or `--rename OLD/VARIANT=NEW/VARIANT` maps run
A's rows onto run B's names before matching; `--allow-source-change` compares rows whose case
source hash differs (a refactor that moved a case's code), saying so in every such row's
reasons, instead of refusing them. Parameters must still be equal.

`main` returns 1 when any row regressed (so the command can gate CI), else 0. Bad input raises
ValueError naming the parameter: a path that is not a stored run, a threshold <= 1 or not
finite, an --out that is not a FILE.csv path, and two runs with no row that could be compared
(a gate that compared nothing must not pass).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from refsim.store.results import KEY

DEFAULT_ERROR_THRESHOLD = 1.10
DEFAULT_TIME_THRESHOLD = 1.5
ROUNDOFF_FRACTION = 1e-3  # errors below this fraction of the tolerance are round-off


from refsim.store.runs import Run, stored_name  # noqa: E402


# ---------------------------------------------------------------------------------------------
# Comparing
# ---------------------------------------------------------------------------------------------
@dataclass
class Result:
    compared: pd.DataFrame
    refused: pd.DataFrame
    only_a: list = field(default_factory=list)
    only_b: list = field(default_factory=list)

    @property
    def regressions(self) -> pd.DataFrame:
        return self.compared[self.compared["verdict"] == "regression"]


def compare_runs(a: Run, b: Run, error_threshold=DEFAULT_ERROR_THRESHOLD,
                 time_threshold=DEFAULT_TIME_THRESHOLD, judge_time=True,
                 allow_source_change=False) -> Result:
    """Match rows on KEY, refuse what cannot be compared, judge the rest (module docstring)."""
    compared, refused = [], []
    for key, ra in a.rows.items():
        if key not in b.rows:
            continue
        rb = b.rows[key]
        case_a, variant_a = stored_name(a, ra)
        why = refusal({**ra, "case": case_a}, rb, a.manifest, b.manifest)
        note = ""
        if why and allow_source_change and why.startswith("case source"):
            why, note = None, f"{why}: compared (--allow-source-change)"
        if why:
            refused.append({**dict(zip(KEY, key)), "reason": why})
            continue
        d = a.definitions.get(case_a, variant_a, ra.get("params", "{}"))
        if d.get("missing"):  # A's case is gone (renamed): the definition B ran it with
            d = b.definitions.get(rb["case"], rb["variant"], rb.get("params", "{}"))
        verdict = judge(ra, rb, error_threshold, time_threshold, judge_time, d)
        if note:
            verdict["reasons"] = "; ".join(r for r in (verdict["reasons"], note) if r)
        compared.append({**dict(zip(KEY, key)), **verdict})
    columns = KEY + ["norm", "err_a", "err_b", "err_ratio", "us_a", "us_b", "time_ratio",
                     "status_a", "status_b", "verdict", "reasons"]
    return Result(pd.DataFrame(compared, columns=columns),
                  pd.DataFrame(refused, columns=KEY + ["reason"]),
                  [k for k in a.rows if k not in b.rows], [k for k in b.rows if k not in a.rows])


def refusal(ra: dict, rb: dict, manifest_a: dict, manifest_b: dict) -> str | None:
    """Why two matched rows must not be compared, or None."""
    case, case_b = ra["case"], rb["case"]
    ha = manifest_a.get("case_hashes", {}).get(case)
    hb = manifest_b.get("case_hashes", {}).get(case_b)
    if ha is None or hb is None:
        return f"case source hash of {case} missing from run {'A' if ha is None else 'B'}'s " \
               f"manifest"
    if ha != hb:
        named = case if case == case_b else f"{case} in A, {case_b} in B"
        return f"case source changed ({named}: hash {ha} in A, {hb} in B)"
    pa, pb = _params(ra), _params(rb)
    if pa != pb:
        return f"case parameters differ ({pa or '{}'} in A, {pb or '{}'} in B)"
    return None


def _params(row: dict) -> dict:
    text = row.get("params", "{}")
    return json.loads(text) if isinstance(text, str) and text else {}


def judge(ra: dict, rb: dict, error_threshold: float, time_threshold: float,
          judge_time: bool, definition: dict | None = None) -> dict:
    """Ratios and verdict of one matched pair: "regression", "improved", "ok" or
    "not ok in A" (a row not ok in A and still not ok in B). `definition`: the case as run A
    ran it (its tolerance column and error floor)."""
    definition = definition or {}
    norm = definition.get("tolerance_column", "err_max")
    err_a, err_b = _number(ra, norm), _number(rb, norm)
    time_column = definition.get("time_column", "us_per_step")
    us_a, us_b = _number(ra, time_column), _number(rb, time_column)
    out = {"norm": norm, "err_a": err_a, "err_b": err_b, "err_ratio": _ratio(err_b, err_a),
           "us_a": us_a, "us_b": us_b, "time_ratio": _ratio(us_b, us_a),
           "status_a": ra["status"], "status_b": rb["status"]}
    if ra["status"] != "ok":
        verdict = "improved" if rb["status"] == "ok" else "not ok in A"
        why = [f"status {ra['status']} -> {rb['status']}"] if rb["status"] == "ok" else []
        return {**out, "verdict": verdict, "reasons": "; ".join(why)}
    if rb["status"] != "ok":
        return {**out, "verdict": "regression",
                "reasons": f"status ok -> {rb['status']} ({rb.get('reason', '')})"}
    floor = _roundoff_floor(ra, rb, definition.get("error_floor", 0.0))
    worse = (_error_regression(err_a, err_b, error_threshold, floor)
             + _tolerance_regression(ra, rb, norm)
             + (_time_regression(us_a, us_b, time_threshold, time_column) if judge_time
                else []))
    if worse:
        return {**out, "verdict": "regression", "reasons": "; ".join(worse)}
    better = _improved(err_a, err_b, error_threshold, floor, ra, rb)
    return {**out, "verdict": "improved" if better else "ok", "reasons": better}


def _error_regression(err_a, err_b, threshold, floor) -> list[str]:
    """Rule 3: err_B > threshold x err_A above the round-off floor; finite -> nan/inf."""
    if not math.isfinite(err_a):
        return []
    if not math.isfinite(err_b):
        return [f"error {err_a:.3g} -> {err_b}"]
    if err_b > threshold * err_a and err_b > floor:
        return [f"error x{_ratio(err_b, err_a):.3g} ({err_a:.3g} -> {err_b:.3g}, threshold "
                f"{threshold:g}, round-off floor {floor:.2g})"]
    return []


def _tolerance_regression(ra, rb, norm) -> list[str]:
    """Rule 2: consistent with its method in A, inconsistent in B; or reaching the target in
    A and not in B."""
    out = []
    if ra.get("consistency") == "consistent" and rb.get("consistency") == "inconsistent":
        out.append(f"now inconsistent with its method ({norm} {_number(rb, norm):.3g} > bound "
                   f"{_number(rb, 'tolerance'):.3g}; {rb.get('consistency_reason', '')})")
    if _truthy(ra.get("reaches_target")) and not _truthy(rb.get("reaches_target")) \
            and "reaches_target" in rb:
        out.append(f"no longer reaches the target ({norm} {_number(rb, norm):.3g})")
    return out


def _time_regression(us_a, us_b, threshold, column="us_per_step") -> list[str]:
    """Rule 4: us_per_step_B > threshold x us_per_step_A (or the stored definition's
    `time_column`, in microseconds), both measured."""
    unit = "us/step" if column == "us_per_step" else f"us ({column})"
    if math.isfinite(us_a) and math.isfinite(us_b) and us_b > threshold * us_a:
        return [f"time x{us_b / us_a:.3f} ({us_a:.3g} -> {us_b:.3g} {unit}, threshold "
                f"{threshold:g})"]
    return []


def _improved(err_a, err_b, threshold, floor, ra, rb) -> str:
    if ra.get("consistency") == "inconsistent" and rb.get("consistency") == "consistent":
        return "now consistent with its method"
    if "reaches_target" in ra and not _truthy(ra.get("reaches_target")) \
            and _truthy(rb.get("reaches_target")):
        return "now reaches the target"
    if math.isfinite(err_a) and math.isfinite(err_b) and err_a > floor \
            and err_b * threshold < err_a:
        return f"error x{_ratio(err_b, err_a):.3g}"
    return ""


def _roundoff_floor(ra, rb, case_floor: float) -> float:
    """max(1e-3 x the smaller tolerance, the case's error floor); 0 when neither is known."""
    tols = [t for t in (_number(ra, "tolerance"), _number(rb, "tolerance")) if math.isfinite(t)]
    floor = ROUNDOFF_FRACTION * min(tols) if tols else 0.0
    return max(floor, case_floor if math.isfinite(case_floor) else 0.0)


def _number(row: dict, column: str) -> float:
    try:
        return float(row.get(column, math.nan))
    except (TypeError, ValueError):
        return math.nan


def _ratio(b: float, a: float) -> float:
    """b / a; inf for b > 0 = a; nan when either is not finite or both are 0."""
    if not (math.isfinite(a) and math.isfinite(b)) or (a == 0 and b == 0):
        return math.nan
    return math.inf if a == 0 else b / a


def _truthy(value) -> bool:
    return value is True or value is np.True_ or str(value) == "True"


# ---------------------------------------------------------------------------------------------
# Printing
# ---------------------------------------------------------------------------------------------
def label(key) -> str:
    """One line naming a row: case/variant engine[:variant] integrator dt=..."""
    case, variant, engine, engine_variant, integrator, dt = key
    eng = engine + (f":{engine_variant}" if engine_variant else "")
    return f"{case}/{variant} {eng} {integrator or '-'} dt={_fmt(dt, '.3g')}"


def print_result(result: Result, run_a: Run, run_b: Run, judge_time=True) -> None:
    print(f"A: {run_a.dir}\nB: {run_b.dir}")
    print(display_table(result.compared).to_string(index=False))
    print(f"compared {len(result.compared)}, refused {len(result.refused)}, only in A "
          f"{len(result.only_a)}, only in B {len(result.only_b)}, regressions "
          f"{len(result.regressions)}")
    note = _machine_note(run_a.manifest, run_b.manifest)
    if judge_time and note:
        print(note)
    for _, r in result.refused.iterrows():
        print(f"refused    {label(tuple(r[k] for k in KEY))}: {r['reason']}")
    for _, r in result.regressions.iterrows():
        print(f"REGRESSION {label(tuple(r[k] for k in KEY))}: {r['reasons']}")


def display_table(compared: pd.DataFrame) -> pd.DataFrame:
    """The compared rows as short strings: key columns, errors, timings, ratios, verdict."""
    table = pd.DataFrame({
        "case": compared["case"], "variant": compared["variant"],
        "engine": [e + (f":{v}" if v else "") for e, v in
                   zip(compared["engine"], compared["engine_variant"])],
        "integrator": compared["integrator"],
        "dt": [_fmt(v, ".3g") for v in compared["dt"]]})
    for col, spec in (("err_a", ".3g"), ("err_b", ".3g"), ("err_ratio", ".3g"),
                      ("us_a", ".3g"), ("us_b", ".3g"), ("time_ratio", ".3g")):
        table[col] = [_fmt(v, spec) for v in compared[col]]
    table["verdict"] = compared["verdict"]
    return table


def _machine_note(ma: dict, mb: dict) -> str:
    differs = [k for k in ("cpu", "threads") if ma.get(k) != mb.get(k)]
    if not differs:
        return ""
    return "note: time ratios also compare machines: " + ", ".join(
        f"{k} {ma.get(k)!r} in A, {mb.get(k)!r} in B" for k in differs)


def _fmt(value, spec) -> str:
    if isinstance(value, str):
        return value or "-"
    if value is None or not math.isfinite(float(value)):
        return "-" if value is None or math.isnan(float(value)) else str(value)
    return format(float(value), spec)
