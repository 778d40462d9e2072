"""Plastic set (von Mises, refsim.models.fem.plasticity): one free regular tetrahedron (edge
a = 1 m, rho = 1 kg/m^3, E = 1000 Pa, nu = 0.3, linear law, ideal plasticity sigma_y = 10 Pa)
flung apart along x from its rest shape by the node velocities v_a = v0 N (X_a - c), N =
diag(2, -1, -1) / sqrt(6) (an isochoric stretch along x, unit norm; c the centroid: no
momentum, no spin), stretches past yield, stops and springs back. Dynamic (the stretch and
the unloading come from the motion itself, no loads or pins to change over time; the
in-house engine commits the plastic strain after every step).

Why it has a closed form: in one P1 element with lumped masses rho V / 4 (equal: MuJoCo's
split too) node a accelerates by -(4 / rho) P grad phi_a, so F = sum_a x_a grad phi_a^T obeys
F'' = -(4 / rho) P B, B = sum_a grad phi_a grad phi_a^T = (2 / a^2) I for a regular
tetrahedron (|grad phi_a| = 1 / h, h = a sqrt(2/3), isotropic by symmetry): F'' = -k P,
k = 8 / (rho a^2). With the linear law, F = I + e N stays on that line (P = sigma stays
along the deviator N, the volume is kept), and e obeys a one-degree-of-freedom elastic-ideally
plastic oscillator: e'' = -k 2 mu (e - e_p), |2 mu (e - e_p)| <= s_y = sqrt(2/3) sigma_y (the
von Mises yield of the deviator), omega^2 = 2 mu k:
  elastic, until e = e_y = s_y / (2 mu):  e = (v0 / omega) sin(omega t);
  plastic (e'' = -k s_y, flow):           e = e_y + w (t - t1) - k s_y (t - t1)^2 / 2,
                                          w = sqrt(v0^2 - omega^2 e_y^2),
                                          to t_max = t1 + w / (k s_y);
  unloading, elastic:                     e = e_p + e_y cos(omega (t - t_max)),
the permanent set e_p = w^2 / (2 k s_y) = e_max - e_y (the yield rule's closed form with the
kinetic energy spent in plastic work), reached when the stress first returns to zero, a
quarter period after t_max: the run's end (past it the stress heads back to -s_y, exactly the
yield surface, where rounding would decide). Default v0 = sqrt(7) omega e_y: e_p = 3 e_y
= 0.032 (uniaxial measures: eps_p,xx = 2 e_p / sqrt(6) = 0.026, lateral half of it).
Variant plane_strain: an equilateral triangle (edge a, unit thickness) in plane strain, N =
diag(1, -1, 0) / sqrt(2) (eps_zz = 0 stays 0: the deviator has no zz part), lumped masses
rho t A / 3: the same argument gives k = 6 / (rho a^2) (B = (2 / a^2) I in 2D).
Variant hardening (H = 200 Pa, linear isotropic: the yield radius s_y + (2 H / 3) e_p in
these units): while flowing e_p = 2 mu (e - e_y) / (2 mu + 2 H / 3) and s = s_y + h' (e - e_y),
h' = 2 mu (2 H / 3) / (2 mu + 2 H / 3), so the plastic phase is a slower oscillation,
e = e_y - (s_y / h')(1 - cos omega_p tau) + (w / omega_p) sin omega_p tau, omega_p^2 = k h',
to its turning point tan(omega_p tau_max) = w h' / (s_y omega_p); e_p = 2 mu (e_max - e_y) /
(2 mu + 2 H / 3) (0.0229), and the unloading cosine's amplitude is e_max - e_p.
Variant green (StVK, ideal, the tetrahedron; MuJoCo's flex law): F leaves the line I + e N
(E = e N + e^2 N^2 / 2 has an isotropic part, tr E = e^2 / 2), but stays diagonal with
F_yy = F_zz (the law is isotropic, B = (2 / a^2) I, the data symmetric): the stretches
l = diag F obey l'' = -k l S, S = lam tr(E_e) I + 2 mu E_e, E_e = E - E_p, E = (l^2 - 1) / 2,
with refsim's return (dev E stays along N, so the flow is radial along N and E_p = dev E -
e_y N while flowing). No closed form: the reference is a converged solve of those three
stretches (cases/fem/_plastic_green.py: DOP853, rtol 1e-13, to yield, to the turning point
n . l l' = 0, then elastic; energy balanced to 6e-13), t_end its turning point plus the linear
quarter period (stress near zero, far from reverse yield); e_p . N = 0.03182 (linear 0.03184).
Bound: each in-house stepper's exact discrete solution of the three stretches (the same
return, committed after each step; backward Euler by Newton with the elastic tangent, Baraff-
Witkin with it), the node error's max over the samples, plus round-off. sigma_y or E 0.1 %
off is 1.7-4.2x Verlet's bound and 38-52x RK4's. MuJoCo's flex `yield` (eps_y = sigma_y /
(3 mu)) has the same yield surface and deviatoric return but keeps det(I + 2 E_p) = 1
(tr E_p = 1.0e-3 here against refsim's 0) and no return inside RK4's stages: its rows are
inconsistent by that (adapters/mujoco_engine/fem_yield.py).
Observable: the four nodes' positions x = c + (I + e(t) N)(X - c) (m), error the 2-norm over
the nodes; the column permanent_strain is e at the end read from the nodes.
Bound: the named method's exact discrete solution of that reduced oscillator (`discrete`:
each of the in-house engine's steppers written out here for the scalar e from its
definition, the force -k s(e) with s = 2 mu (e - e_p) clamped to +-s_y by the radial return
from the committed e_p, committed after each step, as refsim.models.fem.system does; the node
motion stays on the line F = I + e N for every method, each step being built of forces along
it) against the closed form, max over the samples, times ||N (X - c)||_2, plus round-off
(refsim.case.roundoff_tolerance). Steps omega dt = 0.04 (reference: 110 steps; sigma_y or E
0.1 % off is 1.8-4.4x velocity Verlet's bound there, ~200x RK4's), and 0.02 beside it in the
variant sweep (the default run's cost: the sweep by name), each an integer division of the
run so the last sample is the closed form's t_end.
"""
from __future__ import annotations

import numpy as np

from refsim.case import Case, Param, roundoff_tolerance, sample_steps
from refsim.integrators.spec import spec_name
from refsim.scene import Material, Plasticity, Scene, TetMesh, TriangleMesh

from ._plastic_green import DIRECTION, GreenTet, march

PLANE_DIRECTION = np.diag([1.0, -1.0, 0.0]) / np.sqrt(2.0)  # in plane strain: eps_zz = 0
Y_SWEEP = (0.04, 0.02)  # omega dt
Y_REFERENCE = 0.04


def regular_tetrahedron(edge):
    """(4, 3) vertices, positively oriented."""
    a = float(edge)
    return np.array([[0.0, 0.0, 0.0], [a, 0.0, 0.0], [a / 2, a * np.sqrt(3) / 2, 0.0],
                     [a / 2, a * np.sqrt(3) / 6, a * np.sqrt(2.0 / 3.0)]])


class PlasticSet(Case):
    name = "plastic_set"
    description = ("a regular tetrahedron flung apart past yield (von Mises, ideal): it "
                   "stops, springs back and keeps the closed-form permanent set "
                   "e_p = w^2/(2 k s_y)")
    tags = ("fem", "dynamic", "plasticity", "closed form")
    observable, units = "x", "m"
    params = {
        "youngs_modulus": Param(1000.0, 1e-6, 1e12, "E (Pa)", low_inclusive=False),
        "poisson_ratio": Param(0.3, -0.99, 0.49, "nu"),
        "yield_stress": Param(10.0, 0.0, 1e12, "sigma_y (Pa)", low_inclusive=False),
        "hardening": Param(0.0, 0.0, 1e12, "H (Pa), linear isotropic hardening (0: ideal)"),
        "strain": Param("linear", choices=("linear", "green"),
                        doc="the law: linear (the closed form) or green (StVK, ideal, on the "
                            "tetrahedron: the reduced 3-stretch solve)"),
        "element": Param("tetrahedron", choices=("tetrahedron", "triangle")),
        "density": Param(1.0, 1e-6, 1e6, "rho (kg/m^3)", low_inclusive=False),
        "edge": Param(1.0, 1e-3, 1e3, "a (m)", low_inclusive=False),
        "overdrive": Param(np.sqrt(7.0), 1.0, 10.0, "v0 / (omega e_y): e_p = e_y (r^2 - 1) / 2",
                           low_inclusive=False),
        "dt_sweep": Param("reference", choices=("reference", "full"),
                          doc="the reference dt alone (the default run's cost) or the sweep"),
    }
    variants = {"default": {}, "sweep": {"dt_sweep": "full"}, "hardening": {"hardening": 200.0},
                "plane_strain": {"element": "triangle"}, "green": {"strain": "green"}}
    default_variants = ("default",)
    quick_variants = ("default",)

    # -- the closed form --------------------------------------------------------------------
    def constants(self, p) -> dict:
        mu = p["youngs_modulus"] / (2 * (1 + p["poisson_ratio"]))
        k = (8.0 if p["element"] == "tetrahedron" else 6.0) / (p["density"] * p["edge"] ** 2)
        omega = np.sqrt(2 * mu * k)
        s_y = np.sqrt(2.0 / 3.0) * p["yield_stress"]
        e_y = s_y / (2 * mu)
        v0 = p["overdrive"] * omega * e_y
        w = np.sqrt(v0 * v0 - (omega * e_y) ** 2)
        t1 = np.arcsin(e_y * omega / v0) / omega
        two_h = 2.0 * p["hardening"] / 3.0
        slope = 2 * mu * two_h / (2 * mu + two_h)  # h': ds/de while flowing
        if slope == 0.0:
            span = w / (k * s_y)
            e_max = e_y + w * w / (2 * k * s_y)
        else:
            omega_p = np.sqrt(k * slope)
            span = np.arctan2(w * slope, s_y * omega_p) / omega_p
            e_max = e_y - s_y / slope * (1 - np.cos(omega_p * span)) + w / omega_p * np.sin(
                omega_p * span)
        e_p = 2 * mu * (e_max - e_y) / (2 * mu + two_h)
        t_max = t1 + span
        lam = p["youngs_modulus"] * p["poisson_ratio"] / (
            (1 + p["poisson_ratio"]) * (1 - 2 * p["poisson_ratio"]))
        return {"mu": mu, "lam": lam, "k": k, "omega": omega, "s_y": s_y, "e_y": e_y, "v0": v0, "w": w,
                "t1": t1, "t_max": t_max, "e_p": e_p, "e_max": e_max, "slope": slope,
                "two_h": two_h, "t_end": t_max + np.pi / (2 * omega)}

    def strain(self, p, t) -> np.ndarray:
        c = self.constants(p)
        t = np.asarray(t, float)
        elastic = c["v0"] / c["omega"] * np.sin(c["omega"] * np.minimum(t, c["t1"]))
        s = t - c["t1"]
        if c["slope"] == 0.0:
            plastic = c["e_y"] + c["w"] * s - c["k"] * c["s_y"] * s * s / 2
        else:
            omega_p = np.sqrt(c["k"] * c["slope"])
            plastic = (c["e_y"] - c["s_y"] / c["slope"] * (1 - np.cos(omega_p * s))
                       + c["w"] / omega_p * np.sin(omega_p * s))
        unloading = c["e_p"] + (c["e_max"] - c["e_p"]) * np.cos(c["omega"] * (t - c["t_max"]))
        return np.where(t <= c["t1"], elastic, np.where(t <= c["t_max"], plastic, unloading))

    # -- the scene --------------------------------------------------------------------------
    @staticmethod
    def direction(p) -> np.ndarray:
        return DIRECTION if p["element"] == "tetrahedron" else PLANE_DIRECTION

    def _rest(self, p):
        nodes = regular_tetrahedron(p["edge"])
        if p["element"] == "triangle":
            nodes = nodes[:3]
        return nodes, nodes.mean(0)

    def scene(self, p):
        nodes, centre = self._rest(p)
        v0 = self.constants(p)["v0"]
        if p["strain"] == "green" and (p["element"] != "tetrahedron" or p["hardening"]):
            raise ValueError("plastic_set.strain: green runs on the tetrahedron with ideal "
                             "plasticity (element tetrahedron, hardening 0)")
        material = Material(p["youngs_modulus"], p["poisson_ratio"], p["density"], p["strain"],
                            Plasticity(p["yield_stress"], p["hardening"]))
        velocities = v0 * (nodes - centre) @ self.direction(p).T
        if p["element"] == "triangle":
            mesh = TriangleMesh(nodes, np.array([[0, 1, 2]]), material, velocities=velocities,
                                thickness=1.0, plane="strain")
        else:
            mesh = TetMesh(nodes, np.array([[0, 1, 2, 3]]), material, velocities=velocities)
        return Scene(parts=(mesh,), gravity=(0.0, 0.0, 0.0))

    def bodies(self, p):
        return 4

    def _green(self, p) -> GreenTet:
        """The green variant's reduced tetrahedron and its reference solve (cached)."""
        key = tuple(sorted(p.items()))
        cache = self.__dict__.setdefault("_greens", {})
        if key not in cache:
            cache[key] = GreenTet(self.constants(p), self.constants(p)["lam"])
        return cache[key]

    def t_end(self, p):
        return self._green(p).t_end if p["strain"] == "green" else self.constants(p)["t_end"]

    def _dt(self, p, y):
        """The step nearest y / omega that divides t_end into whole steps."""
        t_end = self.t_end(p)
        return t_end / round(t_end * self.constants(p)["omega"] / y)

    def dts(self, p):
        if p["dt_sweep"] == "reference":
            return [self.reference_dt(p)]
        return [self._dt(p, y) for y in Y_SWEEP]

    def reference_dt(self, p):
        return self._dt(p, Y_REFERENCE)

    def observables(self, p, obs):
        return {"x": np.asarray(obs["x"], float)}

    def reference(self, p, t):
        nodes, centre = self._rest(p)
        if p["strain"] == "green":
            return {"x": centre + self._green(p).stretches(t)[:, None, :] * (nodes - centre)}
        e = self.strain(p, np.atleast_1d(t))
        return {"x": centre + (nodes - centre)[None] + e[:, None, None] *
                ((nodes - centre) @ self.direction(p).T)[None]}

    def motion_scale(self, p):
        """The largest displacement's 2-norm over the nodes, e_max ||N (X - c)|| (m); green:
        ||(l - 1) (X - c)|| at the turning point."""
        nodes, centre = self._rest(p)
        c = self.constants(p)
        if p["strain"] == "green":
            return float(np.linalg.norm((self._green(p).l_max - 1.0) * (nodes - centre)))
        return float(c["e_max"] * np.linalg.norm((nodes - centre) @ self.direction(p).T))

    def extra_metrics(self, p, obs, observed, reference):
        nodes, _ = self._rest(p)
        x = observed["x"][-1]
        d = 3 if p["element"] == "tetrahedron" else 2
        dm, ds = (nodes[1:, :d] - nodes[0, :d]).T, (x[1:, :d] - x[0, :d]).T
        f = ds @ np.linalg.inv(dm)
        exact = self.constants(p)["e_p"]
        if p["strain"] == "green":  # N : (F - I) of the reference at t_end
            exact = float(self._green(p).n @ (self._green(p).stretches(obs["t"][-1])[0] - 1.0))
        return {"permanent_strain": float(np.sum((f - np.eye(d)) * self.direction(p)[:d, :d])),
                "permanent_strain_exact": exact}

    def discrete(self, p, integrator, dt, steps) -> np.ndarray:
        """(steps + 1,) e_n of the named method on the reduced oscillator (module docstring);
        (steps + 1, 3) stretches diag F for the green variant (GreenTet)."""
        name, h = spec_name(integrator), float(dt)
        if p["strain"] == "green":
            return self._green(p).discrete(name, h, steps)
        c = self.constants(p)
        k, two_mu, s_y, omega2 = c["k"], 2 * c["mu"], c["s_y"], c["omega"] ** 2
        two_h = c["two_h"]
        share = two_h / (two_mu + two_h)  # of the trial's excess kept as stress
        state = {"e_p": 0.0, "flow": 0.0}  # committed e_p and accumulated |de_p|

        def radius():
            return s_y + two_h * state["flow"]

        def stress(e):  # the radial return from the committed state
            trial = two_mu * (e - state["e_p"])
            excess = abs(trial) - radius()
            return trial if excess <= 0 else np.sign(trial) * (radius() + share * excess)

        def accel(e):
            return -k * float(stress(e))

        def implicit(e, v):  # e1 = e + h v1, v1 = v + h a(e1): a piecewise-linear root
            elastic = (e + h * v + h * h * omega2 * state["e_p"]) / (1 + h * h * omega2)
            if abs(two_mu * (elastic - state["e_p"])) <= radius():
                return elastic
            sign = np.sign(elastic - state["e_p"])  # s = alpha + beta e1 on this branch
            beta = share * two_mu
            alpha = sign * radius() * (1 - share) - beta * state["e_p"]
            return (e + h * v - h * h * k * alpha) / (1 + h * h * k * beta)

        def linearised(e, v, a):  # one Baraff-Witkin step, the elastic tangent
            return v + h * (a - h * omega2 * v) / (1 + h * h * omega2)

        def commit(e):  # the return made permanent
            trial = two_mu * (e - state["e_p"])
            if abs(trial) > radius():
                step = (abs(trial) - radius()) / (two_mu + two_h)
                state["e_p"] += np.sign(trial) * step
                state["flow"] += step

        return march(name, h, 0.0, c["v0"], accel, implicit, linearised, commit, steps)

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """The named method's exact discrete solution against the closed form, plus
        round-off (module docstring)."""
        c = self.constants(p)
        steps = int(round(self.t_end(p) / dt))
        nodes, centre = self._rest(p)
        size = float(np.linalg.norm((nodes - centre) @ self.direction(p).T))
        samples = sample_steps(steps, int(round(self.sample_dt(p) / dt)))
        e = self.discrete(p, integrator, dt, steps)[samples]
        if p["strain"] == "green":  # the node error (l_n - l(t)) (X - c), 2-norm
            gap = (e - self._green(p).stretches(samples * dt))[:, None, :] * (nodes - centre)
            deviation = float(np.max(np.linalg.norm(gap, axis=(1, 2))))
        else:
            deviation = size * float(np.max(np.abs(e - self.strain(p, samples * dt))))
        roundoff, reason = roundoff_tolerance(steps, 0.5 * np.sqrt(12) * (
            float(np.abs(nodes).max()) + self.motion_scale(p)))
        return deviation + roundoff, (
            f"{integrator}'s exact discrete solution of the reduced elastic-plastic "
            f"oscillator (y = omega dt = {c['omega'] * dt:.3g}) errs {deviation:.3g} m from "
            f"the closed form at the {len(samples)} samples (max, times ||N (X - c)||)"
            + reason)


CASE = PlasticSet()
