"""`refsim compare RUN_A RUN_B`: row-by-row error and time ratios of two stored runs (the rules:
refsim.report.compare); exit 1 on a regression."""
from __future__ import annotations

import argparse
from pathlib import Path

from refsim.options import number
from refsim.report.compare import (DEFAULT_ERROR_THRESHOLD, DEFAULT_TIME_THRESHOLD,
                                   compare_runs, print_result)
from refsim.store.atomic import atomic_write
from refsim.store.runs import open_run, parse_renames, rename_rows

HELP = "row-by-row error and time ratios of two stored runs; exit 1 on a regression"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_a", metavar="RUN_A", help="baseline run directory (or run id "
                        "under reports/runs)")
    parser.add_argument("run_b", metavar="RUN_B", help="candidate run directory (or run id)")
    parser.add_argument("--error-threshold", default=DEFAULT_ERROR_THRESHOLD,
                        help=f"flag err_B > this x err_A (> 1, default "
                             f"{DEFAULT_ERROR_THRESHOLD})")
    parser.add_argument("--time-threshold", default=DEFAULT_TIME_THRESHOLD,
                        help=f"flag us_per_step_B > this x us_per_step_A (> 1, default "
                             f"{DEFAULT_TIME_THRESHOLD}; timings are noisy)")
    parser.add_argument("--no-time", action="store_true", help="show timings, never flag them")
    parser.add_argument("--out", default=None, help="also write the compared rows to FILE.csv")
    parser.add_argument("--rename", action="append", default=[], metavar="OLD=NEW",
                        help="map run A's case OLD (or OLD/VARIANT) to NEW (or NEW/VARIANT) "
                             "before matching (cases reorganised); repeatable")
    parser.add_argument("--allow-source-change", action="store_true",
                        help="compare rows whose case source hash differs (said per row) "
                             "instead of refusing them")


def main(args) -> int:
    """Compare, print the table, the counts and one line per regression; 1 if any regressed."""
    error_threshold = check_threshold("--error-threshold", args.error_threshold)
    time_threshold = check_threshold("--time-threshold", args.time_threshold)
    out = _check_out(args.out)
    renames = parse_renames(args.rename)
    run_a, run_b = open_run("RUN_A", args.run_a), open_run("RUN_B", args.run_b)
    run_a = rename_rows(run_a, renames)
    result = compare_runs(run_a, run_b, error_threshold, time_threshold,
                          judge_time=not args.no_time,
                          allow_source_change=args.allow_source_change)
    if result.compared.empty:
        raise ValueError(f"RUN_B must share at least one comparable row with RUN_A, got none "
                         f"({len(result.refused)} refused, {len(result.only_a)} only in A, "
                         f"{len(result.only_b)} only in B)")
    print_result(result, run_a, run_b, judge_time=not args.no_time)
    if out is not None:
        atomic_write(out, result.compared.to_csv(index=False, na_rep="nan"))
    return 0 if result.regressions.empty else 1


def check_threshold(name: str, value) -> float:
    """A ratio threshold: a finite number > 1."""
    return number(name, value, low=1.0)


def _check_out(out) -> Path | None:
    if out is None:
        return None
    path = Path(out)
    if path.is_dir() or path.suffix.lower() != ".csv":
        raise ValueError(f"--out must be a FILE.csv path (not a directory), got {out!r}")
    return path
