"""First-order particle dynamics p' = u(p) as float64 taichi kernels: the affine fields
u = M (p - c) of `refsim.models.advection` (rigid vortex, quadratic descent) stepped by the
tableaux of `refsim.integrators.first_order` written out (explicit Euler, midpoint, Heun,
RK4) and implicit Euler ((I - h M) (p_1 - c) = p - c, the 3 x 3 inverse formed once per
launch). One kernel per stepper serves both fields (M and c are arguments), so no field
recompiles anything. Loops: particles outermost (parallel: independent tracers), each
particle's n steps serial inside it (bit-reproducible).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .kernel_types import f64, nd_vec3, ti, vec3

mat3 = ti.types.matrix(3, 3, f64)


@ti.func
def velocity(M, c, p):
    return M @ (p - c)


@ti.func
def explicit_euler(M, c, p, h):
    return p + h * velocity(M, c, p)


@ti.func
def midpoint(M, c, p, h):
    k1 = velocity(M, c, p)
    k2 = velocity(M, c, p + (0.5 * h) * k1)
    return p + h * k2


@ti.func
def heun(M, c, p, h):
    k1 = velocity(M, c, p)
    k2 = velocity(M, c, p + h * k1)
    return p + (0.5 * h) * k1 + (0.5 * h) * k2


@ti.func
def rk4(M, c, p, h):
    k1 = velocity(M, c, p)
    k2 = velocity(M, c, p + (0.5 * h) * k1)
    k3 = velocity(M, c, p + (0.5 * h) * k2)
    k4 = velocity(M, c, p + h * k3)
    return p + (h / 6.0) * k1 + (h / 3.0) * k2 + (h / 3.0) * k3 + (h / 6.0) * k4


STEPPERS = {"explicit_euler": explicit_euler, "midpoint": midpoint, "heun": heun, "rk4": rk4}


def affine_kernel(name):
    """The kernel advancing every particle n steps of h on u = M (p - c)."""
    if name == "implicit_euler":
        @ti.kernel
        def advance_implicit(p: nd_vec3, M: mat3, c: vec3, h: f64, n: ti.i32):
            step = (ti.Matrix.identity(f64, 3) - h * M).inverse()
            for i in range(p.shape[0]):
                pi = p[i]
                for _ in range(n):
                    pi = c + step @ (pi - c)
                p[i] = pi
        return advance_implicit
    stepper = STEPPERS[name]

    @ti.kernel
    def advance(p: nd_vec3, M: mat3, c: vec3, h: f64, n: ti.i32):
        for i in range(p.shape[0]):  # parallel over particles
            pi = p[i]
            for _ in range(n):  # the time loop of particle i, serial
                pi = stepper(M, c, pi, h)
            p[i] = pi
    return advance
