"""The FDM Poisson group's "p1" formulation (issue 26, case 8): P1 finite elements on the
grid's right triangles, lumped load, solve the same system as the 5-point stencil, so the
poisson_manufactured case's exact discrete solution is met by them too."""
import math

import numpy as np
import pytest

from refsim.registry import get_case, get_engine

ENGINE = get_engine("refsim")
CASE = get_case("poisson_manufactured")


def _scene(**overrides):
    return CASE.scene(CASE.validate(overrides))


def test_p1_is_offered_on_square_2d_grids_only():
    assert "p1" in ENGINE.formulations(_scene())
    assert "p1" not in ENGINE.formulations(_scene(dim=3, points=17))


def _p1_error(solution):
    p = CASE.validate({"points": 33, "solution": solution, "rtol": 1e-12})
    sim = ENGINE.build(CASE.scene(p), 1.0, "steady", "p1")
    sim.step(1)
    exact = CASE.exact_discrete(p)
    return np.abs(sim.observe()["grid.u"] - exact).max() / np.abs(exact).max()


# the P1 matrix is h^2 times the stencil to a few eps of its entries (coordinates from
# linspace); through cond(-L_h) <= 8 / (pi h)^2 ~ 830 at N = 33 and SuperLU's own round-off,
# 16 cond eps of max |u| bounds the difference
BOUND = 16 * 8.0 / (math.pi / 32) ** 2 * np.finfo(float).eps


@pytest.mark.parametrize("solution", ["sine", "polynomial"])
def test_p1_meets_the_exact_discrete_solution(solution):
    assert _p1_error(solution) <= BOUND


def test_a_load_lumped_0_1_percent_off_is_caught(monkeypatch):
    from refsim.models.fem.poisson import P1Poisson
    areas = P1Poisson.lumped_areas
    monkeypatch.setattr(P1Poisson, "lumped_areas", lambda self: 1.001 * areas(self))
    assert _p1_error("sine") > 1e6 * BOUND  # moves u by 1e-3 of itself


def test_p1_on_a_3d_grid_is_refused_with_the_reason():
    scene = _scene(dim=3, points=17)
    with pytest.raises(ValueError, match="formulation must be one of"):  # not offered there
        ENGINE.build(scene, 1.0, "steady", "p1")
