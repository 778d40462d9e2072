"""The Case contract: one canonical scenario with its scene, reference, metrics and tolerances.

Contract for an implementer (one module in `cases/`, one `Case` subclass instance named CASE):
1. `name`, `description`, `tags`, `observable` (the compared quantity) and `units`;
2. `params`: {name: Param(default, low, high, doc)} validated by `validate`; `variants`:
   {variant name: parameter overrides}, the first being the default;
3. `scene(p)` builds the engine-neutral Scene; `t_end(p)`, `sample_dt(p)`, `dts(p)` (the dt
   sweep, halving) and `reference_dt(p)`;
4. `observables(p, obs)` maps stacked engine observations {"t", "x", "v", ...} to named arrays;
   `reference(p, t)` returns the same names from the exact/converged/experimental reference;
5. `energy(p, obs)` (None where energy means nothing) and `energy_scale(p)`;
6. `tolerance(p, integrator, order, dt, engine_variant, settings)` returns (bound, reason):
   the error (in `tolerance_column(p)`) a correct implementation of the NAMED method must
   stay within at this dt — its exact discrete solution's error where the case has one
   (`refsim.expected`), else the method's error constant times the case's stated
   sensitivity with one stated safety factor <= 3, plus round-off (`roundoff_tolerance`).
   It is only asked for a method refsim defines (`refsim.integrators.method_info`); `order`
   is that method's nominal order and `settings["integrator"]` that method's description
   (so `is_symplectic(settings)` is the method's property); the other settings are the
   engine's effective ones (a formulation, a penalty stiffness) and may add a stated term.
   `target_error(p)` is the case's "good enough", the other verdict;
7. `order_meaningful` (False where no convergence order in dt exists, e.g. impulses resolved
   exactly) and `figures(p)`: extra report figures as data (see `figures`), so the report asks
   the case and never branches on its name. `definition(variant, p)` is what the store keeps of
   the case as run; `report` and `compare` read that, not today's code.
"""
from __future__ import annotations

import hashlib
import inspect
import math
from dataclasses import dataclass

import numpy as np

from refsim.integrators.spec import IntegratorSpec


@dataclass(frozen=True)
class Param:
    default: float | str
    low: float = -math.inf
    high: float = math.inf
    doc: str = ""
    low_inclusive: bool = True
    choices: tuple = ()  # a categorical parameter: one of these strings

    def check(self, name: str, value):
        if self.choices:
            if str(value) not in self.choices:
                raise ValueError(f"{name} must be one of {list(self.choices)}, got {value!r}")
            return str(value)
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a number in {self.range_text()}, got {value!r}") \
                from None
        low_ok = value >= self.low if self.low_inclusive else value > self.low
        if not math.isfinite(value) or not low_ok or value > self.high:
            raise ValueError(f"{name} must be in {self.range_text()}, got {value}")
        return value

    def range_text(self) -> str:
        return f"{'[' if self.low_inclusive else '('}{self.low:g}, {self.high:g}]"


class Case:
    name = "case"
    description = ""
    tags: tuple = ()
    observable = ""
    units = ""
    params: dict = {}
    variants: dict = {"default": {}}
    quick_variants: tuple = ("default",)
    default_variants: tuple = ()  # what a plain `refsim run` covers; () means every variant
    # the variants on which a plain `refsim run` also runs the engines' alternative
    # formulations (at the reference dt); () means every variant. --full, or naming the
    # variant, runs them everywhere
    alternatives_variants: tuple = ()
    divergence_factor = 100.0  # |E - E0| beyond this many energy scales: diverged
    tolerance_norm = "err_max"  # the error column the tolerance bounds
    samples = 400  # about this many observations per run (every step when fewer steps)

    # -- parameters ---------------------------------------------------------------------------
    def validate(self, overrides: dict | None = None) -> dict:
        overrides = dict(overrides or {})
        unknown = sorted(set(overrides) - set(self.params))
        if unknown:
            raise ValueError(f"{self.name} parameter must be one of {sorted(self.params)}, "
                             f"got {unknown[0]!r}")
        p = {k: spec.default for k, spec in self.params.items()}
        for key, value in overrides.items():
            p[key] = self.params[key].check(f"{self.name}.{key}", value)
        return p

    def variant_params(self, variant: str, overrides: dict | None = None) -> dict:
        if variant not in self.variants:
            raise ValueError(f"{self.name} variant must be one of {list(self.variants)}, "
                             f"got {variant!r}")
        return self.validate({**self.variants[variant], **(overrides or {})})

    # -- to implement -------------------------------------------------------------------------
    def scene(self, p):
        raise NotImplementedError

    def t_end(self, p) -> float:
        raise NotImplementedError

    def dts(self, p) -> list[float]:
        raise NotImplementedError

    def reference_dt(self, p) -> float:
        raise NotImplementedError

    def order_dts(self, p) -> list[float]:
        """Steps run for the convergence-order fit only (accuracy pass, no timing), beyond
        `dts(p)`, so that the fit spans a decade of dt above the error floor."""
        return []

    def observables(self, p, obs) -> dict:
        raise NotImplementedError

    def reference(self, p, t) -> dict:
        raise NotImplementedError

    def energy(self, p, obs):
        return None

    def energy_scale(self, p) -> float:
        return 1.0

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        raise NotImplementedError

    def motion_scale(self, p) -> float:
        """Size of the motion in the observable's units (amplitude, release angle, ...)."""
        return 1.0

    def target_error(self, p) -> float:
        """The report's default accuracy goal in the tolerance column's units: the cheapest
        configuration reaching it is recommended. 1e-4 of the motion unless a case says."""
        return 1e-4 * self.motion_scale(p)

    # -- shared -------------------------------------------------------------------------------
    def error_floor(self, p) -> float:
        """Errors below this are round-off: left out of convergence-order fits."""
        return 1e-11 * self.motion_scale(p)

    def error_ceiling(self, p) -> float:
        """Errors above this are pre-asymptotic (or unstable): left out of order fits."""
        return 0.1 * self.motion_scale(p)

    def reference_energy(self, p, t):
        """The exact energy at times t where it is not E(0) (a damped or decaying case), for
        `energy_drift`; None (the default): E(0) is the reference."""
        return None

    def energy_mask(self, p, t):
        """Which samples `energy_drift` reads (e.g. outside the impacts of a soft contact);
        None (the default): all of them."""
        return None

    def stability(self, p):
        """The case's stability parameter for `refsim stress` (a refsim.stress.spec
        StabilitySpec); None (the default): the case declares none."""
        return None

    def energy_period(self, p, settings=None) -> float | None:
        """None (the default): the case claims no energy behaviour. A period P (s): the exact
        flow conserves the case's `energy` (no dissipation, no external work, no contacts),
        and in the formulation `settings` declares a symplectic method stays symplectic on it
        (a separable Hamiltonian in canonical coordinates), so a symplectic method's energy
        error stays bounded, oscillating with a period of at most P (the motion's period:
        the energy error of a 1-DOF orbit is a function of its phase). The verdicts then
        read the energy's behaviour (refsim.verdicts.energy_reason)."""
        return None

    def sample_dt(self, p) -> float:
        return self.t_end(p) / self.samples

    def observed(self, p) -> tuple[str, str]:
        """(observable, units) compared for these parameters (a sub-case may differ)."""
        return self.observable, self.units

    def bodies(self, p) -> int:
        """How many bodies or particles the scene moves (for ordering jobs by their work)."""
        return 1

    def work(self, p, dt) -> float:
        """Body-steps of one run at dt: the runner starts the largest first."""
        return self.bodies(p) * self.t_end(p) / dt

    def source_hash(self) -> str:
        """Hash of the source of every module the case is built from: its own and its base
        classes' outside refsim.case (e.g. a shared cases/spheres/_impact.py), and the modules
        of its own package those import from (e.g. a shared bounds helper,
        cases/rigid/_bounds.py), so that an edit to a shared helper module changes the hash of
        every case using it."""
        modules = dict.fromkeys(inspect.getmodule(k) for k in type(self).__mro__
                                if k.__module__ not in (__name__, "builtins"))
        for module in list(modules):
            modules.update(dict.fromkeys(_package_imports(module)))
        source = "".join(inspect.getsource(m) for m in modules if m is not None)
        return hashlib.sha256(source.encode()).hexdigest()[:16]

    order_meaningful = True  # a convergence order in dt means something for this case
    # the reference at t = 0 is the scene's initial state (a trajectory from it): the engine's
    # state reported at t = 0 must then match it to the error floor (a consistency check).
    # False where the reference is an end state (an equilibrium, a converged solve)
    initial_state_is_reference = True

    def figures(self, p) -> list[dict]:
        """Extra report figures, as JSON-serialisable data. One kind exists:
        {"kind": "trace_over_data", "title": str, "x": series key, "y": series key,
         "x_shift_column": results column added to x (or None), "x_label": str,
         "y_label": str, "data": {"x": [...], "y": [...], "label": str}}
        draws each row's stored series y(x) over measured points; and
        {"kind": "profile", "title": str, "panels": [{"y": observable (one vector per
         sample, stored at the last sample, at most 400 numbers), "x": coordinates, "x_label",
         "y_label", "data": {"x", "y", "label"}, "lines": [{"x", "y", "label"}] (optional,
         dashed)}]} draws each row's last profile over measured points. Any kind may add
        "shared": id (one figure for every case declaring that id, e.g. two models of one
        experiment side by side) and "legend_params": [parameter names]."""
        return []

    def definition(self, variant: str, p: dict) -> dict:
        """The case as run, for the store: everything the report and compare read."""
        observable, units = self.observed(p)
        return {"case": self.name, "variant": variant, "description": self.description,
                "tags": list(self.tags), "params": p, "observable": observable,
                "units": units, "tolerance_column": self.tolerance_column(p),
                "target_error": self.target_error(p), "error_floor": self.error_floor(p),
                "error_ceiling": self.error_ceiling(p), "energy_scale": self.energy_scale(p),
                "reference_dt": self.reference_dt(p), "order_meaningful": self.order_meaningful,
                "figures": self.figures(p), "source_hash": self.source_hash(),
                "model_group": module_group(type(self).__module__)}

    def tolerance_column(self, p) -> str:
        """The results column the tolerance bounds (by default `tolerance_norm`)."""
        return self.tolerance_norm

    def extra_metrics(self, p, obs: dict, observed: dict, reference: dict) -> dict:
        """Case-specific columns (e.g. momentum_drift, penetration_max) from a whole run."""
        return {}

    def consistency_checks(self, p, row: dict, settings, stacked=None) -> list[str]:
        """Further conditions of "consistent with its method" beyond the tolerance column's
        bound (e.g. a query case's other measures within theirs, or each answer within its own
        bound), as the reasons that fail: each makes a consistent row inconsistent. `stacked`:
        the run's observations, as observables() takes them. None by default."""
        return []

    def error(self, p, observed: dict, reference: dict) -> np.ndarray:
        """Error of the compared observable at each sample (Euclidean norm over components)."""
        diff = np.asarray(observed[self.observable]) - np.asarray(reference[self.observable])
        return np.abs(diff) if diff.ndim == 1 else np.linalg.norm(
            diff.reshape(len(diff), -1), axis=1)


class SteadyCase(Case):
    """A case whose reference is an end state reached by one complete solve (a linear
    system, an elastic equilibrium): one "step" of pseudo-time is the whole solve, t_end =
    dt = 1, no convergence order in dt, and the reference at t = 0 is not the initial state."""

    order_meaningful = False
    initial_state_is_reference = False

    def t_end(self, p):
        return 1.0

    def dts(self, p):
        return [1.0]

    def reference_dt(self, p):
        return 1.0


def module_group(module_name: str) -> str:
    """The model group of a case defined in `module_name`: its package's last component
    (refsim_cases.<group>.<case>), else the module's top-level name."""
    parts = module_name.split(".")
    return parts[-2] if len(parts) >= 3 else parts[0]


def _package_imports(module) -> list:
    """The modules of `module`'s own distribution package (its top-level package, e.g.
    refsim_cases: a case may share helpers with another model group's folder) that it imports
    names or modules from."""
    if module is None or "." not in module.__name__:
        return []
    package = module.__name__.split(".", 1)[0] + "."
    found = []
    for value in vars(module).values():
        source = value if inspect.ismodule(value) else inspect.getmodule(value)
        if source is not None and source is not module and \
                source.__name__.startswith(package):
            found.append(source)
    return found


def adaptive_rtol(integrator: str) -> float | None:
    """rtol of an adaptive integrator spec ('dopri5_adaptive:1e-9'), None for fixed steps."""
    parsed = IntegratorSpec.parse(integrator)
    if not parsed.name.endswith("_adaptive"):
        return None
    rtol = parsed.number("rtol > 0")
    return 1e-9 if rtol is None else rtol


ADAPTIVE_REASON = ("adaptive: local error held to rtol per step; the global error after omega t "
                   "radians grows at most like omega t * rtol (factor 10 for the controller's "
                   "safety margin)")


def order_tolerance(scale: float, omega_t: float, y: float, order: int,
                    symplectic: bool = False) -> float:
    """Error bound of an order-p one-step method on an oscillation, y = omega dt.

    Per step an order-p method errs by at most c y^(p+1) in amplitude and phase, with c <= 1/2
    for every stepper here (explicit and implicit Euler's amplitude factor (1 + y^2)^(+-1/2)).
    - Not symplectic: the amplitude error compounds over omega t / y steps,
      scale ((1 + y^(p+1))^(omega t / y) - 1) <= scale expm1(omega t y^p).
    - Symplectic: the numerical orbit is an exact orbit of a modified system whose shape and
      frequency differ by O(y^p): a bounded shape error plus a phase error growing linearly,
      scale (y^p + omega t y^q). The frequency error is of even order q = 2 ceil(p/2):
      symplectic Euler is conjugate to Stormer-Verlet by a half kick (Hairer, Lubich & Wanner,
      Geometric Numerical Integration, 2006, sec. VI.8), so its phase error is second order
      while its shape error is first order.
    """
    if symplectic:
        return scale * (y ** order + omega_t * y ** (2 * ((order + 1) // 2)))
    # past exp's range (exponent > 709.78) the bound is infinite: no error is ruled out at
    # that step, and it says so as inf, without numpy's overflow warning on the console
    exponent = max(omega_t, 1.0) * y ** order
    if exponent > np.log(np.finfo(float).max):
        return math.inf
    return scale * np.expm1(exponent)


def is_symplectic(settings) -> bool:
    """The engine's own declaration of its stepper (Sim.settings()["integrator"], read as an
    IntegratorInfo)."""
    from refsim.engine import IntegratorInfo
    described = IntegratorInfo.of(settings)
    return bool(described is not None and described.symplectic)


EPS = float(np.finfo(float).eps)  # double precision: every engine here steps in float64


def sample_steps(steps: int, stride: int) -> np.ndarray:
    """The step counts at which the harness observes a run (refsim.run.job._accuracy_pass): 0,
    stride, 2 stride, ..., and the last step."""
    return np.unique(np.append(np.arange(0, steps, max(1, stride)), steps))


def roundoff_tolerance(steps: int, state_scale: float) -> tuple[float, str]:
    """(bound, reason) of the round-off `steps` steps may accumulate in double precision.

    `state_scale` S is the error, in the observable's units, of rounding the whole state once
    (position and velocity, each to eps/2 of its size; a case derives it from its state's
    size). A one-step method's own arithmetic adds to the increment x_{n+1} - x_n only a
    rounding relative to that increment (of order dt), so the final additions dominate: each
    step errs by at most eps S. A neutrally stable motion (an oscillation, a free flight) keeps
    every such error undamped, so the global round-off is at most n eps S: the linear worst
    case of Henrici (Discrete Variable Methods in ODEs, 1962, sec. 1.4); random roundings give
    sqrt(n) eps S instead. A case multiplies it by any growth its motion gives (a pendulum's
    energy error turning into phase)."""
    bound = steps * EPS * state_scale
    return bound, (f"; plus round-off n eps S = {bound:.3g} (n = {steps} steps, each rounding "
                   f"the state by at most eps S, S = {state_scale:.3g}; kept undamped by the "
                   "motion: Henrici's linear worst case, see roundoff_tolerance)")
