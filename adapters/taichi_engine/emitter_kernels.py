"""The emitter's ballistic update as one float64 taichi kernel: every slot under the constant
acceleration g (refsim.models.emitter; the "as_printed" formulation passes g = 0), stepped by
the arithmetic of refsim's steppers on a ParticleSystem whose acceleration is exactly g:

- SYMPLECTIC_EULER (kick-drift): v += h g; x += h v;
- VELOCITY_VERLET: vh = v + h/2 g; x += h vh; v = vh + h/2 g (the carried a is g at every
  step, spawn included: no array carries it);
- EXPLICIT_RK: a chained explicit tableau (stage i couples to stage i - 1 only: Euler,
  midpoint, Heun, Ralston, RK4) as runtime arrays a_next, b; slopes K_i = V_i, A_i = g, and
  x_1 = x + sum_i (b_i h) K_i summed left to right as refsim's `ExplicitRK` does.
The slots are independent, so the loop over slots is the outer one (each slot's steps serial
inside it): no step's result depends on the thread count. Births are events of one launch:
the host lists, for the launch's n boundaries, each new particle's slot, boundary and spawn
state (refsim's schedule and spawn_states), and the kernel writes them into the slot after
that boundary's step. Removals need no kernel work (a free slot keeps being stepped; only
the host's id table marks it free). State and events are numpy arrays handed to the kernel
(taichi reads and writes them in place on the CPU: no copy to or from taichi ndarrays).
No `from __future__ import annotations` here: taichi reads the annotations as objects.
"""
from .kernel_types import f64, i32, nd_f64, nd_i32, nd_vec3, ti, vec3

ballistic_t = ti.types.argpack(g=vec3, rk_a=nd_f64, rk_b=nd_f64, stages=i32)
SYMPLECTIC_EULER, VELOCITY_VERLET, EXPLICIT_RK = 0, 1, 2


@ti.func
def chained_rk(P: ti.template(), x, v, h):
    """One explicit RK step under constant g (the stage positions X_i are never read: the
    acceleration does not depend on them)."""
    sx, sv, vs = x, v, v
    for k in range(P.stages):
        hb = P.rk_b[k] * h
        sx = sx + hb * vs
        sv = sv + hb * P.g
        if k < P.stages - 1:
            vs = v + (P.rk_a[k] * h) * P.g
    return sx, sv


@ti.func
def one_step(P: ti.template(), x, v, h, method):
    if method == SYMPLECTIC_EULER:
        v = v + h * P.g
        x = x + h * v
    elif method == VELOCITY_VERLET:
        vh = v + (0.5 * h) * P.g
        x = x + h * vh
        v = vh + (0.5 * h) * P.g
    else:
        x, v = chained_rk(P, x, v, h)
    return x, v


@ti.kernel
def advance_emitter(x: nd_vec3, v: nd_vec3, P: ballistic_t, h: f64, n: ti.i32,
                    method: ti.i32, first: nd_i32, when: nd_i32, x0: nd_vec3, v0: nd_vec3):
    """n steps of h of stepper `method` for every slot, with the births of the n boundaries:
    slot i's are events first[i] .. first[i + 1] - 1 (in boundary order), event e puts the
    spawn state (x0[e], v0[e]) into the slot at boundary when[e] (1 .. n, after that step)."""
    for i in range(x.shape[0]):
        xi, vi = x[i], v[i]
        e = first[i]
        for s in range(n):
            xi, vi = one_step(P, xi, vi, h, method)
            if e < first[i + 1]:  # noqa: SIM102 (taichi's `and` does not short-circuit:
                if when[e] == s + 1:  # when[e] must not be read past the slot's events)
                    xi, vi = x0[e], v0[e]
                    e += 1
        x[i], v[i] = xi, vi
