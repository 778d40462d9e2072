"""The stability-limit search behind `refsim stress`: criterion, theory, and two searches.

Scene: the case registered with the tag "stability_probe" (the undamped stiff spring: m = 1
kg, k = 1e4 N/m, rest length 1 m, released from rest; it must offer `omega(p)`) with the
amplitude A lowered from 0.1 m to 1e-7 m (its StabilitySpec params), so that it stays linear
wherever the search goes. It is linear only while the mass stays
on its side of the anchor: near y = 2 a stable symplectic Euler orbit from rest reaches
E0 / (1 - y/2), |u| up to A / sqrt(2 - y) (10 A at y = 1.99: with A = 0.1 m the mass passes
the anchor there and the search found y = 1.99, not 2), and implicit Euler's Newton starts
from the explicit-Euler predictor, which overshoots by y^2 A (with A = 0.1 m it passes the
anchor at y = 3.3 and converges to the mirrored root x = -L0). With A = 1e-7 m both stay
short of the anchor up to y = 3162. MuJoCo refuses springs whose exact motion reaches the
anchor, so a tiny rest length is no option.

Criterion at y = omega dt (`Criterion`): a run is stable when, at every step over P periods
(or 10 P steps, whichever is fewer: the cap binds only below y = 2 pi / 10 = 0.63, where only
the never-stable methods are judged), the state is finite, the engine reports no failure
(`Sim.failure`) and the energy stays below F E0.

Search (`search_limit`): a descending log grid from Y_MAX = 1e3 to Y_MIN = 1e-3 (8 points a
decade) brackets the limit from above (stable at Y_MAX: unbounded), then rounds of
bisection to a tolerance relative to max(1, y). Stable below / unstable above is assumed, as
in `refsim.run.metrics.bisect_limit`. The in-house engine evaluates each grid or round as one
vectorised run (`batch_evaluator`: one oscillator per y, h of shape (batch, 1)); the others
build one Sim per y (`sim_evaluator`).

Theory (`theory`): from the stepper's declared family and, for explicit Runge-Kutta, its
tableau: symplectic Euler and Verlet 2 (characteristic roots of modulus 1 iff y <= 2);
implicit (backward) Euler unbounded (energy x 1/(1 + y^2) per step); explicit RK the first
y > 0 where |R(iy)| > 1 for its stability polynomial R (0 when |R(iy)| > 1 for every y > 0).
`finite_time` predicts where the stated criterion itself must land, from the exact step map.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from refsim.integrators import ExplicitRK, get_integrator

ENERGY_FACTOR = 1e4
STEPS_PER_PERIOD_CAP = 10  # at most 10 P steps
Y_MIN, Y_MAX = 1e-3, 1e3
GRID_PER_DECADE = 8
ROUND_POINTS = 32  # y values per batched bisection round (the bracket shrinks 33-fold)
PROBE_TAG = "stability_probe"  # the default case of `refsim stress` (with its sweep)


@dataclass(frozen=True)
class Criterion:
    periods: int
    factor: float = ENERGY_FACTOR
    cycle: float = 2 * np.pi  # the y-length of one period (StabilitySpec.cycle)
    name: str = "omega dt"
    bound_text: str = ""  # the energy test in words, when not the oscillator's

    @property
    def max_steps(self) -> int:
        """10 P steps for an oscillator: the cap binds below y = 2 pi / 10 whatever the cycle."""
        return int(round(STEPS_PER_PERIOD_CAP * self.cycle / (2 * np.pi) * self.periods))

    def steps(self, y):
        """Steps judged at y: P periods, at most max_steps (array in, array out)."""
        n = np.minimum(np.ceil(self.periods * self.cycle / np.asarray(y, float)),
                       self.max_steps)
        return n.astype(int)

    def text(self) -> str:
        energy = self.bound_text or (f"the energy is < {self.factor:g} E0 (undamped "
                                     "oscillator, from rest)")
        return (f"stable at y = {self.name} when, at every step over {self.periods} periods "
                f"of {self.cycle:.4g}/y steps (at most {self.max_steps} steps), the state is "
                f"finite, the engine reports no failure, and {energy}")


def probe_case():
    """The registered case tagged PROBE_TAG (an undamped linear oscillator with `omega(p)`)."""
    from refsim.registry import case_names, get_case
    for name in case_names():
        if PROBE_TAG in get_case(name).tags:
            return get_case(name)
    raise ValueError(f"a case tagged {PROBE_TAG!r} must be installed for the stability search")


# --------------------------------------------------------------------------------------------
# Theory
# --------------------------------------------------------------------------------------------
def refsim_equivalent(engine, integrator: str) -> str | None:
    """The refsim stepper that `engine`'s integrator equals on the undamped spring (the engine
    declares its own in `Engine.equivalents`, e.g. MuJoCo's implicitfast = symplectic Euler
    when nothing is damped), None when there is none. `engine` None: the name itself."""
    name = getattr(engine, "equivalents", {}).get(integrator, integrator)
    try:
        get_integrator(name)
    except ValueError:
        return None
    return name


def stability_polynomial(tableau) -> np.ndarray:
    """Coefficients c_k of R(z) = sum c_k z^k = 1 + z b^T (I - z A)^-1 1 (c_k = b A^{k-1} 1)."""
    a, b, _ = tableau.arrays()
    coeffs, vec = [1.0], np.ones(len(b))
    for _ in range(len(b)):
        coeffs.append(float(b @ vec))
        vec = a @ vec
    return np.array(coeffs)


def amplification(tableau, y) -> np.ndarray:
    """|R(iy)|^2: the exact energy factor of one RK step on the oscillator (the step matrix is
    normal in (u, v / omega), so every state's energy is multiplied by it)."""
    c = stability_polynomial(tableau)
    return np.abs(np.polynomial.polynomial.polyval(1j * np.asarray(y, float), c)) ** 2


def rk_limit(tableau) -> float:
    """First y > 0 where |R(iy)|^2 - 1 turns positive; 0 when it is positive near 0."""
    c = stability_polynomial(tableau)
    k = np.arange(len(c))
    re = np.where(k % 2 == 0, c * (-1.0) ** (k // 2), 0.0)
    im = np.where(k % 2 == 1, c * (-1.0) ** (k // 2), 0.0)
    poly = np.polynomial.Polynomial(re) ** 2 + np.polynomial.Polynomial(im) ** 2 - 1
    coef = np.where(np.abs(poly.coef) < 1e-12, 0.0, poly.coef)
    low = np.flatnonzero(coef)
    if len(low) == 0:
        return math.inf
    if coef[low[0]] > 0:
        return 0.0
    reduced = np.polynomial.Polynomial(coef[low[0]:])  # divided by y^m: no roots at 0
    for r in sorted(r.real for r in reduced.roots() if abs(r.imag) < 1e-12 and r.real > 0):
        if reduced(r * (1 + 1e-9)) > 0:
            return float(r)
    return math.inf


def theory(stepper) -> float:
    """Largest stable y from the stepper's declared family (NaN where none is known)."""
    if stepper.adaptive:
        return math.nan
    if stepper.family in ("symplectic Euler", "Verlet"):
        return 2.0
    if stepper.family.startswith("implicit"):
        return math.inf
    if isinstance(stepper, ExplicitRK):
        return rk_limit(stepper.tableau)
    return math.nan


def finite_time(stepper, limit: float, criterion: Criterion) -> tuple[float, float]:
    """(where the stated criterion must land, finite-time resolution |that - theory| plus the
    overshoot allowance): symplectic Euler from rest peaks at E0 / (1 - y/2), so 2 - 2/F;
    Verlet from rest never exceeds E0; above y = 2 both grow by ~1 + 2 sqrt(y - 2) per step,
    (ln F / 4n)^2 past 2; explicit RK: the first y with |R(iy)|^(2 n(y)) >= F."""
    ln_f = math.log(criterion.factor)
    if stepper.family in ("symplectic Euler", "Verlet"):
        over = (ln_f / (4 * criterion.steps(2.0))) ** 2
        below = 2.0 / criterion.factor if stepper.family == "symplectic Euler" else 0.0
        return 2.0 - below, float(below + over)
    if math.isinf(limit):
        return math.inf, 0.0
    if not isinstance(stepper, ExplicitRK):
        return math.nan, math.nan
    y_ft = _first_growth(stepper.tableau, criterion, max(limit, Y_MIN * 1e-2))
    return y_ft, abs(y_ft - limit)


def _first_growth(tableau, criterion, start) -> float:
    def grows(y):
        return criterion.steps(y) * np.log(amplification(tableau, y)) >= math.log(
            criterion.factor)
    grid = np.geomspace(start, Y_MAX, 4000)
    hits = np.flatnonzero(grows(grid))
    if len(hits) == 0:
        return math.inf
    if hits[0] == 0:
        return float(grid[0])
    lo, hi = grid[hits[0] - 1], grid[hits[0]]
    while hi - lo > 1e-10 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if grows(mid) else (mid, hi)
    return float(hi)


# --------------------------------------------------------------------------------------------
# Search
# --------------------------------------------------------------------------------------------
@dataclass
class Found:
    limit: float  # inf: stable at Y_MAX; 0: unstable down to Y_MIN
    evaluations: int
    seconds: float
    batched: bool
    fallback: str = ""  # why the in-house engine ran one Sim per y, if it did


def search_limit(evaluate, tol: float, first_chunk: int, round_points: int) -> tuple[float, int]:
    """Largest stable y: bracket on the descending log grid, then bisection rounds of
    `round_points` values to tol * max(1, y). `evaluate(ys)` -> bool array (True: stable, or
    presumed stable below a stable y). Returns (limit, number of y values evaluated)."""
    decades = math.log10(Y_MAX / Y_MIN)
    grid = Y_MAX * 10.0 ** (-np.arange(int(decades * GRID_PER_DECADE) + 1) / GRID_PER_DECADE)
    count, lo, hi = 0, None, None
    for start in range(0, len(grid), first_chunk):
        ys = grid[start:start + first_chunk]
        ok = evaluate(ys)
        count += len(ys)
        if ok.any():
            j = start + int(np.argmax(ok))
            if j == 0:
                return math.inf, count
            lo, hi = grid[j], grid[j - 1]
            break
    if lo is None:
        return 0.0, count
    while hi - lo > tol * max(1.0, lo):
        pts = np.linspace(lo, hi, round_points + 2)[1:-1]
        ok = evaluate(pts)
        count += len(pts)
        stable = np.flatnonzero(ok)
        top = stable[-1] if len(stable) else -1
        lo, hi = (pts[top] if top >= 0 else lo), (pts[top + 1] if top + 1 < len(pts) else hi)
    return float(lo), count


def find_limit(engine, integrator: str, spring, criterion: Criterion, tol: float,
               variant: str = "") -> Found:
    """The measured limit of one engine's integrator, batched where the engine and the
    probe's spec allow it (`StabilitySpec.batch`)."""
    t0 = time.perf_counter()
    evaluate, fallback = (batch_evaluator(engine, integrator, spring, criterion, variant)
                          if spring.spec.batch else (None, ""))
    if evaluate is not None:
        n_grid = int(math.log10(Y_MAX / Y_MIN) * GRID_PER_DECADE) + 1
        limit, count = search_limit(evaluate, tol, n_grid, ROUND_POINTS)
    else:
        limit, count = search_limit(sim_evaluator(engine, integrator, spring, criterion,
                                                  variant), tol, 1, 1)
    return Found(limit, count, time.perf_counter() - t0, evaluate is not None, fallback)


# -- one Sim per y ----------------------------------------------------------------------------
def breach(sim, probe, steps: int) -> int | None:
    """First step (observed one at a time) at which the criterion fails: an engine-reported
    failure, a non-finite state (its energy is then not finite) or |E - floor| >= the
    probe's energy bound (Probe.within)."""
    floor = probe.floor(sim.observe())
    for k in range(1, steps + 1):
        sim.step(1)
        if sim.failure or not probe.within(probe.observed_energy(sim.observe()), floor):
            return k
    return None


def sim_evaluator(engine, integrator, spring, criterion, variant=""):
    def stable(y):
        sim = engine.build(spring.scene, float(spring.spec.to_dt(y)), integrator, variant)
        try:
            return breach(sim, spring, int(criterion.steps(y))) is None
        finally:
            sim.close()
    return lambda ys: np.array([stable(y) for y in ys], bool)


# -- batched (in-house engine) ----------------------------------------------------------------
def _run_batch(system, stepper, spring, ys, steps):
    """`steps` steps of one oscillator per y (h of shape (batch, 1)); synchronised (x, v)."""
    h = (np.asarray(ys, float) / spring.omega)[:, None]
    x0 = np.broadcast_to(spring.x0, (len(ys), 3)).copy()
    v0 = np.broadcast_to(spring.v0, (len(ys), 3)).copy()
    state = stepper.start(system, 0.0, x0, v0, h)
    for k in range(steps):
        state = stepper.step(system, k * h, state, h)
    return stepper.output(system, steps * h, state, h)


def batch_stepper(sim, spring):
    """(stepper that takes an array h, "") or (None, why not): 3 steps of the batch must equal
    3 scalar-h steps of each member to 1e-12."""
    stepper = base = sim.stepper
    ys = np.array([0.05, 0.3, 1.1, 1.7, 2.9])
    try:
        with np.errstate(all="ignore"):
            xb, vb = _run_batch(sim.system, stepper, spring, ys, 3)
            single = [_run_batch(sim.system, base, spring, ys[i:i + 1], 3) for i in range(5)]
    except Exception as exc:  # an array h does not broadcast through this stepper
        return None, f"array h fails in {base.name} ({type(exc).__name__}: {exc})"
    xs, vs = (np.concatenate([s[i] for s in single]) for i in (0, 1))
    if not (np.allclose(xb, xs, rtol=1e-12, atol=0) and np.allclose(vb, vs, rtol=1e-12,
                                                                    atol=1e-12 * spring.omega)):
        return None, f"array h gives other steps than scalar h in {base.name}"
    return stepper, ""


def batch_evaluator(engine, integrator, spring, criterion, variant=""):
    """(evaluate(ys) running every y as one vectorised oscillator batch, "") or (None, why);
    (None, "") for a Sim that does not expose the in-house stepper contract (`system` and
    `stepper`: the engine steps its own way, one Sim per y)."""
    sim = engine.build(spring.scene, 1.0 / spring.omega, integrator, variant)
    if getattr(sim, "system", None) is None or getattr(sim, "stepper", None) is None \
            or not hasattr(sim.stepper, "start"):
        sim.close()
        return None, ""
    stepper, why = batch_stepper(sim, spring)
    if stepper is None:
        return None, why + ": one Sim per y"
    system = sim.system

    def evaluate(ys):
        return _judge_batch(system, stepper, spring, np.asarray(ys, float), criterion)
    return evaluate, ""


def _judge_batch(system, stepper, spring, ys, criterion):
    """Every member judged over its own steps(y). Larger y finish first, so the first member
    to finish stable is the largest stable y: the run stops there and every smaller y not
    yet failed is presumed stable (the search's monotonicity assumption)."""
    h = (ys / spring.omega)[:, None]
    n = criterion.steps(ys)
    state = stepper.start(system, 0.0, np.broadcast_to(spring.x0, (len(ys), 3)).copy(),
                          np.broadcast_to(spring.v0, (len(ys), 3)).copy(), h)
    failed = np.zeros(len(ys), bool)
    finished = failed
    with np.errstate(all="ignore"):
        for k in range(1, int(n.max()) + 1):
            state = stepper.step(system, (k - 1) * h, state, h)
            energy = spring.energy(*stepper.output(system, k * h, state, h))
            failed = failed | (~spring.within(energy, spring.spec.energy_floor) & (k <= n))
            finished = (n <= k) & ~failed
            if finished.any() or failed.all():
                break
    if not finished.any():
        return np.zeros(len(ys), bool)
    return (ys <= ys[finished].max()) & ~failed

