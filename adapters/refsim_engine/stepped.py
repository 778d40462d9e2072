"""The base of the in-house sims run by a `refsim.integrators` stepper (particles, hinges)."""
from __future__ import annotations

import numpy as np

from refsim.engine import Sim
from refsim.integrators import StepFailure


class SteppedSim(Sim):
    """A `system` (forces or constraints) advanced by a `stepper`; `state` is the stepper's.

    `stepper_t` is the time the stepper itself keeps (t + n h per `advance` call), passed back
    to it unchanged so the state is bit-identical to a single running stepper; the observed
    time is the base's steps x dt. A singular KKT matrix (LinAlgError) or a stepper's own
    StepFailure becomes `failure`.
    """

    failures = (StepFailure, np.linalg.LinAlgError)

    def __init__(self, dt, stepper, system, q0, qd0):
        self.dt, self.stepper, self.system, self.stepper_t = float(dt), stepper, system, 0.0
        self.state = stepper.start(system, 0.0, q0, qd0, self.dt)

    def _step_impl(self, n):
        with np.errstate(all="ignore"):
            self.stepper_t, self.state = self.stepper.advance(
                self.system, self.stepper_t, self.state, self.dt, n)

    def coordinates(self):
        with np.errstate(all="ignore"):
            return self.stepper.output(self.system, self.stepper_t, self.state, self.dt)

    def stages(self) -> list[str]:
        raise NotImplementedError

    def base_settings(self):
        return {"integrator": self.stepper.describe(), "dtype": "float64",
                "stages": self.stages(), "threads": 1}
