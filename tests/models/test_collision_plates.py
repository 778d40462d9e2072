"""refsim.models.collision.plates: sphere-plate overlaps (push-out side "approach" against
"nearest"), the time of impact with the faces, and refsim's ContactSim against a tilted plate.
The vectorised functions are checked against a per-pair Python reference written from the
definitions (slab |d| < w/2 + r, square |q.a|, |q.b| <= H)."""
import numpy as np
import pytest

from refsim.models.collision import plates as slab

EPS = np.finfo(float).eps


def _plates(rng, count):
    normal = rng.normal(size=(count, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return (rng.uniform(-1, 1, (count, 3)), normal, rng.uniform(0.01, 0.1, count),
            rng.uniform(0.3, 1.0, count))


def test_plate_axes_are_orthonormal_and_perpendicular():
    rng = np.random.default_rng(1)
    normal = _plates(rng, 50)[1]
    normal[:3] = np.eye(3)
    a, b = slab.plate_axes(normal)
    frame = np.stack([a, b, normal], axis=1)
    # three dot products of unit vectors built by a cross product and one normalisation:
    # a few eps each
    assert np.allclose(frame @ frame.transpose(0, 2, 1), np.eye(3), rtol=0, atol=8 * EPS)


def _reference_contacts(x, radii, plates, x_before):
    center, normal, thickness, half = plates
    a, b = slab.plate_axes(normal)
    found = []
    for s in range(len(x)):
        for k in range(len(center)):
            rel = x[s] - center[k]
            d = rel @ normal[k]
            q = rel - d * normal[k]
            if abs(d) < thickness[k] / 2 + radii[s] and abs(q @ a[k]) <= half[k] and \
                    abs(q @ b[k]) <= half[k]:
                side_d = d if x_before is None else (x_before[s] - center[k]) @ normal[k]
                side = 1.0 if side_d >= 0 else -1.0
                found.append((s, k, side, thickness[k] / 2 + radii[s] - side * d))
    return found


@pytest.mark.parametrize("approach", [False, True])
def test_contacts_equal_the_per_pair_definition(approach):
    rng = np.random.default_rng(2)
    plates = _plates(rng, 7)
    x = rng.uniform(-1.5, 1.5, (400, 3))
    radii = rng.uniform(0.02, 0.2, 400)
    x_before = x + rng.normal(scale=0.2, size=x.shape) if approach else None
    s, k, m, depth = slab.plate_contacts(x, radii, *plates, x_before)
    want = _reference_contacts(x, radii, plates, x_before)
    assert len(want) > 20  # the draw has contacts to compare
    got = sorted(zip(s, k, np.sign(np.einsum("ck,ck->c", m, plates[1][k])), depth))
    assert [(a, b) for a, b, _, _ in got] == [(a, b) for a, b, _, _ in sorted(want)]
    assert [c for _, _, c, _ in got] == [c for _, _, c, _ in sorted(want)]
    # depth: the same three-term dot product in another association (einsum against @):
    # a few eps of |x - c| <= 3.5 m
    assert np.allclose([g[3] for g in got], [w[3] for w in sorted(want)], rtol=0,
                       atol=16 * EPS * 4)


def test_push_out_side_past_the_mid_plane():
    """A sphere that came from -n and overlaps with its centre past the mid-plane: 'approach'
    sends it back (m = -n, depth w/2 + r + d), 'nearest' pushes it through (m = +n)."""
    plate = (np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([0.02]), np.array([1.0]))
    x, radii = np.array([[0.004, 0.0, 0.0]]), np.array([0.05])
    _, _, m, depth = slab.plate_contacts(x, radii, *plate, np.array([[-0.1, 0.0, 0.0]]))
    assert m.tolist() == [[-1.0, 0.0, 0.0]] and depth[0] == pytest.approx(0.064, abs=4 * EPS)
    _, _, m, depth = slab.plate_contacts(x, radii, *plate)
    assert m.tolist() == [[1.0, 0.0, 0.0]] and depth[0] == pytest.approx(0.056, abs=4 * EPS)


def test_rim_is_not_a_contact():
    """Faces only: a centre projecting outside the square touches nothing."""
    plate = (np.zeros((1, 3)), np.array([[0.0, 0, 1]]), np.array([0.02]), np.array([1.0]))
    x = np.array([[0.5, 0.99, 0.0], [0.5, 1.01, 0.0], [1.01, 0.0, 0.0]])
    s, _, _, _ = slab.plate_contacts(x, np.full(3, 0.05), *plate)
    assert s.tolist() == [0]


def test_time_of_impact_against_the_closed_form():
    """Tilted plates, oblique velocities: tau = (|d| - w/2 - r) / |v.n| for the hits, and the
    centre at tau is w/2 + r from the mid-plane (the face touched)."""
    rng = np.random.default_rng(3)
    center, normal, thickness, half = _plates(rng, 1)
    a, b = slab.plate_axes(normal)
    n = 300
    tau_true = rng.uniform(0.0, 1.0, n)
    side = rng.choice([-1.0, 1.0], n)
    radii = rng.uniform(0.01, 0.1, n)
    touch = center + side[:, None] * (thickness / 2 + radii)[:, None] * normal \
        + rng.uniform(-0.8, 0.8, (n, 1)) * half * a + rng.uniform(-0.8, 0.8, (n, 1)) * half * b
    v = rng.normal(size=(n, 3))
    v -= (np.einsum("ik,k->i", v, normal[0]) + side * rng.uniform(0.2, 2.0, n))[:, None] \
        * normal  # v.n = -side |v.n|: approaching
    x = touch - v * tau_true[:, None]
    h = 0.7
    s, k, m, tau = slab.plate_time_of_impact(x, v, radii, center, normal, thickness, half, h)
    hit = tau_true <= h
    # the margin: no draw within 1e-9 of h (the rounding of x = touch - v tau decides those)
    assert np.all(np.abs(tau_true - h) > 1e-9)
    assert sorted(s) == list(np.flatnonzero(hit))
    assert np.array_equal(m, side[s][:, None] * normal)
    # x rounded once from terms of a few metres: |dd| <= 8 eps, over |v.n| >= 0.2
    assert np.allclose(tau, tau_true[s], rtol=0, atol=8 * EPS * 4 / 0.2)


def test_receding_and_already_overlapping():
    plate = (np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([0.02]), np.array([1.0]))
    x = np.array([[-0.2, 0, 0], [-0.05, 0, 0], [-0.05, 0.5, 0]])
    v = np.array([[-1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0]])
    s, _, m, tau = slab.plate_time_of_impact(x, v, np.full(3, 0.05), *plate, 1.0)
    assert s.tolist() == [1] and tau.tolist() == [0.0] and m.tolist() == [[-1.0, 0, 0]]


@pytest.mark.parametrize("formulation", ["discrete", "continuous"])
def test_contact_sim_bounces_off_a_tilted_plate(formulation):
    """A sphere hitting a plate tilted 30 deg, e = 0.5, no friction: the normal velocity
    reverses to -e v_n, the tangential stays; continuous lands on the exact trajectory,
    discrete on the face at the step's end; the walls' impulse balances the momentum."""
    from refsim.scene import Body, ContactModel, Particles, Plates
    from refsim_adapters.refsim_engine.contacts import ContactSim
    n = np.array([np.cos(np.pi / 6), np.sin(np.pi / 6), 0.0])
    plate = Plates(center=np.zeros((1, 3)), normal=[n], thickness=[0.02], half_size=[1.0])
    r, dt, v0 = 0.05, 0.01, np.array([3.0, 0.5, 0.2])
    x0 = -(0.01 + r + 0.013) * n  # on the -n side, its front 0.013 m from the face
    v0 = v0 - (v0 @ n) * n + 2.0 * n  # v.n = +2 from the -n side: approaching
    sphere = Particles.of((Body(mass=2.0, position=x0, velocity=v0, radius=r,
                                inertia=0.4 * 2.0 * r * r),))
    sim = ContactSim(dt, formulation, sphere, np.zeros(3), ContactModel(restitution=0.5),
                     plates=plate)
    sim.step(5)
    tc = 0.013 / 2.0
    v_after = v0 - 1.5 * (v0 @ n) * n
    # 5 steps of additions of terms <= 0.2 m: a few eps of that each
    if formulation == "continuous":
        assert np.allclose(sim.x[0], x0 + v0 * tc + v_after * (5 * dt - tc), rtol=0,
                           atol=64 * EPS)
    else:
        assert np.allclose(sim.x[0] @ n, -(0.01 + r) + v_after @ n * 4 * dt, rtol=0,
                           atol=64 * EPS)
    assert np.allclose(sim.v[0], v_after, rtol=0, atol=8 * EPS * 3)
    assert np.allclose(2.0 * (sim.v[0] - v0), sim.wall_impulse, rtol=0, atol=16 * EPS * 6)
    assert sim.settings()["plate_side"] == "approach" if formulation == "discrete" else \
        "plate_side" not in sim.settings()
