"""Hair cantilever: a chain of hinge springs clamped at its root, bent by gravity (slide 002's
bending springs; docs/models.md#springs-bending-and-cantilever), settled by air drag to its
static equilibrium, against the EXACT DISCRETE equilibrium of the same chain.

Scene (x-z plane, gravity -z): nodes 0 (x = -l) and 1 (x = 0) pinned (the clamped root), N free
links of rest length l = L / N along +x (nodes 2..N+1), stretch springs k_s (N/m) on every
link, hinge springs k_b = E I / l (N m, rest angle 0: straight) at nodes 1..N (each free link
has a hinge at its inner end), free node masses m, the tip node M (the heavy tip), air drag c
on every node (scene.linear_drag). The hair starts straight at rest (theta = 0 at every hinge).
E I is set by the load ratio alpha = P L^2 / (3 E I) (P = M g): the linear tip deflection over L.

Reference (derived here, independently of the network code): with phi_j the angle of free link
j below +x and psi_j = phi_j - phi_(j-1) (phi_0 = 0) its hinge's turning angle,
- moment balance at hinge j (a virtual rigid rotation of the outboard part about node j):
  k_b psi_j = sum_(i outboard) W_i (x_i - x_j), W_i = m_i g every node weight;
- link j's stretch (a virtual slide of the outboard part along link j): k_s (L_j - l) =
  (sum_(i outboard) W_i) sin phi_j;
solved for the N angles by scipy.optimize.root (continuation in the load) to a residual of
round-off. Its small-load limit, the tip load alone, is P l^3 N (N + 1)(2N + 1) / (6 E I)
-> P L^3 / (3 E I) as N -> infinity (relative 3 / (2N)).

Dynamics reach it: every consistent stepper's fixed point (v = 0, a(x*) = 0) is the exact
equilibrium, whatever dt: the error left at t_end is the transient, not a truncation error, so
no order in dt exists (order_meaningful False). The transient bound: linearised about x*, the
state z = (x - x*, v) follows z' = A z, so |x - x*|_2 <= sum_k |V_x,k|_2 |c_k| e^(Re lambda_k t)
(eigenvectors V of A, c = V^-1 z0); t_end is where that bound falls to `settle` L. Tolerance
(on err_final, the last sample): round-off 8 eps k_s L ||K^-1|| (the equilibrium's response to
force round-off) plus the bound at t_end, times exp(|lambda|^2 h t_end) for a stepper's own decay
of the slowest surviving mode (a one-step method's factor differs from e^(lambda h) by at most
(|lambda| h)^2 per step). The first phase from straight is nonlinear in `heavy`: the bound is
the linearised one (the tests check every stepper meets it).

Observable `x` (m): every node position; err_final is the Euclidean norm over nodes at t_end.
Extra metric `tip_deflection_error` (m). Left out: the end moment M = 2 pi E I / L that curls
the hair into a circle needs a follower couple on the last link, which a SpringNetwork scene
cannot express (no scene fields are added for it).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.optimize import brentq, root

from refsim.case import EPS, Case, Param
from refsim.scene import Scene, SpringNetwork

G = 9.81


def tip_load_deflection(load, link, n_links, bending_rigidity):
    """Small-load tip deflection of N hinge links under a tip load P:
    P l^3 N (N + 1)(2N + 1) / (6 E I)."""
    n = n_links
    return load * link ** 3 * n * (n + 1) * (2 * n + 1) / (6 * bending_rigidity)


def _shape(psi, link, k_stretch, weights):
    """(x, z) of the root node 1 and the free nodes for hinge turning angles psi."""
    phi = np.cumsum(psi)
    outboard = np.cumsum(weights[::-1])[::-1]  # weight beyond each link's inner node
    lengths = link + outboard * np.sin(phi) / k_stretch
    x = np.concatenate([[0.0], np.cumsum(lengths * np.cos(phi))])  # root node 1, then free
    z = np.concatenate([[0.0], -np.cumsum(lengths * np.sin(phi))])
    return x, z


def moment_residual(psi, link, k_bend, k_stretch, weights):
    """k_b psi_j - sum_(i > j) W_i (x_i - x_j) at every hinge j (N m)."""
    x, _ = _shape(psi, link, k_stretch, weights)
    lever = x[None, 1:] - x[:-1, None]  # (hinge j, free node i): x_i - x_j
    outboard = np.triu(np.ones((len(psi), len(psi))))  # node i beyond hinge j
    return k_bend * psi - np.sum(outboard * lever * weights[None, :], axis=1)


def hair_equilibrium(link, k_bend, k_stretch, weights, stages=8):
    """Exact discrete equilibrium: (hinge angles psi (N,), free node positions (N, 3))."""
    weights = np.asarray(weights, float)
    psi = np.zeros(len(weights))
    for s in np.linspace(0, 1, stages + 1)[1:]:  # continuation in the load
        sol = root(moment_residual, psi, args=(link, k_bend, k_stretch, s * weights),
                   method="hybr", options={"xtol": 1e-15})
        psi = sol.x
    x, z = _shape(psi, link, k_stretch, weights)
    return psi, np.c_[x[1:], np.zeros(len(psi)), z[1:]]


class HairCantilever(Case):
    name = "hair_cantilever"
    description = ("hair as hinge springs (k_b = EI/l), clamped root, heavy tip under gravity, "
                   "settled by drag: exact discrete equilibrium (moment balance + stretch)")
    tags = ("network", "hair", "bending", "exact", "steady")
    observable, units = "x", "m"
    tolerance_norm = "err_final"
    order_meaningful = False  # the fixed point is exact at every dt: the error is the transient
    initial_state_is_reference = False  # the reference is the end state
    params = {
        "links": Param(6, 1, 256, "N free links (hinges at their inner ends)"),
        "length": Param(1.0, 0.0, 100.0, "L (m)", low_inclusive=False),
        "tip_mass": Param(0.1, 0.0, 1e3, "M (kg), the tip node", low_inclusive=False),
        "hair_mass": Param(0.1, 0.0, 1e3, "kg, spread over the N + 1 nodes other than the tip "
                           "(m = hair_mass / (N + 1) each)", low_inclusive=False),
        "load_ratio": Param(0.1, 0.0, 10.0, "alpha = P L^2 / (3 E I), P = M g",
                            low_inclusive=False),
        "stretch_stiffness": Param(500.0, 0.0, 1e9, "k_s (N/m) of every link",
                                   low_inclusive=False),
        "zeta": Param(0.4, 0.0, 10.0, "drag c = 2 zeta M w1, w1 = sqrt(3 E I / (L^3 M))",
                      low_inclusive=False),
        "settle": Param(1e-4, 1e-15, 0.1, "linearised transient bound at t_end (units of L)",
                        low_inclusive=False),
    }
    variants = {"default": {}, "fine": {"links": 32}, "heavy": {"load_ratio": 1.0}}
    default_variants = quick_variants = ("default",)

    # -- parameters -------------------------------------------------------------------------
    @staticmethod
    def dims(p):
        n = int(p["links"])
        if n != p["links"]:
            raise ValueError(f"hair_cantilever.links must be an integer in [1, 256], got "
                             f"{p['links']}")
        link = p["length"] / n
        rigidity = p["tip_mass"] * G * p["length"] ** 2 / (3 * p["load_ratio"])
        return n, link, rigidity

    def drag(self, p):
        _, _, rigidity = self.dims(p)
        w1 = np.sqrt(3 * rigidity / (p["length"] ** 3 * p["tip_mass"]))
        return 2 * p["zeta"] * p["tip_mass"] * w1

    def masses(self, p):
        n = self.dims(p)[0]
        return np.r_[np.full(n + 1, p["hair_mass"] / (n + 1)), p["tip_mass"]]  # nodes 0..N+1

    def network(self, p):
        n, link, rigidity = self.dims(p)
        nodes = n + 2
        x = np.zeros((nodes, 3))
        x[:, 0] = np.arange(-1, n + 1) * link
        chain = np.arange(nodes)
        return SpringNetwork(positions=x, masses=self.masses(p),
                             edges=np.c_[chain[:-1], chain[1:]],
                             stiffness=p["stretch_stiffness"], rest_length=link,
                             hinges=np.c_[chain[:-2], chain[1:-1], chain[2:]],
                             hinge_stiffness=rigidity / link, hinge_rest_angle=0.0,
                             pinned=[0, 1])

    def scene(self, p):
        return Scene(parts=(self.network(p),), gravity=(0.0, 0.0, -G),
                     linear_drag=self.drag(p))

    # -- reference --------------------------------------------------------------------------
    def equilibrium(self, p):
        """Free node positions (N, 3) of the exact discrete equilibrium."""
        return _equilibrium_cached(tuple(sorted(p.items())))

    def reference_positions(self, p):
        start = self.network(p).positions
        return np.r_[start[:2], self.equilibrium(p)]

    def observables(self, p, obs):
        return {"x": np.asarray(obs["x"], float)}

    def reference(self, p, t):
        return {"x": np.broadcast_to(self.reference_positions(p), (len(t),) +
                                     self.reference_positions(p).shape)}

    def extra_metrics(self, p, obs, observed, reference):
        tip = observed["x"][-1, -1, 2] - reference["x"][-1, -1, 2]
        return {"tip_deflection_error": float(abs(tip))}

    def motion_scale(self, p):
        return float(np.max(np.abs(self.equilibrium(p)[:, 2])))

    def bodies(self, p):
        return self.dims(p)[0]

    # -- transient and steps ----------------------------------------------------------------
    def linearised(self, p):
        return _linearised_cached(tuple(sorted(p.items())))

    def t_end(self, p):
        return self.linearised(p)["t_end"]

    def dts(self, p):
        """One step, 1.5 / w_max: inside every explicit stepper's stability interval on the
        fastest mode (symplectic Euler and Verlet: w dt < 2; RK4: < 2.8). One is enough: the
        error at t_end does not depend on dt (module doc), and the default run's budget is
        ~640 steps."""
        return [1.5 / self.linearised(p)["w_max"]]

    def reference_dt(self, p):
        return self.dts(p)[-1]

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        lin = self.linearised(p)
        t = self.t_end(p)
        stepper = np.exp(lin["slow_rate"] * dt * lin["slow_rate"] * t)
        tol = lin["roundoff"] + lin["bound_at_end"] * stepper
        return tol, (f"round-off {lin['roundoff']:.2g} m (8 eps k_s L ||K^-1||) + the "
                     f"linearised transient bound {lin['bound_at_end']:.2g} m at t_end "
                     f"x exp(|lambda|^2 dt t) = {stepper:.3g} for the stepper's own decay of "
                     "the slowest mode (module doc)")


@lru_cache(maxsize=16)
def _equilibrium_cached(items):
    p = dict(items)
    case = CASE
    _, link, rigidity = case.dims(p)
    weights = case.masses(p)[2:] * G
    return hair_equilibrium(link, rigidity / link, p["stretch_stiffness"], weights)[1]


@lru_cache(maxsize=16)
def _linearised_cached(items):
    """The linearisation about the exact equilibrium: modal transient bound, t_end, w_max,
    round-off (module doc). Uses the model the engines approximate (NetworkSystem)."""
    from refsim.models.spring_network import NetworkSystem
    p = dict(items)
    case = CASE
    scene = case.scene(p)
    system = NetworkSystem(scene.part(SpringNetwork), scene.gravity, scene.linear_drag)
    x_star = case.equilibrium(p).reshape(-1)
    ax, av = system.jacobians(0.0, x_star, np.zeros_like(x_star))
    size = len(x_star)
    a = np.block([[np.zeros((size, size)), np.eye(size)], [ax, av]])
    lam, vec = np.linalg.eig(a)
    z0 = np.r_[scene.part(SpringNetwork).positions[2:].reshape(-1) - x_star, np.zeros(size)]
    weight = np.linalg.norm(vec[:size], axis=0) * np.abs(np.linalg.solve(vec, z0))

    def bound(t):
        return float(np.sum(weight * np.exp(lam.real * t)))

    target = p["settle"] * p["length"]
    t_hi = 1.0
    while bound(t_hi) > target:
        t_hi *= 2
    t_end = brentq(lambda t: bound(t) - target, 0.0, t_hi, xtol=1e-12 * t_hi)
    slowest = np.argmax(weight * np.exp(lam.real * t_end))
    stiffness = -ax * np.repeat(system.masses, 3)[:, None]  # K = -df/dx
    k_inv = np.linalg.norm(np.linalg.inv(stiffness), 2)
    return {"t_end": t_end, "bound_at_end": bound(t_end),
            "slow_rate": float(abs(lam[slowest])),
            "w_max": float(np.sqrt(np.max(np.abs(np.linalg.eigvals(ax))))),
            "roundoff": 8 * EPS * p["stretch_stiffness"] * p["length"] * k_inv}


CASE = HairCantilever()
