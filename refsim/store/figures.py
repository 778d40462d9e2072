"""Ordinary stored runs from figures that are not matrix rows (`refsim stress`, `refsim bench`).

Such a run is a directory like `refsim run`'s: manifest.json, results.csv (+ rows.jsonl) and
cases.json, so `refsim report` and `refsim compare` read it unchanged. Every figure is one
results row keyed on the store's KEY; every (case, variant, params) it uses has a definition
written by the command itself (`definition`), honest about what the row holds: no convergence
order, no figures, and where nothing bounds the figure, no tolerance (tolerance nan,
consistency "", reaches_target False, tol_reason saying why), so that compare judges status
and time only.

A bench's figure (what `main(quick)` of a `refsim.benches` entry returns, a list of dicts):
  required: "figure" (its name, the row's variant), "value" and "units" (the figure itself),
            "description" (one line);
  optional: "engine", "engine_variant", "integrator", "dt" (where a fixed step is meaningful),
            "steps", "us_per_step" and "step_s" (the timed stepping), "time_us" with
            "time_column": "time_us" (a figure whose time is not per step: compare judges
            that column instead of us_per_step), "measured_on" (the case it runs), "show" (a
            list of further columns the report's table shows), and any other scalar columns
            (kept as they are).
"""
from __future__ import annotations

import hashlib
import inspect
import json
import math

import pandas as pd

from refsim.store import results as store

NAN = math.nan
NUMBER_COLUMNS = ("err_max", "err_final", "err_rms", "energy_drift", "setup_s", "compile_s",
                  "step_s", "us_per_step", "tolerance", "t_end")
NO_TOLERANCE = "no tolerance: a speed figure"
BENCH_PREFIX = "bench:"


def base_row(run_id: str, case: str, variant: str, engine: str, integrator: str,
             dt: float = NAN, engine_variant: str = "", params: str = "{}") -> dict:
    """A results row with the store's columns, every number nan until the figure fills it."""
    row = {"run_id": run_id, "case": case, "variant": variant, "engine": engine,
           "engine_variant": engine_variant, "integrator": integrator, "dt": dt,
           "params": params, "engine_version": "", "steps": 0, "status": "ok", "reason": ""}
    row.update({col: NAN for col in NUMBER_COLUMNS})
    row.update(repeats=0, settings="{}", consistency="", consistency_reason="",
               reaches_target=False, tol_reason="", timing="")
    return row


def definition(case: str, variant: str, description: str, observable: str, units: str,
               source_hash: str, key_params: str = "{}", **fields) -> dict:
    """A stored case definition (the keys of Case.definition) for a figure the command wrote
    itself: no target error, no order, no figures, unless `fields` say otherwise."""
    return {"case": case, "variant": variant, "description": description, "tags": [],
            "params": json.loads(key_params), "observable": observable, "units": units,
            "tolerance_column": "err_max", "target_error": NAN, "error_floor": 0.0,
            "error_ceiling": math.inf, "energy_scale": 1.0, "reference_dt": NAN,
            "order_meaningful": False, "figures": [], "source_hash": source_hash,
            "key_params": key_params, **fields}


def store_rows(st: store.RunStore, rows: list[dict], definitions: list[dict]) -> None:
    """Rows to rows.jsonl and results.csv, definitions to cases.json."""
    st.add_definitions(definitions)
    for row in rows:
        st.add(row)
    st.write_table(pd.DataFrame(st.rows))


def source_hash(obj) -> str:
    """Hash of the source of the module defining `obj` (a bench's `main`)."""
    module = inspect.getmodule(obj)
    return hashlib.sha256(inspect.getsource(module).encode()).hexdigest()[:16]


# --------------------------------------------------------------------------------------------
# refsim bench NAME
# --------------------------------------------------------------------------------------------
REQUIRED = ("figure", "value", "units", "description")


def check_figures(figures, name: str) -> list[dict]:
    """The figures of bench `name`, each with the required keys and a distinct store KEY;
    ValueError naming what is wrong otherwise."""
    figures, seen = list(figures), set()
    for fig in figures:
        missing = [k for k in REQUIRED if k not in fig]
        if missing:
            raise ValueError(f"bench {name!r} must return figures with {list(REQUIRED)}, got "
                             f"one without {missing}: {fig}")
        key = store.row_key({"case": name, "variant": fig["figure"],
                             "engine": fig.get("engine", ""),
                             "engine_variant": fig.get("engine_variant", ""),
                             "integrator": fig.get("integrator", ""),
                             "dt": float(fig.get("dt", NAN))})
        if key in seen:
            raise ValueError(f"bench {name!r} must return one figure per (figure, engine, "
                             f"engine_variant, integrator, dt), got {key} twice")
        seen.add(key)
    return figures


def figure_rows(figures: list[dict], case: str, run_id: str, versions: dict) -> list[dict]:
    """One results row per figure: case `case`, variant the figure's name, no tolerance."""
    rows = []
    for fig in figures:
        fig = dict(fig)
        engine = fig.pop("engine", "")
        row = base_row(run_id, case, fig.pop("figure"), engine, fig.pop("integrator", ""),
                       float(fig.pop("dt", NAN)), fig.pop("engine_variant", ""))
        fig.pop("description", None)
        fig.pop("time_column", None)
        fig.pop("show", None)
        row.update(engine_version=versions.get(engine, ""), tol_reason=NO_TOLERANCE,
                   repeats=int(fig.pop("repeats", 0)), **fig)
        rows.append(row)
    return rows


def figure_definitions(figures: list[dict], case: str, digest: str) -> list[dict]:
    """One definition per figure name: the figure's description and units, no tolerance."""
    out = {}
    for fig in figures:
        time_column = fig.get("time_column", "us_per_step")
        out.setdefault(fig["figure"], definition(
            case, fig["figure"], f"{fig['description']} ({NO_TOLERANCE}: compare judges "
            f"{time_column} and status only; the figure is `value` in `units`)", "", "", digest,
            time_column=time_column, report_columns=["value", "units", *fig.get("show", ())]))
    return list(out.values())


