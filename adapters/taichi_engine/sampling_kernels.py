"""Witkin-Heckbert sampling of an implicit sphere as float64 taichi kernels: the model of
`refsim.models.surface_sampling.SphereSampling` written out, stepped by the explicit tableaux
of `refsim.integrators.first_order` with the projection where refsim applies it.

    E_ij = alpha exp(|p_i - p_j|^2 (-1 / (2 sigma^2)))                  (all pairs, j = i too:
    grad_i = (-2 / sigma^2) sum_j E_ij (p_i - p_j)                        its term is 0)
    u_i = -(grad_i - (grad_i . n_i) n_i),  n_i = (p_i - c) / |p_i - c|
    stages k_s = u(p + sum_j (a_sj h) k_j), p_1 = p + sum_s (b_s h) k_s (unprojected stages)
    p_1 <- c + (R / |p_1 - c|) (p_1 - c)                                 (after every step)

The same operations in the same order as refsim's numpy (the coefficients a_sj h and b_s h are
formed as refsim forms them, the tableau's zero entries skipped as refsim skips them): the two
differ only in the order of the pair sums and the last bit of exp.

ONE kernel for every stepper and every N: the tableau is a runtime array argument and the
stage count and N are runtime shapes, so it compiles once per process (four kernels unrolled
per stepper cost 0.2-0.45 s of JIT each). The time loop is the kernel's outermost loop,
serialized (each stage needs every particle's positions), so the loops over particles and
pairs inside it run serially on one thread
(docs/engine_notes.md#taichi-outermost-loop-runs-in-parallel: only a kernel's outermost loop
runs in parallel).
`velocities` alone, for checks and benchmarks, runs its loop over particles in parallel.
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
import numpy as np

from .kernel_types import f64, nd_f64, nd_vec3, ti, vec3

nd2_vec3 = ti.types.ndarray(dtype=vec3, ndim=2)
sampling_t = ti.types.argpack(centre=vec3, radius=f64, alpha=f64, decay=f64, scale=f64)


def sampling_pack(radius, centre, sigma, alpha):
    """The model's constants as refsim forms them: decay = -0.5 / sigma^2 multiplies |d|^2,
    scale = -2 / sigma^2 multiplies the pair sum."""
    sigma = float(sigma)
    return sampling_t(centre=vec3(*np.asarray(centre, float).reshape(3).tolist()),
                      radius=float(radius), alpha=float(alpha), decay=-0.5 / sigma ** 2,
                      scale=-2.0 / sigma ** 2)


def tableau_array(tableau) -> np.ndarray:
    """An explicit tableau as the kernel's runtime argument: [a (s x s, row-major), b (s)]."""
    a, b, _ = tableau.arrays()
    return np.concatenate([a.ravel(), b])


@ti.func
def velocity_of(P: ti.template(), q: ti.template(), i):
    """u_i at the positions q: the tangential part of -grad_{p_i} E_i."""
    qi = q[i]
    acc = vec3(0.0, 0.0, 0.0)
    for j in range(q.shape[0]):
        d = qi - q[j]
        dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        acc += (P.alpha * ti.exp(dist2 * P.decay)) * d
    grad = P.scale * acc
    rel = qi - P.centre
    normal = rel / ti.sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2])
    along = grad[0] * normal[0] + grad[1] * normal[1] + grad[2] * normal[2]
    return -(grad - along * normal)


@ti.func
def projected(P: ti.template(), q):
    rel = q - P.centre
    return P.centre + (P.radius / ti.sqrt(rel[0] * rel[0] + rel[1] * rel[1] +
                                          rel[2] * rel[2])) * rel


@ti.func
def stage_positions(p: ti.template(), stage: ti.template(), slopes: ti.template(),
                    tab: ti.template(), s, h):
    """stage = p + sum_j (a_sj h) k_j over the j < s with a_sj != 0, in j order (as refsim)."""
    stages = slopes.shape[0]
    for i in range(p.shape[0]):
        q = p[i]
        for j in range(s):
            a_sj = tab[s * stages + j]
            if a_sj != 0.0:
                q = q + (a_sj * h) * slopes[j, i]
        stage[i] = q


@ti.kernel
def advance(p: nd_vec3, stage: nd_vec3, slopes: nd2_vec3, tab: nd_f64, P: sampling_t, h: f64,
            n: ti.i32):
    """n steps of h of every particle, projected after each, with the explicit tableau `tab`
    (`tableau_array`; its stage count is slopes.shape[0]): one kernel for every stepper."""
    stages = slopes.shape[0]
    ti.loop_config(serialize=True)  # the time loop is the outermost loop: keep it serial
    for _ in range(n):
        for i in range(p.shape[0]):
            slopes[0, i] = velocity_of(P, p, i)
        for s in range(1, stages):
            stage_positions(p, stage, slopes, tab, s, h)
            for i in range(p.shape[0]):
                slopes[s, i] = velocity_of(P, stage, i)
        for i in range(p.shape[0]):
            q = p[i]
            for s in range(stages):
                b_s = tab[stages * stages + s]
                if b_s != 0.0:
                    q = q + (b_s * h) * slopes[s, i]
            p[i] = projected(P, q)


@ti.kernel
def velocities(p: nd_vec3, u: nd_vec3, P: sampling_t):
    """u = u(p) for every particle; the loop over particles runs on taichi's CPU threads."""
    for i in range(p.shape[0]):
        u[i] = velocity_of(P, p, i)
