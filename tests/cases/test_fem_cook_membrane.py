"""Cook's membrane (cases/fem/cook_membrane.py): the stored refinement study is the in-house
static solve's, its Richardson value and error estimate, P1 locking on the coarse meshes, every
variant within its bound and a stiffer panel caught."""
import numpy as np
import pytest

from refsim.models.fem.model import ElasticBody
from refsim.models.fem.static import solve_static
from refsim.registry import get_case
from refsim.run.job import Job, run_job
from refsim.scene import Material, TriangleMesh
from refsim_cases.fem.cook_membrane import STUDY, converged, point

CASE = get_case("cook_membrane")


def _solve(mesh):
    body = ElasticBody.of(mesh)
    fixed = np.zeros((len(mesh), 2), bool)
    fixed[mesh.pinned] = True
    solved = solve_static(body, body.to_local(mesh.loads), fixed, rtol=1e-12)
    return body.to_world(solved.x)


def _corner_and_midpoint(mesh, x):
    rest = mesh.vertices
    return (x[point(rest, (48.0, 60.0)), 1] - 60.0, x[point(rest, (48.0, 52.0)), 1] - 52.0)


@pytest.mark.parametrize("n", [16, 32, 64, 128])
def test_the_stored_study_is_the_in_house_solve(n):
    """The stored P1 values (from cases/fem/_linear.py) are what the in-house static solve
    gives on the same mesh: 1e-9 relative (its stop at 1e-12 of the force scale through the
    stiffness' condition number, ~2e5 at n = 16; measured agreement ~1e-13)."""
    mesh = CASE.mesh(CASE.variant_params("n16", {"cells": n}))
    corner, mid = _corner_and_midpoint(mesh, _solve(mesh))
    assert corner == pytest.approx(STUDY[n][0], rel=1e-9)
    assert mid == pytest.approx(STUDY[n][1], rel=1e-9)


def test_richardson_value_and_p1_locking():
    value, estimate, order = converged([c for c, _ in STUDY.values()])
    assert value == pytest.approx(25.190, abs=5e-4) and estimate == pytest.approx(0.0113,
                                                                                  abs=1e-4)
    corners = np.array([c for c, _ in STUDY.values()])
    orders = np.log2(-np.diff(corners)[:-1] / -np.diff(corners)[1:])
    assert np.all(np.diff(orders[-3:]) < 0) and 1.0 < order < 1.6  # falling towards 1
    # locking: every mesh below the converged value, rising under refinement; n = 4 less
    # than half of it (11.35)
    assert np.all(np.diff(corners) > 0) and corners[-1] < value - estimate
    mesh = CASE.mesh(CASE.variant_params("n16", {"cells": 4}))
    assert _corner_and_midpoint(mesh, _solve(mesh))[0] < 0.46 * value
    # the quoted 23.96 is the midpoint's converged value, not the corner's
    mid, mid_estimate, _ = converged([m for _, m in STUDY.values()])
    assert abs(mid - 23.96) < 0.02 and abs(value - 23.96) > 100 * estimate


@pytest.mark.parametrize("variant", ["n8", "n16", "n32"])
def test_static_solve_within_its_bound_and_e_off_either_way_fails_it(variant):
    """E 0.1 % high or low moves v_C by 0.1 % (0.018, 0.022, 0.024 at n = 8, 16, 32), far
    past twice the solve bound; the row's p1_share shows the locking."""
    row = run_job(Job("cook_membrane", variant, "refsim", "", "steady", 1.0), repeats=0)
    assert row["status"] == "ok" and row["consistency"] == "consistent", row["reason"]
    assert row["err_max"] <= row["tolerance"]
    assert row["p1_share"] == pytest.approx(STUDY.get(CASE.variant_params(variant)["cells"],
                                                      (17.644674073033066,))[0]
                                            / CASE.converged_corner()[0], rel=1e-9)
    p = CASE.variant_params(variant)
    mesh = CASE.mesh(p)
    for factor in (1.001, 0.999):
        off = TriangleMesh(mesh.vertices, mesh.triangles,
                           Material(factor, 1.0 / 3.0, 1.0, "linear"), thickness=1.0,
                           plane="stress", pinned=mesh.pinned, loads=mesh.loads)
        corner, _ = _corner_and_midpoint(mesh, _solve(off))
        assert abs(corner - CASE.p1_corner(p)) > 1e3 * row["tolerance"]
