"""Flocking rules between the scene's particles: the `Flocking` part.

`Scene(parts=(Particles(...), Flocking(...)))`; every particle is a bird. Two rules:

- "cucker_smale" (Cucker & Smale 2007, IEEE TAC 52(5), "Emergent behavior in flocks"):
      a_i = (1/N) sum_j psi(|x_i - x_j|) (v_j - v_i),   psi(r) = K / (sigma^2 + r^2)^beta
  with K > 0, sigma > 0, beta >= 0 (the paper's H / (1 + r^2)^beta is sigma = 1). All pairs
  interact. The pair term is antisymmetric, so the mean velocity is conserved
  (refsim/models/flocking.py proves it); for beta <= 1/2 every initial state flocks.
- "reynolds" (Reynolds 1987, SIGGRAPH, "Flocks, herds, and schools: a distributed behavioral
  model"): the three steering rules within a neighbourhood radius R, with weights
  (separation, alignment, cohesion). Slide 000 names the rules and prints no formula; the form
  used (refsim/models/flocking.py, `reynolds_accelerations`) is the common reading of the
  paper: over the n_i neighbours j with 0 < |x_j - x_i| < R,
      separation  w_s sum_j (x_i - x_j) / |x_i - x_j|^2
      alignment   w_a (mean_j v_j - v_i)
      cohesion    w_c (mean_j x_j - x_i)
  The per-bird means make it asymmetric: the mean velocity is NOT conserved.
Masses are not used by either rule (accelerations, not forces). Observables are the
particles' (x, v: refsim/observation.py).
"""
from __future__ import annotations

from dataclasses import dataclass

from ._validate import ArrayPart, _nonnegative, _positive, _set, choice

RULES = ("cucker_smale", "reynolds")


@dataclass(frozen=True, eq=False)
class Flocking(ArrayPart):
    """rule: one of RULES. Cucker-Smale: K (1/s m^(2 beta)) > 0, sigma (m) > 0, beta >= 0
    (psi is a rate, 1/s). Reynolds: radius (m) > 0 and the weights, each >= 0: separation
    (m^2/s^2), alignment (1/s), cohesion (1/s^2)."""

    rule: str = "cucker_smale"
    K: float = 1.0
    sigma: float = 1.0
    beta: float = 0.25
    radius: float = 1.0
    separation: float = 0.0
    alignment: float = 1.0
    cohesion: float = 0.0

    kind = "flocking"

    def __post_init__(self):
        _set(self, "rule", choice("flocking.rule", self.rule, RULES))
        _set(self, "K", _positive("flocking.K", self.K))
        _set(self, "sigma", _positive("flocking.sigma", self.sigma))
        _set(self, "beta", _nonnegative("flocking.beta", self.beta))
        _set(self, "radius", _positive("flocking.radius", self.radius))
        for name in ("separation", "alignment", "cohesion"):
            _set(self, name, _nonnegative(f"flocking.{name}", getattr(self, name)))

    def features(self) -> set[str]:
        return {"flocking"}
