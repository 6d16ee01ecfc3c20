"""Mass properties of polygonal plates (`origami_jax.net.polygon_plate`) against closed forms and
an independent quadrature."""

import jax
import numpy as np
import pytest
from matplotlib.path import Path
from scipy.spatial.transform import Rotation

import origami_jax.chain as oc
from origami_jax.net import polygon_plate

# Closed forms and the same formulas by other algebra: round-off of sums of O(10⁴·L²) terms.
EXACT_RTOL = 1e-12
# Midpoint quadrature on a 2000² grid: the boundary cells carry an O(h/L) error, ~1e-3.
GRID_RTOL = 3e-3

THICKNESS, DENSITY = 0.2, 3.1e-3
PLACEMENT = Rotation.from_euler("xyz", [0.4, -0.7, 1.1]).as_matrix(), np.array([30.0, -12.0, 5.0])


def _place(points_2d):
    """Planar points into 3D: a tilted plane through an offset origin."""
    rotation, offset = PLACEMENT
    flat = np.column_stack([points_2d, np.zeros(len(points_2d))])
    return flat @ rotation.T + offset


def _plate_of(points_2d, **kwargs):
    rotation, _ = PLACEMENT
    plate = polygon_plate(
        _place(points_2d), thickness=THICKNESS, density=DENSITY, x_axis=rotation[:, 0], **kwargs
    )
    # With x_axis the plane's first axis, the plate frame is the placement rotated: compare in 2D.
    assert np.allclose(np.asarray(plate.frame[:3, :3]), rotation, atol=1e-14)
    return plate


def _inertia_from_second_moments(area, sxx, syy, sxy):
    """Prism inertia about the CG from the area's central second moments (module formula)."""
    areal = DENSITY * THICKNESS
    mass = areal * area
    flat = mass * THICKNESS**2 / 12
    return mass, np.array(
        [
            [areal * syy + flat, -areal * sxy, 0.0],
            [-areal * sxy, areal * sxx + flat, 0.0],
            [0.0, 0.0, areal * (sxx + syy)],
        ]
    )


def test_rectangle_matches_the_cuboid_formula():
    length, width = 180.0, 70.0
    corners = np.array([[0, 0], [width, 0], [width, length], [0, length]]) - [20.0, 35.0]
    plate = _plate_of(corners)
    mass, inertia = oc.plate_inertia(length, width, THICKNESS, DENSITY)
    np.testing.assert_allclose(plate.mass, mass, rtol=EXACT_RTOL)
    assert np.max(np.abs(plate.inertia - inertia)) < EXACT_RTOL * np.max(np.abs(inertia))
    centre = _place(np.array([[width / 2 - 20.0, length / 2 - 35.0]]))[0]
    np.testing.assert_allclose(plate.frame[:3, 3], centre, rtol=EXACT_RTOL)


def test_triangle_matches_the_vertex_covariance():
    """For a triangle about its centroid, ``∫ r rᵀ dA = (A/12) Σ d_i d_iᵀ`` (d_i the vertices
    relative to the centroid), and the centroid is the vertex mean."""
    vertices = np.array([[0.0, 0.0], [140.0, 30.0], [50.0, 110.0]])
    plate = _plate_of(vertices)
    centroid = vertices.mean(axis=0)
    d = vertices - centroid
    e1, e2 = vertices[1] - vertices[0], vertices[2] - vertices[0]
    area = 0.5 * abs(e1[0] * e2[1] - e1[1] * e2[0])
    moments = area / 12 * d.T @ d
    mass, inertia = _inertia_from_second_moments(area, moments[0, 0], moments[1, 1], moments[0, 1])
    np.testing.assert_allclose(plate.mass, mass, rtol=EXACT_RTOL)
    assert np.max(np.abs(plate.inertia - inertia)) < EXACT_RTOL * np.max(np.abs(inertia))
    np.testing.assert_allclose(plate.frame[:3, 3], _place(centroid[None])[0], rtol=EXACT_RTOL)


def test_rectilinear_polygon_matches_its_rectangles():
    """A non-convex L shape is two rectangles: mass, CG and inertia by the parallel-axis theorem."""
    shape = np.array([[0, 0], [120, 0], [120, 40], [50, 40], [50, 150], [0, 150]], dtype=float)
    plate = _plate_of(shape)
    pieces = [((60.0, 20.0), 120.0, 40.0), ((25.0, 95.0), 50.0, 110.0)]  # centre, width, height
    areas = np.array([w * h for _, w, h in pieces])
    centres = np.array([c for c, _, _ in pieces])
    centroid = areas @ centres / areas.sum()
    sxx = sum(
        a * w**2 / 12 + a * (c[0] - centroid[0]) ** 2
        for a, (c, w, _) in zip(areas, pieces, strict=True)
    )
    syy = sum(
        a * h**2 / 12 + a * (c[1] - centroid[1]) ** 2
        for a, (c, _, h) in zip(areas, pieces, strict=True)
    )
    sxy = sum(
        a * (c[0] - centroid[0]) * (c[1] - centroid[1])
        for a, (c, _, _) in zip(areas, pieces, strict=True)
    )
    mass, inertia = _inertia_from_second_moments(areas.sum(), sxx, syy, sxy)
    np.testing.assert_allclose(plate.mass, mass, rtol=EXACT_RTOL)
    assert np.max(np.abs(plate.inertia - inertia)) < EXACT_RTOL * np.max(np.abs(inertia))
    np.testing.assert_allclose(plate.frame[:3, 3], _place(centroid[None])[0], rtol=EXACT_RTOL)


def test_irregular_polygon_matches_grid_quadrature():
    """A non-convex heptagon with slanted edges against midpoint quadrature on a fine grid."""
    shape = np.array(
        [[0, 0], [130, 20], [90, 60], [150, 130], [60, 110], [20, 160], [-30, 70]], dtype=float
    )
    plate = _plate_of(shape)
    n = 2000
    lo, hi = shape.min(axis=0), shape.max(axis=0)
    h = (hi - lo) / n
    x, y = np.meshgrid(lo[0] + h[0] * (np.arange(n) + 0.5), lo[1] + h[1] * (np.arange(n) + 0.5))
    points = np.column_stack([x.ravel(), y.ravel()])
    inside = points[Path(shape).contains_points(points)]
    cell = h[0] * h[1]
    area = len(inside) * cell
    centroid = inside.mean(axis=0)
    d = inside - centroid
    moments = cell * d.T @ d
    mass, inertia = _inertia_from_second_moments(area, moments[0, 0], moments[1, 1], moments[0, 1])
    np.testing.assert_allclose(plate.mass, mass, rtol=GRID_RTOL)
    assert np.max(np.abs(plate.inertia - inertia)) < GRID_RTOL * np.max(np.abs(inertia))
    offset = np.linalg.norm(plate.frame[:3, 3] - _place(centroid[None])[0])
    assert offset < GRID_RTOL * np.max(hi - lo)


def test_orientation_and_derivatives():
    """Clockwise vertices describe the same plate (the normal flips); mass is linear in t and ρ."""
    shape = np.array([[0, 0], [130, 20], [90, 60], [150, 130], [60, 110]], dtype=float)
    forward = _plate_of(shape)
    backward = polygon_plate(_place(shape[::-1]), thickness=THICKNESS, density=DENSITY)
    np.testing.assert_allclose(backward.mass, forward.mass, rtol=EXACT_RTOL)
    np.testing.assert_allclose(backward.frame[:3, 2], -forward.frame[:3, 2], atol=1e-14)
    dm_dt = jax.grad(lambda t: polygon_plate(_place(shape), thickness=t, density=DENSITY).mass)
    np.testing.assert_allclose(dm_dt(THICKNESS), DENSITY * forward.area, rtol=EXACT_RTOL)


@pytest.mark.parametrize(
    "vertices, message",
    [
        (np.array([[0.0, 0, 0], [1, 0, 0]]), "at least 3 vertices"),
        (np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), "zero area"),
        (np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0]]), "not planar"),
        (np.array([[0.0, 0, 0], [2, 2, 0], [2, 0, 0], [0, 1, 0]]), "crosses itself"),
    ],
)
def test_bad_polygons_are_rejected(vertices, message):
    with pytest.raises(ValueError, match=message):
        polygon_plate(vertices, thickness=THICKNESS, density=DENSITY)


def test_known_and_traced_plates_are_the_same_numbers():
    """Known vertices, thickness and density take the host (NumPy) path, anything traced the JAX
    one: the same formulas, the same numbers to round-off, and every field a JAX array."""
    shape = np.array([[0, 0], [130, 20], [90, 60], [150, 130], [60, 110]], dtype=float)
    axis = np.array([1.0, 0.2, 0.0])
    host = polygon_plate(_place(shape), thickness=THICKNESS, density=DENSITY, x_axis=axis)
    traced = jax.jit(lambda v, t: polygon_plate(v, thickness=t, density=DENSITY, x_axis=axis))(
        _place(shape), THICKNESS
    )
    for name in host._fields:
        assert isinstance(getattr(host, name), jax.Array)
        np.testing.assert_allclose(
            getattr(host, name), getattr(traced, name), rtol=1e-13, atol=1e-9
        )
