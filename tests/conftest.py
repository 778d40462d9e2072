"""The `slow` marker from measured durations: a test whose setup, call and teardown took
SLOW_S or more in the last measured suite (tests/durations.json, written by
tests/durations.py) is marked `slow`, besides those marked by hand, so that
`pytest -m "not slow"` is the quick loop (under 3 minutes on 2 cores) and the whole suite
stays the README's command."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

SLOW_S = 0.5  # s; the quick loop's tests take 0.1 s on average, the rest up to a minute
MEASURED = json.loads((Path(__file__).with_name("durations.json")).read_text())


def pytest_collection_modifyitems(config, items):
    for item in items:
        if MEASURED.get(item.nodeid, 0.0) >= SLOW_S:
            item.add_marker(pytest.mark.slow)
