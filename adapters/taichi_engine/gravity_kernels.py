"""All-pairs gravity as taichi float64 kernels: the accelerations of `refsim.models.
nbody_gravity.pair_accelerations` (a_i = sum_{j != i} G m_j d / (|d|^2 + eps^2)^1.5,
d = x_j - x_i), and three steppers whose time loop runs inside one kernel:

- "symplectic_euler": a = a(x); v += h a; x += h v (refsim's `symplectic_euler`);
- "velocity_verlet": v += h/2 a; x += h v; a = a(x); v += h/2 a, a carried between steps;
- "rk4": the classical 4-stage Runge-Kutta on (x, v), stages in scratch arrays.

Every stage needs every body's position, so a step is a sequence of loops over bodies (each
stage's accelerations first, then the update), all serial inside the serialized time loop
(the outermost loop of a kernel runs in parallel:
docs/engine_notes.md#taichi-outermost-loop-runs-in-parallel). `accelerations` alone, for the
benchmark, is a kernel whose outer loop over bodies may run in parallel.
No `from __future__ import annotations` here: taichi reads the annotations as objects.
"""
from .kernel_types import f64, nd_f64, nd_vec3, ti, vec3

gravity_t = ti.types.argpack(mass=nd_f64, G=f64, eps2=f64)
RK4_WEIGHTS = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
RK4_NEXT_NODE = (0.5, 0.5, 1.0, 0.0)  # c of the stage after stage s (none after the last)


@ti.func
def accel_of(P: ti.template(), x: ti.template(), i):
    """a_i at positions x (a serial loop over j)."""
    acc = vec3(0.0, 0.0, 0.0)
    xi = x[i]
    for j in range(x.shape[0]):
        if j != i:
            d = x[j] - xi
            r2 = d.dot(d) + P.eps2
            acc += (P.mass[j] / (r2 * ti.sqrt(r2))) * d
    return P.G * acc


@ti.func
def fill_accel(P: ti.template(), x: ti.template(), a: ti.template()):
    for i in range(x.shape[0]):
        a[i] = accel_of(P, x, i)


@ti.func
def step_symplectic_euler(P: ti.template(), x: ti.template(), v: ti.template(),
                          a: ti.template(), xs: ti.template(), vs: ti.template(),
                          sx: ti.template(), sv: ti.template(), h):
    fill_accel(P, x, a)
    for i in range(x.shape[0]):
        v[i] = v[i] + h * a[i]
        x[i] = x[i] + h * v[i]


@ti.func
def step_velocity_verlet(P: ti.template(), x: ti.template(), v: ti.template(),
                         a: ti.template(), xs: ti.template(), vs: ti.template(),
                         sx: ti.template(), sv: ti.template(), h):
    for i in range(x.shape[0]):
        v[i] = v[i] + (0.5 * h) * a[i]
        x[i] = x[i] + h * v[i]
    fill_accel(P, x, a)
    for i in range(x.shape[0]):
        v[i] = v[i] + (0.5 * h) * a[i]


@ti.func
def step_rk4(P: ti.template(), x: ti.template(), v: ti.template(), a: ti.template(),
             xs: ti.template(), vs: ti.template(), sx: ti.template(), sv: ti.template(), h):
    """Stage s: slopes (vs, a(xs)); sums sx, sv of b_s h slopes; next stage from the base."""
    for i in range(x.shape[0]):
        xs[i], vs[i] = x[i], v[i]
        sx[i], sv[i] = vec3(0.0, 0.0, 0.0), vec3(0.0, 0.0, 0.0)
    for s in ti.static(range(4)):
        fill_accel(P, xs, a)
        weight = ti.static(RK4_WEIGHTS[s]) * h
        next_c = ti.static(RK4_NEXT_NODE[s]) * h
        for i in range(x.shape[0]):
            kx, kv = vs[i], a[i]
            sx[i] = sx[i] + weight * kx
            sv[i] = sv[i] + weight * kv
            if ti.static(s < 3):
                xs[i] = x[i] + next_c * kx
                vs[i] = v[i] + next_c * kv
    for i in range(x.shape[0]):
        x[i] = x[i] + sx[i]
        v[i] = v[i] + sv[i]


STEPPERS = {"symplectic_euler": step_symplectic_euler,
            "velocity_verlet": step_velocity_verlet, "rk4": step_rk4}


def gravity_kernels(integrator: str):
    """(start, advance): a(x0) for Verlet's carried acceleration, and the time loop."""
    stepper = STEPPERS[integrator]

    @ti.kernel
    def start(x: nd_vec3, v: nd_vec3, a: nd_vec3, xs: nd_vec3, vs: nd_vec3, sx: nd_vec3,
              sv: nd_vec3, P: gravity_t):
        ti.loop_config(serialize=True)
        for i in range(x.shape[0]):
            a[i] = accel_of(P, x, i)

    @ti.kernel
    def advance(x: nd_vec3, v: nd_vec3, a: nd_vec3, xs: nd_vec3, vs: nd_vec3, sx: nd_vec3,
                sv: nd_vec3, P: gravity_t, h: f64, n: ti.i32):
        ti.loop_config(serialize=True)  # the time loop is the outermost loop: keep it serial
        for _ in range(n):
            stepper(P, x, v, a, xs, vs, sx, sv, h)
    return start, advance


@ti.kernel
def accelerations(x: nd_vec3, a: nd_vec3, P: gravity_t):
    """a = a(x) for every body; the outer loop over bodies runs on taichi's CPU threads."""
    for i in range(x.shape[0]):
        a[i] = accel_of(P, x, i)
