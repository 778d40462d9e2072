"""taichi's emitter kernels, what is taichi's own: the same counts as refsim's group over a whole
run, a dense emitter (several births a step, two per slot in one launch), settings and
refusals. Every particle on the exact discrete parabola of its stepper (to round-off) and the
same ids, births and states as refsim's group, per stepper and formulation, with births falling
inside and between launches of any length, is checked in
tests/conformance/test_conformance_emitter.py."""
import numpy as np
import pytest

pytest.importorskip("taichi")

from emitter_runs import EMITTER  # noqa: E402
from emitter_runs import run as _run  # noqa: E402

from refsim.models import emitter as em  # noqa: E402
from refsim.registry import get_engine  # noqa: E402

STEPPERS = ("symplectic_euler", "velocity_verlet", "rk4", "explicit_euler", "midpoint")


def test_counts_match_rate_times_time_and_refsim():
    p = EMITTER.variant_params("default")
    dt = EMITTER.dts(p)[-1]
    chunks = (1,) * 20 + (30, 150)  # the whole run, 1 s
    obs, _ = _run("taichi", p, "rk4", dt, "corrected", chunks)
    ref, _ = _run("refsim", p, "rk4", dt, "corrected", chunks)
    e = EMITTER.emitter(p)
    alive = (obs["id"] >= 0).sum(axis=1)
    assert np.array_equal(alive, (ref["id"] >= 0).sum(axis=1))
    assert np.abs(alive - em.continuum_alive(e, obs["t"])).max() <= em.count_bound(e, dt)
    assert np.array_equal(obs["emitted"], em.emitted_count(e, dt, np.rint(obs["t"] / dt)))


def test_dense_emitter_many_births_per_slot_in_one_launch():
    """rate 2000/s: several births a step and, over one launch of 300 steps, up to two per
    slot (lifetime 1 s = 200 steps): the kernel's event lists in boundary order."""
    p = EMITTER.variant_params("dense")
    dt = 5e-3
    obs, _ = _run("taichi", p, "velocity_verlet", dt, "corrected", (300, 1))
    ref, _ = _run("refsim", p, "velocity_verlet", dt, "corrected", (300, 1))
    for key in ("id", "birth", "emitted"):
        # same operations: ids and counts are integers, births birth_steps * dt on either host
        assert np.array_equal(obs[key], ref[key], equal_nan=True), key
    bound, _ = EMITTER.tolerance(p, "rk4", 4, dt)
    assert np.abs(obs["x"] - ref["x"]).max() <= bound


def test_emitter_settings_and_refusal():
    p = EMITTER.variant_params("default")
    engine = get_engine("taichi")
    scene = EMITTER.scene(p)
    assert engine.formulations(scene) == ("corrected", "as_printed")
    assert engine.offered_integrators(scene) == STEPPERS
    sim = engine.build(scene, 0.01, "rk4", "as_printed")
    s = sim.settings()
    assert s["capacity"] == 50 and "velocity == g*dt" in s["formulation"]
    assert "host" in s["births_removals"] and s["default_fp"].endswith("f64")
    reason = engine.supports(scene, "leapfrog")
    assert reason is not None and "leapfrog" in reason
