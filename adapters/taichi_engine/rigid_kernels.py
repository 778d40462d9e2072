"""Free rigid bodies (Newton-Euler, world frame) as float64 taichi kernels: the model of
common13 (issue 13) that refsim's numpy rigid model follows, and the same steppers, so the two
agree to round-off at equal formulation and stepper.

Per body: x (world COM), v (world), q (unit quaternion (w, x, y, z), body to world), w (world
angular velocity). Forces: gravity only (m v' = m g; no torque about the COM), so
    v' = g,   I_w w' + w x (I_w w) = 0,   I_w = R(q) I0 R(q)^T,   q' = 1/2 (0, w) (x) q.
The gyroscopic term is evaluated in the body frame, w x (I_w w) = R (w_b x I0 w_b) with
w_b = R^T w, so w' = -R I0^-1 (w_b x I0 w_b): the same equation as the world-frame form (the
rotation R commutes with the cross product), one 3x3 inverse per body made once at build.

Steppers (`ti.func`, one signature, state in registers):
- "symplectic_euler": v, w first from the state at k (w_{k+1} = w_k + h w'(q_k, w_k)), then
  x_{k+1} = x_k + h v_{k+1} and the orientation moved by the rotation vector h w_{k+1};
- "rk4": classical RK4 as Runge-Kutta-Munthe-Kaas (RKMK4; Munthe-Kaas 1998, Iserles et al.,
  Acta Numerica 2000, sec. 4), the method of refsim's explicit RK with the `dexpinv` hook
  (refsim/integrators/explicit_rk.py, refsim/models/rigid_orientation.py), `rkmk4` below:
      K_1 = w,  A_1 = w'(q, w),   for i = 2..4:  phi_i = h sum_j a_ij K_j,
      W_i = w + h sum_j a_ij A_j,  K_i = dmap^-1_{phi_i} W_i,  A_i = w'(q (+) phi_i, W_i),
      q_1 = q (+) h sum_i b_i K_i,  w_1 = w + h sum_i b_i A_i,
  q (+) phi the formulation's update below and dmap^-1 the inverse differential of its map
  phi -> q (+) phi: dexp^-1 under quat_exp, dcay^-1 (the Cayley map) under quat_normalised
  (`stage_slope`). The correction keeps RK4's order 4 on the rotation group (without it,
  "RKMK-lite", the dropped commutators leave order 2). Positions by plain addition,
  x_1 = x + h v + h^2/2 g (exact under constant gravity; refsim's stage sum, to round-off).
Orientation updates (the formulation, a runtime i32 in the argpack, no recompilation):
- quat_exp (0): q <- exp(a / 2) (x) q, a the rotation vector, exp of a pure quaternion
  (cos|b|, sin|b| b / |b|) with b = a / 2;
- quat_normalised (1): q <- normalise(q + 1/2 (0, a) (x) q) (= cay(a) (x) q, the Cayley map);
  the squared norm removed by each normalisation is multiplied into `norm_product` (per body),
  so norm_product - 1 is the cumulative drift that the normalisation hid (exact discrete value
  at constant w: (1 + h^2 |w|^2 / 4)^k). RK4's stage orientations leave it alone: only the
  accepted update multiplies it in, as refsim's fifth column does.
Loops: bodies are independent, so the outermost loop runs over bodies (parallel, over
`cpu_max_num_threads` threads) and each body's time loop runs inside it, serially, with the
state in registers: one launch advances n steps of every body, bit-reproducible at any thread
count (no body reads another's state).
No `from __future__ import annotations` here: taichi reads annotations as objects.
"""
from refsim.models.rigid_orientation import SMALL_ANGLE

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


# -- RK4 on the rotation group (RKMK4): the maps' inverse differentials, the stage loop ------------
@ti.func
def dexp_inverse(phi, a):
    """dexp^-1_phi a on so(3) as 3-vectors: a - 1/2 phi x a + (1 - (t/2) cot(t/2)) / t^2
    phi x (phi x a), t = |phi|; the limit 1/12 below refsim's SMALL_ANGLE (its closed form
    and guard, rigid_orientation.dexp_inverse: the coefficient's round-off eps / t^2 meets a
    term of size t^2 |a|, eps |a| overall)."""
    angle = phi.norm()
    coef = 1.0 / 12.0
    if angle > SMALL_ANGLE:
        half = 0.5 * angle
        coef = (1.0 - half / ti.tan(half)) / (4.0 * half * half)
    phi_x_a = phi.cross(a)
    return a - 0.5 * phi_x_a + coef * phi.cross(phi_x_a)


@ti.func
def dcay_inverse(phi, a):
    """dcay^-1_phi a = a - 1/2 phi x a + 1/4 phi (phi . a): the inverse differential of the
    Cayley map that quat_normalised's update is (rigid_orientation.dcay_inverse)."""
    return a - 0.5 * phi.cross(a) + (0.25 * phi) * phi.dot(a)


@ti.func
def stage_slope(P: ti.template(), phi, a):
    """K = dmap^-1_phi a for the formulation of P: dcay^-1 (quat_normalised), else dexp^-1."""
    k = a
    if P.normalise:
        k = dcay_inverse(phi, a)
    else:
        k = dexp_inverse(phi, a)
    return k


@ti.func
def turned(P: ti.template(), q, phi):
    """A stage orientation q (+) phi (its normalisation's squared norm not recorded)."""
    return rotate_by(P, q, phi, 1.0)[0]


@ti.func
def rkmk4(P: ti.template(), i, q, w, norm_product, h, accel: ti.template()):
    """One RKMK4 step of (q, w) for body i (module docstring), w' = accel(P, i, q, w); the
    products with h as refsim forms them (h a_ij, h b_i: (1/6) h, not h / 6), the sums in its
    order. Returns (q_1, w_1, norm_product_1)."""
    half, sixth, third = 0.5 * h, (1.0 / 6.0) * h, (1.0 / 3.0) * h
    A1 = accel(P, i, q, w)  # K_1 = w
    phi2, W2 = half * w, w + half * A1
    K2 = stage_slope(P, phi2, W2)
    A2 = accel(P, i, turned(P, q, phi2), W2)
    phi3, W3 = half * K2, w + half * A2
    K3 = stage_slope(P, phi3, W3)
    A3 = accel(P, i, turned(P, q, phi3), W3)
    phi4, W4 = h * K3, w + h * A3
    K4 = stage_slope(P, phi4, W4)
    A4 = accel(P, i, turned(P, q, phi4), W4)
    turn = sixth * w + third * K2 + third * K3 + sixth * K4
    w1 = w + sixth * A1 + third * A2 + third * A3 + sixth * A4
    q1, norm1 = rotate_by(P, q, turn, norm_product)
    return q1, w1, norm1


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
    """RKMK4 on (q, w) (`rkmk4`); v' = g is constant, so the stage sum of the positions is
    x + h v + h^2/2 g, written out."""
    q1, w1, norm1 = rkmk4(P, i, q, w, norm_product, h, angular_accel)
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
