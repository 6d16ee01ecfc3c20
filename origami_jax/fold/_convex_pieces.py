"""A panel's outline as convex pieces: the plates of a non-convex panel (an L, a T, a notched tab).

Exact plate contact works on convex polygons (a point's distance to a polygon, two plates' overlap
by separating axes), so a panel whose outline is not convex is split into convex pieces, each a
plate of the same body: an ear-clipping triangulation (`triangulate`, as a FOLD file's faces are
triangulated) whose diagonals are then removed wherever the two pieces they separate stay convex
(Hertel and Mehlhorn, 1983: at most four times the fewest pieces; the fewest over several starting
corners is kept). Taking its convex hull instead would
fill the notch: a panel folding into it would be stopped by a plate that is not there. A convex
outline is one piece, its convex hull.
"""

import numpy as np

from ._polygons import signed_area, triangulate


def _turn(o, a, b) -> float:
    """Twice the signed area of the triangle ``o, a, b`` (positive when it turns left)."""
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def convex_hull(xy: np.ndarray) -> np.ndarray:
    """The convex hull of points `xy` `(k, 2)`: its corners counter-clockwise, `(m, 2)` (Andrew's
    monotone chain; points on its edges left out).

    **Raises:** `ValueError` for fewer than three distinct points."""
    pts = sorted({(float(x), float(y)) for x, y in xy})
    if len(pts) < 3:
        raise ValueError("a contact outline needs at least three distinct corners.")
    lower: list = []
    for p in pts:
        while len(lower) >= 2 and _turn(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in reversed(pts):
        while len(upper) >= 2 and _turn(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.asarray(lower[:-1] + upper[:-1])


# An outline whose area is within this fraction of its hull's is convex (one piece, its hull).
_CONVEX = 1e-9
# Triangulations tried (`convex_pieces`), each clipping from another corner first.
_STARTS = 16


def _corners(xy: np.ndarray) -> np.ndarray:
    """The outline's distinct corners, counter-clockwise (repeats and a closing repeat dropped)."""
    points = [p for k, p in enumerate(xy) if k == 0 or np.any(p != xy[k - 1])]
    if len(points) > 1 and np.all(points[0] == points[-1]):
        points.pop()
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return points[::-1] if signed_area(points) < 0 else points


def _is_convex(points: np.ndarray, piece: list[int]) -> bool:
    count = len(piece)
    return all(
        _turn(points[piece[k - 1]], points[piece[k]], points[piece[(k + 1) % count]]) > 0
        for k in range(count)
    )


def _merged(first: list[int], second: list[int], i: int, j: int) -> list[int]:
    """The piece of `first` and `second`, which share the diagonal ``i–j`` (``i → j`` along
    `first`, ``j → i`` along `second`), counter-clockwise."""
    a = first.index(j)
    b = second.index(i)
    rolled_first = first[a:] + first[:a]  # starts at j, ends at i
    rolled_second = second[b:] + second[:b]  # starts at i, ends at j
    return rolled_first[:-1] + rolled_second[:-1]


def _merged_triangles(points: np.ndarray) -> tuple[list[list[int]], dict[int, int]]:
    """Hertel and Mehlhorn's pieces of a simple counter-clockwise polygon from its ear-clipping
    triangulation (corner indices, counter-clockwise), and each used corner's next one along the
    outline (a piece's edge to it lies on the outline; any other edge is a diagonal)."""
    pieces = [list(t) for t in triangulate(points)]
    # Straight corners are left out of the triangles.
    used = sorted({i for piece in pieces for i in piece})
    following = {i: used[(k + 1) % len(used)] for k, i in enumerate(used)}
    # Remove diagonals while the two pieces they separate stay convex.
    merging = True
    while merging:
        merging = False
        for p, first in enumerate(pieces):
            for k in range(len(first)):
                i, j = first[k], first[(k + 1) % len(first)]
                if following[i] == j:
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
    return pieces, following


def convex_pieces(xy) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The convex pieces of a simple planar outline `xy` `(k, 2)` (either orientation): each piece's
    corners counter-clockwise `(m, 2)`, and for each piece which of its edges (from corner ``i`` to
    ``i + 1``) lie on the outline, `(m,)` bool (the others are diagonals inside the panel). A convex
    outline is one piece, its convex hull, every edge on the outline.

    Hertel and Mehlhorn's decomposition depends on the triangulation it starts from: the clipping
    starts at each of the first `_STARTS` corners in turn, and the fewest pieces are kept (an L or a
    T then comes out as its two rectangles' worth).

    **Raises:** `ValueError` for an outline of fewer than three distinct corners or whose edges
    cross."""
    xy = np.asarray(xy, dtype=float)[:, :2]
    hull = convex_hull(xy)
    points = _corners(xy)
    if len(points) < 3 or signed_area(points) >= (1 - _CONVEX) * signed_area(hull):
        return [hull], [np.ones(len(hull), bool)]
    n = len(points)
    best = None
    for start in range(min(n, _STARTS)):
        order = np.roll(np.arange(n), -start)
        try:
            pieces, following = _merged_triangles(points[order])
        except ValueError:
            raise ValueError(
                "a panel outline is not a simple polygon (its edges cross): give each face's "
                "corners in order around it, without crossing edges."
            ) from None
        if best is None or len(pieces) < len(best[0]):
            # Back to the outline's own corner numbers.
            best = (
                [[int(order[i]) for i in piece] for piece in pieces],
                {int(order[i]): int(order[j]) for i, j in following.items()},
            )
    pieces, following = best
    corners = [points[piece] for piece in pieces]
    on_outline = [
        np.asarray([following[piece[k]] == piece[(k + 1) % len(piece)] for k in range(len(piece))])
        for piece in pieces
    ]
    return corners, on_outline
