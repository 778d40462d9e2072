"""Rods on hinges, translated once for every engine: the start-state check, the hinge frames and
angles of the rods, their Cartesian state, and the rod-length error observation.

A rod (scene Joint) holds body `body` at `length` from a fixed `anchor`, turning about `axis`.
Its hinge frame (refsim.models.joints.hinge_frame) is d, the direction of gravity's in-plane
component (theta = 0), and s = d x axis (theta grows towards s)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsim.models.joints import cartesian_to_hinge, hinge_frame, hinge_to_cartesian

ROD_START_RTOL = 1e-9  # a start state this far (relative) off the rod's circle is refused


def rod_start_refusal(scene, who: str) -> str | None:
    """Why some rod's body does not start on the circle its hinge describes (at distance L from
    the anchor, perpendicular to the axis) or moves off it (velocity not a rotation about the
    axis), else None: an engine with a revolute joint cannot hold that state."""
    for joint in scene.joints:
        reason = rod_start_mismatch(scene.bodies[joint.body], joint, who)
        if reason:
            return reason
    return None


def rod_start_mismatch(body, joint, who: str) -> str | None:
    """rod_start_refusal for one rod (`joint`) and the body it holds."""
    r0 = np.subtract(body.position, joint.anchor)
    axis, length = np.asarray(joint.axis), joint.length
    tol = ROD_START_RTOL * length
    distance = np.linalg.norm(r0)
    if abs(distance - length) > tol or abs(r0 @ axis) > tol:
        return (f"{who}: body {joint.body} must start at distance L from the anchor, "
                f"perpendicular to the hinge axis (distance {distance:.6g} m, rod length "
                f"{length:.6g} m)")
    v0 = np.asarray(body.velocity)
    speed = max(np.linalg.norm(v0), 1.0)
    if np.linalg.norm(np.cross(hinge_rate(body, joint) * axis, r0) - v0) > \
            ROD_START_RTOL * speed:
        return (f"{who}: body {joint.body}'s initial velocity must be a rotation about the "
                f"hinge axis")
    return None


def hinge_rate(body, joint) -> float:
    """The body's start angular velocity about the rod's axis (rad/s): ((x - anchor) x v) .
    axis / L^2."""
    r0 = np.subtract(body.position, joint.anchor)
    return float(np.cross(r0, body.velocity) @ np.asarray(joint.axis)) / joint.length ** 2


@dataclass(frozen=True)
class HingeFrames:
    """Every rod of a scene in generalized coordinates, one entry per rod (scene.joints order).

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
        joints = scene.joints
        frames = [hinge_frame(joint.axis, scene.gravity) for joint in joints]
        return cls(bodies=np.array([joint.body for joint in joints], dtype=int),
                   anchor=np.array([joint.anchor for joint in joints]).reshape(-1, 3),
                   length=np.array([joint.length for joint in joints], dtype=float),
                   d=np.array([f[0] for f in frames]).reshape(-1, 3),
                   s=np.array([f[1] for f in frames]).reshape(-1, 3),
                   g_plane=np.array([f[2] for f in frames], dtype=float))

    def initial_angles(self, positions, velocities) -> tuple[np.ndarray, np.ndarray]:
        """(theta, omega) per rod (rad, rad/s) from the bodies' Cartesian start (build time)."""
        x0, v0 = positions[self.bodies], velocities[self.bodies]
        pairs = [cartesian_to_hinge(x0[k], v0[k], self.anchor[k], self.length[k], self.d[k],
                                    self.s[k]) for k in range(len(self.bodies))]
        return (np.array([p[0] for p in pairs], dtype=float),
                np.array([p[1] for p in pairs], dtype=float))

    def cartesian(self, theta, omega, positions, velocities) -> tuple[np.ndarray, np.ndarray]:
        """(x, v) of every body: the rods' bodies from their angles, the others as given."""
        x_rod, v_rod = hinge_to_cartesian(theta, omega, self.anchor, self.length, self.d,
                                          self.s)
        x, v = positions.copy(), velocities.copy()
        x[self.bodies], v[self.bodies] = x_rod, v_rod
        return x, v


def rod_length_errors(scene, x) -> np.ndarray:
    """|x_body - anchor| - L per rod (m), x (n_bodies, 3). Each rod's norm is taken on its own
    3-vector (np.linalg.norm of one row), the operation order engines have always observed."""
    return np.array([np.linalg.norm(x[joint.body] - np.asarray(joint.anchor)) - joint.length
                     for joint in scene.joints])
