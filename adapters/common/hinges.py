"""Rods on hinges, translated once for every engine: the start-state check, the hinge frames and
angles of the rods, their Cartesian state, and the rod-length error observation.

A rod (row k of the scene's `Joints` part) holds body `body[k]` at `length[k]` from a fixed
`anchor[k]`, turning about `axis[k]`. Its hinge frame (refsim.models.joints.hinge_frame) is d,
the direction of gravity's component in the hinge plane (theta = 0), and s = d x axis (theta
grows towards s)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsim.models.joints import cartesian_to_hinge, hinge_frame, hinge_to_cartesian
from refsim.scene import Joints, Particles

ROD_START_RTOL = 1e-9  # a start state this far (relative) off the rod's circle is refused


def rod_start_refusal(scene, who: str) -> str | None:
    """Why the first rod whose body does not start on the circle its hinge describes (at
    distance L from the anchor, perpendicular to the axis: to ROD_START_RTOL L) or moves off it
    (velocity not w axis x r, w = (r x v) . axis / L^2: to ROD_START_RTOL max(|v|, 1)), else
    None: an engine with a revolute joint cannot hold that state."""
    joints, bodies = scene.part(Joints), scene.part(Particles)
    r0, v0 = bodies.position[joints.body] - joints.anchor, bodies.velocity[joints.body]
    distance = np.linalg.norm(r0, axis=1)
    tol = ROD_START_RTOL * joints.length
    off_circle = (np.abs(distance - joints.length) > tol) | \
        (np.abs(np.einsum("kj,kj->k", r0, joints.axis)) > tol)
    rate = np.einsum("kj,kj->k", np.cross(r0, v0), joints.axis) / joints.length ** 2
    slip = np.linalg.norm(np.cross(rate[:, None] * joints.axis, r0) - v0, axis=1)
    off_arc = slip > ROD_START_RTOL * np.maximum(np.linalg.norm(v0, axis=1), 1.0)
    bad = np.flatnonzero(off_circle | off_arc)
    if not bad.size:
        return None
    k = bad[0]
    if off_circle[k]:
        return (f"{who}: body {joints.body[k]} must start at distance L from the anchor, "
                f"perpendicular to the hinge axis (distance {distance[k]:.6g} m, rod length "
                f"{joints.length[k]:.6g} m)")
    return (f"{who}: body {joints.body[k]}'s initial velocity must be a rotation about the "
            f"hinge axis")


@dataclass(frozen=True)
class HingeFrames:
    """Every rod of a scene in generalized coordinates, one entry per rod (joint_set order).

    bodies (n,) int: the body each rod holds; anchor (n, 3) m; length (n,) m; d, s (n, 3): the
    hinge frame; g_plane (n,) m/s^2: gravity's component in the hinge plane."""

    bodies: np.ndarray
    anchor: np.ndarray
    length: np.ndarray
    d: np.ndarray
    s: np.ndarray
    g_plane: np.ndarray

    @classmethod
    def from_scene(cls, scene) -> "HingeFrames":
        joints = scene.part(Joints) or Joints.of(())  # no rods: empty index arrays
        frames = [hinge_frame(axis, scene.gravity) for axis in joints.axis]
        return cls(bodies=joints.body, anchor=joints.anchor, length=joints.length,
                   d=np.array([f[0] for f in frames]).reshape(-1, 3),
                   s=np.array([f[1] for f in frames]).reshape(-1, 3),
                   g_plane=np.array([f[2] for f in frames], dtype=float))

    def initial_angles(self, positions, velocities) -> tuple[np.ndarray, np.ndarray]:
        """(theta, omega) per rod (rad, rad/s) from the bodies' Cartesian start (build time;
        one rod at a time, the operation order the engines have always used)."""
        x0, v0 = positions[self.bodies], velocities[self.bodies]
        pairs = [cartesian_to_hinge(x0[k], v0[k], self.anchor[k], self.length[k], self.d[k],
                                    self.s[k]) for k in range(len(self.bodies))]
        return (np.array([p[0] for p in pairs], dtype=float),
                np.array([p[1] for p in pairs], dtype=float))

    def cartesian(self, theta, omega, positions, velocities) -> tuple[np.ndarray, np.ndarray]:
        """(x, v) of every body, new arrays: the rods' bodies from their angles, the others
        as given."""
        x_rod, v_rod = hinge_to_cartesian(theta, omega, self.anchor, self.length, self.d,
                                          self.s)
        x, v = positions.copy(), velocities.copy()
        x[self.bodies], v[self.bodies] = x_rod, v_rod
        return x, v


def rod_length_errors(scene, x) -> np.ndarray:
    """|x_body - anchor| - L per rod (m), x (n_bodies, 3). Each rod's norm is taken on its own
    3-vector (np.linalg.norm of one row: the bits engines have always observed; a norm along
    axis 1 may sum in another order)."""
    joints = scene.part(Joints)
    return np.array([np.linalg.norm(x[body] - anchor) - length
                     for body, anchor, length in zip(joints.body, joints.anchor, joints.length)],
                    dtype=float)
