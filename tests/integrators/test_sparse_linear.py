"""The sparse implicit steppers are the named methods: on a grid mode they multiply by their
stability function (first order) or by the closed-form 2x2 step of the method (second order),
and the explicit theta step (FTCS) is u + h A u."""
import numpy as np
import pytest

from refsim_cases.grid_evolution._modes import ModeGrid
from refsim_cases.grid_evolution.wave_mode import step_matrix
from refsim.integrators.sparse_linear import first_order_implicit, second_order_implicit
from refsim.models.grid_pde import GridPDE
from refsim.scene import Grid

EPS = np.finfo(float).eps


def _grid(model, coefficient):
    g = ModeGrid({"dim": 2, "cells": 10, "k": 2, "boundary": "dirichlet"})
    fields = {"u": g.mode()} if model == "diffusion" else {"u": g.mode(),
                                                          "v": np.zeros(g.shape)}
    return g, g.scene(model, fields, {coefficient: 0.7}).part(Grid)


@pytest.mark.parametrize("name", ["explicit_euler", "implicit_euler", "crank_nicolson"])
def test_theta_methods_multiply_a_mode_by_their_stability_function(name):
    g, grid = _grid("diffusion", "diffusivity")
    system, stepper, h = GridPDE(grid), first_order_implicit(name), 0.2 * g.h ** 2
    u = g.mode()
    for _ in range(25):
        u = stepper.step(system, 0.0, u, h)
    factor = stepper.stability(h * 0.7 * g.discrete_eigenvalue()).real ** 25
    # 25 steps, each rounding by a few eps (the solve's backward error on a matrix of
    # condition <= 1 + 8 r)
    assert np.max(np.abs(u - factor * g.mode())) <= 25 * 20 * EPS


def test_explicit_theta_step_is_u_plus_h_a_u():
    g, grid = _grid("diffusion", "diffusivity")
    system, h = GridPDE(grid), 0.1 * g.h ** 2
    u = np.random.default_rng(2).standard_normal(g.shape)
    one = first_order_implicit("explicit_euler").step(system, 0.0, u, h)
    assert np.allclose(one, u + h * system.velocity(0.0, u), rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", ["implicit_euler", "implicit_midpoint"])
def test_second_order_implicit_steps_are_the_closed_form_methods_on_a_mode(name):
    g, grid = _grid("wave", "wave_speed")
    system, stepper, h = GridPDE(grid), second_order_implicit(name), 3 * g.h
    omega = 0.7 * np.sqrt(-g.discrete_eigenvalue())
    state = stepper.start(system, 0.0, g.mode(), np.zeros(g.shape), h)
    for _ in range(30):
        state = stepper.step(system, 0.0, state, h)
    m = np.linalg.matrix_power(step_matrix(name, omega, h), 30)
    assert np.max(np.abs(state[0] - m[0, 0] * g.mode())) <= 30 * 50 * EPS
    assert np.max(np.abs(state[1] - m[1, 0] * g.mode())) <= 30 * 50 * EPS * omega
