"""mujoco's rolling group on the rolling_disc case: s(t) against the exact a t^2 / 2 within the
case's tolerance (split step a t h / 2, soft-contact radius, round-off), rolling residual and
spin. Rows that exceed it and that no derivation bounds are xfail(strict) with the numbers."""
import numpy as np
import pytest

from refsim_cases.rigid.rolling_disc import CASE, observed_errors
from refsim import registry

pytest.importorskip("mujoco")
ENGINE = registry.get_engine("mujoco")
INTEGRATOR = "symplectic_euler"

# slipping: MuJoCo's sliding contact (d = 0.9999, elliptic or pyramidal cone, any impratio,
# noslip) pushes the disc up: it hops (gap up to 0.7 mm, contact lost), s(1) err 2.035e-3 at
# dt = 1 ms, 1.003 x the split error a t h / 2 = 2.028e-3: inside the case's bound, which
# carries a stated safety factor 2 for the contact's onset (cases/rigid/rolling_disc.py);
# spin off by 0.22 rad/s.
XFAIL: dict = {}


def test_rk4_rolls_to_the_contact_compliance():
    """RK4 integrates the constant acceleration exactly: what is left (measured 2.5e-8 m at
    1 ms) is the near-hard contact's creep, far inside the soft-contact bound."""
    p = CASE.variant_params("disc")
    err, tol, _ = run(p, 2e-3, "rk4")
    assert err["s"] <= tol and err["s"] < 1e-6


@pytest.mark.parametrize("variant", ["disc", "hoop"])
def test_rk4_bound_is_the_stated_sink_and_creep_within_100x(variant):
    """The soft-contact term with MuJoCo's sink factor (1 - d) / d = 1e-4 (impedance 0.9999)
    and its soft friction's creep: the bound sits 4.6..42 x above the error over 4..0.5 ms
    (measured), where the plain spring's sink (factor 1) put it 1e4..6e5 x above."""
    p = CASE.variant_params(variant)
    for dt in (4e-3, 1e-3, 5e-4):
        err, tol, why = run(p, dt, "rk4")
        assert err["s"] <= tol <= 100 * err["s"], (dt, err["s"], tol)
        assert "sink factor f = 0.0001" in why and "creep" in why


def run(p, dt, integrator=INTEGRATOR):
    """Errors (max over every step of 1 s) of s, residual, spin; the case's tolerance."""
    return observed_errors(ENGINE, p, dt, integrator)


def test_group_claims_the_scene():
    scene = CASE.scene(CASE.variant_params("disc"))
    assert ENGINE.group_for(scene).name == "rolling"
    assert ENGINE.supports(scene, INTEGRATOR) is None


@pytest.mark.parametrize("variant", [
    pytest.param(v, marks=pytest.mark.xfail(strict=True, reason=XFAIL[v])) if v in XFAIL else v
    for v in CASE.variants])
def test_distance_within_tolerance(variant):
    p = CASE.variant_params(variant)
    err, tol, reason = run(p, 1e-3)  # the finest of CASE.dts
    assert err["s"] <= tol, reason


@pytest.mark.parametrize("variant", ["disc", "hoop"])
def test_rolling_residual_within_one_free_kick(variant):
    """v - w r stays within g sin theta dt: at most one step's tangential kick is taken before
    a contact released exactly touching acts (measured: pymunk exactly that, MuJoCo 1e-7,
    pybullet 1e-15 at dt = 2 ms)."""
    p = CASE.variant_params(variant)
    dt = 2e-3
    err, _, _ = run(p, dt)
    assert err["residual"] <= p["g"] * np.sin(p["incline"]) * dt * (1 + 1e-9)
