"""What a case declares so that `refsim stress --case NAME` can bisect its largest stable step.

A case opts in with a method `stability(p) -> StabilitySpec`:
- `name`: the stability parameter y (e.g. "omega dt", "CFL number c0 dt / h"), and
  `dt_unit`: seconds per unit of y, so dt = y dt_unit (`to_dt`);
- `theory(stepper, settings) -> (limit, reason)`: the theory's largest stable y for an
  engine's integrator, given the refsim stepper it equals (None when none) and the Sim's
  effective settings (`Sim.settings()`: its formulation, its declared integrator family);
  NaN with the reason where no theory is stated;
- the criterion's scale: `cycle` (the y-length of one period: 2 pi for an oscillator, so P
  periods are P cycle / y steps), `periods` (the default P) and `quick_periods` (--quick's), and the
  energy bound: a run is stable while |E - energy_floor| < energy_bound at every step
  (energy_floor None: the run's initial energy), the state is finite and the engine reports
  no failure;
- `params`: overrides of the case's parameters for the search (e.g. a tiny amplitude, so that
  the motion stays linear), `variant` the case variant they apply to ("" the first);
- `oscillator`: the scene is an undamped linear oscillator, so the theory is the exact step
  map's and `finite_time` predicts where the criterion lands; `batch`: the in-house engine may
  run every y as one vectorised batch (`stress_search.batch_evaluator`: one body of 3
  coordinates); `formulations`: search every engine formulation (the theory depends on it);
- `resolution` and `resolution_reason` (not an oscillator): how far the measured limit may sit
  from the theory, with the reason (what the theory leaves out, the finite-time criterion).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from refsim.scene import Particles

from refsim.stress.search import ENERGY_FACTOR, theory as oscillator_theory


@dataclass(frozen=True)
class StabilitySpec:
    name: str
    dt_unit: float
    theory: Callable
    source: str
    energy_bound: float
    energy_floor: float | None = None
    cycle: float = 2 * math.pi
    periods: int = 1000
    quick_periods: int = 100
    params: dict = field(default_factory=dict)
    variant: str = ""
    oscillator: bool = False
    batch: bool = False
    formulations: bool = False
    resolution: float = math.nan
    resolution_reason: str = ""

    def to_dt(self, y):
        """The time step (s) of stability parameter y (array in, array out)."""
        return np.asarray(y, float) * self.dt_unit


def oscillator_spec(omega: float, energy_floor: float, oscillation_energy: float, source: str,
                    params: dict, theory: Callable | None = None, **fields) -> StabilitySpec:
    """y = omega dt on an undamped linear oscillator; stable while the oscillation energy
    E - energy_floor stays below F = ENERGY_FACTOR times its initial value. `theory` defaults
    to the stepper's (`stepper_theory`) whatever the settings."""
    return StabilitySpec(name="omega dt", dt_unit=1.0 / float(omega),
                         theory=theory or (lambda stepper, settings: stepper_theory(stepper)),
                         source=source, energy_bound=ENERGY_FACTOR * oscillation_energy,
                         energy_floor=energy_floor, params=params, oscillator=True, **fields)


def stepper_theory(stepper) -> tuple[float, str]:
    """The linear oscillator's limit from the stepper's family or tableau."""
    if stepper is None:
        return math.nan, "no theory: no refsim stepper equals this integrator"
    limit = oscillator_theory(stepper)
    if math.isnan(limit):
        return limit, f"no theory for the family {stepper.family!r}"
    return limit, f"linear oscillator, {stepper.family} (stress_search.theory)"


def declared_formulations(settings) -> list[str]:
    """Every value of a key named "formulation" anywhere in a Sim's settings."""
    found = []
    if isinstance(settings, dict):
        for key, value in settings.items():
            if key == "formulation" and isinstance(value, str):
                found.append(value)
            else:
                found += declared_formulations(value)
    elif isinstance(settings, (list, tuple)):
        for value in settings:
            found += declared_formulations(value)
    return found


def integrator_family(settings) -> str:
    """The family the Sim declares for its integrator ("" when none)."""
    integ = (settings or {}).get("integrator")
    return str(integ.get("family", "")) if isinstance(integ, dict) else ""


class Probe:
    """A case at its stability parameters: scene, spec, and the criterion's energy test."""

    def __init__(self, case=None, variant=None, **overrides):
        """`variant`: the case variant searched (None: the spec's, else the first)."""
        from refsim.stress.search import probe_case
        self.case = case if case is not None else probe_case()
        first = variant or next(iter(self.case.variants))
        declared = self.case.stability(self.case.variant_params(first))
        self.variant = variant or declared.variant or first
        self.overrides = {**declared.params, **overrides}
        self.p = self.case.variant_params(self.variant, self.overrides)
        self.spec = self.case.stability(self.p)
        self.scene = self.case.scene(self.p)
        self.omega = 1.0 / self.spec.dt_unit  # y per second of step (omega for an oscillator)
        self.e0 = self.case.energy_scale(self.p)
        # the particles' start (the batched oscillator's); empty for a scene of other parts
        bodies = self.scene.part(Particles)
        self.x0 = np.zeros(0) if bodies is None else bodies.position.reshape(-1)
        self.v0 = np.zeros(0) if bodies is None else bodies.velocity.reshape(-1)

    def energy(self, x, v):
        """Energy of each row of x, v (batch, 3): one-body scenes (the batched search)."""
        obs = {"x": np.reshape(x, (-1, 1, 3)), "v": np.reshape(v, (-1, 1, 3))}
        return self.case.energy(self.p, obs)

    def observed_energy(self, obs) -> float:
        """The case's energy of one observation (every key given a leading time axis)."""
        stacked = {k: np.asarray(v)[None] for k, v in obs.items()}
        return float(self.case.energy(self.p, stacked)[0])

    def floor(self, initial_obs) -> float:
        """The energy the criterion measures from: the spec's floor, else the initial one."""
        floor = self.spec.energy_floor
        return self.observed_energy(initial_obs) if floor is None else float(floor)

    def within(self, energy, floor):
        """|E - floor| < energy_bound (False for a non-finite E); arrays in, arrays out."""
        return np.abs(np.asarray(energy) - floor) < self.spec.energy_bound
