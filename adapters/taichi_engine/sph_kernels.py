"""2D WCSPH kernels: `start_sph` (grid, pressures, a(x0, rho0)) and `advance_sph`, whose
serialised time loop runs refsim's kick-drift-kick step with the trapezoid density drift;
`step_sph_parallel` is one step of it with each stage a top-level (multi-threaded) loop.
The physics is in sph_physics.
No `from __future__ import annotations` here: taichi reads `ti.template()` annotations as objects.
"""
from .kernel_types import f64, i32, nd_f64, nd_i32, nd_i64, nd_vec2, ti, vec2
from .sph_physics import (accelerations, build_grid, density_rates, fluid_pressure, momentum,
                          wall_pressure)

sph_t = ti.types.argpack(
    n_fluid=i32, no_slip=i32, tension=i32, mass=f64, h=f64, rho0=f64, c0=f64, alpha=f64,
    delta=f64, gravity=vec2, cell_min=f64,
    rho=nd_f64, p=nd_f64, drho=nd_f64, diffused=nd_f64, acc=nd_vec2, cell_count=nd_i32,
    cell_start=nd_i32,
    cell_of=nd_i32, order=nd_i32, grid=nd_f64, dims=nd_i32, stats=nd_i64)


# -- kernels -------------------------------------------------------------------------------
@ti.kernel
def start_sph(x: nd_vec2, v: nd_vec2, S: sph_t):
    ti.loop_config(serialize=True)
    for _ in range(1):
        build_grid(x, S)
        accelerations(x, v, S)


@ti.kernel
def advance_sph(x: nd_vec2, v: nd_vec2, S: sph_t, dt: f64, n: ti.i32):
    """Per step (refsim.models.sph.WCSPH.step): v+ = v + dt/2 a; D0 = D(x, v+) and the
    delta-SPH Dd(x, rho) on the grid of x; x' = x + dt v+; grid of x';
    rho' = rho + dt/2 (D0 + D(x', v+)) + dt Dd;
    a' = a(x', rho'); v' = v+ + dt/2 a'."""
    ti.loop_config(serialize=True)  # the time loop: serial, and so is everything inside
    for _ in range(n):
        half = 0.5 * dt
        nf = S.n_fluid
        for i in range(nf):
            v[i] = v[i] + half * S.acc[i]
        for i in range(nf):
            S.drho[i], S.diffused[i] = density_rates(x, v, S, i, True)
        for i in range(nf):
            x[i] = x[i] + dt * v[i]
        build_grid(x, S)
        for i in range(nf):
            S.rho[i] = S.rho[i] + half * (S.drho[i] + density_rates(x, v, S, i, False)[0]) + (
                dt * S.diffused[i])
        accelerations(x, v, S)
        for i in range(nf):
            v[i] = v[i] + half * S.acc[i]
        S.stats[1] += 1


@ti.kernel
def step_sph_parallel(x: nd_vec2, v: nd_vec2, S: sph_t, dt: f64):
    """One step of `advance_sph`, each stage a top-level loop that taichi runs on
    cpu_max_num_threads threads: every particle writes only its own sums (gathers, no
    atomics), and the counting sort stays serial, so the bits do not depend on the
    thread count or schedule."""
    half = 0.5 * dt
    for i in range(S.n_fluid):
        v[i] = v[i] + half * S.acc[i]
    for i in range(S.n_fluid):
        S.drho[i], S.diffused[i] = density_rates(x, v, S, i, True)
    for i in range(S.n_fluid):
        x[i] = x[i] + dt * v[i]
    ti.loop_config(serialize=True)
    for _ in range(1):
        build_grid(x, S)
    for i in range(S.n_fluid):
        S.rho[i] = S.rho[i] + half * (S.drho[i] + density_rates(x, v, S, i, False)[0]) + (
            dt * S.diffused[i])
    for i in range(S.n_fluid):
        S.p[i] = fluid_pressure(S, i)
    for w in range(S.n_fluid, x.shape[0]):
        wall_pressure(x, S, w)
    for i in range(S.n_fluid):
        S.acc[i] = momentum(x, v, S, i)
    for i in range(S.n_fluid):
        v[i] = v[i] + half * S.acc[i]
    ti.loop_config(serialize=True)
    for _ in range(1):
        S.stats[1] += 1


def advance_sph_parallel(x, v, S, dt, n):
    for _ in range(n):
        step_sph_parallel(x, v, S, dt)
