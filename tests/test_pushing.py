"""Quasi-static pushing: limit surface, one and several contacts, Appendix A's theorem."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clutter_gym.model.objects import OBJECTS, Footprint
from planners.hand2d import push_grasp_profile, sweep_profile
from planners.push_kernels import MAX_CONTACTS, STICK, _nearest
from planners.push_simulation import (
    ConvexPolygon,
    PoseSets,
    Pusher,
    PushState,
    contacts,
    first_overlapped,
    simulate_push,
    smallest_gap,
    swept,
)
from planners.pushing import (
    DiscPressure,
    RectanglePressure,
    RimPressure,
    SampledPressure,
    contact_lcp,
    limit_surface_matrix,
    lynch_sticking_twist,
    single_contact_twist,
    solve_contacts,
)

finite = st.floats(-0.1, 0.1, allow_nan=False)
angle = st.floats(-np.pi, np.pi, allow_nan=False)


def test_c_closed_forms() -> None:
    assert RimPressure(0.04).c == pytest.approx(0.04)
    assert DiscPressure(0.04).c == pytest.approx(2 * 0.04 / 3)
    assert RectanglePressure((0.05, 0.05)).c == pytest.approx(0.3826 * 0.1, rel=1e-4)
    ring = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    pts = tuple((0.03 * np.cos(a), 0.03 * np.sin(a)) for a in ring)
    assert SampledPressure(pts, (1.0,) * len(pts)).c == pytest.approx(0.03)
    grid = (np.arange(200) + 0.5) / 200 - 0.5
    xx, yy = np.meshgrid(grid, grid)
    square = SampledPressure(tuple(zip(xx.ravel(), yy.ravel(), strict=True)), (1.0,) * xx.size)
    assert square.c == pytest.approx(RectanglePressure((0.5, 0.5)).c, rel=1e-4)
    assert limit_surface_matrix(0.02)[2, 2] == pytest.approx(1 / 0.02**2)


@pytest.mark.parametrize(
    "make",
    [
        lambda: RimPressure(0.0),
        lambda: DiscPressure(-1.0),
        lambda: RectanglePressure((0.1, 0.0)),
        lambda: SampledPressure(((0.1, 0.0),), (1.0,)),
        lambda: limit_surface_matrix(float("nan")),
    ],
)
def test_bad_pressure(make: object) -> None:
    with pytest.raises(ValueError):
        make()  # type: ignore[operator]


@settings(max_examples=200, deadline=None)
@given(finite, finite, angle, angle, st.floats(0.005, 0.1))
def test_lynch_matches_general_sticking(
    x: float, y: float, a_n: float, a_v: float, c: float
) -> None:
    """With a huge mu a contact whose sticking force pushes (n.f* > 0) sticks, and the general
    solver equals Lynch's closed form."""
    n = np.array([np.cos(a_n), np.sin(a_n)])
    vp = np.array([np.cos(a_v), np.sin(a_v)])
    jac = np.array([[1, 0, -y], [0, 1, x]])
    f_star = np.linalg.solve(jac @ limit_surface_matrix(c) @ jac.T, vp)
    twist, mode = single_contact_twist(np.array([x, y]), n, vp, 1e9, c)
    if vp @ n > 1e-6 and n @ f_star > 1e-6:
        assert mode == STICK
        np.testing.assert_allclose(twist, lynch_sticking_twist(np.array([x, y]), vp, c), atol=1e-9)
        np.testing.assert_allclose(jac @ twist, vp, atol=1e-9)  # contact point moves with pusher


def test_sliding_formula() -> None:
    """Disc pushed off-centre with low friction: the twist lies on the friction-cone edge and
    the object's normal velocity at the contact equals the pusher's (Lemma 1)."""
    r, n, vp, mu, c = np.array([-0.04, 0.02]), np.array([1.0, 0.0]), np.array([1.0, 0.3]), 0.1, 0.03
    twist, mode = single_contact_twist(r, n, vp, mu, c)
    assert mode == 2
    jac = np.array([[1, 0, -r[1]], [0, 1, r[0]]])
    assert (jac @ twist) @ n == pytest.approx(vp @ n)
    wrench = np.linalg.solve(limit_surface_matrix(c), twist)  # A^-1 V is along J^T e
    t = np.array([-n[1], n[0]])
    edges = [jac.T @ (n + s * mu * t) for s in (1, -1)]
    assert any(abs(np.linalg.det(np.column_stack([wrench[:2], e[:2]]))) < 1e-9 for e in edges)
    assert np.all(single_contact_twist(r, -n, vp, mu, c)[0] == 0)  # separation


@settings(max_examples=100, deadline=None)
@given(finite, finite, angle, angle, st.floats(0.05, 2.0), st.floats(0.005, 0.1))
def test_lcp_reproduces_single_contact(
    x: float, y: float, a_n: float, a_v: float, mu: float, c: float
) -> None:
    r = np.array([[x, y]])
    n = np.array([[np.cos(a_n), np.sin(a_n)]])
    vp = np.array([[np.cos(a_v), np.sin(a_v)]])
    sol = solve_contacts(r[None], n[None], vp[None], mu, c)
    expected, _ = single_contact_twist(r[0], n[0], vp[0], mu, c)
    np.testing.assert_allclose(sol.twist[0], expected, atol=1e-6)
    assert not sol.jammed[0]


@settings(max_examples=100, deadline=None)
@given(st.integers(2, 3), st.integers(0, 2**32 - 1))
def test_multi_contact_solution_satisfies_the_lcp(m: int, seed: int) -> None:
    """The enumerated solution, written as z = (f_n, f_t+, f_t-, lambda), solves the contact
    LCP: w = M z + q >= 0, z >= 0, w.z = 0."""
    rng = np.random.default_rng(seed)
    r = rng.uniform(-0.05, 0.05, (m, 2))
    ang = rng.uniform(-np.pi, np.pi, m)
    n = np.column_stack([np.cos(ang), np.sin(ang)])
    vp = np.tile(rng.normal(size=2), (m, 1))
    mu, c = float(rng.uniform(0.1, 1.5)), float(rng.uniform(0.01, 0.08))
    sol = solve_contacts(r[None], n[None], vp[None], mu, c)
    if sol.jammed[0]:
        return
    fn, ft = sol.forces[0, :, 0], sol.forces[0, :, 1]
    t = np.column_stack([-n[:, 1], n[:, 0]])
    jac = np.stack([[[1, 0, -ry], [0, 1, rx]] for rx, ry in r])
    slip = np.einsum("ik,ikj,j->i", t, jac, sol.twist[0]) - (t * vp).sum(1)
    z = np.concatenate([fn, np.column_stack([ft.clip(0), (-ft).clip(0)]).ravel(), np.abs(slip)])
    big_m, q = contact_lcp(r, n, vp, mu, c)
    w = big_m @ z + q
    scale = 1 + np.abs(z).max()
    assert np.all(z >= -1e-6 * scale) and np.all(w >= -1e-6 * scale)
    assert abs(w @ z) < 1e-6 * scale**2


def _push_distances(mus: np.ndarray, cs: np.ndarray, y: float) -> np.ndarray:
    """Push until a juice bottle's centre passes the grasp line between the fingers, once per
    (mu_c, c) pair, all in one batch."""
    hand = push_grasp_profile(0.12)
    fp = Footprint("circle", radius=0.04)
    out = np.full(len(mus), np.inf)

    def watch(state: PushState) -> np.ndarray:
        p = state.poses
        ok = (p[:, 0] <= hand.grasp_line) & (np.abs(p[:, 1]) <= hand.half_gap)
        out[state.ids[ok]] = state.pushed[ok]
        return ok

    start = np.tile([0.24, y, 0.0], (len(mus), 1))
    simulate_push(fp, hand.pusher, start, mus, cs, 0.6, watch=watch)
    return out


@settings(max_examples=6, deadline=None)
@given(st.floats(0.03, 0.075))
def test_appendix_a_theorem(y: float) -> None:
    """For a cylinder, the push needed never grows as mu_c decreases or as the pressure
    concentrates toward the centre (smaller c)."""
    radius = 0.04
    mus = np.array([100.0, 1.0, 0.3, 0.1, 100.0, 100.0])
    cs = np.array([radius, radius, radius, radius, 2 * radius / 3, radius / 3])
    d = _push_distances(mus, cs, y)
    for seq in (d[:4], d[[0, 4, 5]]):
        assert all(b <= a + 2e-3 for a, b in itertools.pairwise(seq)), seq


def test_box_on_flat_pusher_translates() -> None:
    """A box pushed square-on by a wide flat face moves with it (two stuck corner contacts)."""

    wall = Pusher((ConvexPolygon(((-0.1, -0.2), (0.0, -0.2), (0.0, 0.2), (-0.1, 0.2))),))
    box = Footprint("box", half_extents=(0.05, 0.03))
    res = simulate_push(box, wall, np.array([[0.06, 0.01, 0.0]]), 0.5, 0.03, 0.2)
    np.testing.assert_allclose(res.poses[0], [0.05, 0.01, 0.0], atol=2e-3)


@pytest.mark.parametrize("kind", ["soda_can", "poptart_box"])
def test_a_sample_riding_with_the_pusher_is_a_fixed_point(kind: str) -> None:
    """Without a watcher a sample that moved rigidly with the hand for one step ends there
    (the push has no clock in the hand's frame): the recorded evolution agrees with stepping
    every sample to the end (a watcher that stops nothing turns the shortcut off)."""
    footprint = OBJECTS[kind].footprint
    pusher = push_grasp_profile(0.192).pusher
    rng = np.random.default_rng(3)
    poses = np.column_stack(
        [rng.uniform(0.25, 0.35, 40), rng.uniform(-0.08, 0.08, 40), rng.uniform(-np.pi, np.pi, 40)]
    )
    checkpoints = np.linspace(0.0, 0.3, 16)[1:]

    def none(state: PushState) -> np.ndarray:
        return np.zeros(len(state.ids), dtype=bool)

    fast = simulate_push(footprint, pusher, poses, 0.5, 0.04, 0.3, 5e-3, record=checkpoints)
    stepped = simulate_push(
        footprint, pusher, poses, 0.5, 0.04, 0.3, 5e-3, watch=none, record=checkpoints
    )
    np.testing.assert_allclose(fast.recorded[..., :2], stepped.recorded[..., :2], atol=1e-4)
    turn = np.remainder(fast.recorded[..., 2] - stepped.recorded[..., 2] + np.pi, 2 * np.pi)
    np.testing.assert_allclose(turn - np.pi, 0.0, atol=1e-3)
    assert np.all(fast.pushed == 0.3)


@pytest.mark.parametrize(
    "vertices",
    [
        ((0.0, 0.0), (0.0, 1.0), (1.0, 0.0)),  # clockwise
        ((0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (1.0, 1.0)),  # a straight angle
        ((0.0, 0.0), (2.0, 0.0), (0.5, 0.5), (0.0, 2.0)),  # a reflex vertex
        ((0.0, 0.0), (1.0, 0.0)),
    ],
)
def test_a_polygon_that_is_not_strictly_convex_and_counter_clockwise_is_refused(
    vertices: tuple[tuple[float, float], ...],
) -> None:
    with pytest.raises(ValueError, match="ConvexPolygon"):
        ConvexPolygon(vertices)


@pytest.mark.parametrize("kind", ["soda_can", "poptart_box"])
def test_the_swept_hand_is_the_union_of_its_poses_along_the_push(kind: str) -> None:
    """One overlap test against `swept` says what tests of the hand at every pose along the
    push say: an overlap exactly where a densely spaced pose overlaps, and the same distance
    from the hand where none does (to the spacing of the poses)."""
    footprint = OBJECTS[kind].footprint
    hand = push_grasp_profile(0.15).pusher
    length = 0.3
    rng = np.random.default_rng(4)
    poses = np.column_stack(
        [rng.uniform(-0.1, 0.6, 300), rng.uniform(-0.25, 0.25, 300), rng.uniform(-3, 3, 300)]
    )
    shifts = np.linspace(0.0, length, 601)
    dense = np.min([smallest_gap(footprint, hand, poses - [s, 0.0, 0.0]) for s in shifts], axis=0)
    once = smallest_gap(footprint, swept(hand, length), poses)
    spacing = shifts[1] - shifts[0]
    assert np.all(once[dense < 0.0] < 0.0)  # every overlap along the push is found
    assert np.all(dense[once < 0.0] < spacing)  # and nothing clear of every pose
    clear = dense > 0.0
    assert clear.sum() > 50 and np.allclose(once[clear], dense[clear], atol=spacing / 2)
    assert np.allclose(
        smallest_gap(footprint, hand, poses), contacts(footprint, hand, poses)[0].min(1)
    )


@pytest.mark.parametrize("kind", ["large_box", "poptart_box", "soda_can"])
@pytest.mark.parametrize("hand", ["push-grasp", "swept", "sweep"])
def test_overlap_test_agrees_with_the_smallest_gap(kind: str, hand: str) -> None:
    """The planner's cheap overlap test says exactly what the gap computation says, at every
    depth, for the hand's cross-sections it is used with."""
    footprint = OBJECTS[kind].footprint
    pusher = {
        "push-grasp": push_grasp_profile(0.235).pusher,
        "swept": swept(push_grasp_profile(0.15).pusher, 0.2),
        "sweep": sweep_profile().pusher,
    }[hand]
    rng = np.random.default_rng(11)
    # One pose per hand position: the object at (0, 0, theta), the hand moved to -xy.
    thetas = rng.uniform(-3, 3, 20)
    xys = np.column_stack([rng.uniform(-0.3, 0.5, 4000), rng.uniform(-0.3, 0.3, 4000)])
    poses = np.column_stack([xys, np.repeat(thetas, 200)])
    gap = smallest_gap(footprint, pusher, poses)
    for depth in (1e-4, 2e-3, 0.02):
        found = np.concatenate(
            [
                first_overlapped(
                    PoseSets.of([(footprint, [[0.0, 0.0, t]])]),
                    pusher,
                    -xys[k * 200 : (k + 1) * 200],
                    depth,
                )
                for k, t in enumerate(thetas)
            ]
        )
        assert set(found) == {-1, 0}
        np.testing.assert_array_equal(found == 0, gap < -depth)
    # Many poses of two objects at once: a hand position overlaps an object where any of its
    # poses does, and the first such object is named.
    local = [
        np.column_stack([rng.normal(c, 0.03, (30, 2)), rng.uniform(-3, 3, 30)])
        for c in ((0.1, -0.25), (0.1, 0.25))
    ]
    other = OBJECTS["juice_bottle"].footprint
    shifts = rng.uniform([-0.2, -0.6], [0.4, 0.6], (300, 2))
    hits = [
        [(smallest_gap(f, pusher, poses - [*s, 0.0]) < -2e-3).any() for s in shifts]
        for f, poses in ((footprint, local[0]), (other, local[1]))
    ]
    expected = np.where(hits[0], 0, np.where(hits[1], 1, -1))
    found = first_overlapped(
        PoseSets.of([(footprint, local[0]), (other, local[1])]), pusher, shifts, 2e-3
    )
    assert set(found) == {-1, 0, 1}
    np.testing.assert_array_equal(found, expected)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from([-0.01, 0.0, 0.002, 0.002, 0.03, np.inf]), max_size=12))
def test_the_nearest_contacts_are_a_stable_sorts_first(gaps: list[float]) -> None:
    """The contact kernel keeps the MAX_CONTACTS smallest gaps, smallest first and equal gaps
    in their order (ties are common: a box's corner and the hand's vertex meet at one gap),
    as a stable sort would."""
    values = np.array(gaps, dtype=float)
    nearest = np.full(MAX_CONTACTS, -1, dtype=np.int64)
    kept = _nearest(values, nearest)
    expected = np.argsort(values, kind="stable")[:MAX_CONTACTS]
    assert kept == len(expected)
    np.testing.assert_array_equal(nearest[:kept], expected)
