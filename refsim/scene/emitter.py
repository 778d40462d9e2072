"""A ballistic particle emitter: the `Emitter` part (the scene's moving part).

`Scene(parts=(Emitter(...),), gravity=(0, 0, -9.81))`. Particle i (i = 0, 1, ...) is born at
the origin with velocity mean + spread (2 u - 1), u in [0, 1)^3 a deterministic function of
(seed, i) (`spawn_states`: engines and references use the same), and lives `lifetime` s. How
births and removals fall on the step boundaries is refsim/models/emitter.py's; so is the fixed
number of slots (capacity) a run needs, which depends on the step and the formulation.

Observables (slot arrays of the fixed capacity c, set by the engine at build):
    "id"       (c,)    int    spawn index of the slot's particle, -1 for a free slot
    "x"        (c, 3)  m      positions (free slots: FREE_SLOT_VALUE)
    "v"        (c, 3)  m/s    velocities (free slots: FREE_SLOT_VALUE)
    "birth"    (c,)    s      birth time (a step boundary) of the slot's particle, NaN if free
    "emitted"  ()      1      particles born so far (ids 0 .. emitted - 1)
FREE_SLOT_VALUE is 0, not NaN: the harness (refsim/run/job.py `_divergence`) reads any non-finite
x or v as a divergence; "id" == -1 is what marks a free slot.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import ArrayPart, _nonnegative, _positive, _set, _vec

FREE_SLOT_VALUE = 0.0
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def _splitmix64(z):
    """The SplitMix64 finaliser (Steele, Lea & Flood 2014) on uint64 arrays: a bijective mix."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def spawn_uniforms(seed: int, ids) -> np.ndarray:
    """(m, 3) numbers in [0, 1) (53-bit), a function of (seed, id) only: counter-based, so
    particle i's draw does not depend on how many were drawn before or on the step."""
    ids = np.asarray(ids, dtype=np.uint64).reshape(-1)
    counter = (ids[:, None] * np.uint64(3) + np.arange(3, dtype=np.uint64)) + np.uint64(1)
    with np.errstate(over="ignore"):
        key = _splitmix64(np.uint64(seed) * _GOLDEN + np.uint64(0x632BE59BD9B4E019))
        z = _splitmix64(key ^ (counter * _GOLDEN))
    return (z >> np.uint64(11)).astype(float) * 2.0 ** -53


@dataclass(frozen=True, eq=False)
class Emitter(ArrayPart):
    """rate (1/s) > 0; lifetime (s) > 0; origin (m); velocity (m/s): the mean spawn velocity;
    spread (m/s) >= 0: each component uniform in [-spread, spread) about the mean; seed an
    integer >= 0; per_step an integer >= 1: the k particles the slide's loop generates each
    step (the "as_printed" formulation only)."""

    rate: float = 50.0
    lifetime: float = 1.0
    origin: tuple = (0.0, 0.0, 0.0)
    velocity: tuple = (0.0, 0.0, 5.0)
    spread: float = 1.0
    seed: int = 0
    per_step: int = 1

    kind = "emitter"
    moving = True

    def __post_init__(self):
        _set(self, "rate", _positive("emitter.rate", self.rate))
        _set(self, "lifetime", _positive("emitter.lifetime", self.lifetime))
        _set(self, "origin", _vec("emitter.origin", self.origin))
        _set(self, "velocity", _vec("emitter.velocity", self.velocity))
        _set(self, "spread", _nonnegative("emitter.spread", self.spread))
        for name, low in (("seed", 0), ("per_step", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value or value < low:
                raise ValueError(f"emitter.{name} must be an integer >= {low}, got {value!r}")
            _set(self, name, int(value))

    def features(self) -> set[str]:
        return {"emitter"}

    def spawn_states(self, ids) -> tuple[np.ndarray, np.ndarray]:
        """Spawn positions and velocities (m, 3) of particles `ids` (a function of (seed, id))."""
        u = spawn_uniforms(self.seed, ids)
        x0 = np.broadcast_to(np.asarray(self.origin, float), u.shape).copy()
        return x0, np.asarray(self.velocity, float) + self.spread * (2.0 * u - 1.0)
