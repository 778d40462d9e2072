"""Query cases (issue 28): a batch of geometric queries with exact answers, no time stepping.

A query case is a SteadyCase whose one "step" answers the whole batch: the runner, the store,
the report and both verdicts take its rows as they take any case's. What it declares:

Contract for an implementer (a `QueryCase` subclass in cases/<group>/<case>.py):
1. `scene(p)`: a Scene holding one query part (refsim.scene.queries); `answers`: the answer
   names the case compares (each observed as "query.<name>", shapes in that module);
2. `exact(p)` -> {answer: array}: the exact answers (a closed form, or a brute-force oracle
   exact to round-off); it is computed once per parameter set;
3. `measures`: {results column: (units, meaning)}; `measure(p, answered, exact)` -> {column:
   float} for every measure (max distance error, normal angle, false negatives ...). The
   first measure is the tolerance column (err_max holds it too: the report's error axis);
4. `bounds(p, settings)` -> {column: (bound, reason)}: what a correct answer may differ by,
   per measure, under the engine's effective settings (its declared tolerances, margins,
   float width): round-off of the exact algorithm plus each stated term. Consistency holds
   only when every measure is within its bound (`consistency_checks` names the others);
5. `motion_scale(p)`: the size of the geometry in the tolerance column's units (a bound not
   below half of it is "unresolved"); `target_error(p)`: the accuracy a user asks for.

The row's `throughput` (refsim.run.job: bodies x steps / step_s) is queries per second here
(`bodies(p)` is the batch size); `setup_s` holds the engine's own setup (shape creation, a BVH
build where the engine builds one at setup), apart from the queries.

`QuerySim` is the Sim base of the engines' query groups: `step(n)` answers the batch n times
(each answer is the whole batch, the unit the timing pass times), `observe()` returns the last
answers ("query.<name>"), empty arrays before the first step.
"""
from __future__ import annotations

import json

import numpy as np

from refsim.case import SteadyCase
from refsim.engine import ModelGroup, Sim


class QueryCase(SteadyCase):
    answers: tuple = ()
    measures: dict = {}  # column -> (units, meaning); the first is the tolerance column

    # -- to implement -------------------------------------------------------------------------
    def exact(self, p) -> dict:
        raise NotImplementedError

    def measure(self, p, answered: dict, exact: dict) -> dict:
        raise NotImplementedError

    def bounds(self, p, settings) -> dict:
        raise NotImplementedError

    def batch(self, p) -> int:
        return len(self.scene(p).parts[0])

    # -- the Case hooks, from the above ---------------------------------------------------------
    @property
    def primary(self) -> str:
        return next(iter(self.measures))

    def observed(self, p):
        return self.primary, self.measures[self.primary][0]

    def bodies(self, p) -> int:
        return self.batch(p)

    def work(self, p, dt) -> float:
        return float(self.batch(p))

    def exact_cached(self, p) -> dict:
        key = json.dumps(p, sort_keys=True, default=str)
        cache = self.__dict__.setdefault("_exact", {})
        if key not in cache:
            cache.clear()  # one parameter set at a time: a job asks for one
            cache[key] = self.exact(p)
        return cache[key]

    def observables(self, p, obs) -> dict:
        """The last sample's answers (t = 1: after the one step)."""
        return {name: np.asarray(obs[f"query.{name}"][-1], float) for name in self.answers}

    def reference(self, p, t) -> dict:
        return self.exact_cached(p)

    def _measured(self, p, observed, reference) -> dict:
        """`measure` once per answered batch: the job asks for the error, then the columns."""
        memo = self.__dict__.get("_measure_memo")
        if memo is None or memo[0] is not observed or memo[1] is not reference:
            memo = (observed, reference, self.measure(p, observed, reference))
            self.__dict__["_measure_memo"] = memo
        return memo[2]

    def error(self, p, observed, reference) -> np.ndarray:
        """One value: the tolerance column's measure of the answered batch."""
        return np.array([self._measured(p, observed, reference)[self.primary]])

    def extra_metrics(self, p, obs, observed, reference) -> dict:
        return {**self._measured(p, observed, reference), "queries": self.batch(p)}

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        return self.bounds(p, settings or {})[self.primary]

    def answer_checks(self, p, answered: dict, exact: dict, settings) -> list[str]:
        """Reasons where answers leave their OWN bounds (a batch maximum can hide a wrong
        answer on a pair whose bound is tight behind another pair's loose one); [] by
        default."""
        return []

    def consistency_checks(self, p, row: dict, settings, stacked=None) -> list[str]:
        """Every measure beyond the first outside its bound, and `answer_checks` on the
        answers (when the run's observations are given), as reasons."""
        out = [] if stacked is None else self.answer_checks(
            p, self.observables(p, stacked), self.exact_cached(p), settings or {})
        for column, (bound, why) in self.bounds(p, settings or {}).items():
            if column == self.primary:
                continue
            value = row.get(column, float("nan"))
            if not value <= bound:
                out.append(f"{column} {value:.3g} beyond its bound {bound:.3g} ({why})")
        return out

    def definition(self, variant, p) -> dict:
        return {**super().definition(variant, p), "query": True,
                "measures": {k: list(v) for k, v in self.measures.items()},
                # the report's results table shows every measure, the batch and its rate
                "report_columns": [*self.measures, "queries", "throughput"]}


class QuerySim(Sim):
    """A query scene's Sim: `answer()` -> {name: array} answers the whole batch; `names` the
    answers it gives (observed empty before the first step)."""

    names: tuple = ()
    dt = 1.0

    def __init__(self, dt: float = 1.0):
        self.dt = float(dt)
        self._answers = None

    def answer(self) -> dict:
        raise NotImplementedError

    def _step_impl(self, n: int) -> None:
        for _ in range(n):
            self._answers = self.answer()

    def _observe(self) -> dict:
        if self._answers is None:
            return {f"query.{name}": np.zeros(0) for name in self.names}
        return {f"query.{name}": value for name, value in self._answers.items()}


def query_group(name: str, part_classes, build, **extra) -> ModelGroup:
    """The ModelGroup of an engine's query group (adapters/<engine>/groups/collision_*.py): it
    claims a scene holding one of `part_classes` (refsim.scene.queries), simulates those part
    kinds and the feature "queries", offers the one integrator "query" and builds with
    `build`; `extra`: its formulations and supports, as ModelGroup takes them."""
    classes = tuple(part_classes)
    return ModelGroup(name=name, build=build,
                      claims=lambda scene: any(scene.part(c) is not None for c in classes),
                      parts=frozenset(c.kind for c in classes),
                      features=frozenset({"queries"}), integrators=("query",), **extra)
