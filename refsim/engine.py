"""The contract every engine adapter implements (the in-house `refsim` engine included).

Contract for an implementer (subclass `Engine` and `Sim`):
1. `Engine.name`, `capabilities` (scene features it simulates), `dims` (2, 3 or both) and
   `integrators` (names it offers) are class attributes;
2. `available()` says whether the engine package imports; `version()` gives its version;
3. `supports(scene, integrator)` returns None or one specific sentence saying why not;
4. `variants(scene)` names alternative formulations of the same scene ("" is the default);
5. `build(scene, dt, integrator, variant)` returns a `Sim` at t = 0; model compilation goes in
   `Sim.compile_s`, never in stepping;
6. `Sim.step(n)` advances n steps of dt without observing; `Sim.observe()` returns
   {"t": float, "x": (nbody, 3) positions, "v": (nbody, 3) velocities} plus optional extras
   (e.g. "constraint": rod-length errors); `Sim.settings()` returns the effective engine
   parameters as JSON-serialisable data; `Sim.failure` holds a reason once the engine itself
   reports a breakdown (a solver failure, a silent reset), else None.
"""
from __future__ import annotations

import importlib


class Sim:
    dt: float = 0.0
    compile_s: float = 0.0
    failure: str | None = None

    def step(self, n: int) -> None:
        raise NotImplementedError

    def observe(self) -> dict:
        raise NotImplementedError

    def settings(self) -> dict:
        return {}

    def close(self) -> None:
        """Release engine resources (connections, kernels)."""


class Engine:
    name = "engine"
    package: str | None = None  # the Python package the engine needs
    capabilities: frozenset = frozenset()
    dims: tuple = (3,)
    integrators: tuple = ()

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
        missing = sorted(scene.features() - set(self.capabilities))
        if missing:
            return f"{self.name} does not simulate {', '.join(missing)}"
        if scene.dim not in self.dims:
            return f"{self.name} is {'/'.join(map(str, self.dims))}D only"
        if integrator is not None and integrator.partition(":")[0] not in self.integrators:
            return f"{self.name} offers no integrator {integrator!r}"
        return None

    def variants(self, scene) -> tuple[str, ...]:
        return ("",)

    def build(self, scene, dt: float, integrator: str, variant: str = "") -> Sim:
        raise NotImplementedError
