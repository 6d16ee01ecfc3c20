"""Quadrature over flat polygons (host NumPy): points and area weights for integrating over panels.

Each polygon is split into a fan of triangles from its vertex mean (a polygon that is not convex
first into its convex pieces, `origami_jax.fold.convex_pieces`: a fan from the mean of an L or a U
would cover ground outside it), each triangle into ``m²`` similar sub-triangles, and each
sub-triangle integrated with Radon's 7-point rule, exact for polynomials of degree 5 (Stroud,
*Approximate Calculation of Multiple Integrals*, 1971, T2:5-1).
"""

import numpy as np

from ..fold import convex_pieces

_A1 = (6 - np.sqrt(15)) / 21
_A2 = (6 + np.sqrt(15)) / 21
_W1 = (155 - np.sqrt(15)) / 1200
_W2 = (155 + np.sqrt(15)) / 1200
# Barycentric coordinates and weights (summing to 1) of Radon's degree-5 rule.
_RADON = np.array(
    [
        [1 / 3, 1 / 3, 1 / 3, 9 / 40],
        [_A1, _A1, 1 - 2 * _A1, _W1],
        [_A1, 1 - 2 * _A1, _A1, _W1],
        [1 - 2 * _A1, _A1, _A1, _W1],
        [_A2, _A2, 1 - 2 * _A2, _W2],
        [_A2, 1 - 2 * _A2, _A2, _W2],
        [1 - 2 * _A2, _A2, _A2, _W2],
    ]
)


def _sub_triangles(a: np.ndarray, b: np.ndarray, c: np.ndarray, m: int) -> list[np.ndarray]:
    """The ``m²`` similar triangles of a regular subdivision of triangle ``abc``."""

    def point(i, j):
        return a + (i / m) * (b - a) + (j / m) * (c - a)

    triangles = []
    for i in range(m):
        for j in range(m - i):
            triangles.append(np.stack([point(i, j), point(i + 1, j), point(i, j + 1)]))
            if i + j < m - 1:
                triangles.append(np.stack([point(i + 1, j), point(i + 1, j + 1), point(i, j + 1)]))
    return triangles


def _convex_parts(polygon: np.ndarray) -> list[np.ndarray] | None:
    """A flat polygon `(k, d)`'s convex pieces in its own coordinates, or `None` where it is
    convex (integrated whole)."""
    if polygon.shape[1] == 2:
        origin, axes = np.zeros(2), np.eye(2)
    else:
        normal = np.sum(np.cross(polygon, np.roll(polygon, -1, axis=0)), axis=0)
        edge = polygon[1] - polygon[0]
        u = edge / np.linalg.norm(edge)
        w = np.cross(normal, u)
        origin, axes = polygon[0], np.stack([u, w / np.linalg.norm(w)])
    pieces, _ = convex_pieces((polygon - origin) @ axes.T)
    if len(pieces) == 1:
        return None
    return [origin + piece @ axes for piece in pieces]


def polygon_quadrature(polygon: np.ndarray, subdivisions: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature points `(p, d)` and area weights `(p,)` of a flat polygon `(k, d)` (d = 2 or 3).

    ``Σ_p w_p f(x_p) = ∫ f dA`` exactly for polynomials of degree ≤ 5 in the polygon's plane; for other
    integrands the error falls like ``h⁶`` with the sub-triangle size ``h ∝ 1/subdivisions``. A
    polygon that is not convex is integrated piece by piece (its convex pieces): every point lies in
    it and every weight is positive.
    """
    polygon = np.asarray(polygon, dtype=float)
    parts = _convex_parts(polygon)
    if parts is not None:
        rules = [polygon_quadrature(part, subdivisions) for part in parts]
        return np.concatenate([r[0] for r in rules]), np.concatenate([r[1] for r in rules])
    centre = polygon.mean(axis=0)
    points, weights = [], []
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        for tri in _sub_triangles(centre, a, b, subdivisions):
            edge1, edge2 = tri[1] - tri[0], tri[2] - tri[0]
            if polygon.shape[1] == 2:
                area = 0.5 * abs(edge1[0] * edge2[1] - edge1[1] * edge2[0])
            else:
                area = 0.5 * float(np.linalg.norm(np.cross(edge1, edge2)))
            points.append(_RADON[:, :3] @ tri)
            weights.append(area * _RADON[:, 3])
    return np.concatenate(points), np.concatenate(weights)
