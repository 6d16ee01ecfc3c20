"""A panel's outline as convex pieces: the plates of a non-convex panel (an L, a T, a notched tab).

Exact plate contact works on convex polygons (a point's distance to a polygon, two plates' overlap
by separating axes), so a panel whose outline is not convex is split into convex pieces, each a
plate of the same body: an ear-clipping triangulation whose diagonals are then removed wherever
the two pieces they separate stay convex (Hertel and Mehlhorn, 1983: at most four times the fewest
pieces, in practice the fewest for the outlines of panels). Taking its convex hull instead would
fill the notch: a panel folding into it would be stopped by a plate that is not there. A convex
outline is one piece, its convex hull.
"""

import numpy as np

from ._tables import _convex_hull

# A corner turning less than this (sine of its angle, relative to its edges) is straight: dropped.
_STRAIGHT = 1e-9
# An outline whose area is within this fraction of its hull's is convex (one piece, its hull).
_CONVEX = 1e-9


def _signed_area(xy: np.ndarray) -> float:
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _turn(o, a, b) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _corners(xy: np.ndarray) -> np.ndarray:
    """The outline's distinct corners, counter-clockwise, without repeated or straight ones."""
    points = [p for k, p in enumerate(xy) if k == 0 or np.any(p != xy[k - 1])]
    if len(points) > 1 and np.all(points[0] == points[-1]):
        points.pop()
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if _signed_area(points) < 0:
        points = points[::-1]
    changed = True
    while changed and len(points) > 3:
        changed = False
        for k in range(len(points)):
            o, a, b = points[k - 1], points[k], points[(k + 1) % len(points)]
            scale = np.linalg.norm(a - o) * np.linalg.norm(b - a)
            if abs(_turn(o, a, b)) <= _STRAIGHT * scale:
                points = np.delete(points, k, axis=0)
                changed = True
                break
    return points


def _inside_triangle(p, a, b, c) -> bool:
    return _turn(a, b, p) >= 0 and _turn(b, c, p) >= 0 and _turn(c, a, p) >= 0


def _segments_cross(p, q, r, s) -> bool:
    """Whether segments ``p–q`` and ``r–s`` share a point (touching included)."""
    d1, d2 = _turn(r, s, p), _turn(r, s, q)
    d3, d4 = _turn(p, q, r), _turn(p, q, s)
    if ((d1 > 0 and d2 < 0) or (d1 < 0 and d2 > 0)) and (
        (d3 > 0 and d4 < 0) or (d3 < 0 and d4 > 0)
    ):
        return True

    def on(a, b, c, d):  # c on segment a–b, given collinear
        return (
            d == 0
            and min(a[0], b[0]) <= c[0] <= max(a[0], b[0])
            and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])
        )

    return on(r, s, p, d1) or on(r, s, q, d2) or on(p, q, r, d3) or on(p, q, s, d4)


def _check_simple(points: np.ndarray) -> None:
    """Refuse an outline two of whose edges that are not neighbours meet."""
    n = len(points)
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # neighbours across the start
            if _segments_cross(points[i], points[(i + 1) % n], points[j], points[(j + 1) % n]):
                raise ValueError(
                    "a panel outline is not a simple polygon (its edges cross): give each face's "
                    "corners in order around it, without crossing edges."
                )


def _triangles(points: np.ndarray) -> list[tuple[int, int, int]]:
    """Ear clipping of a simple counter-clockwise polygon: triangles of corner indices."""
    ring = list(range(len(points)))
    triangles = []
    while len(ring) > 3:
        for k in range(len(ring)):
            i, j, m = ring[k - 1], ring[k], ring[(k + 1) % len(ring)]
            if _turn(points[i], points[j], points[m]) <= 0:
                continue  # a reflex corner is no ear
            others = (r for r in ring if r not in (i, j, m))
            if any(_inside_triangle(points[r], points[i], points[j], points[m]) for r in others):
                continue
            triangles.append((i, j, m))
            ring.pop(k)
            break
        else:
            raise ValueError(
                "a panel outline is not a simple polygon (its edges cross): give each face's "
                "corners in order around it, without crossing edges."
            )
    triangles.append(tuple(ring))
    return triangles


def _is_convex(points: np.ndarray, piece: list[int]) -> bool:
    count = len(piece)
    return all(
        _turn(points[piece[k - 1]], points[piece[k]], points[piece[(k + 1) % count]]) > 0
        for k in range(count)
    )


def _merged(first: list[int], second: list[int], i: int, j: int) -> list[int]:
    """The piece of `first` and `second`, which share the diagonal ``i–j`` (``i → j`` along `first`,
    ``j → i`` along `second`), counter-clockwise."""
    a = first.index(j)
    b = second.index(i)
    rolled_first = first[a:] + first[:a]  # starts at j, ends at i
    rolled_second = second[b:] + second[:b]  # starts at i, ends at j
    return rolled_first[:-1] + rolled_second[:-1]


def convex_pieces(xy) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The convex pieces of a simple planar outline `xy` `(k, 2)` (either orientation): each piece's
    corners counter-clockwise `(m, 2)`, and for each piece which of its edges (from corner ``i`` to
    ``i + 1``) lie on the outline, `(m,)` bool (the others are diagonals inside the panel). A convex
    outline is one piece, its convex hull, every edge on the outline.

    **Raises:** `ValueError` for an outline of fewer than three distinct corners or whose edges
    cross."""
    xy = np.asarray(xy, dtype=float)[:, :2]
    hull = _convex_hull(xy)
    hull_area = _signed_area(hull)
    points = _corners(xy)
    if len(points) < 3 or abs(_signed_area(points)) >= (1 - _CONVEX) * hull_area:
        return [hull], [np.ones(len(hull), bool)]
    _check_simple(points)
    pieces = [list(t) for t in _triangles(points)]
    n = len(points)
    # Remove diagonals while the two pieces they separate stay convex.
    merging = True
    while merging:
        merging = False
        for p, first in enumerate(pieces):
            for k in range(len(first)):
                i, j = first[k], first[(k + 1) % len(first)]
                if (j - i) % n == 1:
                    continue  # an edge of the outline
                for s, second in enumerate(pieces):
                    if s == p or i not in second or j not in second:
                        continue
                    if second[(second.index(j) + 1) % len(second)] != i:
                        continue
                    union = _merged(first, second, i, j)
                    if _is_convex(points, union):
                        pieces[p] = union
                        pieces.pop(s)
                        merging = True
                    break
                if merging:
                    break
            if merging:
                break
    corners = [points[piece] for piece in pieces]
    on_outline = [
        np.asarray(
            [(piece[(k + 1) % len(piece)] - piece[k]) % n == 1 for k in range(len(piece))], bool
        )
        for piece in pieces
    ]
    return corners, on_outline
