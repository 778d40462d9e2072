"""Hanging cloth (slides 000-002, issue 16 case 4): a square cloth of n x n nodes, side L,
node mass m = M / n^2, released from rest flat in the x-z plane (rest lengths = initial
lengths) and falling under gravity -z while held by its two top corners (variant `top_row`:
the whole top row pinned). Structural springs join grid neighbours, shear springs both
diagonals of every cell; every spring has stiffness K (N/m, slide 000's convention; slide
001's k_s = K r in N is K l = K L / (n - 1) for a structural and K sqrt(2) l for a shear
spring) and damping c (N s/m) along the edge; air drag -c_air v on every node with
c_air = drag_rate m, none by default (pybullet's deformable world has no node drag: without it
pybullet's own mass-spring soft body runs the default; variant `drag` adds it). In 2D a spring grid's sheet stiffness and viscosity (force per unit length
per unit strain or strain rate) are K and c whatever the spacing, so the variants n20, n50
refine the same cloth. Variant `bending`: dihedral springs 1/2 k_b theta^2 across every
interior edge of the triangulation (each cell cut along its down-right diagonal: see
_cloth_grid), the cloth tilted by 0.5 rad about its top edge so that it swings and folds out of
its plane (a cloth falling in its own plane stays flat, and dihedrals would do nothing).
Variant `undamped`: c = c_air = 0, for each stepper's energy drift.

No closed form: the reference is the converged in-house solution, RK4 on
refsim.models.spring_network at h = dt_min / 4 (dt_min the smallest step of the sweep), with its
error estimated by Richardson extrapolation against a run at 2h (_converged; the estimate is
added to every tolerance and checked in the tests), cached per parameters.
Compared observable `x` (m), every node; the error at a sample is the MEAN over nodes of
|x_i - x_ref_i|. Extra metrics: strain_max, the largest edge strain (|d| - L0)/L0 over the run
(an engine with soft constraints or clamps shows it) beside the reference's strain_max_ref;
node_err_max, the worst single node; energy_rise, the largest rise of the energy
E = kinetic + potential (refsim.models.spring_network) between consecutive samples, over the
energy scale M g L (damping and drag only remove energy: the exact flow's E never rises).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from refsim.case import Case, Param, roundoff_tolerance
from refsim.expected import oscillator_rates
from refsim.models.spring_network import kinetic_energy, network_potential
from refsim.scene import Scene, SpringNetwork

from ._cloth_grid import (dihedral_quads, grid_positions, pinned_nodes, shear_edges,
                          structural_edges)
from ._converged import converged_run

GRAVITY = (0.0, 0.0, -9.81)
REFERENCE_REFINEMENT = 4  # the reference step: the sweep's smallest step / 4
SAFETY = 2.0  # the bound's one stated safety factor (see ClothHang.tolerance)
RATE_Y = 0.1  # w h at which a method's oscillator error coefficient is read


def method_constant(integrator: str, order: int) -> tuple[float, str]:
    """(C, why): the named method's local error coefficient per step, C h^(p+1) |x^(p+1)|.
    Order 1: the Taylor remainder of a one-derivative step, 1/2 (symplectic Euler's position
    error is its O(h) shape error, which its phase error, of order 2, does not show). Order
    >= 2: the leading coefficient of its phase plus log-amplitude error per step on the
    oscillator x'' = -w^2 x, (|phi(y)| + |alpha(y)|) / y^(p+1) from its stability function
    (refsim.expected.oscillator_rates) at y = RATE_Y (within 10 % of the limit y -> 0: RK4
    1/120 = 0.0083 -> 0.0090, velocity Verlet 1/24, implicit midpoint 1/12)."""
    if order <= 1:
        return 0.5, "first order: Taylor remainder h^2 x''/2"
    try:
        phase, amplitude = oscillator_rates(integrator, RATE_Y)
    except ValueError:  # an adaptive spec: no step matrix, the generic Taylor remainder
        return 0.5, f"no step matrix for {integrator}: the generic remainder 1/2"
    constant = (abs(phase) + abs(amplitude)) / RATE_Y ** (order + 1)
    return constant, (f"its oscillator phase + log-amplitude error per step over "
                      f"y^(p+1) at y = {RATE_Y:g}, from its stability function")


def cloth_network(p) -> SpringNetwork:
    n = int(p["n"])
    positions = grid_positions(n, p["side"], p["tilt"])
    structural, shear = structural_edges(n), shear_edges(n)
    edges = np.concatenate([structural, shear])
    stiffness = np.concatenate([np.full(len(structural), p["stiffness"]),
                                np.full(len(shear), p["shear_stiffness"])])
    bending = {}
    if p["bending_stiffness"] > 0:
        bending = {"dihedrals": dihedral_quads(n), "dihedral_stiffness": p["bending_stiffness"]}
    return SpringNetwork(positions=positions, masses=p["mass"] / n ** 2, edges=edges,
                         stiffness=stiffness, damping=p["damping"],
                         pinned=pinned_nodes(n, p["pin"]), **bending)


def _key(p) -> tuple:
    return tuple(sorted(p.items()))


@lru_cache(maxsize=8)
def _reference(key, h, store_every):
    p = dict(key)
    net = cloth_network(p)
    return converged_run(net, GRAVITY, ClothHang.air_drag(p), p["t_end"], h, store_every)


def network_energies(net, x, v) -> np.ndarray:
    """Kinetic + potential energy (J) of each sample of (s, n, 3) positions and velocities."""
    return np.array([kinetic_energy(net, vk) + network_potential(net, xk, GRAVITY)
                     for xk, vk in zip(x, v)])


def edge_strain(net, x) -> np.ndarray:
    """(s, m) strain (|d| - L0) / L0 of every edge at every sample."""
    d = x[:, net.edges[:, 0]] - x[:, net.edges[:, 1]]
    return np.linalg.norm(d, axis=-1) / net.rest_length - 1.0


class ClothHang(Case):
    name = "cloth_hang"
    description = ("Square mass-spring cloth (structural + shear springs, damping, optional "
                   "dihedral bending) hanging from its top corners under gravity: node "
                   "positions vs the converged in-house RK4, edge strain, energy")
    tags = ("networks", "cloth", "mass_spring", "converged")
    observable, units = "x", "m"
    params = {
        "n": Param(6, 3, 200, "nodes per side (n x n grid)"),
        "side": Param(1.0, 0.0, 100.0, "side L of the square cloth (m)", low_inclusive=False),
        "mass": Param(0.1, 0.0, 1e3, "total mass M (kg); node mass M / n^2",
                      low_inclusive=False),
        "stiffness": Param(10.0, 0.0, 1e7, "structural spring stiffness K (N/m)",
                           low_inclusive=False),
        "shear_stiffness": Param(10.0, 0.0, 1e7, "shear (diagonal) spring stiffness (N/m)",
                                 low_inclusive=False),
        "damping": Param(0.05, 0.0, 1e3, "damping c of every spring along its edge (N s/m)"),
        "drag_rate": Param(0.0, 0.0, 1e3, "air drag per unit node mass (1/s): c_air = rate m"),
        "bending_stiffness": Param(0.0, 0.0, 1e3, "dihedral stiffness k_b (N m), 0: none"),
        "tilt": Param(0.0, -1.5, 1.5, "initial tilt of the cloth about its top edge (rad)"),
        "pin": Param("corners", doc="pinned nodes", choices=("corners", "top_row")),
        "t_end": Param(0.15, 0.0, 10.0, "duration (s)", low_inclusive=False),
    }
    variants = {"default": {}, "top_row": {"pin": "top_row"},
                "bending": {"bending_stiffness": 2e-3, "tilt": 0.5},
                "undamped": {"damping": 0.0}, "drag": {"drag_rate": 0.5},
                "n20": {"n": 20}, "n50": {"n": 50, "t_end": 0.05}}
    quick_variants = ("default",)
    default_variants = ("default",)
    # Baraff-Witkin's CG formulation where the sparse solve matters (a plain run keeps the
    # default variant within its time budget; the tests run both solves on the default)
    alternatives_variants = ("n20",)

    @staticmethod
    def air_drag(p) -> float:
        return p["drag_rate"] * p["mass"] / int(p["n"]) ** 2

    def validate(self, overrides=None):
        p = super().validate(overrides)
        if p["n"] != int(p["n"]):
            raise ValueError(f"cloth_hang.n must be a whole number in [3, 200], got {p['n']}")
        return p

    def scene(self, p):
        return Scene(parts=(cloth_network(p),), gravity=GRAVITY,
                     linear_drag=self.air_drag(p))

    def t_end(self, p):
        return p["t_end"]

    def omega_max(self, p) -> float:
        """Gershgorin bound on the fastest free vibration at rest, sqrt(max row sum of
        |M^-1 K|): a node with 4 structural and 4 shear springs has 2 K + 2 K_s on its
        diagonal per axis, the off-diagonal blocks as much again: 4 (K + K_s) / m."""
        m = p["mass"] / int(p["n"]) ** 2
        return math.sqrt(4.0 * (p["stiffness"] + p["shear_stiffness"]) / m)

    def dts(self, p):
        """Two steps, the coarser the largest t_end / 2^k with w_max dt <= 1 (inside every
        explicit stepper's stability interval: symplectic Euler and Verlet 2, RK4 2.8), then
        half of it. Steps t_end / 2^k make every sample time (sample_dt) a stored time of the
        reference."""
        coarse = p["t_end"] / 2 ** math.ceil(math.log2(p["t_end"] * self.omega_max(p)))
        return [coarse, coarse / 2]

    def sample_dt(self, p):
        """The sweep's coarsest step (t_end / 2^k, 32 samples on the default): every dt of the
        sweep divides it, and every sample time is a stored time of the reference."""
        return self.dts(p)[0]

    def reference_dt(self, p):
        return self.dts(p)[-1]

    def reference_step(self, p) -> float:
        """min(sweep) / REFERENCE_REFINEMENT, and at most half the storage interval."""
        return min(min(self.dts(p)) / REFERENCE_REFINEMENT,
                   0.5 * self.sample_dt(p))

    def reference_run(self, p):
        h = self.reference_step(p)
        return _reference(_key(p), h, int(round(self.sample_dt(p) / h)))

    def bodies(self, p):
        return int(p["n"]) ** 2

    def motion_scale(self, p):
        """The reference's largest mean node displacement from the start."""
        run = self.reference_run(p)
        return float(np.max(np.mean(np.linalg.norm(run.x - run.x[0], axis=2), axis=1)))

    def energy_scale(self, p):
        """M g L: the potential energy the cloth can give up falling its own side."""
        return p["mass"] * abs(GRAVITY[2]) * p["side"]

    def observables(self, p, obs):
        return {"x": np.asarray(obs["x"], float)}

    def reference(self, p, t):
        x, _ = self.reference_run(p).at(t)
        return {"x": x}

    def reference_energy(self, p, t):
        run = self.reference_run(p)
        x, v = run.at(t)
        return network_energies(cloth_network(p), x, v)

    def error(self, p, observed, reference):
        diff = np.asarray(observed["x"]) - np.asarray(reference["x"])
        return np.mean(np.linalg.norm(diff, axis=2), axis=1)

    def energy(self, p, obs):
        return network_energies(cloth_network(p), np.asarray(obs["x"], float),
                                np.asarray(obs["v"], float))

    def extra_metrics(self, p, obs, observed, reference):
        net = cloth_network(p)
        x = np.asarray(obs["x"], float)
        diff = np.linalg.norm(x - np.asarray(reference["x"]), axis=2)
        energy = self.energy(p, obs)
        rise = np.max(np.diff(energy), initial=0.0) / self.energy_scale(p)
        return {"strain_max": float(np.max(edge_strain(net, x))),
                "strain_max_ref": float(np.max(edge_strain(net, np.asarray(reference["x"])))),
                "node_err_max": float(np.max(diff)), "energy_rise": float(max(rise, 0.0)),
                "reference_error": self.reference_error(p)}

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """S C_m dt^p int_0^t mean_i |x_i^(p+1)| / sinc(y_s)^(p-1) + the reference's error +
        round-off (the reason below states each factor)."""
        run = self.reference_run(p)
        order = max(int(round(order)), 1)
        constant, why_constant = method_constant(integrator, order)
        derivative = run.derivative_integral(order + 1)
        y_s = min(self.omega_max(p) * (run.t[1] - run.t[0]), 1.0)
        differencing = (y_s / math.sin(y_s)) ** (order - 1)
        bound = SAFETY * constant * dt ** order * derivative * differencing
        reference_error = self.reference_error(p)
        roundoff, why_round = roundoff_tolerance(int(round(p["t_end"] / dt)), p["side"])
        return bound + reference_error + roundoff, (
            f"{integrator} (order {order}): the sum of the local errors C h^(p+1) "
            f"|x^(p+1)(t_k)| over the steps, carried, not amplified (dissipative, bounded "
            f"motion), C = {constant:.4g} ({why_constant}): C h^p times I = int_0^t mean_i "
            f"|x_i^(p+1)| dt = {derivative:.3g} (trapezoid over the stored times) from "
            f"the reference's accelerations differenced p - 1 times at spacing h_s (each "
            f"central difference scales a mode of frequency w by sin(w h_s) / (w h_s): "
            f"corrected by (y_s / sin y_s)^(p-1) = {differencing:.3g}, y_s = w_max h_s = "
            f"{y_s:.3g}), times the safety factor {SAFETY:g} (the nonlinear stretch's "
            f"elementary differentials beyond the linear modes); plus the reference's own "
            f"error {reference_error:.3g} (Richardson)" + why_round)

    def reference_error(self, p) -> float:
        """The converged reference's estimated error (Richardson, RK4 at h vs 2h), m."""
        return float(np.max(self.reference_run(p).richardson))

    def error_floor(self, p) -> float:
        """Ten times the reference's own error: below it the reference, not the stepper."""
        return 10.0 * self.reference_error(p) + 1e-13 * p["side"]


CASE = ClothHang()
