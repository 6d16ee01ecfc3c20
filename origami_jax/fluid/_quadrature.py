"""Quadrature over flat polygons (host NumPy): points and area weights for integrating over panels.

Each polygon is split into a fan of triangles from its vertex mean (exact for convex and star-shaped
polygons), each triangle into ``m²`` similar sub-triangles, and each sub-triangle integrated with
Radon's 7-point rule, exact for polynomials of degree 5 (Stroud, *Approximate Calculation of Multiple
Integrals*, 1971, T2:5-1).
"""

import numpy as np

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


def polygon_quadrature(polygon: np.ndarray, subdivisions: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature points `(p, d)` and area weights `(p,)` of a flat polygon `(k, d)` (d = 2 or 3).

    ``Σ_p w_p f(x_p) = ∫ f dA`` exactly for polynomials of degree ≤ 5 in the polygon's plane; for other
    integrands the error falls like ``h⁶`` with the sub-triangle size ``h ∝ 1/subdivisions``.
    """
    polygon = np.asarray(polygon, dtype=float)
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
