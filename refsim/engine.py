"""The contract every engine adapter implements (the in-house `refsim` engine included).

The base classes do the bookkeeping (scipy's `OdeSolver.step` / `_step_impl` split); a
subclass writes only the engine's own work. Contract for an implementer:
1. `Engine.name`, `parts` (scene part kinds it simulates, refsim.scene.PART_KINDS),
   `capabilities` (scene features it simulates), `dims` (2, 3 or both) and `integrators`
   (names it offers) are class attributes; `package` names the Python package it needs;
2. `available()` says whether that package imports; `version()` gives its version;
3. `supports(scene, integrator)` returns None or one specific sentence saying why not (the
   base checks parts, features, dimension and integrator; override `_supports` for more);
4. `variants(scene)` names alternative formulations of the same scene ("" is the default);
5. `_build(scene, dt, integrator, variant)` returns a `Sim` at t = 0. `build` validates dt,
   variant and support first (ValueError naming the parameter). Model compilation goes in
   `Sim.compile_s`, never in stepping;
6. `Sim._step_impl(n)` advances n >= 1 steps of dt without observing; `Sim.step(n)` validates
   n, does nothing once the sim has failed, counts steps (simulated time `time()` = steps x dt) and
   turns the exceptions listed in `Sim.failures` (and `EngineFailure`) into `Sim.failure`;
7. `Sim._observe()` returns the observables of refsim.observation (per part: "x", "v", ...;
   engine extras such as "constraint"); `observe()` adds "t";
8. `Sim.settings()` returns the effective engine parameters as JSON-serialisable data, with
   "integrator" an `IntegratorInfo` (or its dict): the order and symplecticity tolerances read.
A subclass may still override `step` and `observe` whole (a third-party engine written against
the first contract): then it keeps its own time and failure bookkeeping.
"""
from __future__ import annotations

import importlib
import math
from dataclasses import asdict, dataclass, is_dataclass


class EngineFailure(RuntimeError):
    """An engine's own report of a breakdown (solver failure, silent reset, full buffer)."""


@dataclass(frozen=True)
class IntegratorInfo:
    """What tolerances read of a stepper: its name, order and whether it is symplectic."""

    name: str
    order: float
    symplectic: bool = False
    implicit: bool = False

    @classmethod
    def of(cls, settings) -> "IntegratorInfo | None":
        """The integrator entry of `settings` (a dict or an IntegratorInfo), None if absent."""
        described = (settings or {}).get("integrator") if isinstance(settings, dict) else None
        if isinstance(described, cls):
            return described
        if isinstance(described, dict) and "order" in described:
            return cls(str(described.get("name", "")), float(described["order"]),
                       bool(described.get("symplectic", False)),
                       bool(described.get("implicit", False)))
        return None


def jsonable(value):
    """Settings as plain JSON data: dataclasses (IntegratorInfo...) become dicts."""
    if is_dataclass(value) and not isinstance(value, type):
        return jsonable(asdict(value))
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    return value


class Sim:
    dt: float = 0.0
    steps: int = 0
    compile_s: float = 0.0
    failure: str | None = None
    failures: tuple = ()  # exception types that mean the engine broke down (-> failure)

    def time(self) -> float:
        """Simulated time: steps x dt (never a running sum)."""
        return self.steps * self.dt

    def step(self, n: int) -> None:
        n = int(n)
        if n < 0:
            raise ValueError(f"n must be >= 0, got {n}")
        if self.failure or n == 0:
            return
        try:
            self._step_impl(n)
        except (EngineFailure, *self.failures) as exc:
            self.failure = f"{exc} at t={self.time():.6g}"
            return
        self.steps += n

    def _step_impl(self, n: int) -> None:
        raise NotImplementedError

    def observe(self) -> dict:
        return {"t": self.time(), **self._observe()}

    def _observe(self) -> dict:
        raise NotImplementedError

    def settings(self) -> dict:
        return {}

    def close(self) -> None:
        """Release engine resources (connections, kernels)."""


class Engine:
    name = "engine"
    package: str | None = None  # the Python package the engine needs
    parts: frozenset | None = None  # scene part kinds simulated (None: not declared)
    capabilities: frozenset = frozenset()
    dims: tuple = (3,)
    integrators: tuple = ()
    reference = False  # the in-house reference simulator: listed (and reported) first
    equivalents: dict = {}  # own integrator name -> the refsim stepper it equals on an
    #                         undamped spring (the stability search's theory), where it differs

    def available(self) -> bool:
        if self.package is None:
            return True
        try:
            importlib.import_module(self.package)
        except Exception:
            return False
        return True

    def version(self) -> str:
        if self.package is None:
            return ""
        try:
            from importlib.metadata import version
            return version(self.package)
        except Exception:
            return "unknown"

    def supports(self, scene, integrator: str | None = None) -> str | None:
        kinds = getattr(scene, "part_kinds", None)
        if self.parts is not None and kinds is not None:
            missing = sorted(kinds() - set(self.parts))
            if missing:
                return f"{self.name} does not simulate {', '.join(missing)}"
        missing = sorted(scene.features() - set(self.capabilities))
        if missing:
            return f"{self.name} does not simulate {', '.join(missing)}"
        if scene.dim not in self.dims:
            return f"{self.name} is {'/'.join(map(str, self.dims))}D only"
        if integrator is not None and integrator.partition(":")[0] not in self.integrators:
            return f"{self.name} offers no integrator {integrator!r}"
        return self._supports(scene, integrator)

    def _supports(self, scene, integrator: str | None) -> str | None:
        """Engine-specific reasons beyond parts, features, dimension and integrator."""
        return None

    def variants(self, scene) -> tuple[str, ...]:
        return ("",)

    def build(self, scene, dt: float, integrator: str, variant: str = "") -> Sim:
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite number > 0, got {dt}")
        forms = self.variants(scene)
        if variant not in forms:
            raise ValueError(f"{self.name} variant must be one of {list(forms)}, got "
                             f"{variant!r}")
        reason = self.supports(scene, integrator)
        if reason is not None:
            raise ValueError(reason)
        return self._build(scene, dt, integrator, variant)

    def _build(self, scene, dt: float, integrator: str, variant: str) -> Sim:
        raise NotImplementedError
