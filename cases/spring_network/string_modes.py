"""Pretensioned string (and square membrane) of point masses on ZERO rest-length springs: a
normal mode released from rest (slides 000/001; docs/models.md#springs-string-and-membrane-modes).

String: N free nodes of mass m at x_j = j l (j = 1..N) between pinned ends x_0 = 0 and
x_{N+1} = (N + 1) l, joined by springs of stiffness k (N/m) and rest length 0. A zero
rest-length spring pulls with f = -k d for the whole vector d, so the forces are EXACTLY
linear and the pretension is T = k l. Transverse motion: m z_j'' = k (z_{j+1} - 2 z_j +
z_{j-1}), with normal modes phi_j = sin(n pi j / (N + 1)) of angular frequency
    w_n = 2 sqrt(k / m) sin(n pi / (2 (N + 1)))   (= 2 sqrt(T / (m l)) sin(...)).
Membrane (`shape = membrane`): N x N free nodes at (i l, j l) in the x-y plane inside a pinned
ring, springs to the four grid neighbours; phi = sin(n pi i / (N + 1)) sin(n' pi j / (N + 1)),
w^2 = (4 k / m) [sin^2(n pi / (2 (N + 1))) + sin^2(n' pi / (2 (N + 1)))].

Reference: the exact semi-discrete solution z = A phi cos(w t) (x, y at rest); the compared
error is the largest node distance |x - x_ref| (m). Exact DISCRETE oracles per stepper: the
mode stays a mode (the system is linear and decoupled), and its (z, v) advance by the 2x2 step
matrix S(y), y = w h, of the stepper in closed form (cases.networks._linear_steps): the
tolerance is that exact discrete deviation plus round-off. Baraff-Witkin is backward Euler
exactly on linear forces: amplitude factor (1 + y^2)^(-1/2) and phase arctan(y) per step (its
numerical damping, measured from the run: `amplitude_per_period`). Orders: symplectic Euler
1, velocity Verlet 2, RK4 4, Baraff-Witkin 1.

Stability (`refsim stress --case string_modes`): y = dt sqrt(k / m). Slide 001's limit
2 sqrt(m / k) is that of ONE mass on one spring to an anchor (w = sqrt(k / m)); the string's
stiffest mode n = N has w_max = 2 sqrt(k / m) sin(N pi / (2 (N + 1))) -> 2 sqrt(k / m), so
the explicit limits w_max dt < 2 (symplectic Euler, velocity Verlet), < 2 sqrt 2 (RK4 on an
oscillator: |R(i y)| <= 1) become dt sqrt(k / m) < 1 / sin(...) -> 1 and sqrt 2: HALF the
one-spring value (the membrane: 1 / sqrt 2 of the string's). Baraff-Witkin is unbounded.
"""
from __future__ import annotations

import math

import numpy as np

from refsim.case import EPS, Case, Param, order_tolerance
from refsim.models.spring_network import network_potential
from refsim.scene import Scene, SpringNetwork
from refsim.stress.search import Criterion, finite_time
from refsim.stress.search import theory as oscillator_limit

from ._linear_steps import STEPPERS, mode_amplitude

# w_max dt of the timed sweep, inside every explicit limit (2, 2 sqrt 2); one timed step and
# one halving for the order fit keep the default variant within its share of the default run
Y_SWEEP = (0.5,)
Y_ORDER = (0.25,)  # one order-only dt: the orders are tested (test_string_modes), the default run stays cheap
Y_REFERENCE = 0.5
STRESS_PERIODS = 200


class StringModes(Case):
    name = "string_modes"
    description = ("pretensioned string / membrane of masses on zero rest-length springs: "
                   "normal-mode frequencies, each stepper's exact discrete mode, Baraff-Witkin's "
                   "damping (1 + w^2 h^2)^(-1/2) per step, explicit limit on the stiffest mode")
    tags = ("network", "string", "membrane", "exact")
    observable, units = "x", "m"
    params = {
        "shape": Param("string", choices=("string", "membrane")),
        "nodes": Param(15, 1, 400, "N free nodes per side"),
        "mode": Param(1, 1, 400, "n, the mode number along x (1..N)"),
        "mode2": Param(1, 1, 400, "n', the mode number along y (membrane; 1..N)"),
        "mass": Param(0.01, 0.0, 1e6, "m per node (kg)", low_inclusive=False),
        "spacing": Param(0.1, 0.0, 1e3, "l, node spacing at rest (m)", low_inclusive=False),
        "stiffness": Param(100.0, 0.0, 1e9, "k (N/m), tension T = k l", low_inclusive=False),
        "amplitude": Param(0.01, 0.0, 1e3, "A, the mode's initial z amplitude (m)",
                           low_inclusive=False),
        "periods": Param(1.0, 0.0, 1e4, "t_end in periods of the mode", low_inclusive=False),
    }
    variants = {"default": {}, "membrane": {"shape": "membrane", "nodes": 10, "mode2": 2},
                "long": {"periods": 20.0}}
    default_variants = quick_variants = ("default",)

    # -- geometry -----------------------------------------------------------------------------
    @staticmethod
    def _check(p) -> tuple[int, int, int]:
        n, k1, k2 = int(p["nodes"]), int(p["mode"]), int(p["mode2"])
        for name, value in (("mode", k1), ("mode2", k2)):
            if value > n:
                raise ValueError(f"string_modes.{name} must be in [1, {n}] (nodes), got {value}")
        return n, k1, k2

    def grid(self, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(index per node (n_nodes, d) in 0..N+1, pinned mask, mode shape phi per node)."""
        n, k1, k2 = self._check(p)
        axis = np.arange(n + 2)
        if p["shape"] == "string":
            index = axis[:, None]
        else:
            index = np.stack(np.meshgrid(axis, axis, indexing="ij"), -1).reshape(-1, 2)
        pinned = np.any((index == 0) | (index == n + 1), axis=1)
        modes = (k1, k2)[:index.shape[1]]
        phi = np.prod([np.sin(m * math.pi * index[:, a] / (n + 1))
                       for a, m in enumerate(modes)], axis=0)
        phi[pinned] = 0.0  # sin(n pi) rounds to ~1e-16: the pinned ends are exactly at rest
        return index, pinned, phi

    def rest_positions(self, p) -> np.ndarray:
        index, _, _ = self.grid(p)
        x = np.zeros((len(index), 3))
        x[:, :index.shape[1]] = index * p["spacing"]
        return x

    def scene(self, p):
        index, pinned, phi = self.grid(p)
        x = self.rest_positions(p)
        x[:, 2] = p["amplitude"] * phi
        net = SpringNetwork(positions=x, masses=p["mass"], edges=self._edges(index, pinned),
                            stiffness=p["stiffness"], rest_length=0.0,
                            pinned=np.flatnonzero(pinned))
        return Scene(parts=(net,), gravity=(0.0, 0.0, 0.0))

    @staticmethod
    def _edges(index, pinned) -> np.ndarray:
        """Grid neighbours one step apart along an axis, not both pinned."""
        side = int(index.max()) + 1
        flat = index @ (side ** np.arange(index.shape[1])[::-1])
        node = np.full(side ** index.shape[1], -1)
        node[flat] = np.arange(len(index))
        pairs = []
        for axis in range(index.shape[1]):
            step = np.zeros(index.shape[1], int)
            step[axis] = 1
            has = index[:, axis] + 1 < side
            nxt = node[(index[has] + step) @ (side ** np.arange(index.shape[1])[::-1])]
            pairs.append(np.stack([np.flatnonzero(has), nxt], 1))
        edges = np.concatenate(pairs)
        return edges[~(pinned[edges[:, 0]] & pinned[edges[:, 1]])]

    # -- frequencies --------------------------------------------------------------------------
    def omega(self, p) -> float:
        """w of the released mode (rad/s)."""
        _, k1, k2 = self._check(p)
        return self._omega(p, (k1,) if p["shape"] == "string" else (k1, k2))

    def omega_max(self, p) -> float:
        """w of the stiffest mode (n = N on every axis)."""
        n = int(p["nodes"])
        return self._omega(p, (n,) * (1 if p["shape"] == "string" else 2))

    @staticmethod
    def _omega(p, modes) -> float:
        n = int(p["nodes"])
        s2 = sum(math.sin(m * math.pi / (2 * (n + 1))) ** 2 for m in modes)
        return 2.0 * math.sqrt(p["stiffness"] / p["mass"] * s2)

    # -- the run ------------------------------------------------------------------------------
    def period(self, p) -> float:
        return 2 * math.pi / self.omega(p)

    def t_end(self, p):
        return p["periods"] * self.period(p)

    def dts(self, p):
        return [y / self.omega_max(p) for y in Y_SWEEP]

    def order_dts(self, p):
        return [y / self.omega_max(p) for y in Y_ORDER]

    def reference_dt(self, p):
        return Y_REFERENCE / self.omega_max(p)

    def bodies(self, p):
        return int(np.sum(~self.grid(p)[1]))

    def motion_scale(self, p):
        return p["amplitude"]

    def observables(self, p, obs):
        _, _, phi = self.grid(p)
        x, v = np.asarray(obs["x"], float), np.asarray(obs["v"], float)
        norm = float(phi @ phi)
        return {"x": x, "amplitude": x[..., 2] @ phi / norm,
                "amplitude_rate": v[..., 2] @ phi / norm}

    def reference(self, p, t):
        _, _, phi = self.grid(p)
        t = np.asarray(t, float)
        x = np.broadcast_to(self.rest_positions(p), t.shape + (len(phi), 3)).copy()
        amp = p["amplitude"] * np.cos(self.omega(p) * t)
        x[..., 2] = amp[:, None] * phi
        return {"x": x, "amplitude": amp,
                "amplitude_rate": -p["amplitude"] * self.omega(p) * np.sin(self.omega(p) * t)}

    def error(self, p, observed, reference):
        diff = np.asarray(observed["x"]) - np.asarray(reference["x"])
        return np.max(np.linalg.norm(diff, axis=-1), axis=-1)

    def energy(self, p, obs):
        """Kinetic + spring energy of every sample (J): 1/2 m |v|^2 + 1/2 k |d|^2 (rest length
        0; the same sums as refsim.models.spring_network's network_potential and
        kinetic_energy, vectorised over the samples)."""
        index, pinned, _ = self.grid(p)
        edges = self._edges(index, pinned)
        x, v = np.asarray(obs["x"], float), np.asarray(obs["v"], float)
        d = x[..., edges[:, 0], :] - x[..., edges[:, 1], :]
        return 0.5 * (p["stiffness"] * np.sum(d * d, axis=(-2, -1))
                      + p["mass"] * np.sum(v * v, axis=(-2, -1)))

    def flat_energy(self, p) -> float:
        """The pretension's energy at rest, flat (J): the floor the mode oscillates above."""
        return network_potential(self.scene(p).part(SpringNetwork), self.rest_positions(p),
                                 (0.0, 0.0, 0.0))

    def energy_period(self, p, settings=None):
        """The undamped network conserves its kinetic + spring energy (separable): the
        mode's period (judged where a quarter of the run spans it: the `long` variant)."""
        return self.period(p)

    def energy_scale(self, p):
        """The mode's energy E0 - E_flat = 1/2 m w^2 A^2 sum phi^2 (J)."""
        _, _, phi = self.grid(p)
        return 0.5 * p["mass"] * (self.omega(p) * p["amplitude"]) ** 2 * float(phi @ phi)

    def extra_metrics(self, p, obs, observed, reference):
        """amplitude_per_period: the mode's amplitude sqrt(q^2 + (q'/w)^2) at the last sample
        over A, to the power (period / t): the numerical damping per period measured from the
        run (Baraff-Witkin: (1 + y^2)^(-P / (2 h)) exactly; symplectic steppers ~1)."""
        t = float(np.asarray(obs["t"], float)[-1])
        q, rate = observed["amplitude"][-1], observed["amplitude_rate"][-1]
        ratio = math.hypot(q, rate / self.omega(p)) / p["amplitude"]
        return {"amplitude_per_period": ratio ** (self.period(p) / t) if t > 0 else 1.0}

    # -- tolerance ----------------------------------------------------------------------------
    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        steps = round(self.t_end(p) / dt)
        w, amp = self.omega(p), p["amplitude"]
        peak = float(np.max(np.abs(self.grid(p)[2])))
        roundoff, why_round = self._roundoff(p, steps)
        if integrator not in STEPPERS:
            from refsim.case import is_symplectic
            tol = order_tolerance(amp * peak, w * self.t_end(p), w * dt, order,
                                  is_symplectic(settings))
            return tol + roundoff, (f"order {order}: no closed-form step for {integrator}; "
                                    "the global error bound of such a method (order_tolerance)"
                                    + why_round)
        k = np.arange(steps + 1)
        gap = mode_amplitude(integrator, w, dt, k) - np.cos(w * dt * k)
        deviation = float(np.max(np.abs(gap))) * amp * peak
        return deviation + roundoff, (
            f"the exact discrete mode [S(y)^n]_00 A phi of {integrator} (S its closed-form step "
            f"on the mode, y = w dt = {w * dt:.4g}) deviates from A phi cos(w t) by at most "
            f"{deviation:.6g} m over the run" + why_round)

    def _roundoff(self, p, steps) -> tuple[float, str]:
        """Each step rounds every node's position (|x| <= the span L) and velocity (|v| / w <=
        A) by eps/2 of their size: S = eps/2 (L + A) per component, sqrt 3 components; the
        modes are undamped (neutrally stable) so the roundings add up: n eps S (Henrici's
        linear worst case), doubled for the velocity's share of every later position."""
        span = (int(p["nodes"]) + 1) * p["spacing"] * math.sqrt(2.0 if p["shape"] != "string"
                                                                else 1.0)
        scale = 0.5 * (span + p["amplitude"]) * math.sqrt(3.0)
        bound = 2.0 * (steps + 1) * EPS * scale
        return bound, (f"; plus round-off 2 (n + 1) eps S = {bound:.3g} (n = {steps} steps, "
                       f"S = sqrt 3 (L + A) / 2 = {scale:.3g} m: each step rounds positions of "
                       "size L and velocities of size w A; undamped modes keep the roundings: "
                       "Henrici's linear worst case; 2: position and velocity)")

    # -- stability ----------------------------------------------------------------------------
    def stiffest_factor(self, p) -> float:
        """w_max / sqrt(k / m): 2 sin(N pi / (2 (N + 1))) (string), 2 sqrt 2 sin(...)
        (membrane); -> 2 (2 sqrt 2) as N grows: the slide's one-spring limit halved."""
        return self.omega_max(p) / math.sqrt(p["stiffness"] / p["mass"])

    def stability(self, p):
        """`refsim stress`: y = dt sqrt(k / m) (slide 001's unit), the stiffest mode released
        from rest (mode N on every axis: every other mode is slower and stays stable), so the
        run is one undamped oscillator at w_max; theory: the stepper's limit on an oscillator
        (2 symplectic Euler and Verlet, 2 sqrt 2 RK4, unbounded Baraff-Witkin) over
        w_max / sqrt(k / m)."""
        from refsim.stress.spec import StabilitySpec
        n = int(p["nodes"])
        q = {**p, "mode": n, "mode2": n}
        factor = self.stiffest_factor(q)

        def theory(stepper, settings):
            if stepper is None:
                return math.nan, "no refsim stepper equals this integrator"
            limit = oscillator_limit(stepper)
            return limit / factor, (
                f"dt sqrt(k/m) <= y_max / (w_max / sqrt(k/m)) = {limit:.6g} / {factor:.6g}: "
                f"y_max the oscillator limit of {stepper.family}; the stiffest mode's "
                f"w_max = {factor:.6g} sqrt(k/m) -> 2 sqrt(k/m), half slide 001's one-spring "
                "2 sqrt(m/k)")
        crit = Criterion(STRESS_PERIODS)  # the mode's own units: y_mode = w_max dt
        from refsim.integrators import get_integrator
        slack = max(finite_time(get_integrator(s), oscillator_limit(get_integrator(s)),
                                crit)[1] for s in STEPPERS[:3])
        return StabilitySpec(
            name="dt sqrt(k/m)", dt_unit=math.sqrt(p["mass"] / p["stiffness"]), theory=theory,
            source="linear stability of each stepper on the stiffest normal mode",
            energy_bound=1e4 * self.energy_scale(q), energy_floor=self.flat_energy(q),
            params={"mode": n, "mode2": n}, periods=STRESS_PERIODS,
            quick_periods=20, cycle=2 * math.pi / factor, resolution=slack / factor,
            resolution_reason=(
                "the run is one oscillator at w_max (the stiffest mode from rest), so the "
                "stated criterion lands where refsim.stress.search.finite_time puts it for "
                "that oscillator: symplectic Euler's peak E0 / (1 - y/2) below the limit, "
                "slow growth over the judged steps past it (largest over the explicit "
                "steppers), in units of w_max / sqrt(k/m)"))


CASE = StringModes()
