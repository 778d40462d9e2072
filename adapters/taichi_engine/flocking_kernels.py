"""Flocking birds as float64 taichi kernels: the accelerations of `refsim.models.flocking`
(all pairs) and the steppers of `refsim.integrators`, the time loop inside one kernel.

Rules (runtime switch `rule`, both inlined once):
- Cucker-Smale: a_i = (1/N) sum_j psi_ij (v_j - v_i), psi = K (sigma^2 + |x_j - x_i|^2)^-beta.
  The pair terms are exact negatives of each other (|d|^2 of -d equals that of d bit for bit,
  and v_j - v_i = -(v_i - v_j)), so sum_i a_i is zero up to the rounding of the N sums.
- Reynolds: over the neighbours 0 < |x_j - x_i|^2 < R^2, w_s (-sum_j d / |d|^2) +
  w_a (mean v_j - v_i) + w_c (mean x_j - x_i) (the means only when there is a neighbour).

Steppers (runtime `method`, one kernel for all: compiled once per process):
- SYMPLECTIC_EULER: kick then drift, v += h a(x, v); x += h v (refsim's `symplectic_euler`);
- VELOCITY_VERLET: vh = v + h/2 a; x += h vh; a = a(x, vh); v = vh + h/2 a; then, a depending
  on v, the closing half kick corrected once: a = a(x, v); v = vh + h/2 a (refsim's form);
- EXPLICIT_RK: any explicit Runge-Kutta tableau whose stage i couples to stage i - 1 only
  (Euler, midpoint, Heun, Ralston, classical RK4): coefficients a_{i+1,i} and b_i as runtime
  arrays, x_1 = x + sum_i (b_i h) K_i summed left to right as refsim's `ExplicitRK` does;
- START: a(x0, v0) into `acc` (velocity Verlet's carried acceleration), no step.
Each evaluation needs every bird's stage state, so a step is loops over birds: the stage
states, then every acceleration, then the updates. All loops are serial inside the
serialized time loop (the outermost loop of a kernel runs in parallel:
docs/engine_notes.md#taichi-outermost-loop-runs-in-parallel).
No `from __future__ import annotations` here: taichi reads the annotations as objects.
"""
from .kernel_types import f64, i32, nd_f64, nd_vec3, ti, vec3

flock_t = ti.types.argpack(rule=i32, K=f64, sigma2=f64, beta=f64, radius2=f64, w_sep=f64,
                           w_align=f64, w_coh=f64, acc=nd_vec3, xs=nd_vec3, vs=nd_vec3,
                           sx=nd_vec3, sv=nd_vec3, rk_a=nd_f64, rk_b=nd_f64, stages=i32)
RULES = {"cucker_smale": 0, "reynolds": 1}
SYMPLECTIC_EULER, VELOCITY_VERLET, EXPLICIT_RK, START = 0, 1, 2, 3


@ti.func
def cucker_smale(P: ti.template(), i):
    xi, vi = P.xs[i], P.vs[i]
    total = vec3(0.0, 0.0, 0.0)
    for j in range(P.xs.shape[0]):
        d = P.xs[j] - xi
        total += (P.K * ti.pow(P.sigma2 + d.dot(d), -P.beta)) * (P.vs[j] - vi)
    return total / ti.cast(P.xs.shape[0], f64)


@ti.func
def reynolds(P: ti.template(), i):
    xi, vi = P.xs[i], P.vs[i]
    push, sum_v, sum_x = vec3(0.0, 0.0, 0.0), vec3(0.0, 0.0, 0.0), vec3(0.0, 0.0, 0.0)
    count = 0
    for j in range(P.xs.shape[0]):
        d = P.xs[j] - xi
        r2 = d.dot(d)
        if r2 > 0.0 and r2 < P.radius2:
            push += (1.0 / r2) * d
            sum_v += P.vs[j]
            sum_x += P.xs[j]
            count += 1
    a = P.w_sep * (-push)
    if count > 0:
        inv_count = 1.0 / ti.cast(count, f64)
        a = a + P.w_align * (sum_v * inv_count - vi)  # refsim's order: (s + a) + c
        a = a + P.w_coh * (sum_x * inv_count - xi)
    return a


@ti.func
def fill_accel(P: ti.template()):
    """acc = a(xs, vs) for every bird (one call site: the rules are inlined once)."""
    for i in range(P.xs.shape[0]):
        if P.rule == 0:
            P.acc[i] = cucker_smale(P, i)
        else:
            P.acc[i] = reynolds(P, i)


@ti.func
def before_eval(x: ti.template(), v: ti.template(), P: ti.template(), h, method, i, k):
    """Bird i's stage state (xs, vs) before evaluation k of a step."""
    if method == VELOCITY_VERLET:
        if k == 0:  # half kick with the carried a (vh kept in sv), drift
            P.sv[i] = v[i] + (0.5 * h) * P.acc[i]
            x[i] = x[i] + h * P.sv[i]
            P.xs[i], P.vs[i] = x[i], P.sv[i]
        else:  # the corrected closing kick: a at the new velocity
            P.vs[i] = v[i]
    elif method != EXPLICIT_RK or k == 0:  # Euler-type steps, the start, RK's first stage
        P.xs[i], P.vs[i] = x[i], v[i]
        if method == EXPLICIT_RK:
            P.sx[i], P.sv[i] = x[i], v[i]


@ti.func
def after_eval(x: ti.template(), v: ti.template(), P: ti.template(), h, method, i, k):
    """What evaluation k of a step does to bird i with a(xs, vs) in acc."""
    if method == SYMPLECTIC_EULER:
        v[i] = v[i] + h * P.acc[i]
        x[i] = x[i] + h * v[i]
    elif method == VELOCITY_VERLET:
        v[i] = P.sv[i] + (0.5 * h) * P.acc[i]
    elif method == EXPLICIT_RK:
        kx, kv = P.vs[i], P.acc[i]
        hb = P.rk_b[k] * h
        P.sx[i] = P.sx[i] + hb * kx
        P.sv[i] = P.sv[i] + hb * kv
        if k < P.stages - 1:  # the next stage, from the base state and this slope
            ha = P.rk_a[k] * h
            P.xs[i] = x[i] + ha * kx
            P.vs[i] = v[i] + ha * kv
        else:
            x[i], v[i] = P.sx[i], P.sv[i]


@ti.kernel
def advance_flock(x: nd_vec3, v: nd_vec3, P: flock_t, h: f64, n: ti.i32, method: ti.i32):
    """n steps of h of stepper `method` (START: a(x, v) only, with n = 1)."""
    ti.loop_config(serialize=True)  # the time loop: serial, and so is everything inside
    for _ in range(n):
        evals = 1
        if method == VELOCITY_VERLET:
            evals = 2
        elif method == EXPLICIT_RK:
            evals = P.stages
        for k in range(evals):
            for i in range(x.shape[0]):
                before_eval(x, v, P, h, method, i, k)
            fill_accel(P)
            for i in range(x.shape[0]):
                after_eval(x, v, P, h, method, i, k)


def flock_kernels(method: int):
    """(start, advance) as kernel calls for a stepper code (start: a(x0, v0) into acc)."""
    def start(x, v, P):
        advance_flock(x, v, P, 0.0, 1, START)

    def advance(x, v, P, h, n):
        advance_flock(x, v, P, h, n, method)
    return start, advance
