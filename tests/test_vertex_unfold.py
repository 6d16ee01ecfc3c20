"""unfold: catalogue reaches flat, constraints hold, certificates re-checked independently,
random vertices in one vmapped batch, non-convex open chains never reported flat-unfolded."""

import jax
import numpy as np
import pytest

from origami_jax.vertex import (
    CERT_MARGIN,
    SingleVertex,
    Verdict,
    constraints,
    corner_cube,
    degree4_vertex,
    open_chain_vertex,
    random_vertices,
    unfold,
    unfold_batch,
    waterbomb_base,
)

CONSTRAINT_TOL = 1e-9
N_RANDOM = 30  # per kind: 30 closed + 30 open = 60 random vertices


# --- an independent collision check (different algorithm from the package's) ---------------------


def _angle(a, b):
    return np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b))


def _on_arc(p, a, b, tol=1e-12):
    """p strictly inside the minor arc a b: the two angles add up to the arc length."""
    return (
        abs(_angle(a, p) + _angle(p, b) - _angle(a, b)) < tol
        and _angle(a, p) > tol
        and _angle(p, b) > tol
    )


def _arcs_intersect(a1, a2, b1, b2):
    """Great-circle intersection points ±p tested for lying inside both arcs."""
    p = np.cross(np.cross(a1, a2), np.cross(b1, b2))
    norm = np.linalg.norm(p)
    if norm < 1e-14:
        return False  # same great circle: overlaps are a validation matter
    p = p / norm
    return any(_on_arc(q, a1, a2, 1e-10) and _on_arc(q, b1, b2, 1e-10) for q in (p, -p))


def _arc_distance(a1, a2, b1, b2, samples=64):
    """Brute force: smallest angle between sampled points of the two arcs (upper bound)."""
    t = np.linspace(0, 1, samples)[:, None]

    def slerp(u, v):
        w = _angle(u, v)
        return (np.sin((1 - t) * w) * u + np.sin(t * w) * v) / np.sin(w)

    pa, pb = slerp(a1, a2), slerp(b1, b2)
    dots = np.clip(pa @ pb.T, -1, 1)
    return float(np.min(np.arccos(dots)))


def _fold_angles(x, closed):
    n = len(x)
    idx = range(n) if closed else range(1, n - 1)
    out = []
    for i in idx:
        a, c, b = x[i - 1], x[i], x[(i + 1) % n]
        u, w = a - np.dot(a, c) * c, b - np.dot(b, c) * c
        out.append(np.arctan2(np.dot(np.cross(-u, w), c), np.dot(-u, w)))
    return np.array(out)


def independent_certificate(path, sectors, closed):
    """Re-check a path: no crossing in any state, fold angles off ±π, and every step small
    against the (sampled) clearance so that nothing can cross between two states."""
    n = path.shape[1]
    arcs = [(i, (i + 1) % n) for i in range(n if closed else n - 1)]
    pairs = [
        (e, f)
        for e in range(len(arcs))
        for f in range(e + 1, len(arcs))
        if not set(arcs[e]) & set(arcs[f])
    ]
    clearance = []
    for x in path:
        worst = np.pi
        for e, f in pairs:
            a, b = arcs[e], arcs[f]
            assert not _arcs_intersect(x[a[0]], x[a[1]], x[b[0]], x[b[1]]), "crossing state"
            worst = min(worst, _arc_distance(x[a[0]], x[a[1]], x[b[0]], x[b[1]]))
        clearance.append(worst)
        assert np.all(np.abs(_fold_angles(x, closed)) < np.pi)
    arc_factor = 1 / np.cos(np.max(sectors) / 2)
    for k in range(len(path) - 1):
        step = np.max(np.linalg.norm(path[k + 1] - path[k], axis=1))
        # the sampled distance over-estimates the clearance by at most the sample spacing
        spacing = np.max(sectors) / 63
        assert CERT_MARGIN * step * arc_factor < min(clearance[k], clearance[k + 1]) + spacing
        dfold = np.angle(
            np.exp(1j * (_fold_angles(path[k + 1], closed) - _fold_angles(path[k], closed)))
        )
        assert np.all(np.abs(_fold_angles(path[k], closed)) + np.abs(dfold) < np.pi)


# --- the catalogue ----------------------------------------------------------------------------------

CATALOGUE = {
    "corner-cube": corner_cube,
    "waterbomb": waterbomb_base,
    "open-chain": open_chain_vertex,
}


@pytest.fixture(scope="module")
def catalogue_results():
    return {name: unfold(make()) for name, make in CATALOGUE.items()}


@pytest.mark.parametrize("name", list(CATALOGUE))
def test_catalogue_reaches_flat_with_certificate(catalogue_results, name):
    result = catalogue_results[name]
    assert result.verdict == Verdict.FLAT_UNFOLDED, result.summary()
    assert result.certificate.ok
    end = result.final
    assert np.linalg.svd(end, compute_uv=False)[-1] < 1e-4
    assert np.all(np.abs(result.fold_angles[-1]) < np.deg2rad(1.0))
    assert result.path.shape[0] == result.fold_angles.shape[0] == result.energy.shape[0]
    assert np.all(np.diff(result.energy) < 0)  # a descent


@pytest.mark.parametrize("name", list(CATALOGUE))
def test_constraints_hold_along_path(catalogue_results, name):
    result = catalogue_results[name]
    vertex = result.vertex
    residual = jax.vmap(lambda x: constraints(x, vertex.sector_angles, vertex.closed))(result.path)
    assert float(np.max(np.abs(residual))) <= CONSTRAINT_TOL


@pytest.mark.parametrize("name", list(CATALOGUE))
def test_certificate_rechecked_independently(catalogue_results, name):
    result = catalogue_results[name]
    independent_certificate(
        result.path, np.asarray(result.vertex.sector_angles), result.vertex.closed
    )


def test_paths_of_other_lengths_are_certified_by_one_program(catalogue_results):
    """`certify_path` pads a path to a power of two of states (its last repeated): a run with
    another count of steps compiles nothing again (every `unfold` took 0.7 s compiling its own),
    and the certificate is the unpadded path's."""
    from origami_jax.vertex import _unfold

    result = catalogue_results["corner-cube"]
    sectors = np.asarray(result.vertex.sector_angles)
    whole = _unfold.certify_path(result.path, sectors, closed=True)
    assert whole == result.certificate
    compiled = None
    for count in (3, 7, 9, 16):  # all padded to 16 states
        part = _unfold.certify_path(result.path[:count], sectors, closed=True)
        assert part.ok and part.n_states == count
        compiled = compiled or _unfold._measure_path._cache_size()
    assert _unfold._measure_path._cache_size() == compiled


def test_result_reports_multipliers_and_creases(catalogue_results):
    result = catalogue_results["waterbomb"]
    assert result.multipliers.shape == (16,)
    report = result.crease_report
    assert report.sign_changes.shape == report.reversals.shape == (8,)
    assert "creases" in result.summary()


@pytest.mark.slow
@pytest.mark.parametrize("make", [corner_cube, waterbomb_base, degree4_vertex])
def test_nonseparable_energy_also_unfolds(make):
    result = unfold(make(), energy="nonseparable")
    assert result.verdict == Verdict.FLAT_UNFOLDED
    independent_certificate(result.path, np.asarray(result.vertex.sector_angles), True)


def test_invalid_input_gives_invalid_verdict():
    vertex = open_chain_vertex()
    broken = SingleVertex(vertex.directions, vertex.sector_angles + 0.1, False)
    result = unfold(broken)
    assert result.verdict == Verdict.INVALID and "arc lengths" in result.reason


# --- random vertices, one vmapped compiled call per kind ------------------------------------------


@pytest.fixture(scope="module")
def random_batches():
    # Degree 5, like the corner cube and the open-chain example, so that compiled kernels are shared.
    closed = random_vertices(jax.random.key(5), N_RANDOM, 5, closed=True)
    open_ = random_vertices(jax.random.key(6), N_RANDOM, 5, closed=False)
    return {"closed": (closed, unfold_batch(closed)), "open": (open_, unfold_batch(open_))}


@pytest.mark.slow  # a batch of random vertices; the catalogue's vertices reach flat by default
@pytest.mark.parametrize("kind", ["closed", "open"])
def test_random_vertices_reach_flat(random_batches, kind):
    _, batch = random_batches[kind]
    verdicts = batch.verdicts()
    flat = np.array([v == Verdict.FLAT_UNFOLDED for v in verdicts])
    assert flat.mean() >= 0.95, verdicts
    # the rest stalled, never flat
    assert all(v == Verdict.STALLED for v, f in zip(verdicts, flat, strict=True) if not f)
    assert bool(np.all(np.asarray(batch.certified)[flat]))
    assert float(np.max(np.asarray(batch.max_residual))) <= CONSTRAINT_TOL
    end_folds = np.abs(np.asarray(batch.fold_angles))[flat]
    assert np.all(end_folds < np.deg2rad(1.0))


@pytest.mark.slow
def test_random_paths_certified_independently(random_batches):
    vertices, _ = random_batches["closed"]
    one = jax.tree.map(lambda leaf: leaf[0], vertices)
    result = unfold(one)
    assert result.verdict == Verdict.FLAT_UNFOLDED
    independent_certificate(result.path, np.asarray(one.sector_angles), True)


@pytest.mark.slow
def test_nonconvex_open_chains_never_flat_unfolded_by_separable_descent():
    # Sector sum 1.8π: outside Streinu–Whiteley; flat stops being a minimum of Eq. 1.
    vertices = random_vertices(
        jax.random.key(7), N_RANDOM, 5, closed=False, total=1.8 * np.pi, max_fold=np.deg2rad(120)
    )
    batch = unfold_batch(vertices, escapes=False)
    verdicts = set(batch.verdicts())
    assert verdicts <= {Verdict.STALLED, Verdict.FLAT_FOLDED}, verdicts
    # The batch escapes (the other energy, then other exponents) rerun the stalled members only:
    # members they bring to flat are flat and certified; every other member is left untouched.
    escaped = unfold_batch(vertices)
    used = np.asarray(escaped.escape) > 0
    assert used.any()  # 2 of the first 4 reach flat by switching energy (measured)
    flat = np.array([v == Verdict.FLAT_UNFOLDED for v in escaped.verdicts()])
    np.testing.assert_array_equal(flat, used)
    assert bool(np.all(np.asarray(escaped.certified)[used]))
    final = np.asarray(escaped.final)
    # Flat: all crease directions in one plane (smallest singular value), every fold angle < 1°.
    assert np.all(np.linalg.svd(final[used], compute_uv=False)[:, -1] < 1e-4)
    assert np.all(np.abs(np.asarray(escaped.fold_angles))[used] < np.deg2rad(1.0))
    np.testing.assert_array_equal(final[~used], np.asarray(batch.final)[~used])
    assert [v for v, u in zip(escaped.verdicts(), used, strict=True) if not u] == [
        v for v, u in zip(batch.verdicts(), used, strict=True) if not u
    ]
