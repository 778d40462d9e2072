"""The contract every engine adapter implements (the in-house `refsim` engine included).

An engine is who it is plus the model groups it runs. Contract for an implementer:
1. The `Engine` subclass declares only its identity, as class attributes: `name`, `package`
   (the Python package it needs), `dims` (2, 3 or both), `integrators` (names it offers),
   `reference`, `equivalents`, and `refusals` (part kind or feature -> one sentence saying why
   the engine does not run it: data, not code); `available()` and `version()` come from the
   base;
2. every scene runs through a model group (`ModelGroup`): the group that `claims` the scene
   gives its `parts` and `features` (checked by `supports`, with the dimension and the
   integrator), its own `supports` reasons, its `formulations` (named alternatives of the
   same model, "" the default) and `build(engine, scene, dt, integrator, formulation)` -> a
   `Sim` at t = 0. `Engine.build` validates dt, the formulation and support first
   (ValueError naming the parameter). A scene no group claims is refused with the engine's
   `refusals` entry for its first part kind or feature, or a generic sentence;
3. the groups are the modules of the engine package's `groups/` subpackage that define
   `MODEL_GROUP = ModelGroup(...)` (found by `discover_groups`, in module-name order: a new
   group is a new file, no edit to the engine), after any declared in the class
   (`Engine.groups`, for a small third-party engine). The first group claiming a scene runs it.
   Group modules import the engine's package lazily, like adapters;
4. `Sim._step_impl(n)` advances n >= 1 steps of dt without observing; `Sim.step(n)` validates
   n, does nothing once the sim has failed, counts steps (simulated time `time()` = steps x dt) and
   turns the exceptions listed in `Sim.failures` (and `EngineFailure`) into `Sim.failure`.
   Model compilation goes in `Sim.compile_s`, never in stepping;
5. `Sim._observe()` returns the observables of refsim.observation (per part: "x", "v", ...;
   engine extras such as "constraint"); `observe()` adds "t";
6. `Sim.settings()` returns the effective engine parameters as JSON-serialisable data, with
   "integrator" an `IntegratorInfo` (or its dict): the order and symplecticity tolerances read.
A subclass may still override `step` and `observe` whole (a third-party engine written against
the first contract): then it keeps its own time and failure bookkeeping.
"""
from __future__ import annotations

import functools
import importlib
import pkgutil
from dataclasses import asdict, dataclass, field, is_dataclass
from typing import Callable

from refsim.integrators.spec import spec_name
from refsim.options import number


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


@dataclass(frozen=True)
class ContactInfo:
    """What contact tolerances read of an engine's settings: the contact model ("impulse":
    Newton restitution at the impact; "soft": a spring-damper whose restitution comes from a
    damping ratio), the detection ("discrete" at the end of a step, or "continuous"), the
    soft contact's calibration residual |e_obtained - e| and its contact duration (s); its
    sink factor, the share of the spring's static sink a0 / K that remains (1 for a plain
    spring-damper; (1 - d) / d where the solver blends a = d aref + (1 - d) a0, as MuJoCo's
    impedance d does), and whether its friction rows are soft too (a tangential slip damped
    at rate B = 2 pi / T_c: a creep (1 - d) a0_t / (d B) remains)."""

    model: str = "impulse"
    detection: str = "discrete"
    restitution_residual: float = 0.0
    duration_s: float = 0.0
    sink_factor: float = 1.0
    soft_friction: bool = False

    @classmethod
    def of(cls, settings) -> "ContactInfo":
        """From an engine's settings dict (keys contact_model, detection, restitution_mapping
        .residual_max, contact_duration_s, contact_sink_factor, contact_soft_friction); the
        defaults where absent."""
        s = settings if isinstance(settings, dict) else {}
        mapping = s.get("restitution_mapping", {})
        residual = mapping.get("residual_max", 0.0) if isinstance(mapping, dict) else 0.0
        return cls(str(s.get("contact_model", "impulse")), str(s.get("detection", "discrete")),
                   float(residual), float(s.get("contact_duration_s", 0.0)),
                   float(s.get("contact_sink_factor", 1.0)),
                   bool(s.get("contact_soft_friction", False)))

    @property
    def soft(self) -> bool:
        return self.model == "soft"


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


def _claims_nothing(scene) -> bool:
    return False


@functools.lru_cache(maxsize=None)
def installed_version(package: str) -> str:
    """The installed distribution's version, read once per process (every job's row records
    it; parsing the metadata took 9 ms a call, a fifth of a short MuJoCo job)."""
    try:
        from importlib.metadata import version
        return version(package)
    except Exception:
        return "unknown"


@dataclass(frozen=True)
class ModelGroup:
    """One model group of an engine, declared as MODEL_GROUP in adapters/<engine>/groups/<x>.py.

    name: the group (e.g. "rigid"); claims(scene): whether this group runs the scene (e.g. it
    holds rigid bodies); parts / features: the scene part kinds and features it simulates
    (None: not checked, `supports` alone answers, as for a group that only refuses);
    build(engine, scene, dt, integrator, formulation) -> Sim; supports(engine, scene,
    integrator) -> None or the reason; formulations(engine, scene) -> the formulation names
    (default ("",));
    integrators: the names it offers (None: the engine's)."""

    name: str
    build: Callable
    claims: Callable = _claims_nothing
    parts: frozenset = frozenset()
    features: frozenset = frozenset()
    supports: Callable | None = None
    formulations: Callable | None = None
    integrators: tuple | None = None
    module: str = field(default="", compare=False)


def discover_groups(engine_cls) -> tuple[ModelGroup, ...]:
    """MODEL_GROUP of every module in the `groups` subpackage of the engine class's package
    (none when there is no such subpackage), in module-name order."""
    package = engine_cls.__module__.rpartition(".")[0]
    try:
        groups_pkg = importlib.import_module(f"{package}.groups") if package else None
    except ModuleNotFoundError as exc:
        if exc.name != f"{package}.groups":
            raise
        return ()
    if groups_pkg is None:
        return ()
    out = []
    for info in sorted(pkgutil.iter_modules(groups_pkg.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{groups_pkg.__name__}.{info.name}")
        group = getattr(module, "MODEL_GROUP", None)
        if isinstance(group, ModelGroup):
            out.append(ModelGroup(**{**group.__dict__, "module": module.__name__}))
    return tuple(out)


class Engine:
    """Who an engine is: its name, the package it needs, its dimensions and integrators, and
    why it refuses the scene kinds it does not run (`refusals`). What it runs is its model
    groups (the groups/ modules of its package): every scene goes to the group that claims it."""

    name = "engine"
    package: str | None = None  # the Python package the engine needs
    dims: tuple = (3,)
    integrators: tuple = ()
    reference = False  # the in-house reference simulator: listed (and reported) first
    peer = False  # an optional peer for a few cases: run only where named (--engine NAME),
    #               never by a plain `refsim run` (its rows elsewhere are refusals)
    equivalents: dict = {}  # own integrator name -> the refsim stepper it equals on an
    #                         undamped spring (the stability search's theory), where it differs
    refusals: dict = {}  # part kind or feature -> the sentence saying why the engine refuses it
    groups: tuple = ()  # model groups declared in the class (a small third-party engine's);
    #                     the groups/ modules of the engine's package are found without it

    def available(self) -> bool:
        if self.package is None:
            return True
        try:
            importlib.import_module(self.package)
        except Exception:
            return False
        return True

    def version(self) -> str:
        return "" if self.package is None else installed_version(self.package)

    # -- model groups -----------------------------------------------------------------------
    @classmethod
    def model_groups(cls) -> tuple[ModelGroup, ...]:
        if "_groups" not in cls.__dict__:
            cls._groups = tuple(cls.groups) + discover_groups(cls)
        return cls._groups

    def group_for(self, scene) -> ModelGroup | None:
        """The model group (groups/ modules) that runs `scene`, None when none claims it."""
        return next((g for g in self.model_groups() if g.claims(scene)), None)

    def offered_integrators(self, scene=None) -> tuple:
        group = self.group_for(scene) if scene is not None else None
        return group.integrators if group is not None and group.integrators is not None \
            else self.integrators

    # -- support ------------------------------------------------------------------------------
    def refusal(self, scene) -> str:
        """Why no model group runs `scene`: the `refusals` entry of its first part kind or
        feature found there (part kinds first, each in sorted order), else a generic sentence."""
        kinds, features = sorted(scene.part_kinds()), sorted(scene.features())
        for key in (*kinds, *features):
            if key in self.refusals:
                return self.refusals[key]
        return f"{self.name} has no model group for a scene of {', '.join(kinds)}" + \
            (f" with {', '.join(features)}" if features else "")

    def supports(self, scene, integrator: str | None = None) -> str | None:
        group = self.group_for(scene)
        if group is None:
            return self.refusal(scene)
        parts, features = group.parts, group.features
        missing = sorted(scene.part_kinds() - set(parts)) if parts is not None else []
        missing = missing or (sorted(scene.features() - set(features))
                              if features is not None else [])
        if missing:  # the engine's own sentence for what its group lacks, where it has one
            said = next((self.refusals[k] for k in missing if k in self.refusals), None)
            return said or f"{self.name} does not simulate {', '.join(missing)}"
        if scene.dim not in self.dims:
            return f"{self.name} is {'/'.join(map(str, self.dims))}D only"
        offered = self.offered_integrators(scene)
        if integrator is not None and spec_name(integrator) not in offered:
            return f"{self.name} offers no integrator {integrator!r}"
        return group.supports(self, scene, integrator) if group.supports else None

    def formulations(self, scene) -> tuple[str, ...]:
        """The scene's formulations (named alternatives of the same model; "" the default):
        its model group's."""
        group = self.group_for(scene)
        if group is None or group.formulations is None:
            return ("",)
        return group.formulations(self, scene)

    def matrix_formulations(self, scene) -> tuple[str, ...]:
        """The formulations `refsim run` puts in its matrix: all of them (`formulations`),
        unless an engine leaves out one that the run's own settings make a copy of another
        (taichi's `parallel` kernel on one thread). They stay buildable by name."""
        return self.formulations(scene)

    def build(self, scene, dt: float, integrator: str, formulation: str = "") -> Sim:
        dt = number("dt", dt, unit="s")
        forms = self.formulations(scene)
        if formulation not in forms:
            raise ValueError(f"{self.name} formulation must be one of {list(forms)}, got "
                             f"{formulation!r}")
        reason = self.supports(scene, integrator)
        if reason is not None:
            raise ValueError(reason)
        return self.group_for(scene).build(self, scene, dt, integrator, formulation)
