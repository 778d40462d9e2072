"""Butcher tableaux are data: check they are consistent and reach their declared order."""
import numpy as np
import pytest

from refsim.integrators import DOPRI5, EULER, HEUN, MIDPOINT, RK4, rk2_tableau

TABLEAUX = {"euler": EULER, "midpoint": MIDPOINT, "heun": HEUN, "ralston": rk2_tableau(2 / 3),
            "rk4": RK4, "dopri5": DOPRI5}


@pytest.mark.parametrize("name", TABLEAUX)
def test_weights_sum_to_one_and_rows_sum_to_c(name):
    a, b, c = TABLEAUX[name].arrays()
    assert b.sum() == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(a.sum(axis=1), c, atol=1e-15)
    assert np.all(np.triu(a) == 0), "explicit methods have strictly lower-triangular A"


def test_embedded_weights_sum_to_one():
    assert np.sum(DOPRI5.b_low) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("name", TABLEAUX)
def test_weights_meet_the_linear_order_conditions_to_declared_order(name):
    """The stability polynomial matches exp(z) through z^p: sum b A^(k-1) 1 = 1/k! (k <= p),
    the conditions any method of order p must meet on linear problems."""
    tab = TABLEAUX[name]
    a, b, _ = tab.arrays()
    term = np.ones(len(b))
    for k in range(1, tab.order + 1):
        assert b @ term == pytest.approx(1.0 / np.prod(np.arange(1, k + 1)), rel=1e-13)
        term = a @ term


def test_rk2_tableau_refuses_alpha_zero():
    with pytest.raises(ValueError, match="alpha"):
        rk2_tableau(0.0)
