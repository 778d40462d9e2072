"""refsim.models.advection: the affine fields, the flow and the exact discrete solution."""
import numpy as np
import pytest

from refsim.integrators.first_order import FIRST_ORDER, get_first_order
from refsim.models.advection import (AffineField, axial_radius, discrete_positions,
                                     exact_positions, vortex_radius_factor, vortex_step_angle)
from refsim.scene.velocity_field import VelocityField

EPS = np.finfo(float).eps
VORTEX = VelocityField("rigid_vortex", centre=(0.3, -0.2, 0.1), omega=(1 / 3, 2 / 3, 2 / 3))


def test_velocity_field_validation():
    with pytest.raises(ValueError, match="velocity_field.field"):
        VelocityField("swirl")
    with pytest.raises(ValueError, match="velocity_field.rates"):
        VelocityField("quadratic_descent", rates=(1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="velocity_field.omega"):
        VelocityField("rigid_vortex", omega=(0, 0, 0))


def test_vortex_velocity_is_the_cross_product():
    p = np.random.default_rng(2).normal(size=(7, 3))
    field = AffineField(VORTEX.matrix(), VORTEX.centre)
    want = np.cross(VORTEX.omega, p - np.array(VORTEX.centre))
    assert np.max(np.abs(field.velocity(0.0, p) - want)) <= 8 * EPS * np.max(np.abs(p))


def test_flow_keeps_the_radius():
    p0 = np.random.default_rng(2).normal(size=(7, 3))
    x = exact_positions(VORTEX.matrix(), np.array(VORTEX.centre), p0, [0.0, 1.0, 5.0])
    r = axial_radius(x, np.array(VORTEX.centre), VORTEX.omega)
    assert np.max(np.abs(r - r[0])) <= 32 * EPS * np.max(r)


@pytest.mark.parametrize("name", FIRST_ORDER)
def test_discrete_radius_and_phase(name):
    """The discrete solution's radius after k steps is r0 |R(iy)|^k and its turn k arg R(iy)
    (to a few eps per step of round-off in the modal evaluation)."""
    stepper, h, k = get_first_order(name), 0.1, 60
    centre, axis = np.array(VORTEX.centre), np.array(VORTEX.omega)
    p0 = centre + np.array([[0.5, -0.4, 0.1]])
    x = discrete_positions(stepper, VORTEX.matrix(), centre, p0, h, [0, k])
    r = axial_radius(x[:, 0], centre, axis)
    growth = vortex_radius_factor(stepper, h * np.linalg.norm(axis))
    assert abs(r[1] / r[0] - growth ** k) <= 64 * EPS * growth ** k
    rel0, rel1 = x[0, 0] - centre, x[1, 0] - centre
    perp0, perp1 = (v - (v @ axis) * axis for v in (rel0, rel1))
    turn = np.arctan2(np.cross(perp0, perp1) @ axis, perp0 @ perp1)
    want = np.angle(np.exp(1j * k * vortex_step_angle(stepper, h * np.linalg.norm(axis))))
    assert abs(turn - want) <= 64 * EPS * k
