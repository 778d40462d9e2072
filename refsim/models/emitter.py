"""The ballistic emitter's schedule and its exact discrete paths (the `Emitter` part).

Corrected rule: particle i is born at the first step boundary t_n = n h with t_n >= i / rate,
and removed at the first boundary where its age (n - n_birth) h >= lifetime; in between it
falls under the constant gravity g. Both are step-rounded: a birth is late by less than h, a
life lasts L h with L = the first integer with L h >= lifetime (so lifetime <= L h <
lifetime + h), and the count alive at t_n differs from the continuum rate x time count by at
most rate h + 1 (`count_bound`).
As printed (slide 002, the sprinkler): "Generate k particles" each step, so particle i is born
at boundary i // k (rate k / h, dependent on the step), and `velocity == g*dt` compares instead
of updating: the particles feel no acceleration and fly straight. The slide removes nothing;
here the lifetime removes them too (else no fixed capacity exists).

Slots: the alive ids at a boundary are consecutive, and never more than `capacity`, so slot
i mod capacity is free when particle i is born: the slot of every particle is fixed.

Exact discrete path after k steps under constant g (x0, v0 the spawn state):
    x_k = x0 + k h v0 + h^2 g c(k),  v_k = v0 + k h g,
    c(k) = k (k - 1) / 2   explicit Euler, drift-kick symplectic Euler (old velocity moves x)
         = k (k + 1) / 2   kick-drift symplectic Euler, implicit Euler, Baraff-Witkin (new one)
         = k^2 / 2         every second-order or higher stepper (exact for constant g)
(by induction: x_{k+1} - x_k = h v_k, h v_{k+1} or h (v_k + v_{k+1})/2).
"""
from __future__ import annotations

import math

import numpy as np

from refsim.integrators.spec import spec_name

FORMULATIONS = ("corrected", "as_printed")
# steppers whose position moves with the old velocity (c = k(k-1)/2) or the new (k(k+1)/2)
OLD_VELOCITY_DRIFT = frozenset({"explicit_euler", "symplectic_euler_dk"})
NEW_VELOCITY_DRIFT = frozenset({"symplectic_euler", "implicit_euler", "baraff_witkin"})


def _check_formulation(formulation):
    if formulation not in FORMULATIONS:
        raise ValueError(f"emitter formulation must be one of {list(FORMULATIONS)}, got "
                         f"{formulation!r}")


def life_steps(emitter, h) -> int:
    """L: the first integer with L h >= lifetime (the steps a particle lives)."""
    steps = max(1, math.ceil(emitter.lifetime / h))
    while steps > 1 and (steps - 1) * h >= emitter.lifetime:
        steps -= 1
    while steps * h < emitter.lifetime:
        steps += 1
    return steps


def emitted_count(emitter, h, n, formulation="corrected"):
    """Particles born by boundary n (array or scalar n >= 0): ids i with i / rate <= n h
    (corrected) or i // k <= n (as printed)."""
    _check_formulation(formulation)
    if np.ndim(n) == 0:  # one boundary (the engine's step loop): plain Python arithmetic
        return _emitted_scalar(emitter, h, int(n), formulation)
    n = np.asarray(n, dtype=np.int64)
    if formulation == "as_printed":
        return emitter.per_step * (n + 1)
    count = np.floor(n * h * emitter.rate).astype(np.int64) + 1
    count = np.where(count / emitter.rate <= n * h, count + 1, count)  # the float test decides
    return np.where((count - 1) / emitter.rate > n * h, count - 1, count)


def _emitted_scalar(emitter, h, n, formulation):
    """emitted_count for one boundary, the same float tests."""
    if formulation == "as_printed":
        return emitter.per_step * (n + 1)
    count = math.floor(n * h * emitter.rate) + 1
    if count / emitter.rate <= n * h:
        count += 1
    return count - 1 if (count - 1) / emitter.rate > n * h else count


def birth_steps(emitter, h, ids, formulation="corrected"):
    """The boundary n at which each particle is born (int array like ids)."""
    _check_formulation(formulation)
    ids = np.asarray(ids, dtype=np.int64)
    if formulation == "as_printed":
        return ids // emitter.per_step
    n = np.ceil(ids / emitter.rate / h).astype(np.int64)
    n = np.where((n > 0) & (ids / emitter.rate <= (n - 1) * h), n - 1, n)
    return np.where(ids / emitter.rate > n * h, n + 1, n)


def alive_ids(emitter, h, n, formulation="corrected") -> np.ndarray:
    """The consecutive ids alive at boundary n: born by n, not born by n - L."""
    hi = int(emitted_count(emitter, h, n, formulation))
    dead = n - life_steps(emitter, h)
    lo = int(emitted_count(emitter, h, dead, formulation)) if dead >= 0 else 0
    return np.arange(lo, hi)


def capacity(emitter, h, formulation="corrected") -> int:
    """Slots a run at step h needs: the most ids alive at once, floor(rate L h) + 1 (ids i in
    ((n - L) h rate, n h rate]) corrected, k L as printed."""
    _check_formulation(formulation)
    steps = life_steps(emitter, h)
    if formulation == "as_printed":
        return emitter.per_step * steps
    return int(math.floor(emitter.rate * steps * h)) + 1


def count_bound(emitter, h) -> float:
    """|alive(t_n) - continuum alive(t_n)| <= rate h + 1: births late by < h, lives longer by
    < h, each moves the count by at most ceil(rate h)."""
    return emitter.rate * h + 1.0


def continuum_alive(emitter, t):
    """Particles alive at time t with births at exactly i / rate and lives of `lifetime`:
    #{i >= 0 : t - lifetime < i / rate <= t}."""
    t = np.asarray(t, float)
    born = np.floor(t * emitter.rate) + 1
    dead = np.where(t >= emitter.lifetime,
                    np.floor((t - emitter.lifetime) * emitter.rate) + 1, 0.0)
    return born - dead


def drift_factor(stepper_name: str, k):
    """c(k) of the exact discrete path (module docstring)."""
    k = np.asarray(k, float)
    name = spec_name(stepper_name)
    if name in OLD_VELOCITY_DRIFT:
        return 0.5 * k * (k - 1.0)
    if name in NEW_VELOCITY_DRIFT:
        return 0.5 * k * (k + 1.0)
    return 0.5 * k * k


def discrete_path(stepper_name, x0, v0, gravity, h, k, formulation="corrected"):
    """(x_k, v_k) of particles with spawn states x0, v0 (m, 3) after k (m,) steps of h."""
    _check_formulation(formulation)
    k = np.asarray(k, float)[..., None]
    g = np.zeros(3) if formulation == "as_printed" else np.asarray(gravity, float)
    c = drift_factor(stepper_name, k)
    return x0 + (k * h) * v0 + (h * h) * c * g, v0 + (k * h) * g
