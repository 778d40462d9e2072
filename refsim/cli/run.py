"""`refsim run`: the case x engine x integrator x dt matrix, stored as it runs, then its report."""
from __future__ import annotations

import os
import shlex
import sys

from refsim.cli import THREADS
from refsim.options import integer

HELP = "run the case x engine x integrator x dt matrix"


def add_arguments(run) -> None:
    run.add_argument("--case", action="append", help="case name (repeatable)")
    run.add_argument("--variant", action="append", help="case variant name (repeatable)")
    run.add_argument("--engine", action="append", help="engine name (repeatable)")
    run.add_argument("--integrator", action="append", help="integrator, e.g. rk4, rk2:0.5")
    run.add_argument("--dt", action="append", help="time step in s (repeatable)")
    run.add_argument("--param", action="append", default=[],
                     help="case parameter override NAME=VALUE or CASE.NAME=VALUE")
    run.add_argument("--quick", action="store_true", help="reference dt, default variants, "
                     "each engine's default formulation")
    run.add_argument("--full", action="store_true", help="every engine formulation over the "
                     "whole dt sweep (by default alternatives run at the reference dt)")
    run.add_argument("--out", default=None, help="runs directory (default reports/runs)")
    run.add_argument("--repeats", default="5", help="the most timing repeats (>= 1; they "
                     "stop at two once the median is within 5 %% of the min)")
    run.add_argument("--resume", default=None, help="finish the interrupted run RUN_ID")
    run.add_argument("--threads", default="1", help="BLAS/OpenMP threads (>= 1)")
    run.add_argument("--max-steps", default=None, help="bound on the steps of one run "
                     "(default 1e8: longer runs take hours and drown in round-off)")
    run.add_argument("--no-report", action="store_true", help="skip writing the report")
    run.add_argument("--jobs", default=str(min(2, os.cpu_count() or 1)),
                     help="worker processes, one thread each (default: min(2, cores)); "
                     "--jobs 1 for timings with nothing else running")
    run.add_argument("--scheduler", default=None, help="run the jobs on the Dask cluster "
                     "whose scheduler is at ADDRESS (e.g. tcp://10.0.0.5:8786)")
    run.add_argument("--dask-workers", default=None, help="run the jobs on a local Dask "
                     "cluster of N worker processes, one thread each")
    run.add_argument("--timeout", default=None, help="seconds one job may take; past it the "
                     "job is a `timeout` row and its worker is replaced (default: no limit)")


def main(args) -> int:
    return cmd_run(args, args.argv)


def _params(specs, cases):
    from refsim.registry import get_case
    out = {}
    for spec in specs:
        key, sep, value = spec.partition("=")
        if not sep:
            raise ValueError(f"--param must be NAME=VALUE, got {spec!r}")
        case_name, _, name = key.rpartition(".")
        targets = [case_name] if case_name else cases
        hits = [c for c in targets if name in get_case(c).params]
        if not hits:
            raise ValueError(f"--param {name!r} must be a parameter of {targets}")
        for c in hits:
            get_case(c).validate({name: value})
            out.setdefault(c, {})[name] = value
    return out


def cmd_run(args, argv) -> int:
    from pathlib import Path

    from refsim.registry import case_names
    from refsim.run import runner
    from refsim.store import results as store
    from refsim.run.summary import print_summary, progress_printer

    import time
    start = time.perf_counter()
    repeats = integer("--repeats", args.repeats)
    integer("--threads", args.threads)  # pinned before numpy loaded (_pin_threads)
    executor = _executor(args)  # its flags (and --jobs) checked before anything is stored
    root = Path(args.out) if args.out else store.DEFAULT_ROOT
    if args.resume:
        st = store.RunStore.open(root / args.resume)
        spec = st.manifest["matrix"]
    else:
        spec = {"cases": args.case or case_names(), "engines": args.engine,
                "integrators": args.integrator, "dts": args.dt, "quick": args.quick,
                "full": args.full,
                "variants": args.variant}
        spec["params"] = _params(args.param, spec["cases"])
        if args.max_steps is not None:
            spec["max_steps"] = integer("--max-steps", args.max_steps, example="1000000000 or 1e9")
    jobs = runner.expand(**spec)
    if not args.resume:
        st = store.RunStore.create(root, _manifest(spec, argv, jobs))
    from refsim.store.definitions import for_jobs
    st.add_definitions(for_jobs(jobs))
    table = runner.run_matrix(jobs, st, repeats=repeats, progress=progress_printer(),
                              executor=executor)
    workers = executor.workers
    wall = time.perf_counter() - start
    share = st.harness_s / st.busy_s if st.busy_s > 0 else 0.0
    st.update_manifest(status="complete", wall_s=wall, busy_s=st.busy_s,
                       harness_s=st.harness_s, harness_overhead=share, workers=workers,
                       **{k: v for k, v in executor.describe().items() if k != "workers"})
    print_summary(table)
    status = 0 if args.no_report else _report_after_run(st)
    print(f"\nrun time {wall:.1f} s on {workers} worker(s), {st.busy_s:.1f} s of work: "
          f"harness overhead {st.harness_s:.1f} s ({100 * share:.1f} %; the rest is engines' "
          "setup, compilation, stepping and observation)")
    print(st.dir)
    return status


def _report_after_run(st) -> int:
    """The report of a finished run (its wall time kept in the manifest as `report_s`): 0,
    or 1 when rendering failed. An error inside the report (matplotlib, a figure) is not bad
    input: the stored run is complete and kept, and the message says so instead of exit 2's
    "refsim: error"."""
    import time
    from refsim.report.build import write_report
    run_dir = st.dir
    t0 = time.perf_counter()
    try:
        md, _ = write_report(run_dir)
    except Exception as exc:  # noqa: BLE001 - any failure of rendering, reported as such
        print(f"refsim: the report failed ({type(exc).__name__}: "
              f"{str(exc).splitlines()[0] if str(exc) else ''}); every row is stored in "
              f"{run_dir}: render it again with `refsim report {run_dir}`", file=sys.stderr)
        return 1
    report_s = time.perf_counter() - t0
    st.update_manifest(report_s=report_s)
    print(f"\nreport: {md} and report.html ({report_s:.1f} s)")
    return 0


def _executor(args):
    """Where the jobs run (refsim.run.executors): the local worker processes of --jobs, each job
    isolated in its process, or a Dask cluster (--scheduler ADDRESS | --dask-workers N)."""
    from refsim.run import executors
    from refsim.options import number
    timeout = None if args.timeout is None else number("--timeout", args.timeout, unit="s")
    if args.scheduler and args.dask_workers:
        raise ValueError("--scheduler and --dask-workers must not be given together: one "
                         "names an existing cluster, the other starts a local one")
    if args.scheduler or args.dask_workers:
        workers = integer("--dask-workers", args.dask_workers) if args.dask_workers \
            else None
        return executors.Dask(args.scheduler, workers, timeout)
    return executors.Local(integer("--jobs", args.jobs), timeout)


def _manifest(spec, argv, jobs) -> dict:
    from refsim.registry import get_engine
    from refsim.registry import get_case
    from refsim.store import results as store

    engines = sorted({j.engine for j in jobs})
    versions = {e: (get_engine(e).version() if get_engine(e).available() else "unavailable")
                for e in engines}
    hashes = {c: get_case(c).source_hash() for c in spec["cases"]}
    command = "refsim " + shlex.join(sys.argv[1:] if argv is None else argv)
    return {"run_id": store.new_run_id(), "command": command, "matrix": spec,
            "jobs": len(jobs), "status": "running",
            **store.environment(versions, hashes, THREADS)}
