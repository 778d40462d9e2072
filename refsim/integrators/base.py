"""The stepper contract, the configuration-update hook, and the step failure.

A stepper advances a second-order system x'' = a(t, x, v) given by a *system* object (physics
lives elsewhere, in `refsim.models`):

    system.accel(t, x, v) -> a                   arrays of shape (..., n): any leading batch axes
                                                 (or 0-d scalars for one degree of freedom)
    system.jacobians(t, x, v) -> (da_dx, da_dv)  shape (..., n, n); implicit methods only
    system.linear              True when a is affine in (x, v): one Newton step is exact
    system.velocity_dependent  True when a depends on v (damping, drag, Baumgarte terms)
    system.shift(x, dx) -> x'  optional: the configuration update (jax-md's `shift_fn`)
    system.dexpinv(dx, v) -> k optional, with `shift`: the inverse differential of the map
                                 dx -> shift(x, dx) at dx applied to a tangent velocity v;
                                 explicit RK uses it to correct its stage slopes (RKMK)

`shift` moves a configuration x by an increment dx in its tangent space: the exponential map
for unit quaternions (x of shape (..., 4), dx a rotation vector of shape (..., 3)), a wrap for
angles, a periodic box. A system without it lives in a vector space, and the update is plain
addition x + dx. Steppers never write `x + h * v`: they call the update that
`configuration_update(system)` resolves, so one RK4 serves particles and rigid bodies. Velocities
and accelerations stay in the tangent space (they are summed as vectors); with `shift`, the
Jacobians of implicit methods are taken with respect to the tangent increment (n = dx's size).

Contract for an implementer of a new stepper (subclass `Integrator`):
1. declare `name`, `order`, `family`, `explicit`, `symplectic` as class attributes;
2. `start(system, t, x, v, h)` turns (x, v) into the stepper's state tuple (default: (x, v));
3. `_step(system, t, state, h, shift)` returns the state one step of h later, moving the
   configuration only through `shift(x, dx)` (never `x + dx`); it must not observe;
4. `output(system, t, state, h)` returns synchronised (x, v) (default: the first two entries).
The base class resolves `shift` (once per `advance`, not once per step) and does the time loop.
"""
from __future__ import annotations

from operator import add as plain_addition


class StepFailure(RuntimeError):
    """A step could not be completed (Newton did not converge, adaptive step underflow)."""


def configuration_update(system):
    """The update x (+) dx every stepper applies to the configuration: `system.shift` when
    the system defines one, else plain addition (`operator.add`: x + dx, the same arithmetic,
    bit for bit, as writing the sum)."""
    return getattr(system, "shift", plain_addition)


class Integrator:
    name = "base"
    order = 0
    family = ""
    explicit = True
    symplectic = False
    adaptive = False

    def start(self, system, t, x, v, h):
        return (x, v)

    def step(self, system, t, state, h):
        """One step of h from time t; returns the new state."""
        return self._step(system, t, state, h, configuration_update(system))

    def _step(self, system, t, state, h, shift):
        raise NotImplementedError

    def output(self, system, t, state, h):
        return state[0], state[1]

    def advance(self, system, t, state, h, n):
        """n steps of h from time t; returns (t_new, state). The time loop of every engine."""
        step, shift = self._step, configuration_update(system)
        for k in range(n):
            state = step(system, t + k * h, state, h, shift)
        return t + n * h, state

    def describe(self) -> dict:
        return {"name": self.name, "order": self.order, "family": self.family,
                "explicit": self.explicit, "symplectic": self.symplectic}
