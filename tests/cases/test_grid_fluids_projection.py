"""The projection case's own checks: u_df is exactly divergence-free (a discrete curl of a
dyadic stream function), the exact discrete answer (p = phi - mean phi, u = u_df), every
solver within the stated bound, and a gradient of the wrong sign caught by it."""
import numpy as np
import pytest

from refsim.models.grid_fluid.mac import divergence
from refsim.models.grid_fluid.projection import ALL_METHODS, PressureSystem
from refsim.registry import get_case

CASE = get_case("projection_manufactured")


@pytest.mark.parametrize("variant", ["walls", "periodic", "walls_64"])
def test_u_df_is_a_discrete_curl_with_exactly_zero_divergence(variant):
    p = CASE.variant_params(variant)
    u, v = CASE.divergence_free(p)
    assert np.array_equal(divergence(u, v, CASE.grid(p).h), np.zeros(CASE.grid(p).cells))
    if p["sides"] == "wall":  # no normal velocity on the walls
        assert np.all(u[[0, -1]] == 0) and np.all(v[:, [0, -1]] == 0)
    else:
        assert np.array_equal(u[0], u[-1]) and np.array_equal(v[:, 0], v[:, -1])
    assert np.abs(u).max() > 0.1 and np.abs(v).max() > 0.1  # a real flow, not zero


def _project(p, method, negate_gradient=False):
    grid = CASE.grid(p)
    system = PressureSystem(grid)
    if negate_gradient:  # a planted defect: G of the wrong sign (A = G^T G unchanged)
        system.G = -system.G
    u, v = CASE.initial(p)
    return system.project(u, v, 1.0, method, p["rtol"])


def _rms_error(p, un, vn):
    u, v = CASE.divergence_free(p)
    return float(np.sqrt(np.mean(np.concatenate([(un - u).ravel(), (vn - v).ravel()]) ** 2)))


@pytest.mark.parametrize("method", ALL_METHODS)
@pytest.mark.parametrize("variant", ["walls", "periodic"])
def test_every_solver_returns_u_df_within_the_bound(variant, method):
    p = CASE.variant_params(variant)
    un, vn, pressure, info = _project(p, method)
    bound, _ = CASE.tolerance(p, "steady", 0, 1.0)
    assert _rms_error(p, un, vn) <= bound
    # the exact discrete pressure: phi - mean(phi); error <= ||r|| / lambda_min
    phi = CASE.potential(p)
    assert np.max(np.abs(pressure - (phi - phi.mean()))) <= \
        p["rtol"] * CASE.rhs_norm(p) / CASE.lambda_min(p) + 1e-12
    assert info["divergence"] <= p["rtol"] * CASE.rhs_norm(p)


def test_direct_solves_to_round_off():
    """SuperLU's answer is u_df to the rounding bound alone (no solver term needed)."""
    p = CASE.variant_params("walls")
    un, vn, _, info = _project(p, "direct")
    assert _rms_error(p, un, vn) <= CASE.roundoff(p)[0]
    assert info["divergence"] / np.abs(divergence(*CASE.initial(p), CASE.grid(p).h)).max() \
        < 1e-12


@pytest.mark.parametrize("variant", ["walls", "periodic"])
def test_a_gradient_of_the_wrong_sign_is_caught(variant):
    p = CASE.variant_params(variant)
    un, vn, _, _ = _project(p, "direct", negate_gradient=True)
    bound, _ = CASE.tolerance(p, "steady", 0, 1.0)
    assert _rms_error(p, un, vn) > 1e6 * bound
