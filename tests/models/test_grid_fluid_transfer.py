"""PIC, FLIP, blend and APIC transfers on the MAC grid: their theory as tests (issue 27).

Round-off bounds: P2G divides two bincount sums of the same positive weights (at most ~40
terms per face here: 4 particles a cell x 9 cells), each sum within (N - 1) eps of its value,
and G2P sums 4 or 9 weighted terms; hence the ulp counts below. Momentum sums cancel: their
bounds are relative to the sum of |terms| (scale=), the accumulation over ~40 terms a face
and a pairwise sum over faces and particles (log2 N ~ 13).
"""
from __future__ import annotations

import numpy as np
import pytest
from ulp import assert_ulp

from refsim.models.grid_fluid import transfer_theory as th
from refsim.models.grid_fluid.transfer import (KERNELS, SCHEMES, MacLayout, TransferScheme,
                                               g2p, p2g, parse_transfer, stencils,
                                               transfer_info)

EPS = np.finfo(float).eps
N = 32
LAYOUT = MacLayout(N, N, 1.0 / N)
PERIODIC = MacLayout(N, N, 1.0 / N, periodic=(True, True))


def jittered(n=N, per_side=2, seed=0, lo=0.0, hi=1.0):
    """per_side^2 particles a cell, each jittered in its sub-cell (seeded), in [lo, hi]^2."""
    rng = np.random.default_rng(seed)
    g = (np.arange(n * per_side) + 0.5) / (n * per_side)
    x = np.stack([a.ravel() for a in np.meshgrid(g, g, indexing="ij")], axis=1)
    x = x + rng.uniform(-0.5, 0.5, x.shape) / (n * per_side)
    keep = np.all((x >= lo) & (x <= hi), axis=1)
    return x[keep], rng.uniform(0.5, 1.5, keep.sum()) / (per_side * n) ** 2


def disk(n=N, radius=0.3, seed=0):
    x, m = jittered(n, seed=seed)
    keep = np.hypot(x[:, 0] - 0.5, x[:, 1] - 0.5) < radius
    return x[keep], np.full(keep.sum(), 1.0 / (4 * n * n))


def rotation(x, omega=2.0):
    return np.stack([-omega * (x[:, 1] - 0.5), omega * (x[:, 0] - 0.5)], axis=1)


def round_trip(layout, scheme, x, vel, m, c=None):
    sts = stencils(layout, x, scheme.kernel)
    field = p2g(layout, x, vel, m, scheme.kernel, c=c if scheme.affine else None, sts=sts)
    return (*g2p(scheme, sts, field, field, vel), field, sts)


ALL = [TransferScheme(s, k) for s in SCHEMES for k in KERNELS]
INTERIOR = dict(lo=0.2, hi=0.8)  # every stencil inside the array (3 nodes reach 1.5 h)


@pytest.mark.parametrize("scheme", ALL, ids=lambda s: s.label)
@pytest.mark.parametrize("layout", [LAYOUT, PERIODIC], ids=["walls", "periodic"])
def test_constant_velocity_round_trip_exact(scheme, layout):
    x, m = jittered(**(INTERIOR if layout is LAYOUT else {}))
    vel = np.broadcast_to([0.7, -1.3], x.shape).copy()
    c = np.zeros((len(x), 2, 2))
    out, c_out, *_ = round_trip(layout, scheme, x, vel, m, c)
    # ratio of two ~40-term sums (2 x 40 eps) then a 9-term weighted sum: 100 ulps of |U|
    assert_ulp(out, vel, 100, "P2G's ratio of two bincount sums and G2P's weighted sum",
               scale=np.abs(vel))
    if scheme.affine:  # the constant's gradient: round-off of |U| amplified by 1/h
        assert np.max(np.abs(c_out)) <= 100 * EPS * 1.3 / layout.h


@pytest.mark.parametrize("kernel", KERNELS)
def test_affine_field_exact_for_apic_not_pic(kernel):
    x, m = disk()  # free-surface faces too: APIC is exact on every face that has mass
    a, b = np.array([[0.3, -1.2], [0.7, -0.3]]), np.array([0.1, -0.2])
    vel, c = x @ a.T + b, np.broadcast_to(a, (len(x), 2, 2)).copy()
    out, c_out, *_ = round_trip(LAYOUT, TransferScheme("apic", kernel), x, vel, m, c)
    # |v| <= 1: 100 ulps as above; c: the same round-off over the 1/h of D^-1 (x_i - x_p)
    assert_ulp(out, vel, 100, "APIC reproduces affine fields", scale=1.0)
    assert_ulp(c_out, c, 100 / LAYOUT.h, "c = D^-1 sum w u (x_i - x_p): round-off / h",
               scale=1.0)
    pic, *_ = round_trip(LAYOUT, TransferScheme("pic", kernel), x, vel, m)
    assert np.max(np.abs(pic - vel)) > 1e-3  # PIC smooths the edge's faces (their centroid)


@pytest.mark.parametrize("scheme", ALL, ids=lambda s: s.label)
@pytest.mark.parametrize("layout", [LAYOUT, PERIODIC], ids=["walls", "periodic"])
def test_linear_momentum_conserved(scheme, layout):
    x, m = jittered(seed=3, **(INTERIOR if layout is LAYOUT else {}))
    rng = np.random.default_rng(4)
    vel, c = rng.normal(size=x.shape), rng.normal(size=(len(x), 2, 2))
    out, c_out, field, sts = round_trip(layout, scheme, x, vel, m, c)
    scale = np.sum(m[:, None] * np.abs(vel), axis=0)
    assert_ulp(th.grid_momentum(layout, field), th.particle_momentum(vel, m), 64,
               "P2G: sums of the same products in another order", scale=scale)
    if scheme.name in ("pic", "apic"):  # G2P: sum_p m_p sum_i w u_i = sum_i m_i u_i
        assert_ulp(th.particle_momentum(out, m), th.grid_momentum(layout, field), 64,
                   "G2P: the same sum regrouped", scale=scale)


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("x0", [(0.5, 0.5), (0.0, 0.0)], ids=["centre", "corner"])
def test_apic_round_trip_keeps_angular_momentum(kernel, x0):
    x, m = jittered(seed=5, **INTERIOR)
    rng = np.random.default_rng(6)
    vel, c = rng.normal(size=x.shape), rng.normal(size=(len(x), 2, 2))
    sts = stencils(LAYOUT, x, kernel)
    before = th.particle_angular_momentum(x, vel, m, x0, c, sts)
    field = p2g(LAYOUT, x, vel, m, kernel, c=c, sts=sts)
    out, c_out = g2p(TransferScheme("apic", kernel), sts, field, None, vel)
    after = th.particle_angular_momentum(x, out, m, x0, c_out, sts)
    scale = float(np.sum(m * (np.abs(vel).sum(1) + np.abs(c).sum((1, 2)) * LAYOUT.h)))
    # terms |x| m |v| <= scale; summed over ~40 terms a face, faces and particles: 64 ulps
    assert_ulp(th.grid_angular_momentum(LAYOUT, field, x0), before, 64, "P2G", scale=scale)
    assert_ulp(after, before, 64, "round trip", scale=scale)


@pytest.mark.parametrize("kernel", KERNELS)
def test_pic_loses_the_affine_angular_momentum(kernel):
    """PIC's G2P drops exactly sum_p m_p [(D_v c_v)_x - (D_u c_u)_y]; on a rigid rotation that
    is ~ omega sum_p m_p (D_u,yy + D_v,xx) (the smoothing estimate, O(h / R) from the edge)."""
    x, m = disk(n=64)
    layout, omega = MacLayout(64, 64, 1 / 64), 2.0
    vel = rotation(x, omega)
    out, _, field, sts = round_trip(layout, TransferScheme("pic", kernel), x, vel, m)
    lost = th.grid_angular_momentum(layout, field, (0.5, 0.5)) - \
        th.particle_angular_momentum(x, out, m, (0.5, 0.5))
    total = th.particle_angular_momentum(x, vel, m, (0.5, 0.5))
    assert_ulp(lost, th.pic_angular_loss(sts, field, m), 1e3, "the identity; the terms are "
               "m r v, summed over ~5000 particles and faces (cancellation)", scale=total)
    assert_ulp(th.grid_angular_momentum(layout, field, (0.5, 0.5)), total, 1e3,
               "PIC's P2G conserves it (linear reproduction)", scale=total)
    estimate = th.rigid_rotation_pic_loss(sts, m, omega)[1]
    # measured 0.966 (hat), 0.969 (B-spline); the edge's faces (mass fraction ~2 h / R = 0.10)
    # see their particles' centroid inside them
    assert 1.0 - 2 * layout.h / 0.3 < lost / estimate < 1.0


@pytest.mark.parametrize("kernel", KERNELS)
def test_apic_angular_momentum_across_particle_motion(kernel):
    """Move the particles by dt v between two APIC round trips (no grid forces): under the
    quadratic B-spline D_p = h^2/4 I is the same everywhere, so the particles' angular
    momentum is kept (to round-off); under the hat D_p changes with position, so it is not."""
    x, m = disk(n=64)
    layout = MacLayout(64, 64, 1 / 64)
    rng = np.random.default_rng(7)
    vel = rotation(x) + 0.3 * rng.normal(size=x.shape)
    scheme = TransferScheme("apic", kernel)
    out, c, _, sts = round_trip(layout, scheme, x, vel, m, np.zeros((len(x), 2, 2)))
    before = th.particle_angular_momentum(x, out, m, (0.5, 0.5), c, sts)
    moved = x + 0.3 * layout.h * out / np.max(np.abs(out))
    after = th.particle_angular_momentum(moved, out, m, (0.5, 0.5), c,
                                         stencils(layout, moved, kernel))
    scale = float(np.sum(m * np.abs(out).sum(1)))
    if kernel == "quadratic_bspline":
        assert_ulp(after, before, 64, "x x v unchanged along v, D constant", scale=scale)
    else:
        # measured 4.3e-6 of the scale, 2e10 ulps: 1e4 x the bound above is not round-off
        assert abs(after - before) > 1e4 * 64 * EPS * scale


@pytest.mark.parametrize("kernel", KERNELS)
def test_flip_without_grid_change_returns_velocities(kernel):
    x, m = disk()
    vel = np.random.default_rng(8).normal(size=x.shape)
    out, _, field, sts = round_trip(LAYOUT, TransferScheme("flip", kernel), x, vel, m)
    assert np.array_equal(out, vel)  # vel + 1 x 0.0 + 0 x PIC: the same numbers
    blend = TransferScheme("blend", kernel, alpha=0.95)
    pic = g2p(TransferScheme("pic", kernel), sts, field, field, vel)[0]
    out = g2p(blend, sts, field, field, vel)[0]
    assert np.array_equal(out, 0.95 * (vel + 0.0) + (1.0 - 0.95) * pic)  # same operations


def test_flip_adds_the_grid_change():
    """FLIP adds the grid's change, interpolated: a uniform change dU on every face moves
    every particle by dU (the wrong sign would move it by -dU)."""
    x, m = jittered(**INTERIOR)
    vel = np.random.default_rng(9).normal(size=x.shape)
    scheme = TransferScheme("flip", "quadratic_bspline")
    sts = stencils(LAYOUT, x, scheme.kernel)
    old = p2g(LAYOUT, x, vel, m, scheme.kernel, sts=sts)
    new = old._replace(u=old.u + 0.25, v=old.v - 0.5)
    out = g2p(scheme, sts, new, old, vel)[0]
    assert_ulp(out - vel, np.broadcast_to([0.25, -0.5], x.shape), 64,
               "a 9-term weighted sum of a difference of two O(|v|) faces", scale=4.0)


@pytest.mark.parametrize("kernel", KERNELS)
def test_pic_energy_loss_per_transfer(kernel):
    """KE lost by PIC's P2G and G2P each equal their weighted variances (exact identities),
    and on a rigid rotation the round trip loses ~ omega^2 sum_p m_p (D_u,yy + D_v,xx):
    a fraction h^2 / R_g^2 for the B-spline (D = h^2 / 4), less for the hat."""
    ratios = []
    for n in (32, 64, 128):
        x, m = disk(n=n)
        layout = MacLayout(n, n, 1 / n)
        vel = rotation(x)
        out, _, field, sts = round_trip(layout, TransferScheme("pic", kernel), x, vel, m)
        ke0, ke_grid, ke1 = (th.particle_energy(vel, m), th.grid_energy(layout, field),
                             th.particle_energy(out, m))
        # identities: differences of sums of ~1e4 positive terms (pairwise): 1e3 ulps of KE
        assert_ulp(ke0 - ke_grid, th.p2g_energy_loss(sts, field, vel, m), 1e3, "P2G", ke0)
        assert_ulp(ke_grid - ke1, th.g2p_energy_loss(sts, field, m), 1e3, "G2P", ke0)
        ratios.append((ke0 - ke1) / th.rigid_rotation_pic_loss(sts, m, 2.0)[0])
        if kernel == "quadratic_bspline":  # the fraction h^2 / R_g^2, R_g^2 = R^2 / 2
            frac = (ke0 - ke1) / ke0 / (layout.h ** 2 / 0.045)
            assert 1.0 - 2 * layout.h / 0.3 < frac < 1.0  # measured 0.93, 0.96, 0.97
    # measured 0.929, 0.958, 0.970 (hat); 0.930, 0.962, 0.978 (B-spline): -> 1 as h -> 0
    assert all(1.0 - 2 * h / 0.3 < r < 1.0 for r, h in zip(ratios, (1 / 32, 1 / 64, 1 / 128)))
    assert ratios[0] < ratios[1] < ratios[2]


def test_empty_faces_and_bad_input():
    x, m = disk(radius=0.1)
    field = p2g(LAYOUT, x, rotation(x), m, "bilinear")
    empty = field.mu == 0.0
    assert empty.any() and np.all(field.u[empty] == 0.0)
    with pytest.raises(ValueError, match="x must lie"):
        stencils(LAYOUT, np.array([[1.5, 0.5]]), "bilinear")
    with pytest.raises(ValueError, match="scheme"):
        TransferScheme("mpm")
    with pytest.raises(ValueError, match="alpha"):
        TransferScheme("blend", alpha=1.5)
    for scheme in ALL + [TransferScheme("blend", "bilinear", 0.5)]:
        assert parse_transfer(scheme.spec) == scheme
    assert transfer_info("blend_bilinear:0.9")["flip_fraction"] == 0.9
    assert transfer_info("sl_linear:rk2") is None
    for bad in ("apic", "apic_quadratic_bspline:0.5", "blend_bilinear:x", "blend_bilinear:2"):
        with pytest.raises(ValueError, match="transfer scheme|alpha"):
            parse_transfer(bad)


@pytest.mark.parametrize("kernel", KERNELS)
def test_shear_mode_dissipation_at_zero_dt(kernel):
    """A round trip with no grid step (dt = 0) on the shear mode u = sin(k y) (periodic box,
    every stencil inside): PIC loses ~ 2 D k^2 of the energy (the smoothing estimate, second
    order in k h); APIC reproduces the mode's affine part, so it loses only the curvature's
    share, fourth order in k h: APIC too dissipates at dt = 0 (Ding et al.'s point)."""
    x, m = jittered(seed=1)
    losses = {}
    for mode in (1, 2):
        k = 2 * np.pi * mode
        vel = np.stack([np.sin(k * x[:, 1]), np.zeros(len(x))], axis=1)
        c = np.zeros((len(x), 2, 2))
        c[:, 0, 1] = k * np.cos(k * x[:, 1])
        for name in ("pic", "apic"):
            out, *_, sts = round_trip(PERIODIC, TransferScheme(name, kernel), x, vel, m, c)
            losses[name, mode] = 1 - th.particle_energy(out, m) / th.particle_energy(vel, m)
        estimate = 2 * np.mean(sts[0].dmat[:, 1]) * k ** 2
        # measured 0.96 (k h = 0.2) and 0.95 (0.4): the estimate's next order, -O((k h)^2)
        assert 0.9 < losses["pic", mode] / estimate < 1.0
    # measured 15.3 (hat) and 15.8 (B-spline) for k h doubled from 0.2; second order gives 4
    assert 14.0 < losses["apic", 2] / losses["apic", 1] < 16.5
    assert losses["apic", 1] < 0.01 * losses["pic", 1]  # measured 0.3 % (hat), 0.5 %
