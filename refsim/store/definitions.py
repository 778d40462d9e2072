"""The cases as a run ran them: what `report`, `compare` and the summary read of a case.

A run stores each case x variant x parameters' `Case.definition` (store.DEFINITIONS) when it
starts, so a stored run reads the same after the code changes. A run stored before
definitions were kept gets today's definition from the registry, marked `"legacy": True`
(the report says so); a case that no longer exists gets a neutral one (`"missing": True`).
"""
from __future__ import annotations

import json
import math

from refsim.store import results as store

NEUTRAL = {"description": "", "tags": [], "observable": "", "units": "",
           "tolerance_column": "err_max", "target_error": math.nan, "error_floor": 0.0,
           "error_ceiling": math.inf, "energy_scale": 1.0, "reference_dt": math.nan,
           "order_meaningful": True, "figures": [], "source_hash": ""}


def params_text(params) -> str:
    """The results' `params` column: the parameter overrides as JSON (sorted pairs)."""
    if isinstance(params, str):
        return params or "{}"
    return json.dumps(dict(params))


def for_jobs(jobs) -> list[dict]:
    """Today's definition of every case x variant x parameters among `jobs`."""
    out, seen = [], set()
    for job in jobs:
        key = (job.case, job.variant, params_text(job.params))
        if key not in seen:
            seen.add(key)
            out.append(today(*key))
    return out


def today(case_name: str, variant: str, key_params: str) -> dict:
    from refsim.registry import get_case
    case = get_case(case_name)
    p = case.variant_params(variant, json.loads(key_params or "{}"))
    return {**case.definition(variant, p), "key_params": key_params}


class Definitions:
    """Lookup of a run's definitions by results row (case, variant, params)."""

    def __init__(self, stored: dict):
        self.stored = dict(stored)

    @classmethod
    def of_run(cls, run_dir) -> "Definitions":
        return cls(store.load_definitions(run_dir))

    def get(self, case: str, variant: str, key_params) -> dict:
        key = (case, str(variant), params_text(key_params))
        if key not in self.stored:
            self.stored[key] = _fallback(*key)
        return self.stored[key]

    def of_row(self, row) -> dict:
        return self.get(row["case"], row["variant"], row.get("params", "{}"))

    @property
    def legacy(self) -> bool:
        return any(d.get("legacy") or d.get("missing") for d in self.stored.values())


def _fallback(case_name: str, variant: str, key_params: str) -> dict:
    try:
        return {**today(case_name, variant, key_params), "legacy": True}
    except (ValueError, ImportError, AttributeError, KeyError):
        return {**NEUTRAL, "case": case_name, "variant": variant, "params": {},
                "key_params": key_params, "missing": True}


def model_group(definitions: Definitions, case_name: str) -> str:
    """A case's model group as the run stored it (`model_group` of its definition), else from
    today's registry, "other" for a case no longer known."""
    for d in getattr(definitions, "stored", {}).values():
        if d.get("case") == case_name and d.get("model_group"):
            return d["model_group"]
    try:
        from refsim.case import module_group
        from refsim.registry import get_case
        return module_group(type(get_case(case_name)).__module__)
    except (ValueError, ImportError, AttributeError, KeyError):
        return "other"
