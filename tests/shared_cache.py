"""The cases' memoised references shared by the pytest-xdist workers of one test session.

A case keeps its expensive pure computations (a converged reference trajectory, the per-step
defects a tolerance sums) in `functools.lru_cache`: once per process. Under `-n 2` both
workers computed such a value whenever tests needing it ran on both (measured on a subset of
the case tests: 37 s of 166 s computed twice, e.g. cloth_hang's reference, 14 s on each).
Here each module-level lru_cache'd function of a `refsim_cases` module is wrapped, in each
worker, by a cache on disk in the session's own temporary directory (the parent of the
workers' basetemps, which pytest makes afresh for every session), so that within one session
each value is computed once: the code cannot change during a session, and the key is the
function and its arguments. The first worker to need a value computes it under an exclusive
lock (fcntl, released if the worker dies); another needing it meanwhile waits instead of
computing it too, then reads it (pickle, exact). Nothing is shared between sessions.

Only arguments whose repr is their whole value are keys (numbers, strings, None, bools and
tuples of them): anything else (an array, whose repr is abridged) calls the function as
before, in this process only; so does a value pickle cannot write.
"""
from __future__ import annotations

import fcntl
import functools
import hashlib
import importlib
import pickle
import pkgutil
from pathlib import Path

import numpy as np

PLAIN = (int, float, str, bool, type(None), np.integer, np.floating)


def _plain(value) -> bool:
    if isinstance(value, tuple):
        return all(_plain(v) for v in value)
    return isinstance(value, PLAIN)


def shared(function, directory: Path):
    """`function` (lru_cache'd) computed once per session across processes for plain
    arguments, its values kept under `directory`; in this process an lru_cache of the same
    size answers first."""
    name = f"{function.__module__}.{function.__qualname__}"

    @functools.wraps(function)
    def compute(*args, **kwargs):
        if kwargs or not _plain(args):
            return function(*args, **kwargs)
        key = hashlib.sha256(repr((name, args)).encode()).hexdigest()[:40]
        path = directory / f"{key}.pickle"
        with open(directory / f"{key}.lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # another worker needing it meanwhile waits here
            if path.exists():
                return pickle.loads(path.read_bytes())
            value = function(*args)
            try:
                data = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
            except (pickle.PicklingError, TypeError, AttributeError):
                return value
            partial = path.with_suffix(".partial")
            partial.write_bytes(data)
            partial.replace(path)
            return value

    cached = functools.lru_cache(maxsize=function.cache_info().maxsize)(compute)
    cached.shared_from = function
    return cached


def share_case_caches(directory: Path) -> list[str]:
    """Wrap every module-level lru_cache'd function defined in a `refsim_cases` module (the
    module's global replaced, so that the case's own calls go through it); the names."""
    import refsim_cases
    directory.mkdir(parents=True, exist_ok=True)
    wrapped = []
    for info in pkgutil.walk_packages(refsim_cases.__path__, "refsim_cases."):
        module = importlib.import_module(info.name)
        for attr, value in list(vars(module).items()):
            if (isinstance(value, functools._lru_cache_wrapper)
                    and getattr(value, "__module__", None) == module.__name__
                    and not hasattr(value, "shared_from")):
                setattr(module, attr, shared(value, directory))
                wrapped.append(f"{module.__name__}.{attr}")
    return wrapped
