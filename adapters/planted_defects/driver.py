"""Runs each planted defect where it matters and says whether the verdicts catch it.

For each defect: the jobs of the default matrix (`refsim.run.runner.expand(engines=["refsim"])`,
or its quick form) whose scene and integrator the defect can touch (`Defect.touches`), re-labelled
to the defect's engine; the control engine (refsim behind the same wrapper, no defect) runs the
same jobs. Both run in one pass (accuracy only, no timing pass; `refsim.run.executors.Local` with
2 processes by default), the order fits are added over the whole table (`runner.with_orders`),
and nothing is cached between runs.

A defect MATTERS to a row when the defect's row and the control's row differ by more than
round-off: their statuses differ, or both are ok and their err_max (or the column the case's
tolerance judges, where that is another) differ by more than
    ROUNDOFF_ABS x the case's motion scale + ROUNDOFF_REL x the control's value
(1e-9 of the motion: round-off after 1e6 steps is ~1e-10 of the state; 1e-6 relative: far
above the last-bit differences of a reordered sum). A row whose defect finds nothing to change
in the sim (UNREACHABLE, see engines) never matters; the table counts those separately.
A (case, integrator) pair MATTERS when one of its rows does, and is CAUGHT when `caught` finds
a catching row among the rows that matter. A pair is MATERIAL when at one of its rows the
defect moves the error by at least the correct method's own error there (|err_defect -
err_control| >= err_control, above round-off): a smaller change hides inside the method's own
error, which any honest bound must allow (times its safety factor); the table gives both.

The control's false alarms are its inconsistent rows outside the slides' deliberately wrong
formulations (SEED_FORMULATIONS: inconsistent by design, listed apart); its diverged and
failed rows (past a stability limit, a Newton solve giving up) are statuses, not verdicts,
and are listed apart too.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from functools import lru_cache

import pandas as pd

from refsim.run import executors
from refsim.registry import get_case
from refsim.run.runner import expand, with_orders

from .engines import DEFECTS, UNREACHABLE, register_all

ROUNDOFF_ABS = 1e-9
ROUNDOFF_REL = 1e-6
# the slides' formulas run as printed: inconsistent with the method they name by design
SEED_FORMULATIONS = ("as_printed", "hard_sphere_seed", "matrix_printed")
KEY = ("case", "variant", "engine_variant", "integrator", "dt", "params", "timed")
CONTROL = DEFECTS["control"]


# ---------------------------------------------------------------------------------------------
# The verdict question: one function, so that it follows the verdict columns
# ---------------------------------------------------------------------------------------------
def caught(defect_rows, correct_rows) -> str | None:
    """The reason of the first defect row that the verdicts catch, None when none is caught.
    Rows pair up in order (the defect's and the control's run of the same job). A row is
    caught when it is inconsistent with its named method where the control's row is not (an
    inconsistency the control shares is a false alarm, not a catch), misses the case's
    accuracy target where the control's row reaches it, or is diverged or failed where the
    control's is ok."""
    for d, c in zip(defect_rows, correct_rows):
        label = f"{d['variant']} dt={d['dt']:.3g}"
        if d["status"] in ("diverged", "failed") and c["status"] == "ok":
            return f"{label}: {d['status']}: {d['reason']}"
        if d["status"] != "ok":
            continue
        if d["consistency"] == "inconsistent" and c["consistency"] != "inconsistent":
            return f"{label}: inconsistent: {d['consistency_reason']}"
        if not _true(d["reaches_target"]) and c["status"] == "ok" and _true(c["reaches_target"]):
            return (f"{label}: misses the target: err_max {d['err_max']:.3g}, target "
                    f"{d['target_error']:.3g} (the control's {c['err_max']:.3g} reaches it)")
    return None


def _true(value) -> bool:
    return value is True or value in (1, "True", "true") or (
        not isinstance(value, str) and bool(value) and value == value)


# ---------------------------------------------------------------------------------------------
# Jobs
# ---------------------------------------------------------------------------------------------
def base_jobs(cases=None, quick=False):
    """The refsim jobs of the default (or quick) matrix that run (an engine that supports no
    case gives rows without a dt: left out)."""
    return [j for j in expand(cases=cases, engines=["refsim"], quick=quick) if j.dt == j.dt]


def defect_jobs(defect, jobs, scenes=None) -> list:
    """The jobs the defect can touch, re-labelled to its engine."""
    scenes = {} if scenes is None else scenes
    out = []
    for job in jobs:
        key = (job.case, job.variant, job.params)
        if key not in scenes:
            case = get_case(job.case)
            scenes[key] = case.scene(case.variant_params(job.variant, dict(job.params)))
        if defect.touches(scenes[key], job.integrator):
            out.append(replace(job, engine=defect.engine))
    return out


def _size(job) -> float:
    case = get_case(job.case)
    return case.work(case.variant_params(job.variant, dict(job.params)), job.dt)


def run_jobs(jobs, workers: int = 2) -> pd.DataFrame:
    """Every job's row (accuracy pass only), with the order fits over the whole table."""
    register_all()
    executor = executors.InProcess() if workers <= 1 else executors.Local(workers)
    tasks = [(job, "planted", 0, 0.0) for job in jobs]
    rows = [row for _, row in executor.results(tasks, size=_size)]
    return with_orders(pd.DataFrame(rows)) if rows else pd.DataFrame()


# ---------------------------------------------------------------------------------------------
# Comparison
# ---------------------------------------------------------------------------------------------
def _key(row) -> tuple:
    return tuple(row[k] for k in KEY)


@lru_cache(maxsize=None)
def _scale_and_column(case_name: str, variant: str, params: str) -> tuple:
    """The case's motion scale and the column its tolerance judges (case data, not results)."""
    case = get_case(case_name)
    p = case.variant_params(variant, json.loads(params))
    return float(case.motion_scale(p)), case.tolerance_column(p)


def unreachable(row) -> bool:
    return row["status"] == "failed" and UNREACHABLE in str(row["reason"])


def matters(d, c) -> bool:
    """Whether the defect's row differs from the control's beyond round-off (module doc)."""
    if unreachable(d):
        return False
    if d["status"] != c["status"]:
        return True
    if d["status"] != "ok":
        return False
    scale, column = _scale_and_column(c["case"], c["variant"], c["params"])
    for col in dict.fromkeys(("err_max", column)):
        a, b = float(d[col]), float(c[col])
        if math.isnan(a) != math.isnan(b):
            return True
        if not math.isnan(a) and abs(a - b) > ROUNDOFF_ABS * scale + ROUNDOFF_REL * abs(b):
            return True
    return False


def material(d, c) -> bool:
    """The defect moves the error by at least the correct method's own error (module doc)."""
    if not matters(d, c) or d["status"] != "ok" or c["status"] != "ok":
        return matters(d, c) and d["status"] != c["status"]
    _, column = _scale_and_column(c["case"], c["variant"], c["params"])
    a, b = float(d[column]), float(c[column])
    return not math.isnan(a) and abs(a - b) >= abs(b)


def summarise(name: str, table: pd.DataFrame, control: dict) -> dict:
    """One line of the table for defect `name`: rows run, unreachable rows, cases and
    (case, integrator) pairs where it matters, pairs caught, first message, missed pairs."""
    rows = table[table["engine"] == DEFECTS[name].engine].to_dict("records")
    pairs: dict = {}
    for d in rows:
        c = control[_key(d)]
        if matters(d, c):
            pairs.setdefault((d["case"], d["integrator"]), []).append((d, c))
    found = {pair: caught(*zip(*both)) for pair, both in pairs.items()}
    first = next((why for why in found.values() if why), "")
    hit = [pair for pair, why in found.items() if why]
    missed = [pair for pair, why in found.items() if not why]
    big = [pair for pair, both in pairs.items() if any(material(d, c) for d, c in both)]
    return {"defect": name, "rows": len(rows),
            "unreachable": sorted({r["case"] for r in rows if unreachable(r)}),
            "cases": sorted({case for case, _ in pairs}), "pairs": len(pairs),
            "caught": len(hit), "pct": 100.0 * len(hit) / len(pairs) if pairs else float("nan"),
            "material": len(big), "material_caught": sum(1 for pair in big if found[pair]),
            "first": f"{hit[0][0]} {hit[0][1]}: {first}" if hit else "", "missed": missed}


def false_alarms(table: pd.DataFrame) -> pd.DataFrame:
    """The control's rows that are inconsistent, diverged or failed, with `kind`: "false
    alarm" (inconsistent, outside SEED_FORMULATIONS), "seed formula" (inconsistent by design)
    or "stopped" (diverged or failed: a status, not a verdict)."""
    c = table[table["engine"] == CONTROL.engine]
    bad = c[c["status"].isin(["diverged", "failed"]) | (c["consistency"] == "inconsistent")]
    kind = ["stopped" if s != "ok" else "seed formula" if ev in SEED_FORMULATIONS
            else "false alarm" for s, ev in zip(bad["status"], bad["engine_variant"])]
    return bad.assign(kind=kind)


# ---------------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------------
def run(defects=None, cases=None, quick=False, workers: int = 2):
    """(summaries, table, seconds) for the named defects (all but the control by default)."""
    t0 = time.perf_counter()
    names = [n for n in (defects or DEFECTS) if n != CONTROL.name]
    for n in names:
        if n not in DEFECTS:
            raise ValueError(f"defect must be one of {list(DEFECTS)}, got {n!r}")
    base, scenes = base_jobs(cases, quick), {}
    per_defect = {n: defect_jobs(DEFECTS[n], base, scenes) for n in names}
    keys = {(j.case, j.variant, j.engine_variant, j.integrator, j.dt, j.params, j.timed)
            for jobs in per_defect.values() for j in jobs}
    control_jobs = [replace(j, engine=CONTROL.engine) for j in base if
                    (j.case, j.variant, j.engine_variant, j.integrator, j.dt, j.params,
                     j.timed) in keys]
    table = run_jobs(control_jobs + [j for n in names for j in per_defect[n]], workers)
    control = {_key(r): r for r in table[table["engine"] == CONTROL.engine].to_dict("records")}
    summaries = [summarise(n, table, control) for n in names]
    return summaries, table, time.perf_counter() - t0


def render(summaries, alarms: pd.DataFrame, seconds: float, rows: int) -> str:
    head = (f"{'defect':<24} {'cases':>5} {'pairs':>5} {'caught':>6} {'%':>5} "
            f"{'material':>8} {'caught':>6} {'%':>5}  first message")
    lines = [head, "-" * len(head)]
    for s in summaries:
        pct = "-" if math.isnan(s["pct"]) else f"{s['pct']:.0f}"
        mat = f"{100.0 * s['material_caught'] / s['material']:.0f}" if s["material"] else "-"
        lines.append(f"{s['defect']:<24} {len(s['cases']):>5} {s['pairs']:>5} "
                     f"{s['caught']:>6} {pct:>5} {s['material']:>8} {s['material_caught']:>6} "
                     f"{mat:>5}  {s['first'][:160]}")
    lines.append("")
    for s in summaries:
        lines.append(f"{s['defect']}: matters on {', '.join(s['cases']) or 'nothing'}")
        if s["missed"]:
            lines.append("  missed: " + ", ".join(f"{c}/{i}" for c, i in s["missed"]))
        if s["unreachable"]:
            lines.append("  unreachable (nothing to change in the sim): "
                         + ", ".join(s["unreachable"]))
    lines.append("")
    counts = alarms["kind"].value_counts().to_dict() if len(alarms) else {}
    lines.append(f"control false alarms (inconsistent outside the seed formulas): "
                 f"{counts.get('false alarm', 0)}; seed formulas inconsistent by design: "
                 f"{counts.get('seed formula', 0)}; stopped runs (diverged/failed): "
                 f"{counts.get('stopped', 0)}")
    for _, r in alarms.iterrows():
        why = r["consistency_reason"] if r["status"] == "ok" else r["reason"]
        form = f":{r['engine_variant']}" if r["engine_variant"] else ""
        lines.append(f"  [{r['kind']}] {r['case']}/{r['variant']}{form} {r['integrator']} "
                     f"dt={r['dt']:.3g} {r['status']}: {str(why)[:130]}")
    lines.append(f"{rows} rows in {seconds:.0f} s")
    return "\n".join(lines)
