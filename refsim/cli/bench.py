"""`refsim bench NAME`: run a speed benchmark (a `refsim.benches` entry), which prints its
figures side by side, and store them as an ordinary run (refsim.store.figures) that `refsim
report` and `refsim compare` read."""
from __future__ import annotations

import os
import sys
import time

from refsim.store import results as store
from refsim.store.figures import (BENCH_PREFIX, check_figures, figure_definitions, figure_rows,
                                  source_hash, store_rows)

HELP = "speed benchmarks (registered under refsim.benches; default: inhouse, the in-house " \
       "engine on one core)"


def add_arguments(parser) -> None:
    parser.add_argument("name", nargs="?", default="inhouse", help="bench name (refsim list)")
    parser.add_argument("--quick", action="store_true", help="smaller batch, fewer repeats")
    parser.add_argument("--sph", action="store_true", help="the same as `refsim bench sph` "
                        "(kept for earlier command lines)")
    parser.add_argument("--out", default=None, help="runs directory for the stored figures "
                        "(default reports/runs)")


def main(args) -> int:
    return run_bench("sph" if args.sph else args.name, args.quick, args.out)


def bench_manifest(name: str, quick: bool, case: str, digest: str, engines: list) -> dict:
    from refsim.registry import get_engine
    versions = {}
    for engine in engines:
        try:
            versions[engine] = get_engine(engine).version()
        except ValueError:  # not a registered engine (e.g. scipy measured beside them)
            versions[engine] = _package_version(engine)
    threads = os.environ.get("OMP_NUM_THREADS", "1")
    env = store.environment(versions, {case: digest}, int(threads) if threads.isdigit() else 1)
    return {"run_id": store.new_run_id(), "kind": "bench", "bench": name,
            "command": "refsim bench " + name + (" --quick" if quick else ""),
            "argv": sys.argv, "options": {"quick": quick}, "status": "running", **env}


def _package_version(name: str) -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(name)
    except PackageNotFoundError:
        return "unknown"


def store_bench(name: str, main, figures: list[dict], quick: bool, out, wall_s: float):
    """The stored run of one bench's figures under `out`; returns the RunStore."""
    case, digest = BENCH_PREFIX + name, source_hash(main)
    engines = list(dict.fromkeys(f["engine"] for f in figures if f.get("engine")))
    st = store.RunStore.create(out, bench_manifest(name, quick, case, digest, engines))
    versions = st.manifest["engines"]
    store_rows(st, figure_rows(figures, case, st.manifest["run_id"], versions),
               figure_definitions(figures, case, digest))
    st.update_manifest(status="complete", wall_s=round(wall_s, 2))
    return st


def run_bench(name: str, quick: bool, out=None) -> int:
    """`refsim bench NAME`: run the bench (it prints its figures), store them as a run under
    `out` (default reports/runs) and print the run directory. A bench whose main returns an
    exit code (the contract before figures were stored) stores nothing."""
    from refsim.registry import entry
    main = entry("bench", name).load()
    t0 = time.perf_counter()
    figures = main(quick=quick)
    if isinstance(figures, int):
        return figures
    st = store_bench(name, main, check_figures(figures, name), quick, out or store.DEFAULT_ROOT,
                     time.perf_counter() - t0)
    print(st.dir)
    return 0
