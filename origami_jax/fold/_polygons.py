"""Polygon helpers for nets: triangulating faces and testing whether face interiors intersect.

Plain numpy. A face is triangulated once, in the flat pattern (ear clipping); its triangles move
rigidly with it, so the same triangles serve every folded state. Two faces *overlap* when their
interiors intersect: faces that only touch (along a crease, a seam, a corner) do not overlap.

- Coplanar triangles: separating-axis test on the six edge normals; the triangles overlap when
  their projections overlap by more than `tol` on every axis.
- Other triangles: each must cross the other's plane strictly (vertices more than `tol` on both
  sides; a triangle touching a plane only along an edge or a corner has no interior point in it),
  and the two chords on the planes' common line must overlap by more than `tol` (the triangle
  intersection test of Möller, J. Graphics Tools 2, 1997, with strict inequalities).
"""

from __future__ import annotations

import numpy as np

# Corners whose turn (twice the triangle area) is below this fraction of the face's squared size
# are collinear: they add no area and are left out of the triangles.
COLLINEAR_REL_TOL = 1e-12


def signed_area(xy: np.ndarray) -> float:
    """The area of the polygon with corners `xy` `(k, 2)` (shoelace), positive when they run
    counter-clockwise."""
    return 0.5 * float(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))


def triangulate(xy: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles `(i, j, k)` (indices into `xy`, counter-clockwise) covering a simple polygon.

    **Arguments:** `xy`: float64 `(n, 2)`, the polygon's corners counter-clockwise.

    **Returns:** `n_effective - 2` triangles, `n_effective` the number of corners that are not
    collinear with their neighbours (those are skipped: they add no area).

    **Raises:** `ValueError` if the polygon is not simple (it crosses itself) or not
    counter-clockwise.
    """
    xy = np.asarray(xy, dtype=float)
    size2 = max(float(np.max(np.ptp(xy, axis=0))) ** 2, 1e-300)
    eps = COLLINEAR_REL_TOL * size2

    def turn(a: int, b: int, c: int) -> float:
        (ax, ay), (bx, by), (cx, cy) = xy[a], xy[b], xy[c]
        return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)

    def drop_collinear(ring: list[int]) -> list[int]:
        changed = True
        while changed and len(ring) > 3:
            changed = False
            for k in range(len(ring)):
                if abs(turn(ring[k - 1], ring[k], ring[(k + 1) % len(ring)])) <= eps:
                    ring.pop(k)
                    changed = True
                    break
        return ring

    ring = drop_collinear(list(range(len(xy))))
    triangles: list[tuple[int, int, int]] = []
    while len(ring) > 3:
        for k in range(len(ring)):
            a, b, c = ring[k - 1], ring[k], ring[(k + 1) % len(ring)]
            if turn(a, b, c) <= eps:
                continue  # a reflex corner is not an ear
            others = [w for w in ring if w not in (a, b, c)]
            if not any(_in_closed_triangle(xy[w], xy[a], xy[b], xy[c], eps) for w in others):
                triangles.append((a, b, c))
                ring.pop(k)
                ring = drop_collinear(ring)
                break
        else:
            raise ValueError("the polygon is not simple (no ear left to clip)")
    if len(ring) == 3:
        if turn(*ring) <= eps:
            raise ValueError("the polygon is degenerate or clockwise")
        triangles.append((ring[0], ring[1], ring[2]))
    area = 0.5 * float(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))
    covered = sum(0.5 * turn(*t) for t in triangles)
    if area <= 0 or abs(covered - area) > 1e-9 * max(area, size2):
        raise ValueError("the polygon is not simple (it crosses itself) or not counter-clockwise")
    return triangles


def _in_closed_triangle(
    p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, eps: float
) -> bool:
    d1 = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    d2 = (c[0] - b[0]) * (p[1] - b[1]) - (c[1] - b[1]) * (p[0] - b[0])
    d3 = (a[0] - c[0]) * (p[1] - c[1]) - (a[1] - c[1]) * (p[0] - c[0])
    return bool(d1 >= -eps and d2 >= -eps and d3 >= -eps)


def _sat_overlap_2d(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """Whether coplanar triangles' interiors overlap: `a`, `b` `(P, 3, 2)` → bool `(P,)`."""
    edges = np.concatenate([np.roll(a, -1, axis=1) - a, np.roll(b, -1, axis=1) - b], axis=1)
    axes = np.stack([-edges[..., 1], edges[..., 0]], axis=-1)  # (P, 6, 2)
    axes = axes / np.maximum(np.linalg.norm(axes, axis=-1, keepdims=True), 1e-300)
    pa = np.einsum("pkd,pvd->pkv", axes, a)
    pb = np.einsum("pkd,pvd->pkv", axes, b)
    overlap = np.minimum(pa.max(-1), pb.max(-1)) - np.maximum(pa.min(-1), pb.min(-1))
    return np.all(overlap > tol, axis=-1)


def _chord(tri: np.ndarray, dist: np.ndarray, line: np.ndarray, tol: float) -> np.ndarray:
    """Interval `(P, 2)` along `line` `(P, 3)` of a triangle's cut by a plane (signed `dist` (P, 3))."""
    sign = np.where(np.abs(dist) <= tol, 0.0, np.sign(dist))
    lo = np.full(len(tri), np.inf)
    hi = np.full(len(tri), -np.inf)
    for i in range(3):
        j = (i + 1) % 3
        # a corner lying in the plane
        t_corner = np.einsum("pd,pd->p", tri[:, i], line)
        on = sign[:, i] == 0
        lo = np.where(on, np.minimum(lo, t_corner), lo)
        hi = np.where(on, np.maximum(hi, t_corner), hi)
        # an edge crossing the plane strictly
        crosses = sign[:, i] * sign[:, j] < 0
        denom = np.where(crosses, dist[:, i] - dist[:, j], 1.0)
        point = tri[:, i] + (tri[:, j] - tri[:, i]) * (dist[:, i] / denom)[:, None]
        t_edge = np.einsum("pd,pd->p", point, line)
        lo = np.where(crosses, np.minimum(lo, t_edge), lo)
        hi = np.where(crosses, np.maximum(hi, t_edge), hi)
    return np.stack([lo, hi], axis=-1)


def triangles_overlap(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """Whether the interiors of triangle pairs intersect (see the module docstring).

    **Arguments:** `a`, `b`: float64 `(P, 3, 3)`, triangles in 3D; `tol`: a length (the same unit).

    **Returns:** bool `(P,)`.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    out = np.zeros(len(a), dtype=bool)
    if len(a) == 0:
        return out
    na = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    nb = np.cross(b[:, 1] - b[:, 0], b[:, 2] - b[:, 0])
    na = na / np.linalg.norm(na, axis=-1, keepdims=True)
    nb = nb / np.linalg.norm(nb, axis=-1, keepdims=True)
    db = np.einsum("pvd,pd->pv", b - a[:, :1], na)  # b's corners above a's plane
    da = np.einsum("pvd,pd->pv", a - b[:, :1], nb)
    coplanar = np.all(np.abs(db) <= tol, axis=-1) & np.all(np.abs(da) <= tol, axis=-1)
    if np.any(coplanar):
        u = a[coplanar, 1] - a[coplanar, 0]
        u = u / np.linalg.norm(u, axis=-1, keepdims=True)
        v = np.cross(na[coplanar], u)
        basis = np.stack([u, v], axis=1)  # (Q, 2, 3)
        a2 = np.einsum("qvd,qkd->qvk", a[coplanar], basis)
        b2 = np.einsum("qvd,qkd->qvk", b[coplanar], basis)
        out[coplanar] = _sat_overlap_2d(a2, b2, tol)
    straddle = (
        ~coplanar
        & (db.max(-1) > tol)
        & (db.min(-1) < -tol)
        & (da.max(-1) > tol)
        & (da.min(-1) < -tol)
    )
    if np.any(straddle):
        line = np.cross(na[straddle], nb[straddle])
        line = line / np.linalg.norm(line, axis=-1, keepdims=True)
        ca = _chord(a[straddle], da[straddle], line, tol)
        cb = _chord(b[straddle], db[straddle], line, tol)
        overlap = np.minimum(ca[:, 1], cb[:, 1]) - np.maximum(ca[:, 0], cb[:, 0])
        out[straddle] = overlap > tol
    return out


def overlapping_pairs(
    triangles: np.ndarray, owners: np.ndarray, tol: float
) -> list[tuple[int, int]]:
    """Pairs of owners (faces) with a triangle each whose interiors intersect.

    **Arguments:**
    - `triangles`: float64 `(T, 3, 3)`, every face's triangles in their current position.
    - `owners`: int `(T,)`, the face each triangle belongs to (triangles of one face are never
      tested against each other).
    - `tol`: length below which separations and penetrations do not count.

    **Returns:** sorted `(f, g)` pairs, `f < g`.
    """
    lo = triangles.min(axis=1) - tol
    hi = triangles.max(axis=1) + tol
    pairs: set[tuple[int, int]] = set()
    chunk = 512
    for start in range(0, len(triangles), chunk):
        stop = min(start + chunk, len(triangles))
        boxes = np.all(
            (lo[start:stop, None] <= hi[None]) & (lo[None] <= hi[start:stop, None]), axis=-1
        )
        i, j = np.nonzero(boxes)
        i = i + start
        keep = (i < j) & (owners[i] != owners[j])
        i, j = i[keep], j[keep]
        hit = triangles_overlap(triangles[i], triangles[j], tol)
        for f, g in zip(owners[i[hit]].tolist(), owners[j[hit]].tolist(), strict=True):
            pairs.add((min(f, g), max(f, g)))
    return sorted(pairs)
