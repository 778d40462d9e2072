"""Particle <-> MAC-grid transfers: PIC, FLIP, the PIC/FLIP blend and APIC (issue 27).

Grid (the group's MAC conventions): nx x ny square cells of side h on [0, nx h] x [0, ny h],
u[i, j] at (i h, (j + 1/2) h), shape (nx + 1, ny); v[i, j] at ((i + 1/2) h, j h), shape
(nx, ny + 1); arrays indexed [i, j] ('ij'); a periodic axis stores its last face equal to its
first. Particles: positions x (n, 2) inside the domain, velocities (n, 2), masses m (n,).

Kernels (tensor products of one 1D weight per axis, node distance r = |x_i - x_p| / h):
- "bilinear": the hat N(r) = 1 - r for r < 1 (2 nodes per axis);
- "quadratic_bspline": N(r) = 3/4 - r^2 (r < 1/2), (3/2 - r)^2 / 2 (1/2 <= r < 3/2) (3 nodes).
Both are partitions of unity that reproduce linear functions (sum_i w_ip x_i = x_p), which is
what every conservation statement below rests on.

Transfers, for each face component a in {u, v} separately (weights w_aip of the a-faces):
- P2G: m_ai = sum_p w_aip m_p; m_ai u_ai = sum_p w_aip m_p (v_pa + c_ap . (x_ai - x_p)) with
  c_ap = 0 except for APIC; faces with m_ai = 0 are empty: velocity 0 and `mass == 0` says so.
- G2P: PIC v_pa = sum_i w_aip u_ai; FLIP v_pa += sum_i w_aip (u_ai^new - u_ai^old) (the grid's
  change added to the particle's own velocity); blend: alpha FLIP + (1 - alpha) PIC;
  APIC: PIC's v_p and c_ap = sum_i u_ai w_aip D_ap^-1 (x_ai - x_p).
APIC on the MAC grid is the form of Ding, Shinar & Schroeder (JCP 2020, "Affine particle in
cell method for MAC grids and fluid simulation"): one affine vector c_ap in R^2 per particle
and face component (the a-th row of the velocity gradient), with the per-component inertia-like
D_ap = sum_i w_aip (x_ai - x_p)(x_ai - x_p)^T. D_ap is diagonal for these tensor-product
kernels; it is (h^2 / 4) I for the quadratic B-spline wherever the particle is (constant), and
diag(f_x (1 - f_x), f_y (1 - f_y)) h^2 for the hat (f the particle's fraction in its a-grid
cell), where w_aip D_ap^-1 (x_ai - x_p) = grad w_aip (Jiang et al. 2015's multilinear MAC form):
that gradient is what is computed for the hat (defined also where D_ap is singular).
What is conserved (derived in `transfer_theory`, measured by the tests):
- linear momentum sum_a sum_i m_ai u_ai = sum_p m_p v_p by P2G for every scheme and kernel,
  and by G2P of PIC and APIC;
- angular momentum about any point x0 (2D: its z component), the grid's
  sum_a sum_i m_ai ((x_ai - x0) x e_a u_ai) against the particles'
  sum_p m_p [(x_p - x0) x v_p + (D_vp c_vp)_x - (D_up c_up)_y], by APIC's P2G and by its G2P
  (round trip: to round-off), with either kernel. Between transfers the particles move: under
  the quadratic B-spline D_ap is constant, so moving a particle leaves its angular momentum as
  it was; under the hat D_ap changes with the particle's position, so angular momentum is kept
  across each transfer but not across particle motion. Source: only the paper's abstract was
  read (it extends Jiang et al. 2015's multilinear MAC transfers to smooth basis functions
  and says they conserve angular momentum, "something which eluded" Jiang et al.); the
  D-weighted particle angular momentum above and both kernels' statements are derived here
  and measured by tests/models/test_grid_fluid_transfer*.py.
- PIC's G2P loses exactly the affine term APIC keeps: sum_p m_p [(D_v c_v)_x - (D_u c_u)_y]
  with c from the grid (`transfer_theory.pic_angular_loss`).
Walls: the stencil's nodes outside the array are dropped in P2G (the faces inside keep
their weighted averages; linear momentum is then conserved only for particles whose stencil
is inside); in G2P they read the mirrored face, the normal component odd (u = 0 on the wall)
and the tangential one even (free slip). Periodic axes wrap. No loop over particles or faces.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

KERNELS = ("bilinear", "quadratic_bspline")
SCHEMES = ("pic", "flip", "blend", "apic")


@dataclass(frozen=True)
class MacLayout:
    """The grid's geometry: nx x ny cells of side h; `periodic` per axis (else walls)."""
    nx: int
    ny: int
    h: float
    periodic: tuple = (False, False)

    def __post_init__(self):
        if self.nx < 2 or self.ny < 2:
            raise ValueError(f"nx, ny must be >= 2, got {self.nx}, {self.ny}")
        if not (np.isfinite(self.h) and self.h > 0):
            raise ValueError(f"h must be finite and > 0, got {self.h}")

    def cells(self, axis: int) -> int:
        return (self.nx, self.ny)[axis]

    def face_shape(self, comp: int) -> tuple:
        """(nx + 1, ny) for u (comp 0), (nx, ny + 1) for v (comp 1)."""
        return tuple(self.cells(d) + (d == comp) for d in (0, 1))

    def face_positions(self, comp: int) -> np.ndarray:
        """(*face_shape, 2): the faces' centres."""
        axes = [(np.arange(self.cells(d) + (d == comp)) + 0.5 * (d != comp)) * self.h
                for d in (0, 1)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)

    def unique_faces(self, comp: int) -> np.ndarray:
        """Bool mask of the faces counted once (a periodic axis' last face repeats its first)."""
        mask = np.ones(self.face_shape(comp), bool)
        if self.periodic[comp]:
            mask[(slice(-1, None), slice(None)) if comp == 0 else (slice(None), slice(-1, None))] \
                = False
        return mask


@dataclass(frozen=True)
class TransferScheme:
    """A transfer: `name` in SCHEMES, `kernel` in KERNELS, `alpha` the FLIP fraction of the
    blend (1 for "flip", 0 for "pic" and "apic")."""
    name: str
    kernel: str = "quadratic_bspline"
    alpha: float = 0.95

    def __post_init__(self):
        if self.name not in SCHEMES:
            raise ValueError(f"scheme must be one of {SCHEMES}, got {self.name!r}")
        if self.kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {self.kernel!r}")
        if not 0.0 <= self.alpha <= 1.0:
            raise ValueError(f"alpha (the FLIP fraction) must be in [0, 1], got {self.alpha}")

    @property
    def flip_fraction(self) -> float:
        return {"pic": 0.0, "apic": 0.0, "flip": 1.0}.get(self.name, self.alpha)

    @property
    def affine(self) -> bool:
        return self.name == "apic"

    @property
    def label(self) -> str:
        name = f"blend{self.alpha:g}" if self.name == "blend" else self.name
        return f"{name}_{self.kernel}"

    @property
    def spec(self) -> str:
        """The scheme's name as an integrator spec (`parse_transfer` reads it back)."""
        tail = f":{self.alpha:g}" if self.name == "blend" else ""
        return f"{self.name}_{self.kernel}{tail}"


TRANSFER_SPECS = tuple(f"{s}_{k}" for s in SCHEMES for k in KERNELS)


def parse_transfer(spec: str) -> TransferScheme:
    """"<scheme>_<kernel>[:alpha]" -> TransferScheme, e.g. "apic_quadratic_bspline",
    "blend_bilinear:0.95" (alpha, the FLIP fraction, only for the blend; default 0.95)."""
    name, _, arg = str(spec).partition(":")
    if name not in TRANSFER_SPECS or (arg and not name.startswith("blend_")):
        raise ValueError(f"transfer scheme must be one of {list(TRANSFER_SPECS)} (the blend "
                         f"optionally :alpha), got {spec!r}")
    scheme, kernel = name.split("_", 1)
    try:
        alpha = float(arg) if arg else 0.95
    except ValueError:
        raise ValueError(f"blend alpha must be a number in [0, 1], got {spec!r}") from None
    return TransferScheme(scheme, kernel, alpha)


def transfer_info(spec) -> dict | None:
    """The method a transfer spec names, in refsim.integrators.method_info's form (order 1
    in dt: the particle-fluid step is an operator splitting, particle_fluid's docstring),
    plus its kernel and FLIP fraction; None for another name."""
    try:
        scheme = parse_transfer(spec)
    except ValueError:
        return None
    return {"name": scheme.spec, "order": 1.0, "symplectic": False, "implicit": False,
            "adaptive": False, "family": "particle-in-cell transfer around a pressure "
            "solve (operator splitting)", "kernel": scheme.kernel,
            "flip_fraction": scheme.flip_fraction}


class Stencil(NamedTuple):
    """One face component's stencil for n particles and S = k^2 nodes each, node-major (the
    particle index last, so that every array operation runs along n; node (i, j) of the
    k x k block at row i k + j).

    flat (S, n) index into the face array (raveled, C order) of the node or of its mirror;
    w (S, n) weights; sign (S, n) the mirror's sign (G2P); inside (S, n) node in the array
    (P2G); per axis (k, n) (x then y): `wa` the 1D weights, `da` x_i - x_p along the axis
    (the node's own position, ghost or not), `ga` the 1D affine weights w D^-1 (x_i - x_p)
    along it (the hat's derivative); dmat (n, 2) D's diagonal. The (S, n, 2) offsets and
    affine weights are tensor products of these (never formed: `offsets_dot`,
    `affine_vectors`).
    """
    flat: np.ndarray
    w: np.ndarray
    sign: np.ndarray
    inside: np.ndarray
    wx: np.ndarray
    wy: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    gx: np.ndarray
    gy: np.ndarray
    dmat: np.ndarray

    def offsets_dot(self, c: np.ndarray) -> np.ndarray:
        """(S, n): c_p . (x_i - x_p) for vectors c (n, 2)."""
        k, n = self.wx.shape
        return ((c[:, 0] * self.dx)[:, None, :] + (c[:, 1] * self.dy)[None, :, :]).reshape(
            k * k, n)


def _weights_1d(s: np.ndarray, kernel: str):
    """Nodes (k, n), weights (k, n), offsets in cells node - s (k, n), the affine weight
    w D^-1 d per cell (k, n) and D (n,) in cells^2 for particles at s (in cells from node 0)
    on one axis."""
    if kernel == "bilinear":
        base = np.floor(s)
        f = s - base
        off = np.array([0.0, 1.0])[:, None]
        w = np.stack([1.0 - f, f])
        g = np.repeat(np.array([[-1.0], [1.0]]), len(s), axis=1)  # the hat's slope, 1/cell
    else:
        base = np.floor(s - 0.5)
        f = s - base  # in [0.5, 1.5)
        off = np.array([0.0, 1.0, 2.0])[:, None]
        w = np.stack([0.5 * (1.5 - f) ** 2, 0.75 - (f - 1.0) ** 2, 0.5 * (f - 0.5) ** 2])
        g = None
    nodes = base.astype(np.int64) + off.astype(np.int64)
    d = off - f
    dd = np.sum(w * d * d, axis=0)  # D in cells^2 (1/4 for the B-spline)
    if g is None:
        g = w * d / dd
    return nodes, w, d, g, dd


def _map_axis(nodes: np.ndarray, cells: int, staggered: bool, periodic: bool):
    """Array index, mirror sign and inside-ness of stencil nodes along one axis."""
    if periodic:
        return np.mod(nodes, cells), np.ones(nodes.shape), np.ones(nodes.shape, bool)
    last = cells if staggered else cells - 1
    inside = (nodes >= 0) & (nodes <= last)
    if staggered:  # normal component: odd about the wall faces 0 and cells
        idx = np.where(nodes < 0, -nodes, np.where(nodes > last, 2 * last - nodes, nodes))
        sign = np.where(inside, 1.0, -1.0)
    else:  # tangential: even about the walls at -1/2 and cells - 1/2
        idx = np.where(nodes < 0, -1 - nodes, np.where(nodes > last, 2 * last + 1 - nodes,
                                                       nodes))
        sign = np.ones(nodes.shape)
    return np.clip(idx, 0, last), sign, inside


def stencil(layout: MacLayout, x: np.ndarray, comp: int, kernel: str) -> Stencil:
    """The `comp` faces' stencil (0: u, 1: v) for particles at x (n, 2)."""
    x = np.asarray(x, float)[:, :2]
    size = np.array([layout.nx, layout.ny]) * layout.h
    if np.any(x < 0.0) or np.any(x > size):
        raise ValueError("particle positions x must lie in the domain [0, nx h] x [0, ny h]")
    per_axis = []
    for d in (0, 1):
        staggered = d == comp
        s = x[:, d] / layout.h - (0.0 if staggered else 0.5)
        nodes, w, off, g, dd = _weights_1d(s, kernel)
        idx, sign, inside = _map_axis(nodes, layout.cells(d), staggered, layout.periodic[d])
        per_axis.append((idx, sign, inside, w, off * layout.h, g / layout.h, dd * layout.h ** 2))
    (ix, sx, inx, wx, dx, gx, ddx), (iy, sy, iny, wy, dy, gy, ddy) = per_axis
    k, n = wx.shape
    ny_arr = layout.face_shape(comp)[1]

    def outer(a, b, op=np.multiply):
        return op(a[:, None, :], b[None, :, :]).reshape(k * k, n)
    return Stencil(flat=outer(ix * ny_arr, iy, np.add), w=outer(wx, wy), sign=outer(sx, sy),
                   inside=outer(inx, iny, np.logical_and), wx=wx, wy=wy, dx=dx, dy=dy,
                   gx=gx, gy=gy, dmat=np.stack([ddx, ddy], axis=1))


def stencils(layout: MacLayout, x: np.ndarray, kernel: str) -> tuple:
    """(u stencil, v stencil) for particles at x."""
    return stencil(layout, x, 0, kernel), stencil(layout, x, 1, kernel)


class FaceField(NamedTuple):
    """Face velocities and masses on the MAC grid: u (nx+1, ny), v (nx, ny+1), mu, mv."""
    u: np.ndarray
    v: np.ndarray
    mu: np.ndarray
    mv: np.ndarray

    def velocity(self, comp: int) -> np.ndarray:
        return (self.u, self.v)[comp]

    def mass(self, comp: int) -> np.ndarray:
        return (self.mu, self.mv)[comp]


def _accumulate(layout: MacLayout, comp: int, st: Stencil, values: np.ndarray) -> np.ndarray:
    """sum_p values[s, p] onto the comp faces (nodes outside the array dropped; a periodic
    axis' repeated last face set equal to its first)."""
    shape = layout.face_shape(comp)
    if st.inside.all():  # no node outside the array: no masked copies
        flat, values = st.flat.ravel(), values.ravel()
    else:
        flat, values = st.flat[st.inside], values[st.inside]
    out = np.bincount(flat, values, minlength=shape[0] * shape[1]).reshape(shape)
    if layout.periodic[0] and comp == 0:
        out[-1, :] = out[0, :]
    if layout.periodic[1] and comp == 1:
        out[:, -1] = out[:, 0]
    return out


def p2g_component(layout: MacLayout, st: Stencil, comp: int, vel: np.ndarray, m: np.ndarray,
                  c: np.ndarray | None = None) -> tuple:
    """(velocity, mass) of the comp faces from particle velocities vel (n,) and affine
    vectors c (n, 2) (None: PIC/FLIP); empty faces get velocity 0."""
    mw = m * st.w
    carried = vel if c is None else vel + st.offsets_dot(c)
    mass = _accumulate(layout, comp, st, mw)
    momentum = _accumulate(layout, comp, st, mw * carried)
    with np.errstate(invalid="ignore", divide="ignore"):
        velocity = np.where(mass > 0.0, momentum / np.where(mass > 0.0, mass, 1.0), 0.0)
    return velocity, mass


def p2g(layout: MacLayout, x, vel, m, kernel: str, c=None, sts=None) -> FaceField:
    """Particles -> faces. vel (n, 2); c (n, 2, 2) with c[:, a] the affine vector of
    component a (APIC), or None. `sts` reuses stencils computed at x."""
    vel = np.asarray(vel, float)
    m = np.broadcast_to(np.asarray(m, float), (vel.shape[0],))
    sts = stencils(layout, x, kernel) if sts is None else sts
    (u, mu), (v, mv) = (p2g_component(layout, sts[a], a, vel[:, a], m,
                                      None if c is None else c[:, a]) for a in (0, 1))
    return FaceField(u, v, mu, mv)


def interpolate(st: Stencil, field: np.ndarray) -> np.ndarray:
    """sum_i w_ip u_i (mirror signs applied): the field at the particles."""
    return np.sum(st.sign * st.w * field.ravel()[st.flat], axis=0)


def affine_vectors(st: Stencil, field: np.ndarray) -> np.ndarray:
    """(n, 2): c_p = sum_i u_i w_ip D_p^-1 (x_i - x_p) (Ding et al.'s MAC APIC)."""
    k, n = st.wx.shape
    nodes = (st.sign * field.ravel()[st.flat]).reshape(k, k, n)
    along_y = np.sum(nodes * st.wy[None], axis=1), np.sum(nodes * st.gy[None], axis=1)
    return np.stack([np.sum(along_y[0] * st.gx, axis=0), np.sum(along_y[1] * st.wx, axis=0)],
                    axis=1)


def g2p(scheme: TransferScheme, sts, new: FaceField, old: FaceField | None, vel) -> tuple:
    """Faces -> particles: (velocities (n, 2), affine vectors (n, 2, 2) or None).

    new: the grid after the step's forces and projection; old: the grid P2G gave (needed by
    FLIP and the blend); vel: the particles' velocities before (FLIP, blend)."""
    pic = np.stack([interpolate(sts[a], new.velocity(a)) for a in (0, 1)], axis=1)
    alpha = scheme.flip_fraction
    if alpha > 0.0:
        delta = np.stack([interpolate(sts[a], new.velocity(a) - old.velocity(a))
                          for a in (0, 1)], axis=1)
        out = alpha * (np.asarray(vel, float) + delta) + (1.0 - alpha) * pic
    else:
        out = pic
    if not scheme.affine:
        return out, None
    return out, np.stack([affine_vectors(sts[a], new.velocity(a)) for a in (0, 1)], axis=1)
