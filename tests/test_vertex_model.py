"""SingleVertex: construction, fold angles, spherical coordinates (Eq. 3), validation errors."""

import jax.numpy as jnp
import numpy as np
import pytest

from origami_jax.vertex import (
    InvalidVertexError,
    SingleVertex,
    corner_cube,
    degree4_vertex,
    fold_angles,
    open_chain_vertex,
    spherical_arc_lengths,
    to_spherical,
    validate_vertex,
    waterbomb_base,
)

DEG = np.pi / 180


def _tangent_fold_angles(x, closed):
    """Independent fold angles: signed angle between the tangent projections of the neighbours."""
    n = len(x)
    idx = range(n) if closed else range(1, n - 1)
    out = []
    for i in idx:
        a, c, b = x[i - 1], x[i], x[(i + 1) % n]
        u = a - np.dot(a, c) * c
        w = b - np.dot(b, c) * c
        out.append(np.arctan2(np.dot(np.cross(-u, w), c), np.dot(-u, w)))
    return np.array(out)


@pytest.mark.parametrize(
    "folds", [(30.0, -45.0), (170.0, -170.0), (0.0, 90.0)], ids=["mixed", "near-flat-folded", "one"]
)
def test_open_chain_fold_angles_round_trip(folds):
    sectors = np.array([50.0, 60.0, 40.0]) * DEG
    vertex = SingleVertex.from_fold_angles(sectors, np.array(folds) * DEG, closed=False)
    np.testing.assert_allclose(np.asarray(fold_angles(vertex)), np.array(folds) * DEG, atol=1e-12)
    np.testing.assert_allclose(
        _tangent_fold_angles(np.asarray(vertex.directions), False),
        np.array(folds) * DEG,
        atol=1e-12,
    )


def test_valley_is_positive_fold_convention():
    # Flap 0 in the xy-plane, front side +z; a valley lifts the next flap towards +z.
    vertex = SingleVertex.from_fold_angles([np.pi / 2, np.pi / 2], [np.pi / 4], closed=False)
    assert vertex.directions[2, 2] > 0.5


@pytest.mark.parametrize(
    "make",
    [
        corner_cube,
        waterbomb_base,
        pytest.param(degree4_vertex, marks=pytest.mark.slow),  # its own compilations (n = 4)
        open_chain_vertex,
    ],
)
def test_catalogue_is_valid_and_round_trips(make):
    vertex = make()
    report = validate_vertex(vertex)
    assert report.contacts == ()
    rebuilt = SingleVertex.from_fold_angles(
        vertex.sector_angles, fold_angles(vertex), closed=vertex.closed
    )
    # Same shape up to a rotation: compare the Gram matrices.
    x, y = np.asarray(vertex.directions), np.asarray(rebuilt.directions)
    np.testing.assert_allclose(x @ x.T, y @ y.T, atol=1e-10)


@pytest.mark.slow
def test_catalogue_shapes():
    assert corner_cube().n == 5 and waterbomb_base().n == 8 and degree4_vertex().n == 4
    assert np.all(np.abs(np.asarray(fold_angles(degree4_vertex()))) > 10 * DEG)
    folds = np.asarray(fold_angles(waterbomb_base()))
    assert np.all(folds[0::2] > 0) and np.all(folds[1::2] < 0)  # alternating valley/mountain


def test_pinched_corner_cube_is_a_contact_not_an_error():
    report = validate_vertex(corner_cube(gusset_opening=0.0))
    assert report.contacts and any("touch" in c for c in report.contacts)


def test_spherical_round_trip_and_corrected_eq3():
    vertex = waterbomb_base()
    psi, phi = to_spherical(vertex)
    again = SingleVertex.from_spherical(psi, phi, closed=True)
    np.testing.assert_allclose(
        np.asarray(again.directions), np.asarray(vertex.directions), atol=1e-12
    )
    np.testing.assert_allclose(
        np.asarray(spherical_arc_lengths(psi, phi, closed=True)),
        np.asarray(vertex.sector_angles),
        atol=1e-7,
    )


def test_from_directions_measures_sectors():
    vertex = open_chain_vertex()
    again = SingleVertex.from_directions(vertex.directions, closed=False)
    np.testing.assert_allclose(np.asarray(again.sector_angles), np.asarray(vertex.sector_angles))


# --- invalid inputs raise the documented errors -------------------------------------------------


def test_wrong_arc_lengths():
    vertex = open_chain_vertex()
    with pytest.raises(InvalidVertexError, match="arc lengths do not match"):
        SingleVertex.from_directions(
            vertex.directions, np.asarray(vertex.sector_angles) + 0.01, closed=False
        )


def test_loop_not_closing():
    with pytest.raises(InvalidVertexError, match="do not close the loop"):
        SingleVertex.from_fold_angles(np.full(4, np.pi / 2), [0.3, 0.2, 0.1, 0.0], closed=True)


def test_sector_sum_of_closed_chain():
    with pytest.raises(InvalidVertexError, match="sum to 2π"):
        SingleVertex.from_fold_angles(np.full(4, 1.5), np.zeros(4), closed=True)


@pytest.mark.parametrize("bad", [0.0, np.pi, -0.1])
def test_sector_angles_strictly_between_0_and_pi(bad):
    with pytest.raises(InvalidVertexError, match="strictly between 0 and π"):
        SingleVertex.from_fold_angles([bad, 1.0, 1.0], [0.1, 0.2], closed=False)


def test_not_unit_directions():
    x = 2 * np.asarray(open_chain_vertex().directions)
    with pytest.raises(InvalidVertexError, match="unit vectors"):
        SingleVertex.from_directions(x, closed=False)


def test_crossing_flaps():
    # A spiral: the last flap comes back across the first one.
    sectors = np.array([80.0, 80.0, 80.0, 80.0]) * DEG
    with pytest.raises(InvalidVertexError, match="cross"):
        SingleVertex.from_fold_angles(sectors, np.array([120.0, 120.0, 120.0]) * DEG, closed=False)


def test_overlapping_flaps():
    # Two non-adjacent flaps on the same great circle, one lying on the other.
    at = lambda deg: np.array([np.cos(deg * DEG), np.sin(deg * DEG), 0.0])
    x = np.stack([at(0), at(90), at(30), at(60)])
    with pytest.raises(InvalidVertexError, match="overlap|cross"):
        SingleVertex.from_directions(x, closed=False)


def test_fully_flat_folded_state_is_rejected_with_advice():
    with pytest.raises(InvalidVertexError, match="flat-folded.*Open it slightly"):
        SingleVertex.from_fold_angles([1.0, 0.5], [np.pi], closed=False)


def test_shape_errors():
    with pytest.raises(ValueError):
        SingleVertex(jnp.zeros((2, 3)), jnp.zeros(1), False)
    with pytest.raises(ValueError):
        SingleVertex(jnp.eye(3), jnp.zeros(3), False)
    with pytest.raises(InvalidVertexError, match="fold angles"):
        SingleVertex.from_fold_angles([1.0, 1.0, 1.0], [0.1], closed=False)
