"""pymunk (Chipmunk2D / Munk2D) behind the refsim engine contract.

pymunk is 2D. A 3D scene is accepted only when `scene.stays_in_xz_plane()`: refsim's (x, z)
become pymunk's (x, y), y-up, and observations come back with y = 0. A 2D scene (y-up) maps
(x, y) to (x, y) directly and comes back with z = 0.

The step is Chipmunk's `cpSpaceStep` (pymunk 7.3.1, Munk2D 2.0.1, src/cpSpaceStep.c):
1. `position_func` for every body: x += h v (the step-start velocity);
2. constraint `preStep` at the new positions: a `DampedSpring` applies its spring impulse
   k (L0 - d) h here, a `PinJoint` computes its normal and bias velocity here;
3. `velocity_func` for every body: v = v damping^h + h (g + f / m), then forces are cleared;
4. cached (warm-start) impulses, then `space.iterations` impulse passes over the constraints.
For free bodies and springs that is refsim's drift-kick `symplectic_euler_dk` exactly
(x1 = x + h v; v1 = v + h a(x1)); docs/engine_notes.md#pymunk-drift-kick-step: free-fall
error +g t dt / 2, the opposite sign of pybullet's kick-drift.

Contacts (feature "contacts", planar scenes only) use the same step (src/cpSpaceStep.c,
src/cpArbiter.c, src/cpCollision.c): after the drift, circles that overlap (distance < r1 + r2,
strictly) get an arbiter with the normal along the centre line at the drifted positions; its
target bounce velocity is e times the normal relative velocity before the kick; each impulse
pass sets the normal relative velocity to -bounce (accumulated normal impulse >= 0) and clamps
the tangential impulse to u times the accumulated normal impulse. That is Newton's restitution
law with Coulomb stick/slide, applied at the step in which the overlap is first seen: there is
no continuous collision detection, so the contact normal is the one of the penetrated pose.
Head-on impacts are exact whatever the step; an oblique impact's normal is rotated by the
overlap (an O(dt) error in the outcome). Walls are static segments.

docs/engine_notes.md#pymunk facts applied (pymunk 7.3.1): no damping (space.damping = 1.0 keeps
1.0^h = all of the velocity), zero gravity unless the scene sets it, 10 iterations, mass and
moment > 0 with moment = inf for a point mass, `Body.kinetic_energy` (m v^2 + I w^2, twice the
kinetic energy) never used, springs as `DampedSpring`, the `PinJoint` bias made explicit,
elasticity and friction multiplied per pair (sqrt of e and mu on every shape).

Modules: `engine` (PymunkEngine: who it is and its refusals table), `groups/` (the model
groups: particles, spheres, gravity_pairs, pivots, rolling in contact_rolling.py,
spring_network), `plane` (refsim's 3-vectors onto pymunk's plane), `space` (the pymunk Space,
bodies, shapes, walls, springs and joints built from the parts a group passes), `sim`
(PymunkSim: stepping and observation of the particles and spheres groups), `settings` (the
effective parameters reported with every row), `body_arrays`, `network_springs` and
`network_links` (the spring_network group's batched access and sims).
"""
from .engine import PymunkEngine

__all__ = ["PymunkEngine"]
