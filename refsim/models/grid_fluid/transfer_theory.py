"""What the particle <-> MAC-grid transfers conserve and lose, as functions (issue 27).

Momenta and energies of the particles and of the faces (a periodic axis' repeated face
counted once), and the transfers' exact loss identities, used by the tests and the case:

- P2G is a mass-weighted average: u_ai = sum_p (m_p w_aip / m_ai) v_pa. For each face,
  sum_p m_p w v^2 - m_ai u_ai^2 = sum_p m_p w (v_pa - u_ai)^2 (the weighted variance), so,
  when every particle's stencil lies inside the array (sum_i w_aip = 1),
  KE_particles - KE_grid = 1/2 sum_a sum_p m_p sum_i w_aip (v_pa - u_ai)^2 >= 0
  (`p2g_energy_loss`); PIC and FLIP P2G lose this, APIC's P2G carries c_ap and loses less.
- PIC's G2P is a convex combination: v_pa = sum_i w_aip u_ai, and with the same masses
  KE_grid - KE_particles = 1/2 sum_a sum_p m_p sum_i w_aip (u_ai - v_pa)^2 (`g2p_energy_loss`).
- For a smooth field the variance is the kernel's smoothing: u_ai - v_pa ~ grad u_a .
  (x_ai - x_p), so each transfer loses ~ 1/2 sum_p m_p grad u_a . D_ap grad u_a per component.
  A rigid rotation (u = -omega (y - yc), v = omega (x - xc)) then loses per PIC round trip
  ~ omega^2 sum_p m_p (D_up,yy + D_vp,xx) of kinetic energy and
  ~ omega sum_p m_p (D_up,yy + D_vp,xx) of angular momentum (`rigid_rotation_pic_loss`); with
  D = h^2/4 (quadratic B-spline) that is a fraction h^2 / R_g^2 of the energy (twice the
  fraction of angular momentum), R_g^2 the mass-weighted mean squared radius (D = h^2 / 6 on
  average for the hat over uniform positions: 2/3 h^2 / R_g^2). The
  estimate neglects where a face's particles are not centred on it (jitter, the free
  surface), which the exact identities above include.
- Angular momentum (z, about x0): PIC's G2P loses exactly
  sum_p m_p [(D_vp c_vp)_x - (D_up c_up)_y] with c from the grid (`pic_angular_loss`),
  the term APIC keeps on its particles (`particle_angular_momentum` with c).
No loop over particles or faces.
"""
from __future__ import annotations

import numpy as np

from refsim.models.grid_fluid.transfer import (FaceField, MacLayout, Stencil, affine_vectors,
                                               interpolate)


def particle_momentum(vel, m) -> np.ndarray:
    """sum_p m_p v_p, (2,)."""
    vel = np.asarray(vel, float)[:, :2]
    return np.sum(np.broadcast_to(np.asarray(m, float), vel.shape[:1])[:, None] * vel, axis=0)


def grid_momentum(layout: MacLayout, field: FaceField) -> np.ndarray:
    """sum_i m_ai u_ai per component over the unique faces, (2,)."""
    return np.array([np.sum((field.mass(a) * field.velocity(a))[layout.unique_faces(a)])
                     for a in (0, 1)])


def particle_energy(vel, m) -> float:
    vel = np.asarray(vel, float)[:, :2]
    return 0.5 * float(np.sum(np.asarray(m, float) * np.sum(vel * vel, axis=1)))


def grid_energy(layout: MacLayout, field: FaceField) -> float:
    return 0.5 * sum(float(np.sum((field.mass(a) * field.velocity(a) ** 2)
                                  [layout.unique_faces(a)])) for a in (0, 1))


def affine_spin(sts, c, m) -> float:
    """sum_p m_p [(D_vp c_vp)_x - (D_up c_up)_y]: the angular momentum APIC's affine vectors
    carry (D diagonal for the tensor-product kernels)."""
    m = np.broadcast_to(np.asarray(m, float), (c.shape[0],))
    return float(np.sum(m * (sts[1].dmat[:, 0] * c[:, 1, 0] - sts[0].dmat[:, 1] * c[:, 0, 1])))


def particle_angular_momentum(x, vel, m, x0=(0.0, 0.0), c=None, sts=None) -> float:
    """sum_p m_p (x_p - x0) x v_p (z), plus `affine_spin` when c (APIC) is given (then the
    stencils `sts` at x are needed for D)."""
    r = np.asarray(x, float)[:, :2] - np.asarray(x0, float)
    vel = np.asarray(vel, float)[:, :2]
    m = np.broadcast_to(np.asarray(m, float), vel.shape[:1])
    orbital = float(np.sum(m * (r[:, 0] * vel[:, 1] - r[:, 1] * vel[:, 0])))
    return orbital if c is None else orbital + affine_spin(sts, c, m)


def grid_angular_momentum(layout: MacLayout, field: FaceField, x0=(0.0, 0.0)) -> float:
    """sum over unique faces of m_ai ((x_ai - x0) x e_a) u_ai: -(y - y0) m u + (x - x0) m v."""
    x0 = np.asarray(x0, float)
    lu = -(layout.face_positions(0)[..., 1] - x0[1]) * field.mu * field.u
    lv = (layout.face_positions(1)[..., 0] - x0[0]) * field.mv * field.v
    return float(np.sum(lu[layout.unique_faces(0)]) + np.sum(lv[layout.unique_faces(1)]))


def _node_values(st: Stencil, field: np.ndarray) -> np.ndarray:
    return st.sign * field.ravel()[st.flat]


def p2g_energy_loss(sts, field: FaceField, vel, m) -> float:
    """1/2 sum_a sum_p m_p sum_i w_aip (v_pa - u_ai)^2 over the nodes inside the array: the
    kinetic energy PIC/FLIP's P2G loses when every stencil lies inside."""
    vel = np.asarray(vel, float)
    m = np.broadcast_to(np.asarray(m, float), vel.shape[:1])
    total = 0.0
    for a in (0, 1):
        st = sts[a]
        diff = vel[:, a] - _node_values(st, field.velocity(a))
        total += float(np.sum(m * st.w * st.inside * diff * diff))
    return 0.5 * total


def g2p_energy_loss(sts, field: FaceField, m) -> float:
    """1/2 sum_a sum_p m_p sum_i w_aip (u_ai - v_pa)^2 with v_pa PIC's G2P: the kinetic energy
    PIC's G2P loses (masses m_ai from these particles' P2G)."""
    total = 0.0
    m = np.asarray(m, float)
    for a in (0, 1):
        st = sts[a]
        nodes = _node_values(st, field.velocity(a))
        diff = nodes - interpolate(st, field.velocity(a))
        total += float(np.sum(m * st.w * diff * diff))
    return 0.5 * total


def pic_angular_loss(sts, field: FaceField, m) -> float:
    """sum_p m_p [(D_vp c_vp)_x - (D_up c_up)_y], c from the grid: the angular momentum PIC's
    G2P drops (the grid's minus the particles' after it)."""
    c = np.stack([affine_vectors(sts[a], field.velocity(a)) for a in (0, 1)], axis=1)
    return affine_spin(sts, c, m)


def rigid_rotation_pic_loss(sts, m, omega: float) -> tuple:
    """(kinetic energy, angular momentum) a PIC round trip loses on a rigid rotation of rate
    omega by the smoothing estimate: omega^2 S and omega S, S = sum_p m_p (D_up,yy + D_vp,xx)."""
    n = sts[0].w.shape[1]
    s = float(np.sum(np.broadcast_to(np.asarray(m, float), (n,))
                     * (sts[0].dmat[:, 1] + sts[1].dmat[:, 0])))
    return omega ** 2 * s, omega * s
