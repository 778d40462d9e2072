"""Point masses and hinged rods as taichi functions, the three steppers, and the kernel
factories that join them (one compiled kernel per system and stepper per process).

taichi has no integrator of its own (whatever the kernel says; the adapter decides and
declares it: docs/engine_notes.md#taichi-the-adapter-writes-the-integrator), so this adapter
writes three, each as a `ti.func` with one signature, driven by one generic kernel whose time
loop runs inside the kernel:

- "symplectic_euler": kick-drift, v += h a(x, v); x += h v (refsim's `symplectic_euler`);
- "velocity_verlet": half kick, drift, half kick, acceleration carried between steps, and one
  corrected closing half kick when forces depend on velocity (refsim's `velocity_verlet`);
- "rk4": the classical 4-stage Runge-Kutta on (x, v) (refsim's `rk4`).

Physics is separate from the steppers (two `ti.func` accelerations): point masses under
gravity, linear drag f = -b v and springs to fixed anchors (f = -k (|d| - L0) u - c (v.u) u),
and hinged rods in generalized coordinates (theta'' = -(g/L) sin theta - (b/m) theta', the
angle mapped to the bob with refsim's hinge frame). Each body's motion is independent of the
others', so a step is a serial loop over bodies. The outermost loop of a kernel runs in
parallel: the time loop carries `ti.loop_config(serialize=True)`, so runs are
bit-reproducible. State and parameters are ndarray/argpack arguments and n is a runtime i32,
so no build or step recompiles anything.
No `from __future__ import annotations` here: taichi reads `ti.template()` annotations as objects.
"""
from .kernel_types import f64, i32, nd_f64, nd_i32, nd_vec3, ti, vec3

particles_t = ti.types.argpack(inv_m=nd_f64, gravity=vec3, drag=f64, spring_body=nd_i32,
                               spring_anchor=nd_vec3, spring_k=nd_f64, spring_rest=nd_f64,
                               spring_c=nd_f64, velocity_dependent=i32)
hinges_t = ti.types.argpack(g_over_l=nd_f64, drag_over_m=nd_f64, velocity_dependent=i32)


# -- physics: acceleration of element i at (x, v) ----------------------------------------------
@ti.func
def particle_accel(P: ti.template(), i, x, v):
    """Springs to fixed anchors (-k (|d| - L0) u - c (v.u) u), drag -b v, then f/m + g."""
    f = vec3(0.0, 0.0, 0.0)
    for s in range(P.spring_body.shape[0]):
        if P.spring_body[s] == i:
            d = x - P.spring_anchor[s]
            length = d.norm()
            u = vec3(0.0, 0.0, 0.0)
            if length > 0.0:
                u = d / length
            f += -(P.spring_k[s] * (length - P.spring_rest[s])) * u
            f -= P.spring_c[s] * v.dot(u) * u
    f -= P.drag * v
    return f * P.inv_m[i] + P.gravity


@ti.func
def hinge_accel(P: ti.template(), i, q, qd):
    """theta'' = -(g/L) sin theta - (b/m) theta' for rod i."""
    return -P.g_over_l[i] * ti.sin(q) - P.drag_over_m[i] * qd


# -- steppers: (x, v, a) -> (x, v, a) one step of h later; a is carried (Verlet) ---------------
@ti.func
def kick_drift(accel: ti.template(), P: ti.template(), i, x, v, a, h):
    a1 = accel(P, i, x, v)
    v1 = v + h * a1
    return x + h * v1, v1, a1


@ti.func
def velocity_verlet(accel: ti.template(), P: ti.template(), i, x, v, a, h):
    vh = v + (0.5 * h) * a
    x1 = x + h * vh
    a1 = accel(P, i, x1, vh)
    v1 = vh + (0.5 * h) * a1
    if P.velocity_dependent:
        a1 = accel(P, i, x1, v1)
        v1 = vh + (0.5 * h) * a1
    return x1, v1, a1


@ti.func
def rk4(accel: ti.template(), P: ti.template(), i, x, v, a, h):
    k1x, k1v = v, accel(P, i, x, v)
    k2x = v + (0.5 * h) * k1v
    k2v = accel(P, i, x + (0.5 * h) * k1x, k2x)
    k3x = v + (0.5 * h) * k2v
    k3v = accel(P, i, x + (0.5 * h) * k2x, k3x)
    k4x = v + h * k3v
    k4v = accel(P, i, x + h * k3x, k4x)
    x1 = x + (h / 6.0) * k1x + (h / 3.0) * k2x + (h / 3.0) * k3x + (h / 6.0) * k4x
    v1 = v + (h / 6.0) * k1v + (h / 3.0) * k2v + (h / 3.0) * k3v + (h / 6.0) * k4v
    return x1, v1, k1v


SYSTEMS = {"particles": (particle_accel, nd_vec3, particles_t),
           "hinges": (hinge_accel, nd_f64, hinges_t)}
STEPPERS = {"symplectic_euler": kick_drift, "velocity_verlet": velocity_verlet, "rk4": rk4}


# -- kernel factories ---------------------------------------------------------------------------
def advance_kernel(stepper, accel, state_t, pack_t):
    @ti.kernel
    def advance(x: state_t, v: state_t, a: state_t, P: pack_t, h: f64, n: ti.i32):
        ti.loop_config(serialize=True)  # the time loop is the outermost loop: keep it serial
        for _ in range(n):
            for i in range(x.shape[0]):
                x1, v1, a1 = stepper(accel, P, i, x[i], v[i], a[i], h)
                x[i], v[i], a[i] = x1, v1, a1
    return advance


def accel_kernel(accel, state_t, pack_t):
    @ti.kernel
    def start(x: state_t, v: state_t, a: state_t, P: pack_t):
        ti.loop_config(serialize=True)
        for i in range(x.shape[0]):
            a[i] = accel(P, i, x[i], v[i])
    return start


def system_kernels(system: str, integrator: str):
    """(start, advance): a(x0, v0) for the carried acceleration, and the time loop."""
    accel, state_t, pack_t = SYSTEMS[system]
    return (accel_kernel(accel, state_t, pack_t),
            advance_kernel(STEPPERS[integrator], accel, state_t, pack_t))
