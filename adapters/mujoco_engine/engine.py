"""The MuJoCo engine: which scenes it takes (parts, features, plan checks) and building a Sim."""
from __future__ import annotations

from refsim.engine import Engine

from .contact_params import IMPEDANCE
from .methods import CONTACT_METHODS, METHODS
from .plans import plan_scene
from .sim import MujocoSim

DISCRETE_CONTACT_REASON = (
    "mujoco discrete integrates the contact spring with backward Euler, which dissipates: "
    "e = 0.65 measured at zero damping for a 10-step contact, so larger e cannot be asked of it")


class MujocoEngine(Engine):
    name = "mujoco"
    package = "mujoco"
    parts = frozenset({"particles", "springs", "joints", "walls"})
    capabilities = frozenset({"gravity", "springs", "joints", "drag", "contacts", "walls"})
    dims = (3,)
    integrators = tuple(METHODS)
    # the refsim stepper each method equals on an undamped spring (refsim stress's theory)
    equivalents = {"implicit": "symplectic_euler",  # damping implicit: nothing damped here
                   "implicitfast": "symplectic_euler",
                   "discrete": "implicit_euler"}  # spring stiffness and damping implicit

    def _supports(self, scene, integrator):
        """The scene plan's reason (plans.plan_scene), then the discrete-with-contacts one."""
        try:
            plan_scene(scene)
        except ValueError as exc:
            return str(exc)
        if scene.contact is not None and integrator is not None and \
                integrator not in CONTACT_METHODS:
            return DISCRETE_CONTACT_REASON
        return None

    def build(self, scene, dt, integrator, variant=""):
        """MuJoCo integrators are exact names (the base also accepts "name:parameter" and
        None): an unknown one is refused first, then the base validates dt, variant, support."""
        if integrator not in METHODS:
            raise ValueError(f"mujoco integrator must be one of {list(METHODS)}, "
                             f"got {integrator!r}")
        return super().build(scene, dt, integrator, variant)

    def _build(self, scene, dt, integrator, variant):
        return MujocoSim(scene, plan_scene(scene), dt, integrator, variant)

    def variants(self, scene):
        """Sphere scenes: "" (spring-dashpot per contact, d = 1e-4) and "coupled" (MuJoCo's
        constraint regime, d = 0.9999)."""
        return tuple(IMPEDANCE) if scene.contact is not None else ("",)
