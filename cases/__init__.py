"""Canonical scenarios, one module each; adding a module with a `CASE` adds a case."""
from __future__ import annotations

import importlib
import pkgutil

_SKIP = {"data"}


def case_names() -> list[str]:
    return [m.name for m in pkgutil.iter_modules(__path__) if m.name not in _SKIP
            and not m.name.startswith("_")]


def get_case(name: str):
    names = case_names()
    if name not in names:
        raise ValueError(f"case must be one of {names}, got {name!r}")
    return importlib.import_module(f"cases.{name}").CASE
