"""Writes tests/durations.json from pytest's `--durations=0` output: seconds per test (setup,
call and teardown summed), the measure tests/conftest.py marks `slow` from.

    python -m pytest -q -n 2 --dist worksteal --durations=0 > durations.txt
    python tests/durations.py durations.txt

Measured on a 2-core machine under the suite's own load; a test not listed (new since, or
under KEEP_S) counts as quick until the file is written again.
"""
from __future__ import annotations

import json
import re
import sys
from collections import Counter
from pathlib import Path

KEEP_S = 0.1  # quicker tests are left out (they are quick whatever the machine)
LINE = re.compile(r"\s*([\d.]+)s (?:call|setup|teardown)\s+(\S+)")


def durations(text: str) -> dict:
    total = Counter()
    for line in text.splitlines():
        found = LINE.match(line)
        if found:
            total[found.group(2)] += float(found.group(1))
    return {node: round(seconds, 2) for node, seconds in sorted(total.items())
            if seconds >= KEEP_S}


if __name__ == "__main__":
    measured = durations(Path(sys.argv[1]).read_text())
    out = Path(__file__).with_name("durations.json")
    out.write_text(json.dumps(measured, indent=0, sort_keys=True) + "\n")
    print(f"{len(measured)} tests, {sum(measured.values()):.0f} s -> {out}")
