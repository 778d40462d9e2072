"""Free rigid bodies (Newton-Euler, world frame) as float64 taichi kernels: the model of
common13 (issue 13) that refsim's numpy rigid model follows, so the two agree to round-off at
equal formulation and stepper.

Per body: x (world COM), v (world), q (unit quaternion (w, x, y, z), body to world), w (world
angular velocity). Forces: gravity only (m v' = m g; no torque about the COM), so
    v' = g,   I_w w' + w x (I_w w) = 0,   I_w = R(q) I0 R(q)^T,   q' = 1/2 (0, w) (x) q.
The gyroscopic term is evaluated in the body frame, w x (I_w w) = R (w_b x I0 w_b) with
w_b = R^T w, so w' = -R I0^-1 (w_b x I0 w_b): the same equation as the world-frame form (the
rotation R commutes with the cross product), one 3x3 inverse per body made once at build.

Steppers (`ti.func`, one signature, state in registers):
- "symplectic_euler": v, w first from the state at k (w_{k+1} = w_k + h w'(q_k, w_k)), then
  x_{k+1} = x_k + h v_{k+1} and the orientation moved by the rotation vector h w_{k+1};
- "rk4": classical 4-stage RK in the "RKMK-lite" retraction form of refsim's explicit RK
  (refsim/integrators/explicit_rk.py): stage orientations Q_i = exp(h sum_j a_ij W_j / 2) (x) q
  from the base point, q_1 = exp(h sum_i b_i W_i / 2) (x) q (no dexp^-1 correction);
  positions by plain addition (exact under constant gravity).
Orientation updates (the formulation, a runtime i32 in the argpack, no recompilation):
- quat_exp (0): q <- exp(a / 2) (x) q, a the rotation vector, exp of a pure quaternion
  (cos|b|, sin|b| b / |b|) with b = a / 2;
- quat_normalised (1): q <- normalise(q + 1/2 (0, a) (x) q); the squared norm removed by each
  normalisation is multiplied into `norm_product` (per body), so norm_product - 1 is the
  cumulative drift that the normalisation hid (exact discrete value at constant w:
  (1 + h^2 |w|^2 / 4)^k).
Loops: bodies are independent, so the outermost loop runs over bodies (parallel, over
`cpu_max_num_threads` threads) and each body's time loop runs inside it, serially, with the
state in registers: one launch advances n steps of every body, bit-reproducible at any thread
count (no body reads another's state).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from .kernel_types import f64, i32, nd_f64, nd_vec3, ti, vec3

vec4 = ti.types.vector(4, f64)
mat3 = ti.types.matrix(3, 3, f64)
nd_vec4 = ti.types.ndarray(dtype=vec4, ndim=1)
nd_mat3 = ti.types.ndarray(dtype=mat3, ndim=1)

FORMULATIONS = ("quat_exp", "quat_normalised")  # index = the argpack's `normalise` flag
rigid_t = ti.types.argpack(inertia0=nd_mat3, inertia0_inv=nd_mat3, gravity=vec3,
                           normalise=i32)


# -- quaternion algebra -------------------------------------------------------------------------
@ti.func
def quat_mul(a, b):
    """Hamilton product a (x) b, scalar first."""
    return vec4(a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])


@ti.func
def quat_matrix(q):
    """R(q) rotating body vectors to world (q taken as unit)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return mat3([[1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
                 [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
                 [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)]])


@ti.func
def quat_exp_half(a):
    """exp of the pure quaternion (0, a / 2): (cos|b|, sin|b| b / |b|), b = a / 2."""
    b = 0.5 * a
    angle = b.norm()
    sinc = 1.0
    if angle > 0.0:
        sinc = ti.sin(angle) / angle
    return vec4(ti.cos(angle), sinc * b[0], sinc * b[1], sinc * b[2])


@ti.func
def rotate_by(P: ti.template(), q, a, norm_product):
    """q moved by the rotation vector a (world frame, on the left) in the formulation of P;
    returns (q', norm_product') (norm_product unchanged under quat_exp)."""
    q1 = q
    if P.normalise:
        q_euler = q + 0.5 * quat_mul(vec4(0.0, a[0], a[1], a[2]), q)
        norm2 = q_euler.dot(q_euler)
        q1 = q_euler / ti.sqrt(norm2)
        norm_product *= norm2
    else:
        q1 = quat_mul(quat_exp_half(a), q)
    return q1, norm_product


# -- physics --------------------------------------------------------------------------------------
@ti.func
def angular_accel(P: ti.template(), i, q, w):
    """w' = -I_w^-1 (w x I_w w) = -R I0^-1 (w_b x I0 w_b), w_b = R^T w (torque-free)."""
    R = quat_matrix(q)
    w_body = R.transpose() @ w
    gyro = w_body.cross(P.inertia0[i] @ w_body)
    return -(R @ (P.inertia0_inv[i] @ gyro))


# -- steppers: one step of h for body i ---------------------------------------------------------
@ti.func
def symplectic_euler(P: ti.template(), i, x, v, q, w, norm_product, h):
    w1 = w + h * angular_accel(P, i, q, w)
    v1 = v + h * P.gravity
    q1, norm1 = rotate_by(P, q, h * w1, norm_product)
    return x + h * v1, v1, q1, w1, norm1


@ti.func
def rk4(P: ti.template(), i, x, v, q, w, norm_product, h):
    """RKMK-lite classical RK4 (stage orientations from the base point q; see the module
    docstring); v' = g is constant, so every stage velocity slope is g."""
    W1 = w
    A1 = angular_accel(P, i, q, W1)
    W2 = w + (0.5 * h) * A1
    A2 = angular_accel(P, i, rotate_by(P, q, (0.5 * h) * W1, 1.0)[0], W2)
    W3 = w + (0.5 * h) * A2
    A3 = angular_accel(P, i, rotate_by(P, q, (0.5 * h) * W2, 1.0)[0], W3)
    W4 = w + h * A3
    A4 = angular_accel(P, i, rotate_by(P, q, h * W3, 1.0)[0], W4)
    turn = (h / 6.0) * W1 + (h / 3.0) * W2 + (h / 3.0) * W3 + (h / 6.0) * W4
    w1 = w + (h / 6.0) * A1 + (h / 3.0) * A2 + (h / 3.0) * A3 + (h / 6.0) * A4
    q1, norm1 = rotate_by(P, q, turn, norm_product)
    x1 = x + h * v + (0.5 * h * h) * P.gravity
    return x1, v + h * P.gravity, q1, w1, norm1


STEPPERS = {"symplectic_euler": symplectic_euler, "rk4": rk4}


def advance_kernel(stepper):
    """The kernel advancing every body n steps of h (bodies outermost, time loop inside)."""
    @ti.kernel
    def advance(x: nd_vec3, v: nd_vec3, q: nd_vec4, w: nd_vec3, norm_product: nd_f64,
                P: rigid_t, h: f64, n: ti.i32):
        for i in range(x.shape[0]):  # parallel over bodies (independent of each other)
            xi, vi, qi, wi, ni = x[i], v[i], q[i], w[i], norm_product[i]
            for _ in range(n):  # the time loop of body i, serial
                xi, vi, qi, wi, ni = stepper(P, i, xi, vi, qi, wi, ni, h)
            x[i], v[i], q[i], w[i], norm_product[i] = xi, vi, qi, wi, ni
    return advance


def rigid_kernels(integrator: str):
    """(start, advance) in the runtime's kernel convention: no start kernel (nothing carried)."""
    if integrator not in STEPPERS:
        raise ValueError(f"taichi rigid integrator must be one of {list(STEPPERS)}, got "
                         f"{integrator!r}")
    return None, advance_kernel(STEPPERS[integrator])
