"""Float64 taichi kernels of a spring network WITH bending terms (refsim.models.bending's hinges
and dihedrals, energy 1/2 k (theta - theta0)^2), for the three explicit steppers of
`network_kernels.make_steppers`: a separate kernel family per set of terms present (hinges,
dihedrals, both), so a network without bending never compiles (nor pays for) this code.

The arithmetic is refsim's, in its order (so the rows agree to round-off):
- hinge (a, b, c): e1 = x_b - x_a, e2 = x_c - x_b, l = |e|, u = e / l, c = u1.u2,
  s = |u1 x u2|, theta = atan2(s, c), F'(c) = -k / sinc(theta) (+ k theta0 / s where
  theta0 != 0 anywhere in the network and s != 0: refsim's `_safe_div`), sinc as np.sinc
  (y = pi (theta / pi), eps where y = 0, sin(y) / y);
  g1 = -F' (u2 - c u1) / l1, g2 = -F' (u1 - c u2) / l2; forces (-g1, g1 - g2, g2) on (a, b, c);
- dihedral (a, b, c, d): n1 = (b - a) x (c - a), n2 = (c - d) x (b - d), E = c - b,
  theta = atan2((n1 x n2).E / |E|, n1.n2), torque -k (theta - theta0) times Bridson et al.'s
  gradient (refsim.models.bending.dihedral_gradient, term by term);
- each term's per-node sums in tuple order, then added to the stretch forces (stretch - drag v
  + hinge sum + dihedral sum, refsim's NetworkSystem.forces), then a = f / m + g.
A corner on a pinned node reads its fixed position (anchor) and receives no force.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
import math

from .kernel_types import i32, nd_f64, nd_i32, nd_vec3, ti, vec3
from .network_kernels import NET_FIELDS, make_steppers, spring_sum

EPS = 2.220446049250313e-16  # np.finfo(float).eps: np.sinc's stand-in for y = 0

# the network's fields plus the bending terms: corner p of tuple t at [P + t], P the corners
# per tuple (node: free index or -1 for a pinned node, whose position is the anchor)
bent_t = ti.types.argpack(**NET_FIELDS, h_node=nd_i32, h_anchor=nd_vec3, h_k=nd_f64,
                          h_theta0=nd_f64, h_rested=i32, d_node=nd_i32, d_anchor=nd_vec3,
                          d_k=nd_f64, d_theta0=nd_f64, bend=nd_vec3)


@ti.func
def corner(node: ti.template(), anchor: ti.template(), x: ti.template(), q, off):
    """Position of tuple corner q (a free node's x[off + i], or its anchor)."""
    pos = anchor[q]
    if node[q] >= 0:
        pos = x[node[q] + off]
    return pos


@ti.func
def deposit(P: ti.template(), node: ti.template(), q, f):
    if node[q] >= 0:
        P.bend[node[q]] += f


@ti.func
def cross(a, b):
    return vec3(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@ti.func
def sinc(theta):
    """np.sinc(theta / pi) in np.sinc's operations."""
    y = math.pi * (theta / math.pi)
    if y == 0.0:
        y = EPS
    return ti.sin(y) / y


@ti.func
def hinge_forces(P: ti.template(), x: ti.template(), off):
    """P.bend = the hinges' forces on every free node (refsim's HingeSet.forces)."""
    for t in range(P.h_k.shape[0]):
        xa = corner(P.h_node, P.h_anchor, x, 3 * t, off)
        xb = corner(P.h_node, P.h_anchor, x, 3 * t + 1, off)
        xc = corner(P.h_node, P.h_anchor, x, 3 * t + 2, off)
        e1, e2 = xb - xa, xc - xb
        l1, l2 = ti.sqrt(e1.dot(e1)), ti.sqrt(e2.dot(e2))
        u1, u2 = e1 / l1, e2 / l2
        c = u1.dot(u2)
        w = cross(u1, u2)
        s = ti.sqrt(w.dot(w))
        theta = ti.atan2(s, c)
        first = -P.h_k[t] / sinc(theta)
        if P.h_rested and s != 0.0:
            first = first + P.h_k[t] * (P.h_theta0[t] / s)
        g1 = -first * (u2 - c * u1) / l1
        g2 = -first * (u1 - c * u2) / l2
        deposit(P, P.h_node, 3 * t, -g1)
        deposit(P, P.h_node, 3 * t + 1, g1 - g2)
        deposit(P, P.h_node, 3 * t + 2, g2)


@ti.func
def dihedral_forces(P: ti.template(), x: ti.template(), off):
    """P.bend = the dihedrals' forces on every free node (refsim's DihedralSet.forces)."""
    for t in range(P.d_k.shape[0]):
        a = corner(P.d_node, P.d_anchor, x, 4 * t, off)
        b = corner(P.d_node, P.d_anchor, x, 4 * t + 1, off)
        c = corner(P.d_node, P.d_anchor, x, 4 * t + 2, off)
        d = corner(P.d_node, P.d_anchor, x, 4 * t + 3, off)
        n1, n2 = cross(b - a, c - a), cross(c - d, b - d)
        edge = c - b
        edge_sq = edge.dot(edge)
        edge_len = ti.sqrt(edge_sq)
        theta = ti.atan2(cross(n1, n2).dot(edge / edge_len), n1.dot(n2))
        torque = -P.d_k[t] * (theta - P.d_theta0[t])
        ga = -edge_len * n1 / n1.dot(n1)
        gd = -edge_len * n2 / n2.dot(n2)
        gb = ((a - c).dot(edge) / edge_sq) * ga + ((d - c).dot(edge) / edge_sq) * gd
        gc = -((a - b).dot(edge) / edge_sq) * ga - ((d - b).dot(edge) / edge_sq) * gd
        deposit(P, P.d_node, 4 * t, torque * ga)
        deposit(P, P.d_node, 4 * t + 1, torque * gb)
        deposit(P, P.d_node, 4 * t + 2, torque * gc)
        deposit(P, P.d_node, 4 * t + 3, torque * gd)


@ti.func
def add_bend(P: ti.template(), a: ti.template(), off):
    for i in range(P.mass.shape[0]):
        a[off + i] = a[off + i] + P.bend[i]


@ti.func
def minus_drag(P: ti.template(), v: ti.template(), a: ti.template(), off):
    for i in range(P.mass.shape[0]):
        a[off + i] = a[off + i] - P.drag * v[off + i]


@ti.func
def to_accel(P: ti.template(), a: ti.template(), off):
    """Forces in a[off + i] to accelerations: f / m + g."""
    for i in range(P.mass.shape[0]):
        a[off + i] = a[off + i] * P.inv_m[i] + P.gravity


@ti.func
def clear_bend(P: ti.template()):
    for i in range(P.mass.shape[0]):
        P.bend[i] = vec3(0.0, 0.0, 0.0)


def make_accel(hinges: bool, dihedrals: bool):
    """The acceleration ti.func of a network with the given bending terms."""

    @ti.func
    def accel(P: ti.template(), x: ti.template(), v: ti.template(), a: ti.template(), off):
        spring_sum(P, x, v, a, off)
        minus_drag(P, v, a, off)
        if ti.static(hinges):
            clear_bend(P)
            hinge_forces(P, x, off)
            add_bend(P, a, off)
        if ti.static(dihedrals):
            clear_bend(P)
            dihedral_forces(P, x, off)
            add_bend(P, a, off)
        to_accel(P, a, off)

    return accel


_FAMILIES: dict = {}


def steppers(hinges: bool, dihedrals: bool):
    """(start, symplectic_euler, velocity_verlet, rk4) for networks with these bending terms,
    made once per process (and compiled on first launch)."""
    key = (bool(hinges), bool(dihedrals))
    if key not in _FAMILIES:
        _FAMILIES[key] = make_steppers(bent_t, make_accel(*key))
    return _FAMILIES[key]
