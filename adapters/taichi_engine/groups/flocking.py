"""taichi's flocking group: birds under a `Flocking` part (Cucker-Smale or Reynolds, all pairs),
the model of `refsim.models.flocking` as the float64 kernels of
`refsim_adapters.taichi_engine.flocking_kernels` (equal to refsim's group to round-off at equal
stepper). Integrators: symplectic Euler (kick-drift), velocity Verlet (closing kick corrected
once, as refsim's: the rules depend on v), RK4, explicit Euler and midpoint: one kernel for
all of them (the stepper a runtime argument), the time loop inside it.

Claims scenes whose parts are exactly particles and a Flocking part. Observes x, v (n, 3), as
refsim's group does.
"""
from __future__ import annotations

import numpy as np

from refsim.engine import ModelGroup
from refsim.integrators import get_integrator
from refsim.scene import Particles
from refsim.scene.flocking import Flocking

from ..kernel_store import arrays_setting, observed, to_ndarray, to_taichi
from ..sim import KernelSim

INTEGRATORS = ("symplectic_euler", "velocity_verlet", "rk4", "explicit_euler", "midpoint")
NATIVE = {"symplectic_euler": "kernel: a = a(x, v) (all pairs); v += h a; x += h v",
          "velocity_verlet": "kernel: vh = v + h/2 a; x += h vh; a = a(x, vh); v = vh + h/2 a; "
                             "a = a(x, v); v = vh + h/2 a (a carried)",
          "rk4": "kernel: explicit RK, tableau of refsim's rk4 (b-weighted stage sums)",
          "explicit_euler": "kernel: explicit RK, one stage: x += h v; v += h a(x, v)",
          "midpoint": "kernel: explicit RK, tableau of refsim's midpoint (alpha = 1/2)"}


def chain_tableau(stepper):
    """(a_next, b, stages) of an explicit RK stepper whose stage i couples to stage i - 1 only:
    a_next[i] = a_{i+1,i}, padded to 4 entries. ValueError for any other tableau."""
    a, b, _ = stepper.tableau.arrays()
    a, b = np.asarray(a, float), np.asarray(b, float)
    stages = len(b)
    below = np.tril(a, -2)
    if stages > 4 or np.any(below) or np.any(np.triu(a)):
        raise ValueError(f"taichi kernels run chained explicit tableaux of <= 4 stages only, "
                         f"not {stepper.name!r}")
    a_next = np.zeros(4)
    a_next[:stages - 1] = np.diag(a, -1)
    return a_next, np.pad(b, (0, 4 - stages)), stages


def method_of(stepper):
    """The kernels' stepper code and tableau arrays (a_next, b, stages)."""
    from .. import flocking_kernels as fk
    if stepper.name == "symplectic_euler":
        return fk.SYMPLECTIC_EULER, (np.zeros(4), np.zeros(4), 0)
    if stepper.name == "velocity_verlet":
        return fk.VELOCITY_VERLET, (np.zeros(4), np.zeros(4), 0)
    return fk.EXPLICIT_RK, chain_tableau(stepper)


class FlockKernelSim(KernelSim):
    """x, v (n, 3) numpy arrays; the rule's parameters, stage arrays and tableau in `flock_t`."""

    system = "flocking"

    def __init__(self, scene, dt, integrator):
        from .. import flocking_kernels as fk
        from ..runtime import runtime
        rt = runtime()
        method, (a_next, b, stages) = method_of(get_integrator(integrator))
        made = rt["kernels"]
        if (self.system, integrator) not in made:
            made[(self.system, integrator)] = fk.flock_kernels(method)
        cold = not any(key[0] == self.system for key in rt["compiled"])
        birds = scene.part(Particles)
        self.flocking, n = scene.part(Flocking), len(birds)
        f = self.flocking
        # x, v: numpy arrays handed to the kernel (read and written in place: observing
        # them is a numpy copy, not a taichi-to-numpy transfer of ~1 ms a call)
        self.x, self.v = to_ndarray(birds.position), to_ndarray(birds.velocity)
        stage = {name: to_taichi(np.zeros((n, 3))) for name in ("acc", "xs", "vs", "sx", "sv")}
        self.pack = fk.flock_t(rule=fk.RULES[f.rule], K=f.K, sigma2=f.sigma * f.sigma,
                               beta=f.beta, radius2=f.radius * f.radius, w_sep=f.separation,
                               w_align=f.alignment, w_coh=f.cohesion, **stage,
                               rk_a=to_taichi(a_next), rk_b=to_taichi(b), stages=stages)
        super().__init__(dt, integrator, "", (self.x, self.v, self.pack))
        self.cold = cold  # one kernel for every stepper: cold only on the first build

    def _observe(self):
        return {"x": observed(self.x), "v": observed(self.v)}

    def settings(self):
        from ..runtime import THREADS, effective_config
        f = self.flocking
        rule = ({"K": f.K, "sigma": f.sigma, "beta": f.beta} if f.rule == "cucker_smale" else
                {"radius": f.radius, "separation": f.separation, "alignment": f.alignment,
                 "cohesion": f.cohesion})
        entry = {**self.stepper.describe(), "native": NATIVE[self.integrator]}
        if entry.get("symplectic"):
            entry.update(symplectic=False, symplectic_note="the flocking rules are "
                         "dissipative (velocity-dependent, no Hamiltonian): no symplectic "
                         "structure to keep")
        return {"integrator": entry, "dtype": "float64", "threads": THREADS,
                **effective_config(), "rule": f.rule, **rule,
                "pairs": "all pairs, a serial loop over j per bird (no cut-off search)",
                "time_loop": "time loop inside one kernel, ti.loop_config(serialize=True)",
                "arrays": arrays_setting("x", "v"),
                "kernel": "one kernel for every stepper and rule (runtime codes, tableau "
                          "coefficients as arrays): compiled once per process",
                "compile": "cold JIT in this build" if self.cold else
                "kernel already compiled in this process (launch time only)",
                "per_step_python_call": "none (one launch per Sim.step(n) call)"}


def claims(scene) -> bool:
    return scene.part(Flocking) is not None


def supports(engine, scene, integrator):
    if integrator is not None and integrator not in INTEGRATORS:
        return (f"taichi flocking group: integrator must be one of {list(INTEGRATORS)} (got "
                f"{integrator!r})")
    if scene.part(Particles) is None:
        return "taichi flocking needs the birds as a Particles part"
    return None


def build(engine, scene, dt, integrator, formulation):
    if integrator not in INTEGRATORS:
        raise ValueError(f"taichi flocking integrator must be one of {list(INTEGRATORS)}, "
                         f"got {integrator!r}")
    return FlockKernelSim(scene, dt, integrator)


MODEL_GROUP = ModelGroup(name="flocking", build=build, claims=claims,
                         parts=frozenset({"particles", "flocking"}),
                         features=frozenset({"flocking"}), supports=supports,
                         integrators=INTEGRATORS)
