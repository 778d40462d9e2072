"""Planted-defect engines: the in-house engine (`refsim`) behind the public `Engine` / `Sim`
contract with ONE deliberate bug each, to show that the harness's verdicts catch real bugs.

Each engine wraps `refsim.registry.get_engine("refsim")`: it asks refsim whether it supports a
scene, which formulations it has and which integrators it offers, and builds refsim's own sim;
the defect changes one thing, in one of three places:
- the scene it receives (`Defect.scene`: a frozen Scene rebuilt with `dataclasses.replace`);
- the stepper (`Defect.swap`: the built sim's stepper replaced by an impostor that runs another
  tableau under the claimed integrator's name, order and family, so every report says "rk4");
- the state (`Defect.at_build`: once after the build; `Defect.after_step`: after every single
  step, so that `step(n)` becomes n steps of one).
Every sim is returned inside `DefectSim`, which does the contract's bookkeeping itself and calls
refsim's sim for the work; with no hook (the `control` engine) it runs the same operations in
the same order as refsim's own sim, so its rows equal refsim's bit for bit.

A defect that finds nothing to change in a sim (a velocity hook on a first-order field, an
integrator swap on the SPH step, which is its own kick-drift-kick) raises `Unreachable` at the
build: its row is `failed` with a reason starting UNREACHABLE, and the driver leaves it out.
`register_all()` registers every engine under "planted_<defect>" (idempotent).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Callable

import numpy as np

from refsim import registry
from refsim.engine import Engine, Sim
from refsim.integrators import EULER, HEUN, ExplicitRK, Tableau
from refsim.integrators.first_order import FirstOrderRK, FirstOrderStepper
from refsim.scene.gravity_pairs import GravityPairs
from refsim.scene import Joints, RigidBodies, SpringNetwork, Springs
from refsim.scene.pivots import RigidPivots

PREFIX = "planted_"
UNREACHABLE = "UNREACHABLE"
INNER = "refsim"

# Kutta's third-order method (1901): c = (0, 1/2, 1), b = (1/6, 2/3, 1/6)
KUTTA3 = Tableau(a=((0, 0, 0), (0.5, 0, 0), (-1, 2, 0)), b=(1 / 6, 2 / 3, 1 / 6),
                 c=(0, 0.5, 1), order=3)
GRAVITY_FACTOR = 1.001
STIFFNESS_FACTOR = 1.01
LENGTH_FACTOR = 1.005
VELOCITY_KEEP = 1.0 - 1e-4


class Unreachable(ValueError):
    """The defect has nothing to change in this sim."""


def _unreachable(defect: str, sim, what: str):
    return Unreachable(f"{UNREACHABLE}: planted defect {defect!r} finds no {what} in "
                       f"{type(sim).__name__}")


# ---------------------------------------------------------------------------------------------
# Scene defects (one field of the frozen scene; the scene itself when there is nothing to change)
# ---------------------------------------------------------------------------------------------
def _rebuilt(scene, changes: dict, change_part=None):
    """The scene with `changes` to its settings and every part p replaced by change_part(p)
    (the part itself where nothing changes); the scene itself when nothing changed."""
    parts = tuple(change_part(p) for p in scene.parts) if change_part else scene.parts
    if not changes and all(a is b for a, b in zip(parts, scene.parts)):
        return scene
    return replace(scene, parts=parts, **changes)


def stronger_gravity(scene):
    """Uniform gravity and the pair-gravity constant G x GRAVITY_FACTOR."""
    changes = {}
    if any(scene.gravity):
        changes["gravity"] = tuple(GRAVITY_FACTOR * float(g) for g in scene.gravity)
    return _rebuilt(scene, changes, lambda p: replace(p, G=p.G * GRAVITY_FACTOR)
                    if isinstance(p, GravityPairs) else p)


def _springs_and_networks(spring_fields: dict, network_fields: Callable):
    """A part change: every Spring rebuilt with `spring_fields` (field -> function of the old
    value), every SpringNetwork with `network_fields(net)` (a dict of new values)."""
    def change(part):
        if isinstance(part, Springs):
            return Springs.of(tuple(replace(s, **{k: f(getattr(s, k)) for k, f in
                                                  spring_fields.items()})
                                    for s in part.to_records()))
        if isinstance(part, SpringNetwork):
            return replace(part, **network_fields(part))
        return part
    return change


def stiffer_springs(scene):
    """Every spring stiffness x STIFFNESS_FACTOR: springs, network stretch edges, network
    hinge and dihedral (bending) springs."""
    k = STIFFNESS_FACTOR
    return _rebuilt(scene, {}, _springs_and_networks(
        {"stiffness": lambda s: s * k},
        lambda n: {"stiffness": n.stiffness * k, "hinge_stiffness": n.hinge_stiffness * k,
                   "dihedral_stiffness": n.dihedral_stiffness * k}))


def undamped_springs(scene):
    """Spring damping dropped (springs and network edges); air drag is kept."""
    damped = any(np.any(p.damping > 0) for p in scene.parts
                 if isinstance(p, (Springs, SpringNetwork)))
    return _rebuilt(scene, {}, _springs_and_networks(
        {"damping": lambda c: 0.0}, lambda n: {"damping": 0.0})) if damped else scene


def longer_links(scene):
    """Every rest length and rod or link length x LENGTH_FACTOR: springs, network edges, rods
    (joints) and the pivot arm of pivoted rigid bodies (the anchor moves with the body point,
    so the body still starts on its pivot)."""
    s = LENGTH_FACTOR
    links = _springs_and_networks({"rest_length": lambda r: r * s},
                                  lambda n: {"rest_length": n.rest_length * s})
    rigid = scene.part(RigidBodies)

    def change(part):
        if isinstance(part, Joints):
            return Joints.of(tuple(replace(j, length=j.length * s) for j in part.to_records()))
        if isinstance(part, RigidPivots):
            return _longer_pivots(part, rigid, s)
        return links(part)
    return _rebuilt(scene, {}, change)


def _longer_pivots(pivots, rigid, factor):
    q = rigid.orientation[pivots.body]
    w, v = q[:, :1], q[:, 1:]
    extra = (factor - 1.0) * pivots.body_point
    rotated = extra + 2.0 * np.cross(v, np.cross(v, extra) + w * extra)  # q p q*
    return replace(pivots, body_point=pivots.body_point * factor,
                   anchor=pivots.anchor + rotated)


# ---------------------------------------------------------------------------------------------
# Stepper defects: an impostor stepper under the claimed integrator's name, order and family
# ---------------------------------------------------------------------------------------------
def impostor(old, tableau: Tableau):
    """A stepper that runs `tableau` and describes itself exactly as `old` does."""
    cls = FirstOrderRK if isinstance(old, FirstOrderStepper) else ExplicitRK
    new = cls(old.name, replace(tableau, order=old.order))
    for attr in ("family", "explicit", "symplectic"):
        setattr(new, attr, getattr(old, attr))
    return new


def swap_stepper(claimed: str, tableau: Tableau, defect: str):
    def swap(sim, integrator):
        if integrator != claimed:
            return
        old = getattr(sim, "stepper", None)
        if old is None or old.name != claimed:
            raise _unreachable(defect, sim, f"{claimed} stepper")
        sim.stepper = new = impostor(old, tableau)
        if isinstance(getattr(sim, "state", None), tuple):  # restart on the new state layout
            x, v = old.output(sim.system, 0.0, sim.state, sim.dt)
            sim.state = new.start(sim.system, 0.0, x, v, sim.dt)
    return swap


# ---------------------------------------------------------------------------------------------
# State defects
# ---------------------------------------------------------------------------------------------
def map_state(sim, fn, velocity_only: bool, defect: str) -> None:
    """Replaces each state array a of the in-house sim by fn(a) (fn None: only checks that
    there is one): the stepper's state tuple (x, v, ...) of the stepped sims (velocity: its
    second entry, v or Stormer's d = h v or leapfrog's v_-1/2), the SPH FluidState (x, v,
    rho), the contact sim's x, v, w, the first-order and grid sims' p or u (no velocity)."""
    state = getattr(sim, "state", None)
    if isinstance(state, tuple):
        if fn is not None:
            sim.state = ((state[0], fn(state[1])) + state[2:] if velocity_only
                         else tuple(fn(s) for s in state))
        return
    owner = state if state is not None and hasattr(state, "v") else sim
    names = ("v", "w") if velocity_only else ("x", "v", "w", "rho", "p", "u")
    found = [n for n in names if isinstance(getattr(owner, n, None), np.ndarray)]
    if not found:
        raise _unreachable(defect, sim, "velocity state" if velocity_only else "state")
    for name in found if fn is not None else ():
        setattr(owner, name, fn(getattr(owner, name)))


def as_float32(value):
    """The value rounded to float32 (kept as float64): arrays of floats and plain floats."""
    if isinstance(value, np.ndarray) and value.dtype == np.float64:
        with np.errstate(over="ignore"):  # a diverging state overflows: it is judged, not run
            return value.astype(np.float32).astype(np.float64)
    if isinstance(value, float):
        return float(np.float32(value))
    return value


def one_step_ahead(sim) -> None:
    """The state steps once at build while the observed time stays at 0."""
    sim._step_impl(1)
    sim.steps += 1


def damp_velocity(sim) -> None:
    map_state(sim, lambda v: v * VELOCITY_KEEP, True, "velocity_damping")


def round_to_float32(sim) -> None:
    map_state(sim, as_float32, False, "float32_state")


# ---------------------------------------------------------------------------------------------
# Defects
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Defect:
    name: str
    description: str
    scene: Callable | None = None  # scene -> scene (the same object: nothing to change)
    integrator: str | None = None  # the claimed integrator whose stepper `swap` replaces
    swap: Callable | None = None  # (sim, integrator) -> None
    at_build: Callable | None = None  # (sim) -> None, once after the build
    after_step: Callable | None = None  # (sim) -> None, after every single step
    check: tuple = ()  # (velocity_only,): map_state checked at build (Unreachable if none)

    @property
    def engine(self) -> str:
        return PREFIX + self.name

    def touches(self, scene, integrator: str) -> bool:
        """Whether a job on `scene` with `integrator` can see the defect at all (the driver
        runs only those; whether it then matters is measured)."""
        if self.scene is not None:
            return self.scene(scene) is not scene
        if self.integrator is not None:
            return integrator == self.integrator
        return True


DEFECTS = {d.name: d for d in (
    Defect("control", "no defect: refsim behind the wrapper"),
    Defect("heun_as_rk4", "rk4 that is Heun's method (order 2), reported as rk4",
           integrator="rk4", swap=swap_stepper("rk4", HEUN, "heun_as_rk4")),
    Defect("rk3_as_rk4", "rk4 that is Kutta's third-order method, reported as rk4",
           integrator="rk4", swap=swap_stepper("rk4", KUTTA3, "rk3_as_rk4")),
    Defect("euler_as_verlet", "velocity_verlet that is explicit Euler, reported as "
           "velocity_verlet", integrator="velocity_verlet",
           swap=swap_stepper("velocity_verlet", EULER, "euler_as_verlet")),
    Defect("gravity_plus_0.1pct", "gravity (uniform field and pair G) x 1.001",
           scene=stronger_gravity),
    Defect("stiffness_plus_1pct", "every spring stiffness (springs, network stretch and "
           "bending) x 1.01", scene=stiffer_springs),
    Defect("no_spring_damping", "spring damping dropped", scene=undamped_springs),
    Defect("time_off_by_one", "the state steps once at build: observed t one step behind",
           at_build=one_step_ahead),
    Defect("velocity_damping", "v *= 1 - 1e-4 after every step", after_step=damp_velocity,
           check=(True,)),
    Defect("rest_length_plus_0.5pct", "every rest length, rod and pivot arm x 1.005",
           scene=longer_links),
    Defect("float32_state", "state rounded to float32 after every step",
           after_step=round_to_float32, check=(False,)),
)}


# ---------------------------------------------------------------------------------------------
# The engine and its sim
# ---------------------------------------------------------------------------------------------
class DefectSim(Sim):
    """refsim's sim `inner` behind the contract, with the defect's per-step hook."""

    def __init__(self, inner, defect: Defect):
        self.inner, self.defect = inner, defect
        self.dt, self.failures = inner.dt, inner.failures

    @property
    def compile_s(self):
        return self.inner.compile_s

    def _step_impl(self, n):
        inner, hook = self.inner, self.defect.after_step
        if hook is None:
            inner._step_impl(n)
            inner.steps += n
            return
        for _ in range(n):
            inner._step_impl(1)
            inner.steps += 1
            hook(inner)

    def _observe(self):
        return self.inner._observe()

    def settings(self):
        return self.inner.settings()

    def close(self):
        self.inner.close()


class DefectEngine(Engine):
    """refsim with one defect (the class attribute `defect`); everything but the build is
    refsim's answer."""

    defect: Defect = DEFECTS["control"]
    reference = False

    def __init__(self):
        self.inner = registry.get_engine(INNER)

    @classmethod
    def model_groups(cls):
        return registry.entry("engine", INNER).load().model_groups()

    def available(self):
        return self.inner.available()

    def version(self):
        return f"{self.inner.version()}+{self.name}"

    def group_for(self, scene):
        return self.inner.group_for(scene)

    def offered_integrators(self, scene=None):
        return self.inner.offered_integrators(scene)

    def supports(self, scene, integrator=None):
        return self.inner.supports(scene, integrator)

    def formulations(self, scene):
        return self.inner.formulations(scene)

    def matrix_formulations(self, scene):
        return self.inner.matrix_formulations(scene)

    def build(self, scene, dt, integrator, formulation=""):
        d = self.defect
        sim = self.inner.build(d.scene(scene) if d.scene else scene, dt, integrator,
                               formulation)
        if d.swap is not None:
            d.swap(sim, integrator)
        for velocity_only in d.check:
            map_state(sim, None, velocity_only, d.name)
        if d.at_build is not None:
            d.at_build(sim)
        return DefectSim(sim, d)


def _engine_class(defect: Defect) -> type:
    inner = registry.entry("engine", INNER).load()
    attrs = {k: getattr(inner, k) for k in ("dims", "integrators", "package", "refusals")}
    return type(f"Planted_{defect.name.replace('.', '_')}", (DefectEngine,),
                {**attrs, "name": defect.engine, "defect": defect, "__module__": __name__})


ENGINES = SimpleNamespace(**{d.name.replace(".", "_"): _engine_class(d)
                             for d in DEFECTS.values()})


def register_all() -> list[str]:
    """Registers every planted engine as "planted_<defect>" for this process (and the
    sandboxes of `refsim.run.executors.Local`, which repeat run-time registrations)."""
    for d in DEFECTS.values():
        registry.register("engine", d.engine, f"{__name__}:ENGINES.{d.name.replace('.', '_')}")
    return [d.engine for d in DEFECTS.values()]
