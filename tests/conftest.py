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


def pytest_configure(config):
    """Under pytest-xdist, each case's memoised references computed once per session for all
    workers (tests/shared_cache.py), in the session's temporary directory: the workers'
    basetemps are its children."""
    workerinput = getattr(config, "workerinput", None)
    if workerinput is not None and config.option.basetemp:
        from shared_cache import share_case_caches
        share_case_caches(Path(config.option.basetemp).parent / "case-caches")
