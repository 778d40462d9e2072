"""`refsim list | run | report | stress | compare | bench`: the command line, one module per
command in this package.

Bad input (an unknown name, dt <= 0, a non-finite or out-of-range parameter) prints one line
naming the parameter and the valid values, and exits with code 2.
"""
from __future__ import annotations

import os
import sys


def _pin_threads(argv) -> int:
    """BLAS/OpenMP threads must be set before numpy loads: read --threads early (default 1)."""
    threads = "1"
    for k, arg in enumerate(argv):
        if arg == "--threads" and k + 1 < len(argv):
            threads = argv[k + 1]
        elif arg.startswith("--threads="):
            threads = arg.split("=", 1)[1]
    if not threads.isdigit() or int(threads) < 1:
        threads = "1"
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, threads)
    return int(threads)


THREADS = _pin_threads(sys.argv)

import argparse  # noqa: E402
import importlib  # noqa: E402


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        _fail(message)


def _fail(message: str, code: int = 2):
    print(f"refsim: error: {message}", file=sys.stderr)
    raise SystemExit(code)


# one module per command (refsim.cli.<command>): HELP, add_arguments(parser), main(args) -> code
COMMANDS = ("list", "run", "report", "stress", "compare", "bench")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="refsim", description="Reference validation and benchmarking of "
                     "physics engines against exact, converged or experimental references.")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    for name in COMMANDS:
        module = importlib.import_module(f"refsim.cli.{name}")
        module.add_arguments(sub.add_parser(name, help=module.HELP))
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    args.argv = argv
    try:
        if args.command in COMMANDS:
            return importlib.import_module(f"refsim.cli.{args.command}").main(args)
    except ValueError as exc:
        _fail(str(exc).splitlines()[0])
    except KeyboardInterrupt:
        print("\nrefsim: interrupted; finished rows are saved (resume with --resume RUN_ID)",
              file=sys.stderr)
        return 130
    build_parser().print_help()
    return 2


if __name__ == "__main__":
    sys.exit(main())
