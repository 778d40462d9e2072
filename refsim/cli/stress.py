"""`refsim stress`: stability limits and a stiffness sweep on every engine (what they measure:
refsim.stress)."""
from __future__ import annotations

import argparse
import time

import pandas as pd

from refsim.store import results as store
from refsim.stress.limits import (PERIODS, QUICK_PERIODS, QUICK_TOL, limits_table, manifest,
                                  options)
from refsim.stress.report import atomic_csv, print_report
from refsim.stress.store import store_run
from refsim.stress.sweep import QUICK_SPAN, SWEEP_DT, sweep_table

HELP = "stability limits (bisection on omega dt) and a stiffness sweep on every engine"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--case", default=None,
                        help="a case that declares its stability parameter (`stability(p)`); "
                             "default: the stability-probe case, with the stiffness sweep")
    parser.add_argument("--variant", default=None,
                        help="the --case variant searched (default: the one its stability "
                             "spec names, else its first)")
    parser.add_argument("--engine", action="append",
                        help="engine (repeatable; default: every available engine)")
    parser.add_argument("--integrator", action="append",
                        help="integrator (repeatable; default: every fixed-step one offered)")
    parser.add_argument("--periods", default=None,
                        help=f"periods judged per y in the limit search, at most 10 steps "
                             f"each (default {PERIODS}, --quick {QUICK_PERIODS})")
    parser.add_argument("--dt", default=None, help=f"sweep time step in s (default {SWEEP_DT})")
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_PERIODS} periods, bisection to {QUICK_TOL:g}, "
                             f"sweep runs of at most {QUICK_SPAN} s")
    parser.add_argument("--out", default=None, help="runs directory (default reports/runs)")


def main(args) -> int:
    opts = options(args)
    t0 = time.perf_counter()
    spring = opts["probe"]
    st = store.RunStore.create(opts["out"], manifest(opts))
    limits = limits_table(opts, spring)
    atomic_csv(st.dir / "stress_limits.csv", limits)
    sweep = sweep_table(opts) if opts["sweep"] else pd.DataFrame()
    atomic_csv(st.dir / "stress_sweep.csv", sweep)
    store_run(st, opts, spring, limits, sweep)
    st.update_manifest(status="complete", wall_s=round(time.perf_counter() - t0, 2))
    print_report(opts, spring, limits, sweep)
    print(st.dir)
    return 0
