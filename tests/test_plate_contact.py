"""Exact plate contact: its distances, overlap depths and time of impact against independent
references, its force against its energy, and the folds that let panels through with sampled
contact, checked at every saved sample by an exact test written here (linear programming), not by
the contact code.

Tolerances: distances against scipy's constrained minimisation to 1e-7 of the panel size (the
optimiser's own tolerance); forces against central differences to 1e-5 relative (the difference
step's truncation); overlaps as stated per case.
"""

import functools

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import linprog, minimize

import origami_jax.simulation as sim
from origami_jax.contact import PlateContact, additive_ccd, overlap_depth
from origami_jax.contact._primitives import (
    additive_ccd_groups,
    point_polygon_sq,
    polygon_normal,
    segment_segment_sq,
)
from origami_jax.net import load_net
from origami_jax.system import HingeDrag

# The panels of a cube net of 100 µm squares (the catalogue's 200 µm nets at half scale).
SCALE = 0.5


# ---- the independent exact test: do two convex polygons share a point? ----


def polygons_meet(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether convex polygons `a` `(k, 3)` and `b` `(m, 3)` share a point: linear programming
    feasibility of ``Σ λ_i a_i = Σ μ_j b_j`` with ``λ, μ`` on simplices (scipy's HiGHS)."""
    k, m = len(a), len(b)
    equality = np.zeros((5, k + m))
    equality[:3, :k], equality[:3, k:] = a.T, -b.T
    equality[3, :k] = equality[4, k:] = 1
    result = linprog(
        np.zeros(k + m), A_eq=equality, b_eq=[0, 0, 0, 1, 1], bounds=[(0, None)] * (k + m)
    )
    return result.status == 0


def plates_pass_through(polygons, joined, thickness):
    """Pairs of polygons (indices) whose plates overlap by more than the film `thickness`: their
    mid-surfaces, shrunk by `thickness` towards their centroids along every edge (so that plates
    meeting at a shared corner or cut edge, or touching within the thickness, do not count),
    share a point. `joined`: pairs that share a crease, left out (a hinge joins them)."""
    shrunk = []
    for p in polygons:
        centre = p.mean(axis=0)
        reach = np.min(np.linalg.norm(p - centre, axis=1))
        shrunk.append(centre + (1 - thickness / reach) * (p - centre))
    n = len(polygons)
    return [
        (a, b)
        for a in range(n)
        for b in range(a + 1, n)
        if (a, b) not in joined and polygons_meet(shrunk[a], shrunk[b])
    ]


def through_at_samples(system, states):
    """Every saved state's plates that pass through each other (`plates_pass_through`)."""
    mechanism = system.mechanism
    layout = mechanism.hinge_layout()
    base = mechanism.base_outline()
    n = mechanism.n_bodies + (base is not None)
    parent = np.where(layout.parent < 0, n - 1, layout.parent)
    joined = {tuple(sorted((int(a), int(b)))) for a, b in zip(parent, layout.child, strict=True)}
    thickness = 2 * float(np.min(np.asarray(system.contact.half_thickness)))
    found = []
    for k, q in enumerate(np.asarray(states)):
        if not np.all(np.isfinite(q)):
            continue
        polygons = mechanism.panel_polygons(q) + ([base] if base is not None else [])
        found += [(k, *pair) for pair in plates_pass_through(polygons, joined, thickness)]
    return found


# ---- primitives against scipy ----


def _reference_segment_distance(p0, p1, q0, q1):
    def f(st):
        s, t = st
        return np.sum((p0 + s * (p1 - p0) - q0 - t * (q1 - q0)) ** 2)

    best = min(
        (minimize(f, x0, bounds=[(0, 1), (0, 1)], method="L-BFGS-B", tol=1e-14) for x0 in
         ([0.5, 0.5], [0, 0], [1, 1], [0, 1], [1, 0])),
        key=lambda r: r.fun,
    )  # fmt: skip
    return best.fun


def _reference_polygon_distance(p, polygon):
    k = len(polygon)
    constraint = {"type": "eq", "fun": lambda w: np.sum(w) - 1}
    result = minimize(
        lambda w: np.sum((w @ polygon - p) ** 2), np.full(k, 1 / k), bounds=[(0, 1)] * k,
        constraints=[constraint], method="SLSQP", options={"ftol": 1e-16, "maxiter": 500},
    )  # fmt: skip
    return result.fun


def test_primitive_distances_match_constrained_minimisation():
    rng = np.random.default_rng(0)
    for _ in range(30):
        p0, p1, q0, q1 = rng.normal(size=(4, 3))
        got = float(segment_segment_sq(*map(jnp.asarray, (p0, p1, q0, q1))))
        assert got == pytest.approx(_reference_segment_distance(p0, p1, q0, q1), abs=1e-9)
    # Parallel and collinear segments.
    for shift in ([0, 1, 0], [0.5, 0, 0], [3, 0, 0]):
        p0, p1 = np.zeros(3), np.array([1.0, 0, 0])
        q0, q1 = p0 + shift, p1 + shift
        got = float(segment_segment_sq(*map(jnp.asarray, (p0, p1, q0, q1))))
        assert got == pytest.approx(_reference_segment_distance(p0, p1, q0, q1), abs=1e-9)
    # A convex pentagon, tilted, and points above, beside and beyond its corners.
    angles = np.sort(rng.uniform(0, 2 * np.pi, 5))
    flat = np.stack([np.cos(angles), np.sin(angles), np.zeros(5)], axis=1)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rotation *= np.sign(np.linalg.det(rotation))
    polygon = flat @ rotation.T + rng.normal(size=3)
    normal = polygon_normal(jnp.asarray(polygon))
    for _ in range(30):
        p = polygon.mean(axis=0) + rng.normal(size=3) * 1.5
        got = float(point_polygon_sq(jnp.asarray(p), jnp.asarray(polygon), normal))
        assert got == pytest.approx(_reference_polygon_distance(p, polygon), abs=1e-8)


def _square(size=1.0, centre=(0, 0, 0), rotation=None):
    corners = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float) * size / 2
    if rotation is not None:
        corners = corners @ rotation.T
    return corners + np.asarray(centre, float)


def test_overlap_depth_closed_forms_and_separation():
    t = 0.1
    # Stacked squares 0.06 apart with thickness 0.1 overlap by 0.04 along the normal.
    a, b = _square(), _square(centre=(0.3, 0.2, 0.06))
    assert float(overlap_depth(a, b, t, t)) == pytest.approx(0.04, abs=1e-12)
    assert float(overlap_depth(a, b)) == 0.0  # the mid-surfaces are apart
    # Side by side in one plane, their edges 0.03 apart: no overlap of the mid-surfaces, and as
    # plates (round-free prisms) none either.
    assert float(overlap_depth(a, _square(centre=(1.03, 0, 0)), t, t)) == 0.0
    # Overlapping in-plane by 0.05: the prisms 0.05 deep (sideways is the shortest way out); the
    # mid-surfaces, flat, part with any lift at all (depth 0).
    c = _square(centre=(0.95, 0, 0))
    assert float(overlap_depth(a, c, t, t)) == pytest.approx(0.05, abs=1e-12)
    assert float(overlap_depth(a, c)) == 0.0
    # A square standing on its edge, pushed 0.02 down through a lying one's mid-plane near its
    # rim (0.1 from the rim): the shortest way out is up by 0.02 (or sideways by 0.1).
    stand = np.array([[0.4, -0.2, -0.02], [0.4, 0.2, -0.02], [0.4, 0.2, 0.5], [0.4, -0.2, 0.5]])
    assert float(overlap_depth(a, stand)) == pytest.approx(0.02, abs=1e-12)
    assert float(overlap_depth(a, stand, t, t)) == pytest.approx(0.02 + t / 2, abs=1e-12)
    # Random plates: zero exactly when the independent test finds them apart, and the shortest
    # translation separates them along some axis (moving b by more than the depth along the
    # best of 2,000 directions never separates less than the depth: a lower bound holds).
    rng = np.random.default_rng(1)
    for _ in range(40):
        r1 = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        r2 = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        p, q = _square(rotation=r1), _square(rotation=r2, centre=rng.normal(size=3) * 0.6)
        depth = float(overlap_depth(p, q))
        assert (depth > 1e-12) == polygons_meet(p, q)


def test_ccd_bounds_the_time_of_impact_from_below():
    # A vertex falls through the unit square's middle, z from +1 to −1 over the step: distance
    # ξ = 0.1 is reached at t* = 0.45; the bound is below it and not far off.
    square = jnp.asarray(_square())[None]
    point = jnp.array([[0.1, 0.2, 1.0]])

    def vertex_face(p, poly):
        return point_polygon_sq(p, poly, polygon_normal(poly))

    toi = additive_ccd(
        vertex_face, (point, square), (jnp.array([[0.0, 0.0, -2.0]]), jnp.zeros_like(square)),
        jnp.array([0.1]),
    )  # fmt: skip
    assert 0.3 < float(toi[0]) <= 0.45
    # Beside the square it passes the plane without coming near: no impact.
    beside = jnp.array([[3.0, 0.0, 1.0]])
    toi = additive_ccd(
        vertex_face, (beside, square), (jnp.array([[0.0, 0.0, -2.0]]), jnp.zeros_like(square)),
        jnp.array([0.1]),
    )  # fmt: skip
    assert float(toi[0]) == np.inf
    # Two edges crossing in an X between the step's ends (one above, one below the other), the
    # whole pair translating sideways too (the mean motion is removed): an impact within the step.
    p0, p1 = jnp.array([[-1.0, 0, 0.5]]), jnp.array([[1.0, 0, 0.5]])
    q0, q1 = jnp.array([[0, -1.0, 0]]), jnp.array([[0, 1.0, 0]])
    down, drift = jnp.array([[0, 0, -1.0]]), jnp.array([[5.0, 5.0, 0]])
    toi = additive_ccd(
        segment_segment_sq, (p0, p1, q0, q1), (down + drift, down + drift, drift, drift),
        jnp.array([0.05]),
    )  # fmt: skip
    assert 0.2 < float(toi[0]) <= 0.45


def random_ccd_groups(seed=3):
    """Random CCD groups: 40 vertex–face pairs (points falling past the unit square) and 30
    edge–edge pairs, some moving into contact, some clear, some already within ξ (arguments of
    `additive_ccd_groups`)."""
    rng = np.random.default_rng(seed)
    square = jnp.asarray(np.broadcast_to(_square(), (40, 4, 3)))
    point = jnp.asarray(rng.uniform(-0.5, 1.5, (40, 3)))
    fall = jnp.asarray(rng.normal(0, 1.5, (40, 3)))
    ends = [jnp.asarray(rng.normal(0, 1, (30, 3))) for _ in range(4)]
    moves = [jnp.asarray(rng.normal(0, 1, (30, 3))) for _ in range(4)]

    def vertex_face(p, poly):
        return point_polygon_sq(p, poly, polygon_normal(poly))

    vf = (vertex_face, (point, square), (fall, 0.3 * fall[:, None] + 0 * square), jnp.full(40, 0.1))
    ee = (segment_segment_sq, tuple(ends), tuple(moves), jnp.full(30, 0.05))
    return [vf, ee]


def test_grouped_ccd_gives_each_pair_its_own_time_of_impact():
    # Random vertex–face and edge–edge pairs, some moving into contact, some clear, some already
    # within ξ: one loop over both groups (`additive_ccd_groups`, what `PlateContact` runs) gives
    # each pair the time `additive_ccd` gives its group alone, to the last bit but rounding (the
    # pairs advance independently; only the loop's length is shared).
    vf, ee = random_ccd_groups()
    alone = jnp.concatenate([additive_ccd(*vf), additive_ccd(*ee)])
    together = additive_ccd_groups([vf, ee])
    hits = np.isfinite(np.asarray(alone)) & (np.asarray(alone) > 0)
    assert 5 < hits.sum() < 65  # the draw has impacts, clear pairs and pairs within ξ
    np.testing.assert_allclose(together, alone, rtol=1e-12, atol=0)


# ---- the model: forces from the energy, exact reports ----


@functools.cache
def _cube_net(scale=SCALE):
    return load_net("cube_net_01", length_scale=scale)


@eqx.filter_jit
def _potential(contact, mechanism, q):
    return contact.potential(mechanism, q)


@eqx.filter_jit
def _force(contact, mechanism, q, v):
    return contact.force(mechanism, q, v)


@eqx.filter_jit
def _report(contact, mechanism, q):
    return contact.report(mechanism, q)


def test_force_is_minus_the_energy_gradient_and_damping_dissipates():
    net = _cube_net()
    system = net.system()
    contact, mechanism = system.contact, system.mechanism
    assert isinstance(contact, PlateContact)
    # A state where panels meet, apart (0.5 % short of the closed cube, creases off by up to
    # 0.06°: no symmetric coincidence): rims within the activation gap of each other.
    rng = np.random.default_rng(3)
    q = jnp.asarray(net.intended_angles) * 0.995 + jnp.asarray(rng.uniform(-1e-3, 1e-3, 5))
    report = _report(contact, mechanism, q)
    assert int(report["engaged"]) > 0 and 0 < float(report["min_gap"]) < float(contact.activation)
    elastic = eqx.tree_at(lambda c: c.damping, contact, jnp.zeros(()))
    force = np.asarray(_force(elastic, mechanism, q, jnp.zeros_like(q)))
    h = 1e-6
    numeric = [
        -(float(_potential(elastic, mechanism, q + h * e)) - float(_potential(elastic, mechanism, q - h * e)))
        / (2 * h)
        for e in np.eye(len(q))
    ]  # fmt: skip
    assert np.abs(force).max() > 0
    np.testing.assert_allclose(force, numeric, rtol=1e-5, atol=1e-7 * np.abs(numeric).max())
    v = jnp.asarray(rng.normal(size=len(q))) * 0.01
    dissipative = np.asarray(_force(contact, mechanism, q, v) - _force(elastic, mechanism, q, v))
    assert float(np.dot(dissipative, v)) < 0


def test_pick_gathers_what_its_one_hot_product_picks(monkeypatch):
    """`pick`: the rows of an array and their adjoint (sums into rows), as a one-hot product (host
    rows within `DENSE_PICK_LIMIT`, 0 by default) and as a gather and a scatter-add (past it, and
    traced rows always): the same numbers."""
    from origami_jax.contact import _pick

    rng = np.random.default_rng(0)
    rows = rng.integers(0, 7, size=30)
    flat, picked = jnp.asarray(rng.normal(size=(7, 3))), jnp.asarray(rng.normal(size=(30, 3)))

    def both(rows):
        return _pick.pick(rows, 7, flat), _pick.pick(rows, 7, picked, transpose=True)

    monkeypatch.setattr(_pick, "DENSE_PICK_LIMIT", 1 << 22)
    dense = both(rows)
    np.testing.assert_allclose(dense[0], np.asarray(flat)[rows], rtol=1e-15)
    assert _pick.dense_pick(rows, 7) and not _pick.dense_pick(jnp.asarray(rows), 7)
    monkeypatch.setattr(_pick, "DENSE_PICK_LIMIT", 0)
    for gathered in (both(rows), jax.jit(both)(jnp.asarray(rows))):
        for a, b in zip(dense, gathered, strict=True):
            np.testing.assert_allclose(b, a, rtol=1e-13, atol=1e-14)


@pytest.mark.slow  # two compilations of the contact's Jacobians on a cube net: ~40 s
def test_gathered_picks_give_the_one_hot_products_forces(monkeypatch):
    """The contact gathers and scatters its pairs' rows (`DENSE_PICK_LIMIT` 0, the default): the
    same forces and Gauss–Newton derivatives as the dense one-hot products (forced here on a cube
    net by a limit of 4M entries), to round-off."""
    from origami_jax.contact import _pick

    net = _cube_net()
    system = net.system()
    contact, mechanism = system.contact, system.mechanism
    rng = np.random.default_rng(5)
    q = jnp.asarray(net.intended_angles) * 0.995 + jnp.asarray(rng.uniform(-1e-3, 1e-3, 5))
    v = jnp.asarray(rng.normal(size=5)) * 0.01

    def evaluate():
        # Traced afresh (not `_force`'s cached program): the pick is chosen while tracing.
        jacobians = eqx.filter_jit(lambda m, q, v: contact.force_jacobians(m, q, v))(
            mechanism, q, v
        )
        report = eqx.filter_jit(lambda m, q: contact.report(m, q))(mechanism, q)
        return [np.asarray(x) for x in (*jacobians, report["min_gap"], report["touching"])]

    monkeypatch.setattr(_pick, "DENSE_PICK_LIMIT", 1 << 22)
    dense = evaluate()
    monkeypatch.setattr(_pick, "DENSE_PICK_LIMIT", 0)
    gathered = evaluate()
    assert np.abs(dense[0]).max() > 0 and np.abs(dense[1]).max() > 0
    for a, b in zip(dense, gathered, strict=True):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * max(np.abs(a).max(), 1.0))


def _strip_net(tmp_path, squares: int):
    """A strip of `squares` 100 µm squares in a row, creases alternately valley and mountain at
    170° (an accordion)."""
    import json

    coords = [[100.0 * (i // 2), 100.0 * (i % 2)] for i in range(2 * squares + 2)]
    faces = [[2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1] for i in range(squares)]
    edges, assignment, angle = [], [], []
    for i in range(squares + 1):
        edges.append([2 * i, 2 * i + 1])
        inner = 0 < i < squares
        assignment.append(("V" if i % 2 else "M") if inner else "B")
        angle.append((170.0 if i % 2 else -170.0) if inner else 0.0)
    for i in range(squares):
        edges += [[2 * i, 2 * i + 2], [2 * i + 1, 2 * i + 3]]
        assignment += ["B", "B"]
        angle += [0.0, 0.0]
    data = dict(
        file_spec=1.2, frame_unit="um", vertices_coords=coords, faces_vertices=faces,
        edges_vertices=edges, edges_assignment=assignment, edges_foldAngle=angle,
    )  # fmt: skip
    path = tmp_path / "strip.fold"
    path.write_text(json.dumps(data))
    return load_net(path)


@functools.cache
def _broad_phase_cases(tmp_path_factory_root):
    """The strip of 16 squares (`_strip_net`) and two states of it, each with a step from it and a
    velocity: curled gently (10° creases: neighbours only within reach) and folded into a stack
    (179.9°: panels within reach of more than their neighbours, pairs engaged)."""
    from pathlib import Path

    net = _strip_net(Path(tmp_path_factory_root), 16)
    system = net.system()
    target = jnp.asarray(net.intended_angles)
    rng = np.random.default_rng(2)
    m = len(target)
    cases = []
    for fraction in (0.06, 1.058):
        q0 = target * fraction
        step = jnp.asarray(rng.uniform(-0.02, 0.02, m))
        cases.append((q0, q0 + step, jnp.asarray(rng.normal(size=m) * 0.01)))
    return system, cases


def _broad_phase_check(tmp_path_factory, monkeypatch, parts, settings):
    """`parts(contact, mechanism, q0, q1, v)` evaluated with the broad phase forced on 16 squares
    under each of `settings` (module attributes of `_plates` to set) and with every pair: equal
    to round-off (the same terms, fewer zeros added)."""
    from origami_jax.contact import _plates

    system, cases = _broad_phase_cases(str(tmp_path_factory.mktemp("strip")))
    contact, mechanism = system.contact, system.mechanism
    x = contact.vertices(mechanism, cases[1][0])
    near = np.asarray(contact._near_bodies(x, x, contact.activation))
    assert near.sum(axis=1).max() > 3 and float(jnp.min(contact._gaps(x)[0])) < contact.activation

    def evaluate():
        # Traced afresh for each setting: the broad phase is chosen while tracing.
        run = jax.jit(lambda q0, q1, v: parts(contact, mechanism, q0, q1, v))
        return [[np.asarray(y) for y in run(*case)] for case in cases]

    results = []
    for setting in settings:
        for name, value in setting.items():
            monkeypatch.setattr(_plates, name, value)
        results.append(evaluate())
    monkeypatch.setattr(_plates, "BROAD_PHASE_MIN_PAIRS", 1 << 62)
    whole = evaluate()
    assert np.abs(whole[1][0]).max() > 0  # the stack's panels push on each other
    for result in results:
        for narrowed, every in zip(result, whole, strict=True):
            for a, b in zip(narrowed, every, strict=True):
                scale = max(float(np.abs(b).max()), 1e-300)
                np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * scale)


@pytest.mark.slow  # a strip's system and two force programs: ~25 s; no default net reaches it
def test_the_broad_phase_changes_no_force(tmp_path_factory, monkeypatch):
    """A pattern of many panels evaluates only the pairs whose bodies' boxes come within reach
    (`PlateContact._broad`, forced here on 16 squares: the same code as past
    `BROAD_PHASE_MIN_PAIRS`, at a fraction of the compile time): the same contact force as every
    pair's, curled and stacked."""
    _broad_phase_check(
        tmp_path_factory,
        monkeypatch,
        lambda contact, mechanism, q0, q1, v: (contact.force(mechanism, q0, v),),
        [{"BROAD_PHASE_MIN_PAIRS": 0}],
    )


@pytest.mark.slow  # six programs with and without the broad phase: ~1.5 min
def test_the_broad_phase_changes_nothing_but_the_cost(tmp_path_factory, monkeypatch):
    """The force, energy, time of impact and collision verdict with the broad phase equal the whole
    contact's, in the rows kept and, with too few rows for the pairs within reach, through every
    pair."""

    def parts(contact, mechanism, q0, q1, v):
        return (
            contact.force(mechanism, q0, v),
            contact.potential(mechanism, q0),
            contact.time_of_impact(mechanism, q0, q1),
            contact.crossed(mechanism, q0, q1),
        )

    kept = {"BROAD_PHASE_MIN_PAIRS": 0}
    overflowing = kept | {"_BROAD_PAIRS_PER_BODY": 1, "_BROAD_BODY_PAIRS_PER_BODY": 1}
    _broad_phase_check(tmp_path_factory, monkeypatch, parts, [kept, overflowing])


def test_report_gives_the_exact_overlap_of_plates_passed_through():
    """At the closed cube the plates meet at their rims (overlap at most half the film's thickness,
    where two perpendicular plates' rims meet); with one crease turned 10°–60° past or short of
    the cube, the report's penetration exceeds the film's thickness exactly when the independent
    test finds two plates through each other."""
    net = _cube_net()
    system = net.system()
    contact, mechanism = system.contact, system.mechanism
    thickness = 2 * float(np.min(np.asarray(contact.half_thickness)))
    closed = jnp.asarray(net.intended_angles)
    assert float(_report(contact, mechanism, closed)["penetration"]) <= thickness / 2 + 1e-9
    seen = set()
    for crease in range(len(closed)):
        for turn in (-60, -30, -10, 10, 30, 60):
            q = closed.at[crease].add(jnp.sign(closed[crease]) * np.radians(turn))
            depth = float(_report(contact, mechanism, q)["penetration"])
            through = through_at_samples(system, q[None]) != []
            assert (depth > thickness) == through, (crease, turn, depth)
            seen.add(through)
    assert seen == {True, False}  # both kinds of state were tried


# ---- folds that let panels through with sampled contact ----


@functools.cache
def _fold(case: str, model: str, engine: str = "adaptive", scale: float = SCALE):
    """The cube net (`scale`: its length scale) folded 150 µs in air (`case`: aimed at its
    creases, 10° past them, or with no drag) with contact `model`, by the adaptive default or
    (`engine="fixed"`) `ImplicitStep`."""
    net = _cube_net(scale)
    targets, drag = None, "panel"
    if case == "past":
        targets = np.asarray(net.intended_angles) + np.sign(net.intended_angles) * np.radians(10)
    system = net.system(targets=targets, drag=drag, contact=model)
    if case == "dragless":
        system = eqx.tree_at(lambda s: s.drag, system, HingeDrag(jnp.zeros(system.n_hinges)))
    solver = sim.ImplicitStep(dt=2.5) if engine == "fixed" else None
    options = sim.SolveOptions(saveat=sim.SaveAt(n=151), max_steps=100_000, solver=solver)
    trajectory = sim.simulate(system, sim.Step(), options, t1=150.0)
    return system, trajectory


@pytest.mark.parametrize("case", ["air", pytest.param("past", marks=pytest.mark.slow),
                                  pytest.param("dragless", marks=pytest.mark.slow)])  # fmt: skip
def test_cube_net_plates_never_pass_through(case):
    """A cube net of 100 µm squares in air (the literature design, whose creases ring): with the
    hinges aimed at their creases, 10° past them, or with no drag at all. No saved sample has two
    plates overlapping by more than the film's thickness (the independent test above), and the
    report's penetration is below the thickness too."""
    system, trajectory = _fold(case, "plate")
    assert bool(trajectory.succeeded), trajectory.result
    q = trajectory.theta if trajectory.state is None else trajectory.state[0]
    assert through_at_samples(system, q) == []
    thickness = 2 * float(np.min(np.asarray(system.contact.half_thickness)))
    outcome = _cube_net().outcome(system, trajectory)
    assert float(outcome.penetration) < thickness


def test_a_net_of_another_size_folds_with_the_programs_compiled_for_the_first():
    """The panels' coordinates (outlines, plate tables) are data of the compiled programs, not
    constants: the cube net at three times the size builds its system and folds in air with what
    its fold at twice the size compiled (before, every program compiled again), no plates pass
    through each other (the independent test), and its compiled contact energy is its own
    geometry's: equal to the same energy evaluated op by op, and not the smaller net's. (Both
    folds in this test: the suite may drop compiled programs between tests.)"""
    small, _ = _fold("air", "plate", scale=2 * SCALE)
    compiles = []

    def listen(event, duration, **kwargs):
        if event == "/jax/core/compile/backend_compile_duration":
            compiles.append(duration)

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        system, trajectory = _fold("air", "plate", scale=3 * SCALE)
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    # At most a single operation or two on first use (a division skipped at scale 1, 0.04 s);
    # the fold's own programs take 20-40 s to compile.
    assert sum(compiles) < 1.0, compiles
    assert bool(trajectory.succeeded), trajectory.result
    assert through_at_samples(system, trajectory.theta) == []
    closed = 0.995 * jnp.asarray(_cube_net().intended_angles)
    energies = [float(_potential(s.contact, s.mechanism, closed)) for s in (small, system)]
    with jax.disable_jit():
        direct = float(system.contact.potential(system.mechanism, closed))
    assert energies[1] == pytest.approx(direct, rel=1e-10) and energies[1] > 0
    assert abs(energies[1] - energies[0]) > 1e-3 * energies[1]


@pytest.mark.slow  # three folds by the fixed-step engine, ~40 s each
@pytest.mark.parametrize("case", ["air", "past", "dragless"])
def test_the_fixed_step_engine_never_lets_plates_through(case):
    """The same three folds by the time-stepping engine (`ImplicitStep`, 2.5 µs steps, its line
    search capped by the collision check): no saved sample has two plates overlapping by more than
    the film's thickness (the independent test), nor does the verdict report one."""
    system, trajectory = _fold(case, "plate", "fixed")
    assert bool(trajectory.succeeded), trajectory.result
    q = trajectory.theta if trajectory.state is None else trajectory.state[0]
    assert through_at_samples(system, q) == []
    thickness = 2 * float(np.min(np.asarray(system.contact.half_thickness)))
    assert float(_cube_net().outcome(system, trajectory).penetration) < thickness


@pytest.mark.slow
def test_sampled_contact_lets_the_air_fold_through():
    """The case above is not vacuous: the sampled model's points let one panel's edge through its
    neighbour (found by the same independent test)."""
    system, trajectory = _fold("air", "sampled")
    q = trajectory.theta if trajectory.state is None else trajectory.state[0]
    assert through_at_samples(system, q) != []


# ---- impacts: a lid launched into a closed box, flaps meeting edge on edge, no energy gain ----


@eqx.filter_jit  # one compiled call per system structure
def _step_energy(system, trajectory):
    """Mechanical energy (the contact's stored energy included) with the step's potential
    ``−Σ k θ_target θ``: conserved without drag and contact damping, so it may only fall."""
    k, target = system.hinges.stiffness, system.hinges.target
    q, v = trajectory.theta, trajectory.theta_dot
    return jax.vmap(system.energy)(q, v) - q @ (k * target)


def _launched(name: str, kick) -> tuple:
    """Net `name` (100 µm panels) folded to its targets, no drag, crease velocities `kick`
    (rad/µs) at its closed state; 100 µs under the contact guard, Tsit5 at rtol 1e-8."""
    net = load_net(name, length_scale=SCALE)
    system = net.system(drag="hinge")
    system = eqx.tree_at(lambda s: s.drag, system, HingeDrag(jnp.zeros(system.n_hinges)))
    closed = jnp.asarray(net.intended_angles)
    trajectory = sim.simulate(system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=201), solver=diffrax.Tsit5(), rtol=1e-8, atol=1e-10, max_steps=100_000), t1=100.0, theta0=closed * 0.98, theta_dot0=jnp.asarray(kick))  # fmt: skip
    return net, system, trajectory


# Energy may rise between samples by no more than the integrator's error (rtol 1e-8 local errors
# over ~1e3 steps) relative to the energy in play.
ENERGY_RTOL = 1e-6


@pytest.mark.parametrize(
    "name, kick",
    [
        # The corner cube's two flaps launched at each other (their far corners and rims meet).
        pytest.param("corner_cube", [0.02, 0.02], marks=pytest.mark.slow),
        # The cube's lid launched inward onto the walls' top edges (corner on face, edge on edge).
        pytest.param("cube_net_01", [0.0, 0.02, 0.0, 0.0, 0.0], marks=pytest.mark.slow),
    ],
)
def test_launched_panels_stop_on_each_other_without_gaining_energy(name, kick):
    net, system, trajectory = _launched(name, kick)
    assert bool(trajectory.succeeded), trajectory.result
    assert through_at_samples(system, trajectory.theta) == []
    energy = np.asarray(_step_energy(system, trajectory))
    scale = np.max(np.abs(energy))
    assert np.max(np.diff(energy)) <= ENERGY_RTOL * scale
    assert energy[-1] < energy[0]  # the contact's damping took some out
    thickness = 2 * float(np.min(np.asarray(system.contact.half_thickness)))
    assert float(net.outcome(system, trajectory).penetration) < thickness


def test_the_model_is_chosen_by_name_and_a_sampling_needs_the_sampled_model(tmp_path, capsys):
    from origami_jax.cli import main
    from origami_jax.contact import PanelContact

    net = load_net("corner_cube")
    assert isinstance(net.system().contact, PlateContact)
    assert isinstance(net.system(contact="sampled").contact, PanelContact)
    assert net.system(contact=False).contact is None
    with pytest.raises(
        ValueError, match="contact must be True, False or one of 'plate', 'sampled'"
    ):
        net.system(contact="exact")
    with pytest.raises(ValueError, match="applies to contact='sampled' only"):
        net.system(contact_sampling=(8, 6))
    for command in ("fold", "yield"):
        argv = [command, "corner_cube", "--contact-sampling", "8,6", "--out", str(tmp_path / "x")]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "add --contact sampled" in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "x").exists()
