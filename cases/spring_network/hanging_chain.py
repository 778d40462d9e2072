"""Hanging chain: N elastic links between two pins at the same height, settling under gravity
and air drag to its EXACT DISCRETE static equilibrium (slides 000-002;
docs/models.md#springs-hanging-chain).

Chain: N + 1 nodes in the x-z plane (y = 0), nodes 0 and N pinned at (0, 0, 0) and (S, 0, 0);
the chain of length L and mass M has links of rest length l0 = L / N and stiffness
k = EA / l0 (N/m; EA the axial stiffness in N, so `fine` refines the same chain), and free
nodes of mass m = M / N (each carries one link's mass; the half links at the ends hang on the
pins). Gravity (0, 0, -9.81), no edge damping, air drag -c v on every free node.

Reference: the exact discrete equilibrium (cases.networks._chain: constant horizontal tension
H, V_i = V0 + sum of the weights, link i stretched to l0 (1 + T_i / k); a two-unknown root
find to ~1e-16 relative) at every sample; its continuum limit is the catenary (tested: the
sag converges at O(N^-2)). Start: at rest at x* + s (q - x*), q the nodes at x_j = j S / N on
the parabola through the pins as deep as the equilibrium x*, s = `start_fraction` (0.05: the
transient stays near the linear regime, where its bound is derived). Compared error: the largest node distance from the
equilibrium at the LAST sample (`err_final`, m).

Drag: c = 2 zeta m w_min, w_min the lowest angular frequency of the chain linearised at the
equilibrium (K phi = w^2 m phi), so every mode is underdamped (zeta_n = zeta w_min / w_n <=
zeta < 1) and, the damping being mass-proportional, decays exactly as exp(-c t / (2 m)) in
the linear regime; t_end = `e_folds` 2 m / c. Tolerance: the named method's exact discrete
transient on the linearised chain from the actual start (refsim.expected.discrete_solution, the
start at rest), its largest node distance at the last step, plus the links' geometric
nonlinearity to first order, |x0 - x*|_2 / l0 times the transient's worst case
||P S(h)^n P^T||_2 |x0 - x*|_2 (P the positions' rows), the sum times one stated safety factor
2; plus round-off. Every consistent stepper maps (x*, 0) to itself (zero force, zero velocity), so its
fixed point is the exact equilibrium and the error is the transient alone: no convergence
order in dt exists (`order_meaningful = False`). Energy (potential + kinetic) must not rise
under the drag: `energy_rise`, the largest rise over any earlier sample, in energy scales.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from refsim.case import EPS, Case, Param
from refsim.expected import discrete_solution, has_discrete_solution, maps
from refsim.models.spring_network import NetworkSystem
from refsim.scene import Scene, SpringNetwork

from ._chain import chain_equilibrium
from ._linear_steps import first_order_matrix

G = 9.81
SAFETY = 2.0  # the transient bound's one stated safety factor (transient_bound)
Y_STEP = 1.5  # w_max dt: inside every explicit stepper's limit (2; 2 sqrt 2 for RK4)


class HangingChain(Case):
    name = "hanging_chain"
    description = ("hanging chain of elastic links settling under air drag to its exact "
                   "discrete equilibrium (two-unknown root find; catenary limit)")
    tags = ("network", "chain", "equilibrium", "exact")
    observable, units = "x", "m"
    tolerance_norm = "err_final"
    order_meaningful = False  # every stepper's fixed point is the exact equilibrium
    initial_state_is_reference = False  # the reference is the end state
    params = {
        "links": Param(8, 2, 2000, "N links"),
        "length": Param(1.0, 0.0, 1e3, "L, the chain's rest length N l0 (m)",
                        low_inclusive=False),
        "mass": Param(0.08, 0.0, 1e6, "M, the chain's mass (kg)", low_inclusive=False),
        "axial_stiffness": Param(5.0, 0.0, 1e12, "EA = k l0 (N)", low_inclusive=False),
        "span": Param(0.8, 0.0, 1e3, "S, the distance between the pins (m), < L",
                      low_inclusive=False),
        "zeta": Param(0.9, 0.0, 0.99, "damping ratio of the lowest mode (< 1)",
                      low_inclusive=False),
        "start_fraction": Param(0.05, 0.0, 1.0, "s: the start is x* + s (parabola - x*)",
                                low_inclusive=False),
        "e_folds": Param(14.0, 0.0, 200.0, "t_end in decay times 2 m / c",
                         low_inclusive=False),
    }
    variants = {"default": {}, "fine": {"links": 40}, "stiff": {"axial_stiffness": 500.0}}
    default_variants = quick_variants = ("default",)

    # -- the chain ----------------------------------------------------------------------------
    @staticmethod
    def _sizes(p) -> tuple[int, float, float, float]:
        n = int(p["links"])
        rest = p["length"] / n
        if p["span"] >= p["length"]:
            raise ValueError(f"hanging_chain.span must be in (0, {p['length']:g}) m (the "
                             f"chain's length), got {p['span']}")
        return n, rest, p["axial_stiffness"] / rest, p["mass"] / n

    def equilibrium(self, p):
        return _equilibrium(*self._key(p))

    def _key(self, p):
        return tuple(float(p[k]) for k in ("links", "length", "mass", "axial_stiffness",
                                           "span"))

    def equilibrium_positions(self, p) -> np.ndarray:
        nodes = self.equilibrium(p).nodes
        return np.stack([nodes[:, 0], np.zeros(len(nodes)), nodes[:, 1]], 1)

    def start_positions(self, p) -> np.ndarray:
        n, _, _, _ = self._sizes(p)
        x = np.linspace(0.0, p["span"], n + 1)
        depth = -float(self.equilibrium(p).nodes[:, 1].min())
        z = -depth * (1.0 - (2.0 * x / p["span"] - 1.0) ** 2)
        z[[0, -1]] = 0.0
        parabola = np.stack([x, np.zeros(n + 1), z], 1)
        eq = self.equilibrium_positions(p)
        return eq + p["start_fraction"] * (parabola - eq)

    def network(self, p, positions) -> SpringNetwork:
        n, rest, k, m = self._sizes(p)
        edges = np.stack([np.arange(n), np.arange(1, n + 1)], 1)
        return SpringNetwork(positions=positions, masses=m, edges=edges, stiffness=k,
                             rest_length=rest, pinned=np.array([0, n]))

    def drag(self, p) -> float:
        """c = 2 zeta m w_min (N s/m)."""
        return 2.0 * p["zeta"] * self._sizes(p)[3] * self.linearised(p)[2]

    def linearised(self, p):
        """(A = K / m on the free coordinates (no drag), the free mask, w_min, w_max)."""
        return _linearised(*self._key(p))

    def scene(self, p):
        return Scene(parts=(self.network(p, self.start_positions(p)),),
                     gravity=(0.0, 0.0, -G), linear_drag=self.drag(p))

    # -- the run ------------------------------------------------------------------------------
    def decay_rate(self, p) -> float:
        """alpha = c / (2 m) = zeta w_min (1/s)."""
        return p["zeta"] * self.linearised(p)[2]

    def t_end(self, p):
        return p["e_folds"] / self.decay_rate(p)

    def dts(self, p):
        return [Y_STEP / self.linearised(p)[3]]

    def reference_dt(self, p):
        return self.dts(p)[0]

    def bodies(self, p):
        return int(p["links"]) - 1

    def motion_scale(self, p):
        """The start's largest node distance from the equilibrium (m)."""
        return float(np.max(np.linalg.norm(self.start_positions(p)
                                           - self.equilibrium_positions(p), axis=1)))

    def target_error(self, p):
        return 1e-6 * self.motion_scale(p)

    def error_floor(self, p):
        return 1e-13 * p["length"]

    def observables(self, p, obs):
        return {"x": np.asarray(obs["x"], float),
                "mid_depth": -np.asarray(obs["x"], float)[:, int(p["links"]) // 2, 2]}

    def reference(self, p, t):
        t = np.asarray(t, float)
        x = self.equilibrium_positions(p)
        return {"x": np.broadcast_to(x, t.shape + x.shape),
                "mid_depth": np.full(t.shape, -x[int(p["links"]) // 2, 2])}

    def error(self, p, observed, reference):
        diff = np.asarray(observed["x"]) - np.asarray(reference["x"])
        return np.max(np.linalg.norm(diff, axis=-1), axis=-1)

    # -- energy -------------------------------------------------------------------------------
    def energy(self, p, obs):
        """Stretch + gravity + kinetic energy of every sample (J), the sums of
        refsim.models.spring_network's network_potential and kinetic_energy vectorised over
        the samples (pinned nodes do not move: their terms are constant)."""
        _, rest, k, m = self._sizes(p)
        x, v = np.asarray(obs["x"], float), np.asarray(obs["v"], float)
        length = np.linalg.norm(np.diff(x, axis=-2), axis=-1)
        return (0.5 * k * np.sum((length - rest) ** 2, axis=-1)
                + m * G * np.sum(x[..., 1:-1, 2], axis=-1)
                + 0.5 * m * np.sum(v * v, axis=(-2, -1)))

    def energy_scale(self, p):
        """E(start) - E(equilibrium): the energy the drag removes (J)."""
        start, eq = self.start_positions(p), self.equilibrium_positions(p)
        e = self.energy(p, {"x": np.stack([start, eq]), "v": np.zeros((2,) + start.shape)})
        return float(e[0] - e[1])

    def extra_metrics(self, p, obs, observed, reference):
        """energy_rise: max over samples of E_k - min_{j<k} E_j, in energy scales (zero when
        the energy never rises under the drag)."""
        e = self.energy(p, obs)
        rise = float(np.max(e - np.minimum.accumulate(e)))
        return {"energy_rise": rise / self.energy_scale(p)}

    # -- tolerance ----------------------------------------------------------------------------
    def transient_bound(self, p, integrator, dt) -> tuple[float, str]:
        """The named method's exact discrete transient on the linearised chain from the actual
        start, max over nodes, plus the links' geometric nonlinearity (reason below)."""
        a, free, _, _ = self.linearised(p)
        b = -self.drag(p) / self._sizes(p)[3] * np.eye(len(a))
        steps = round(self.t_end(p) / dt)
        start = (self.start_positions(p) - self.equilibrium_positions(p))[free].reshape(-1)
        delta = float(np.linalg.norm(start))
        if has_discrete_solution(integrator):
            x_n, _ = discrete_solution(integrator, a, b, start, np.zeros_like(start), dt,
                                       [steps])
            power = np.linalg.matrix_power(maps(integrator, a, b, dt)[1], steps)
            how = (f"{integrator}'s exact discrete solution (refsim.expected) after n = "
                   f"{steps} steps")
        else:
            from scipy.linalg import expm
            power = expm(first_order_matrix(a, b) * steps * dt)
            x_n = (power[:len(a), :len(a)] @ start)[None]
            how = (f"no step matrix for {integrator}: the exact linearised flow exp(J t) at "
                   f"t = {steps * dt:.4g} s")
        linear = float(np.max(np.linalg.norm(x_n[0].reshape(-1, 3), axis=1)))
        gain = float(np.linalg.norm(power[:len(a), :len(a)], 2))
        ratio = delta / self._sizes(p)[1]
        nonlinear = ratio * gain * delta
        return SAFETY * (linear + nonlinear), (
            f"linearised transient: {how} from the actual start (at rest, |x0 - x*| = "
            f"{delta:.3g} m), the largest node distance {linear:.3g} m; plus the links' "
            f"geometric nonlinearity |x0 - x*| / l0 = {ratio:.3g} times the transient's "
            f"worst case, ||P S^n P^T||_2 |x0 - x*| = {gain * delta:.3g} m (a link displaced by "
            "|delta| turns by at most |delta| / l0, so the forces' remainder beyond the "
            "linearisation is at most that fraction of the linear ones; every mode decays at "
            "the same rate c / 2m, so its share of the transient stays that fraction, to "
            f"first order): {nonlinear:.3g} m; the sum times the safety factor {SAFETY:g} "
            "(the nonlinear remainder is a first-order estimate: measured up to 1.56 x it on "
            "the stiff variant's velocity Verlet)")

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        transient, why = self.transient_bound(p, integrator, dt)
        roundoff, why_round = self._roundoff(p, dt)
        return transient + roundoff, why + why_round

    def _roundoff(self, p, dt) -> tuple[float, str]:
        """Each step rounds positions of size <= S by eps/2 per component; the drag damps
        those roundings at rate alpha, so they add up over 1 / (alpha dt) steps at most (the
        geometric sum of exp(-alpha dt) per step); the forces' rounding, eps T_max per node,
        shifts the discrete fixed point by at most that over m w_min^2."""
        _, _, w_min, _ = self.linearised(p)
        n_eff = min(self.t_end(p) / dt, 1.0 / (self.decay_rate(p) * dt)) + 1.0
        scale = 0.5 * math.sqrt(3.0) * p["span"]
        tension = float(self.equilibrium(p).tensions.max())
        shift = 4.0 * EPS * tension * math.sqrt(3 * int(p["links"])) / (
            self._sizes(p)[3] * w_min ** 2)
        bound = n_eff * EPS * scale + shift
        return bound, (f"; plus round-off {bound:.3g} m: n_eff eps S (n_eff = {n_eff:.3g} "
                       f"steps, S = sqrt 3 span / 2: each step rounds the positions; the drag "
                       f"forgets them after 1 / (alpha dt) steps) + the fixed point's shift "
                       f"by the forces' rounding 4 eps T_max sqrt(3 N) / (m w_min^2)")


@functools.lru_cache(maxsize=32)
def _equilibrium(links, length, mass, axial_stiffness, span):
    n = int(links)
    rest = length / n
    return chain_equilibrium(np.full(n - 1, mass / n * G), rest, axial_stiffness / rest, span)


@functools.lru_cache(maxsize=32)
def _linearised(links, length, mass, axial_stiffness, span):
    """(da/dx of the chain at its equilibrium on the free coordinates (3 (N - 1))^2, the free
    mask, w_min, w_max): the in-house model's exact Jacobian (no drag), its spectrum by
    eigvalsh (K is symmetric: the forces are conservative)."""
    case = HangingChain()
    p = dict(zip(("links", "length", "mass", "axial_stiffness", "span"),
                 (links, length, mass, axial_stiffness, span)))
    x_eq = case.equilibrium_positions(p)
    system = NetworkSystem(case.network(p, x_eq), (0.0, 0.0, -G), 0.0)
    x_free = x_eq[system.free].reshape(-1)
    a, _ = system.jacobians(0.0, x_free, np.zeros_like(x_free))
    a = 0.5 * (a + a.T)  # equal masses: da/dx = K / m is symmetric up to round-off
    w2 = np.linalg.eigvalsh(-a)
    if w2[0] <= 0:
        raise ValueError("hanging_chain: the equilibrium must be stable (w_min^2 > 0), got "
                         f"{w2[0]:.3g}")
    return a, system.free.copy(), math.sqrt(w2[0]), math.sqrt(w2[-1])


CASE = HangingChain()
