"""Finds engines, cases and benches: the entry-point groups `refsim.engines`, `refsim.cases`
and `refsim.benches`.

The only core module that knows where engines and cases live. An installed distribution
declares its own in its metadata, as pytest plugins declare `pytest11`:

    [project.entry-points."refsim.engines"]
    my_engine = "my_pkg.engine:MyEngine"          # an Engine subclass (built with no arguments)
    [project.entry-points."refsim.cases"]
    my_case = "my_pkg.cases:CASE"                 # a Case instance
    [project.entry-points."refsim.benches"]
    my_bench = "my_pkg.bench:main"                # main(quick) -> list of figure dicts

refsim's own engines and cases are declared the same way in its pyproject. `register` adds
one at run time (a test's engine class); it never replaces a name already known. Targets are
loaded lazily: listing names imports no engine package.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from functools import lru_cache
from importlib.metadata import entry_points

GROUPS = {"engine": "refsim.engines", "case": "refsim.cases", "bench": "refsim.benches"}
BUILTIN = "refsim"  # the distribution whose entries come first, in their declared order


@dataclass(frozen=True)
class Entry:
    name: str
    target: str  # "module:attribute"
    origin: str  # "refsim 0.1.0", "my-engines 1.2 (entry point)", "registered at run time"

    def load(self):
        module, _, attr = self.target.partition(":")
        obj = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj


_RUNTIME: dict[str, dict[str, Entry]] = {kind: {} for kind in GROUPS}


@lru_cache(maxsize=None)
def _installed(kind: str) -> tuple[Entry, ...]:
    """Entries of one group from every installed distribution: refsim's first, then the rest
    by distribution name; the first of two entries with one name wins."""
    found = []
    for ep in entry_points(group=GROUPS[kind]):
        dist = getattr(ep, "dist", None)
        dname = dist.metadata["Name"] if dist is not None else "?"
        version = dist.version if dist is not None else ""
        found.append((dname != BUILTIN, dname, Entry(ep.name, ep.value,
                                                     f"{dname} {version}".strip())))
    found.sort(key=lambda item: item[:2])  # stable: keeps each distribution's own order
    out, seen = [], set()
    for _, _, entry in found:
        if entry.name not in seen:
            seen.add(entry.name)
            out.append(entry)
    return tuple(out)


def entries(kind: str) -> dict[str, Entry]:
    out = {e.name: e for e in _installed(kind)}
    for name, entry in _RUNTIME[kind].items():
        out.setdefault(name, entry)
    return out


def names(kind: str) -> list[str]:
    return list(entries(kind))


def entry(kind: str, name: str) -> Entry:
    known = entries(kind)
    if name not in known:
        raise ValueError(f"{kind} must be one of {list(known)}, got {name!r}")
    return known[name]


def register(kind: str, name: str, target: str) -> None:
    """Add `name` -> "module:attribute" for this process. A name known from an installed
    distribution is never replaced (ValueError); a run-time one is."""
    if kind not in GROUPS:
        raise ValueError(f"kind must be one of {list(GROUPS)}, got {kind!r}")
    if any(e.name == name for e in _installed(kind)):
        raise ValueError(f"{kind} {name!r} is already installed "
                         f"({entry(kind, name).origin}): choose another name")
    _RUNTIME[kind][name] = Entry(name, target, "registered at run time")


def unregister(kind: str, name: str) -> None:
    """Forget a run-time registration (installed entries stay)."""
    _RUNTIME[kind].pop(name, None)


def refresh() -> None:
    """Forget the cached entry points (after installing a distribution in this process)."""
    _installed.cache_clear()
    importlib.invalidate_caches()


# -- the two kinds, by name ---------------------------------------------------------------------
def engine_names() -> list[str]:
    """Engine names, the in-house reference engine(s) (`Engine.reference`) first, the rest in
    their distributions' order (setuptools writes entry points sorted by name)."""
    known = names("engine")
    return sorted(known, key=lambda n: not getattr(entry("engine", n).load(), "reference",
                                                   False))


def case_names() -> list[str]:
    return names("case")


def get_engine(name: str):
    """A fresh Engine instance of the engine registered as `name`."""
    return entry("engine", name).load()()


@lru_cache(maxsize=None)
def _case(name: str, target: str):
    return entry("case", name).load()


def get_case(name: str):
    """The Case instance registered as `name`."""
    return _case(name, entry("case", name).target)
