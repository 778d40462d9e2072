"""`refsim report RUN_DIR`: report.md and report.html of a stored run (refsim.report.build)."""
from __future__ import annotations

from pathlib import Path

from refsim.report.build import write_report

HELP = "report.md and a self-contained report.html from a stored run"


def add_arguments(parser) -> None:
    parser.add_argument("run_dir", metavar="RUN_DIR", help="a stored run (or its id under "
                        "reports/runs)")
    parser.add_argument("--target-error", default=None, help="accuracy goal for the "
                        "recommendation, in each case's error units (default: per case)")
    parser.add_argument("--out", default=None, help="directory for the report (default RUN_DIR)")


def main(args) -> int:
    from refsim.store.runs import open_run
    run_dir = open_run("RUN_DIR", args.run_dir).dir
    from refsim.options import number
    target = None if args.target_error is None else number("--target-error", args.target_error)
    md, page = write_report(run_dir, target, Path(args.out) if args.out else None)
    print(md)
    print(page)
    return 0
