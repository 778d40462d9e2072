"""python -m refsim_adapters.planted_defects [--defect NAME ...] [--case NAME ...]
[--quick] [--workers N] [--out CSV]: runs each planted defect where it matters (and the control
engine on the same jobs) and prints which defects the verdicts catch (see driver)."""
from __future__ import annotations

import argparse

from .driver import false_alarms, render, run
from .engines import DEFECTS


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m refsim_adapters.planted_defects",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--defect", action="append", choices=[d for d in DEFECTS
                                                              if d != "control"],
                        help="a defect to run (repeatable; default: all)")
    parser.add_argument("--case", action="append", help="a case to run (repeatable; "
                        "default: every case of the default matrix)")
    parser.add_argument("--quick", action="store_true",
                        help="the quick matrix: each case's reference dt and quick variants")
    parser.add_argument("--workers", type=int, default=2,
                        help="processes (default 2; 1 runs in this process)")
    parser.add_argument("--out", help="also write every row (defects and control) to this "
                        "CSV file")
    args = parser.parse_args(argv)
    summaries, table, seconds = run(args.defect, args.case, args.quick, args.workers)
    if args.out:
        table.to_csv(args.out, index=False)
    print(render(summaries, false_alarms(table), seconds, len(table)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
