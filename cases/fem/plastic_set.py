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


DIRECTION = np.diag([2.0, -1.0, -1.0]) / np.sqrt(6.0)
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
        "element": Param("tetrahedron", choices=("tetrahedron", "triangle")),
        "density": Param(1.0, 1e-6, 1e6, "rho (kg/m^3)", low_inclusive=False),
        "edge": Param(1.0, 1e-3, 1e3, "a (m)", low_inclusive=False),
        "overdrive": Param(np.sqrt(7.0), 1.0, 10.0, "v0 / (omega e_y): e_p = e_y (r^2 - 1) / 2",
                           low_inclusive=False),
        "dt_sweep": Param("reference", choices=("reference", "full"),
                          doc="the reference dt alone (the default run's cost) or the sweep"),
    }
    variants = {"default": {}, "sweep": {"dt_sweep": "full"}, "hardening": {"hardening": 200.0},
                "plane_strain": {"element": "triangle"}}
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
        return {"mu": mu, "k": k, "omega": omega, "s_y": s_y, "e_y": e_y, "v0": v0, "w": w,
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
        material = Material(p["youngs_modulus"], p["poisson_ratio"], p["density"], "linear",
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

    def t_end(self, p):
        return self.constants(p)["t_end"]

    def _dt(self, p, y):
        """The step nearest y / omega that divides t_end into whole steps."""
        c = self.constants(p)
        return c["t_end"] / round(c["t_end"] * c["omega"] / y)

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
        e = self.strain(p, np.atleast_1d(t))
        return {"x": centre + (nodes - centre)[None] + e[:, None, None] *
                ((nodes - centre) @ self.direction(p).T)[None]}

    def motion_scale(self, p):
        """The largest displacement's 2-norm over the nodes, e_max ||N (X - c)|| (m)."""
        nodes, centre = self._rest(p)
        c = self.constants(p)
        return float(c["e_max"] * np.linalg.norm((nodes - centre) @ self.direction(p).T))

    def extra_metrics(self, p, obs, observed, reference):
        nodes, _ = self._rest(p)
        x = observed["x"][-1]
        d = 3 if p["element"] == "tetrahedron" else 2
        dm, ds = (nodes[1:, :d] - nodes[0, :d]).T, (x[1:, :d] - x[0, :d]).T
        f = ds @ np.linalg.inv(dm)
        return {"permanent_strain": float(np.sum((f - np.eye(d)) * self.direction(p)[:d, :d])),
                "permanent_strain_exact": self.constants(p)["e_p"]}

    def discrete(self, p, integrator, dt, steps) -> np.ndarray:
        """(steps + 1,) e_n of the named method on the reduced oscillator (module docstring);
        a scalar loop over the run's steps (four nodes: the case's reference, not a hot
        path)."""
        c = self.constants(p)
        k, two_mu, s_y, omega2 = c["k"], 2 * c["mu"], c["s_y"], c["omega"] ** 2
        two_h = c["two_h"]
        share = two_h / (two_mu + two_h)  # of the trial's excess kept as stress
        name, h = spec_name(integrator), float(dt)
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

        e, v, out = 0.0, c["v0"], [0.0]
        a = accel(e)
        for _ in range(int(steps)):
            if name == "explicit_euler":
                e, v = e + h * v, v + h * a
            elif name == "symplectic_euler":
                v = v + h * a
                e = e + h * v
            elif name == "velocity_verlet":
                half = v + h / 2 * a
                e = e + h * half
                v = half + h / 2 * accel(e)
            elif name == "rk4":
                k1x, k1v = v, a
                k2x, k2v = v + h / 2 * k1v, accel(e + h / 2 * k1x)
                k3x, k3v = v + h / 2 * k2v, accel(e + h / 2 * k2x)
                k4x, k4v = v + h * k3v, accel(e + h * k3x)
                e, v = (e + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x),
                        v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v))
            elif name == "implicit_euler":
                e1 = implicit(e, v)
                e, v = e1, (e1 - e) / h
            elif name == "baraff_witkin":  # one linearised step, the elastic tangent
                v = v + h * (a - h * omega2 * v) / (1 + h * h * omega2)
                e = e + h * v
            else:
                raise ValueError(f"plastic_set has no discrete solution for {integrator!r}")
            trial = two_mu * (e - state["e_p"])
            if abs(trial) > radius():  # commit the return
                step = (abs(trial) - radius()) / (two_mu + two_h)
                state["e_p"] += np.sign(trial) * step
                state["flow"] += step
            a = accel(e)
            out.append(e)
        return np.array(out)

    def tolerance(self, p, integrator, order, dt, engine_variant="", settings=None):
        """The named method's exact discrete solution against the closed form, plus
        round-off (module docstring)."""
        c = self.constants(p)
        steps = int(round(c["t_end"] / dt))
        nodes, centre = self._rest(p)
        size = float(np.linalg.norm((nodes - centre) @ self.direction(p).T))
        samples = sample_steps(steps, int(round(self.sample_dt(p) / dt)))
        e = self.discrete(p, integrator, dt, steps)[samples]
        deviation = size * float(np.max(np.abs(e - self.strain(p, samples * dt))))
        roundoff, reason = roundoff_tolerance(steps, 0.5 * np.sqrt(12) * (
            float(np.abs(nodes).max()) + self.motion_scale(p)))
        return deviation + roundoff, (
            f"{integrator}'s exact discrete solution of the reduced elastic-plastic "
            f"oscillator (y = omega dt = {c['omega'] * dt:.3g}) errs {deviation:.3g} m from "
            f"the closed form at the {len(samples)} samples (max, times ||N (X - c)||)"
            + reason)


CASE = PlasticSet()
