"""The work a run costs: measured per case from a stored run, predicted for a matrix.

A row's work is its `wall_s` (both passes, the engine's calls and the harness's own checks,
in its worker). `work_by(table, keys)` sums it; `measure(run_dir)` keeps, per case x variant x
engine, the mean work of one job with the run's machine and the report's wall time;
`predict(jobs, measured)` is the sum over a matrix's jobs of their group's mean (the jobs of a
group that was not measured are listed apart: a prediction never guesses them).
`python -m refsim.run.budget RUN_DIR OUT.json` writes a measurement.
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

KEYS = ("case", "variant", "engine")


def work_by(table: pd.DataFrame, keys) -> pd.DataFrame:
    """Work seconds, job count and share of the run's work per `keys`, largest first."""
    work = pd.to_numeric(table["wall_s"], errors="coerce").fillna(0.0)
    out = work.groupby([table[k] for k in keys], sort=False).agg(["sum", "size"])
    out.columns = ["work_s", "jobs"]
    out["share"] = out["work_s"] / max(float(work.sum()), 1e-12)
    return out.sort_values("work_s", ascending=False).reset_index()


def measure(run_dir) -> dict:
    """Mean work per job of each case x variant x engine of a stored run, with its machine,
    workers, wall time and the report's wall time when the run recorded it."""
    from refsim.store.results import load_results
    run_dir = Path(run_dir)
    table = load_results(run_dir)
    manifest = json.loads((run_dir / "manifest.json").read_text())
    groups = work_by(table, KEYS)
    return {"run_id": manifest.get("run_id", ""), "cpu": manifest.get("cpu", ""),
            "workers": manifest.get("workers", 1), "wall_s": manifest.get("wall_s"),
            "report_s": manifest.get("report_s"), "work_s": float(groups["work_s"].sum()),
            "jobs": int(groups["jobs"].sum()),
            "job_s": {"/".join(str(r[k]) for k in KEYS): r["work_s"] / r["jobs"]
                      for _, r in groups.iterrows()}}


@dataclass
class Prediction:
    work_s: float = 0.0  # the measured groups' jobs
    jobs: int = 0
    unmeasured: list = field(default_factory=list)  # "case/variant/engine" never measured

    def wall_s(self, workers: int, report_s: float = 0.0) -> float:
        """The run's wall time if its work spreads evenly over `workers`, plus the report."""
        return self.work_s / max(1, workers) + report_s


def predict(jobs, measured: dict) -> Prediction:
    out = Prediction()
    for job in jobs:
        key = f"{job.case}/{job.variant}/{job.engine}"
        if key in measured["job_s"]:
            out.work_s += measured["job_s"][key]
            out.jobs += 1
        elif key not in out.unmeasured:
            out.unmeasured.append(key)
    return out


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: python -m refsim.run.budget RUN_DIR OUT.json")
    Path(sys.argv[2]).write_text(json.dumps(measure(sys.argv[1]), indent=1, sort_keys=True)
                                 + "\n")
