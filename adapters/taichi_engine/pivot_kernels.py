"""Pivoted rigid bodies (each turning about a fixed point, a ball joint to the world) as float64
taichi kernels of the model of `refsim.models.rigid_pivot`, so the two agree to round-off at
equal formulation and stepper.

Per body: q (unit quaternion (w, x, y, z), body to world) and w (world angular velocity) only:
the pivot fixes the centre of mass at anchor + R c (c: the centre of mass from the pivot, body
frame). Model, world frame:
    I_p w' + w x (I_p w) = (R c) x m g,   I_p = R I_pivot R^T,   q' = 1/2 (0, w) (x) q,
with I_pivot = I0 + m (|c|^2 1 - c c^T) (made once at build by refsim's `pivot_inertia`).
Evaluated as refsim's orthogonal formulations do, in the body frame:
    w' = R I_pivot^-1 (-(w_b x I_pivot w_b) + R^T tau),   w_b = R^T w,   tau = (R c) x m g.

Steppers (`ti.func`, state in registers), the free bodies' (`rigid_kernels`) on (q, w):
- "symplectic_euler": w_{k+1} = w_k + h w'(q_k, w_k), then q moved by the rotation vector
  h w_{k+1};
- "rk4": classical RK4 as Runge-Kutta-Munthe-Kaas, `rigid_kernels.rkmk4` with `pivot_accel`:
  stage slopes K_i = dexp^-1_{phi_i} W_i (quat_exp) or dcay^-1_{phi_i} W_i (quat_normalised,
  the Cayley map) at the stage increments phi_i = h sum_j a_ij K_j, refsim's explicit RK with
  the `dexpinv` hook of `PivotedRigidSystem`: order 4 on the rotation group.
Orientation updates: `rigid_kernels.rotate_by` (quat_exp, quat_normalised with the squared norms
removed multiplied into `norm_product`), selected by the argpack's runtime `normalise` flag.
Loops: bodies outermost (parallel), each body's n steps serial inside (bit-reproducible).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .kernel_types import f64, nd_f64, nd_vec3, ti
from .rigid_kernels import FORMULATIONS, nd_mat3, nd_vec4, quat_matrix, rkmk4, rotate_by

__all__ = ["FORMULATIONS", "STEPPERS", "pivot_kernels", "pivot_t"]

pivot_t = ti.types.argpack(inertia_pivot=nd_mat3, inertia_pivot_inv=nd_mat3,
                           com_offset=nd_vec3, weight=nd_vec3, normalise=ti.i32)


@ti.func
def pivot_accel(P: ti.template(), i, q, w):
    """w' = R I_pivot^-1 (-(w_b x I_pivot w_b) + R^T ((R c) x m g)), w_b = R^T w."""
    R = quat_matrix(q)
    Rt = R.transpose()
    torque = (R @ P.com_offset[i]).cross(P.weight[i])
    w_body = Rt @ w
    rhs = -w_body.cross(P.inertia_pivot[i] @ w_body) + Rt @ torque
    return R @ (P.inertia_pivot_inv[i] @ rhs)


@ti.func
def symplectic_euler(P: ti.template(), i, q, w, norm_product, h):
    w1 = w + h * pivot_accel(P, i, q, w)
    q1, norm1 = rotate_by(P, q, h * w1, norm_product)
    return q1, w1, norm1


@ti.func
def rk4(P: ti.template(), i, q, w, norm_product, h):
    """RKMK4 on (q, w) (see the module docstring)."""
    return rkmk4(P, i, q, w, norm_product, h, pivot_accel)


STEPPERS = {"symplectic_euler": symplectic_euler, "rk4": rk4}


def advance_kernel(stepper):
    """The kernel advancing every pivoted body n steps of h (bodies outermost)."""
    @ti.kernel
    def advance(q: nd_vec4, w: nd_vec3, norm_product: nd_f64, P: pivot_t, h: f64, n: ti.i32):
        for i in range(q.shape[0]):  # parallel over bodies (independent of each other)
            qi, wi, ni = q[i], w[i], norm_product[i]
            for _ in range(n):  # the time loop of body i, serial
                qi, wi, ni = stepper(P, i, qi, wi, ni, h)
            q[i], w[i], norm_product[i] = qi, wi, ni
    return advance


def pivot_kernels(integrator: str):
    """(start, advance) in the runtime's kernel convention: no start kernel."""
    if integrator not in STEPPERS:
        raise ValueError(f"taichi pivot integrator must be one of {list(STEPPERS)}, got "
                         f"{integrator!r}")
    return None, advance_kernel(STEPPERS[integrator])

