"""Expected errors of the named methods: the exact discrete solution of each refsim stepper on
a LINEAR system x'' = A x + B v (per unit mass; scalars for one mode), written from each
method's definition and its tableau, not from its code, so that a case can predict what a
correct implementation of the method must give at a dt, to round-off:

    z_k = O S(h)^k T z_0,   z = (x, v),

with S the step matrix on the method's own state, T the start map (x, v) -> state and O the
output map state -> (x, v). The methods:
- explicit Runge-Kutta from their Butcher tableaux (stages K_i = J (I + h sum_j a_ij K_j),
  S = I + h sum_i b_i K_i, J = [[0, I], [A, B]]): explicit_euler, midpoint, heun, rk2[:alpha],
  rk4, dopri5 (its fifth-order solution, fixed step);
- symplectic_euler (kick-drift), symplectic_euler_dk (drift-kick), velocity_verlet (its closing
  half kick repeated once when B != 0, as refsim's), stormer_verlet (state (x, d = x - x_prev),
  velocity from d / h and a half kick) and leapfrog (state (x, v_{-1/2}), velocity
  synchronised by a half kick), each as defined in Hairer, Lubich & Wanner, Geometric
  Numerical Integration (2006), ch. I.1 and VI.3, with refsim's one-correction rule for
  velocity-dependent forces;
- implicit_euler and baraff_witkin: (I - h J)^-1 (one Newton step is exact on linear forces;
  Baraff & Witkin 1998, sec. 4.1); implicit_midpoint: (I - h J / 2)^-1 (I + h J / 2).

An adaptive method has no step matrix (its dt is an output interval): `has_discrete_solution`
says which specs have one. Nothing here names a case or an engine.
"""
from __future__ import annotations

import numpy as np

from refsim.integrators.spec import IntegratorSpec
from refsim.integrators.tableaux import DOPRI5, EULER, HEUN, MIDPOINT, RK4, rk2_tableau

_TABLEAUX = {"explicit_euler": EULER, "midpoint": MIDPOINT, "heun": HEUN, "rk4": RK4,
             "dopri5": DOPRI5}
_OTHERS = ("symplectic_euler", "symplectic_euler_dk", "velocity_verlet", "stormer_verlet",
           "leapfrog", "implicit_euler", "baraff_witkin", "implicit_midpoint")


def _split(spec: str) -> tuple[str, str]:
    parsed = IntegratorSpec.parse(spec)
    return parsed.name, parsed.arg


def has_discrete_solution(spec: str) -> bool:
    """True when `spec` names a fixed-step refsim method this module writes out."""
    name, _ = _split(spec)
    return name in _TABLEAUX or name in _OTHERS or name == "rk2"


def _blocks(a, b):
    a = np.atleast_2d(np.asarray(a, float))
    b = np.zeros_like(a) if b is None else np.atleast_2d(np.asarray(b, float))
    return a, b, np.eye(len(a)), np.zeros_like(a)


def _tableau(name: str, arg: str):
    if name == "rk2":
        return rk2_tableau(float(arg) if arg else 2.0 / 3.0)
    return _TABLEAUX[name]


def _rk_matrix(tableau, jac, h) -> np.ndarray:
    eye = np.eye(len(jac))
    a, b = np.asarray(tableau.a, float), np.asarray(tableau.b, float)
    stages = []
    for i in range(len(b)):
        inner = eye + h * sum((a[i, j] * stages[j] for j in range(i)), np.zeros_like(eye))
        stages.append(jac @ inner)
    return eye + h * sum(b[i] * stages[i] for i in range(len(b)))


def maps(spec: str, a, b, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(T, S, O) of the named method on x'' = A x + B v at step h (module docstring)."""
    name, arg = _split(spec)
    a, b, eye, zero = _blocks(a, b)
    n = len(a)
    big = np.eye(2 * n)
    jac = np.block([[zero, eye], [a, b]])
    accel = np.hstack([a, b])  # a(x, v) as a row block acting on (x, v)
    take_x, take_v = np.hstack([eye, zero]), np.hstack([zero, eye])
    if name in _TABLEAUX or name == "rk2":
        return big, _rk_matrix(_tableau(name, arg), jac, h), big
    if name == "symplectic_euler":
        v1 = take_v + h * accel
        return big, np.vstack([take_x + h * v1, v1]), big
    if name == "symplectic_euler_dk":
        x1 = take_x + h * take_v
        return big, np.vstack([x1, take_v + h * (a @ x1 + b @ take_v)]), big
    if name == "velocity_verlet":
        return _velocity_verlet(a, b, eye, zero, accel, h)
    if name in ("implicit_euler", "baraff_witkin"):
        return big, np.linalg.inv(big - h * jac), big
    if name == "implicit_midpoint":
        return big, np.linalg.solve(big - 0.5 * h * jac, big + 0.5 * h * jac), big
    if name == "stormer_verlet":
        return _stormer(a, b, eye, zero, take_x, accel, h)
    if name == "leapfrog":
        return _leapfrog(a, b, eye, zero, take_x, accel, h)
    raise ValueError(f"integrator must be a fixed-step refsim method ({list(_TABLEAUX)}, rk2, "
                     f"{list(_OTHERS)}) for an exact discrete solution, got {spec!r}")


def _velocity_verlet(a, b, eye, zero, accel, h):
    """State (x, v, a) with the acceleration carried from the last evaluation: vh = v + h/2 a;
    x1 = x + h vh; a1 = a(x1, vh), v1 = vh + h/2 a1; when B != 0, a1 = a(x1, v1) and v1 again
    (a1 is the carried one)."""
    n = len(a)
    sx, sv, sa = (np.hstack([eye if i == j else zero for j in range(3)]) for i in range(3))
    vh = sv + 0.5 * h * sa
    x1 = sx + h * vh
    a1 = a @ x1 + b @ vh
    v1 = vh + 0.5 * h * a1
    if np.any(b):
        a1 = a @ x1 + b @ v1
        v1 = vh + 0.5 * h * a1
    start = np.vstack([np.eye(2 * n), accel])
    return start, np.vstack([x1, v1, a1]), np.hstack([np.eye(2 * n), np.zeros((2 * n, n))])


def _half_kick_velocity(a, b, x_rows, v_rows, h):
    """v = v_b + h/2 a(x, v_b), corrected once with v when B != 0 (refsim's rule)."""
    v = v_rows + 0.5 * h * (a @ x_rows + b @ v_rows)
    if np.any(b):
        v = v_rows + 0.5 * h * (a @ x_rows + b @ v)
    return v


def _stormer(a, b, eye, zero, take_x, accel, h):
    """State (x, d): d0 = h v0 - h^2/2 a(x0, v0); v = d / h + h/2 a(x, d / h) (corrected);
    d1 = d + h^2 a(x, v), x1 = x + d1."""
    start = np.vstack([take_x, h * np.hstack([zero, eye]) - 0.5 * h * h * accel])
    sx, sd = np.hstack([eye, zero]), np.hstack([zero, eye])
    v = _half_kick_velocity(a, b, sx, sd / h, h) if np.any(b) else sd / h
    d1 = sd + h * h * (a @ sx + b @ v)
    step = np.vstack([sx + d1, d1])
    out = np.vstack([sx, _half_kick_velocity(a, b, sx, sd / h, h)])
    return start, step, out


def _leapfrog(a, b, eye, zero, take_x, accel, h):
    """State (x, v_{-1/2}): start v0 - h/2 a(x0, v0); v = sync; vm1 = vm + h a(x, v);
    x1 = x + h vm1; output v = vm + h/2 a(x, vm) (corrected)."""
    start = np.vstack([take_x, np.hstack([zero, eye]) - 0.5 * h * accel])
    sx, sv = np.hstack([eye, zero]), np.hstack([zero, eye])
    sync = _half_kick_velocity(a, b, sx, sv, h)
    v = sync if np.any(b) else sv
    vm1 = sv + h * (a @ sx + b @ v)
    return start, np.vstack([sx + h * vm1, vm1]), np.vstack([sx, sync])


def discrete_solution(spec: str, a, b, x0, v0, h: float, steps) -> tuple[np.ndarray, np.ndarray]:
    """(x_k, v_k) of the named method after each k in `steps`, from (x0, v0), on
    x'' = A x + B v: shapes (len(steps), n). Powers by repeated squaring of S (exact
    matrix products, no eigen-decomposition: defective S at critical damping is fine)."""
    t_map, s_map, o_map = maps(spec, a, b, h)
    z0 = t_map @ np.concatenate([np.atleast_1d(np.asarray(x0, float)),
                                 np.atleast_1d(np.asarray(v0, float))])
    steps = np.asarray(steps, int)
    out = np.empty((len(steps), o_map.shape[0]))
    order = np.argsort(steps)
    z, done = z0, 0
    for i in order:  # one pass over the sorted sample steps: S^(k_i - k_{i-1}) each
        z = np.linalg.matrix_power(s_map, int(steps[i]) - done) @ z
        done = int(steps[i])
        out[i] = o_map @ z
    n = len(np.atleast_1d(x0))
    return out[:, :n], out[:, n:]


def oscillator_rates(spec: str, y: float) -> tuple[float, float]:
    """(phase error, log amplitude factor) per step of the named method on the undamped
    oscillator x'' = -w^2 x at y = w h: the principal eigenvalue lambda of S (the one with
    arg in (0, pi)) gives arg(lambda) - y and ln|lambda|. After n steps from rest at A the
    method's solution is, up to the O(y^p) difference of its eigenvectors from the exact ones,
    A |lambda|^n cos(n arg lambda): the global error of a nonlinear oscillation of frequency w
    scales with these rates times the case's sensitivity. NaN when S has no complex pair
    (y beyond the method's oscillatory range)."""
    _, s_map, _ = maps(spec, -1.0, None, y)
    values = np.linalg.eigvals(s_map)
    upper = values[(values.imag > 0)]
    if len(upper) == 0:
        return float("nan"), float("nan")
    lam = upper[np.argmax(np.abs(upper))]
    return float(np.angle(lam) - y), float(np.log(np.abs(lam)))
