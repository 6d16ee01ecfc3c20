"""Exact distances between thin plates: the contact primitives of Incremental Potential Contact.

A plate is a planar convex polygon (its mid-surface) swept by a ball of the film's half-thickness.
The distance between two disjoint convex polygons is the smallest of the distances of every
vertex of one to the other polygon (*vertex–face*) and of every edge of one to every edge of the
other (*edge–edge*), as in IPC (Li et al., SIGGRAPH 2020) for triangles; the gap between the two
plates is that distance less their two half-thicknesses. Everything here is a pure function of
world coordinates (length units), vectorised over leading axes, with finite gradients wherever the
distance is positive (squared distances: no square root at zero).

- `point_segment_sq`, `segment_segment_sq`, `point_polygon_sq`: squared distances.
- `overlap_depth`: the exact depth by which two convex plates (prisms of given thicknesses)
  overlap, the length of the shortest translation that separates them (separating axes).
- `additive_ccd`: the conservative time of impact of two primitives moving on straight paths
  (additive continuous collision detection, Li, Kaufman & Jiang, ACM TOG 2021).
"""

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float


def _dot(a, b):
    return jnp.sum(a * b, axis=-1)


# The primitives are computed component by component (``(x, y, z)`` tuples of arrays): every
# operation is then elementwise over the pairs, which XLA vectorises (over a batch too), where a
# trailing axis of three does not. The distances take the array module `xp` (`jax.numpy` by
# default, NumPy for the host-side tables in float64, `build_plate_tables`): one formula for both.


def _split(a):
    return a[..., 0], a[..., 1], a[..., 2]


def _sub(a, b):
    return tuple(u - v for u, v in zip(a, b, strict=True))


def _vdot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _vcross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _along(a, s, d):
    """``a + s d`` by component."""
    return tuple(u + s * w for u, w in zip(a, d, strict=True))


def _point_segment_sq(p, a, b, xp=jnp):
    ab = _sub(b, a)
    length_sq = _vdot(ab, ab)
    s = xp.clip(_vdot(_sub(p, a), ab) / xp.where(length_sq > 0, length_sq, 1.0), 0.0, 1.0)
    d = _sub(p, _along(a, s, ab))
    return _vdot(d, d)


def point_segment_sq(
    p: Float[Array, "*b 3"], a: Float[Array, "*b 3"], b: Float[Array, "*b 3"]
) -> Float[Array, "*b"]:
    """Squared distance from points `p` to segments ``[a, b]`` (a zero-length segment is a point)."""
    return _point_segment_sq(_split(p), _split(a), _split(b))


def _closest(p0, p1, q0, q1, xp=jnp):
    d1, d2, r = _sub(p1, p0), _sub(q1, q0), _sub(p0, q0)
    a, e = _vdot(d1, d1), _vdot(d2, d2)
    b, c, f = _vdot(d1, d2), _vdot(d1, r), _vdot(d2, r)
    denom = a * e - b * b
    parallel = denom <= 1e-12 * a * e
    s = xp.where(parallel, 0.0, xp.clip((b * f - c * e) / xp.where(parallel, 1.0, denom), 0, 1))
    t = (b * s + f) / e
    s = xp.where(t < 0, xp.clip(-c / a, 0, 1), xp.where(t > 1, xp.clip((b - c) / a, 0, 1), s))
    t = xp.clip(t, 0.0, 1.0)
    return _along(p0, s, d1), _along(q0, t, d2)


def closest_on_segments(
    p0: Float[Array, "*b 3"],
    p1: Float[Array, "*b 3"],
    q0: Float[Array, "*b 3"],
    q1: Float[Array, "*b 3"],
) -> tuple[Float[Array, "*b 3"], Float[Array, "*b 3"]]:
    """The closest points of segments ``[p0, p1]`` and ``[q0, q1]`` (Ericson, *Real-Time Collision
    Detection* §5.1.9: the closest parameters clamped to the segments, parallel segments included:
    then one of the closest pairs). Segments must have positive length."""
    on_p, on_q = _closest(*map(_split, (p0, p1, q0, q1)))
    return jnp.stack(on_p, axis=-1), jnp.stack(on_q, axis=-1)


def segment_segment_sq(
    p0: Float[ArrayLike, "*b 3"],
    p1: Float[ArrayLike, "*b 3"],
    q0: Float[ArrayLike, "*b 3"],
    q1: Float[ArrayLike, "*b 3"],
    *,
    xp=jnp,
) -> Float[ArrayLike, "*b"]:
    """Squared distance between segments ``[p0, p1]`` and ``[q0, q1]`` (`closest_on_segments`;
    `xp` the array module)."""
    on_p, on_q = _closest(*map(_split, (p0, p1, q0, q1)), xp=xp)
    d = _sub(on_p, on_q)
    return _vdot(d, d)


def _roll(components, xp=jnp):
    return tuple(xp.roll(c, -1, axis=-1) for c in components)


def _normal(vertices, xp=jnp):
    """Newell's unit normal of polygons given by component `(…, v)` arrays."""
    total = tuple(xp.sum(c, axis=-1) for c in _vcross(vertices, _roll(vertices, xp)))
    norm = xp.sqrt(_vdot(total, total))
    return tuple(c / norm for c in total)


def polygon_normal(vertices: Float[ArrayLike, "*b v 3"], *, xp=jnp) -> Float[ArrayLike, "*b 3"]:
    """Unit normal of planar polygons (Newell's sum: right-handed with counter-clockwise vertices;
    repeated vertices, the padding of shorter polygons, add nothing; `xp` the array module)."""
    return xp.stack(_normal(_split(vertices), xp), axis=-1)


def point_polygon_sq(
    p: Float[ArrayLike, "*b 3"],
    vertices: Float[ArrayLike, "*b v 3"],
    normal: Float[ArrayLike, "*b 3"],
    *,
    xp=jnp,
) -> Float[ArrayLike, "*b"]:
    """Squared distance from points `p` to convex planar polygons (`vertices` counter-clockwise
    about `normal`, padded by repeating a vertex): the squared height over the plane where the
    point projects inside, else the squared distance to the nearest edge (`xp` the array
    module)."""
    corners = _split(vertices)
    nxt = _roll(corners, xp)
    n = tuple(c[..., None] for c in _split(normal))
    point = tuple(c[..., None] for c in _split(p))
    inward = _vcross(n, _sub(nxt, corners))  # unnormalised; zero for padding edges
    inside = xp.all(_vdot(_sub(point, corners), inward) >= 0, axis=-1)
    height = _vdot(_sub(point, corners), n)[..., 0]
    to_edges = _point_segment_sq(point, corners, nxt, xp)
    return xp.where(inside, height**2, xp.min(to_edges, axis=-1))


def _closest_on_polygon(point, corners, n):
    """`closest_on_polygon` by component: `point` and `n` tuples of `(…)` arrays, `corners` of
    `(…, v)`; returns a tuple of `(…)` arrays."""
    nxt = _roll(corners)
    n = tuple(c[..., None] for c in n)
    point = tuple(c[..., None] for c in point)
    edge = _sub(nxt, corners)
    inward = _vcross(n, edge)
    to_point = _sub(point, corners)
    inside = jnp.all(_vdot(to_point, inward) >= 0, axis=-1)
    height = _vdot(to_point, n)[..., :1]
    projected = tuple((u - height * w)[..., 0] for u, w in zip(point, n, strict=True))
    length_sq = _vdot(edge, edge)
    s = jnp.clip(_vdot(to_point, edge) / jnp.where(length_sq > 0, length_sq, 1.0), 0.0, 1.0)
    on_edges = _along(corners, s, edge)
    away = _sub(point, on_edges)
    # The nearest edge as a one-hot weight (elementwise: vectorises, and differentiates without a
    # scatter); a padding edge is a point and repeats its neighbour's end.
    nearest = jax.nn.one_hot(jnp.argmin(_vdot(away, away), axis=-1), s.shape[-1], dtype=s.dtype)
    on_edge = tuple(jnp.sum(nearest * c, axis=-1) for c in on_edges)
    return tuple(jnp.where(inside, u, w) for u, w in zip(projected, on_edge, strict=True))


def closest_on_polygon(
    p: Float[Array, "*b 3"], vertices: Float[Array, "*b v 3"], normal: Float[Array, "*b 3"]
) -> Float[Array, "*b 3"]:
    """The point of convex planar polygons (`point_polygon_sq`'s arguments) closest to points `p`:
    the projection onto the plane where it falls inside, else the closest point of the nearest edge
    (the first of equals). ``|p − closest|²`` is `point_polygon_sq`."""
    closest = _closest_on_polygon(_split(p), _split(vertices), _split(normal))
    return jnp.stack(closest, axis=-1)


def overlap_depth(
    a: Float[ArrayLike, "*b v 3"],
    b: Float[ArrayLike, "*b w 3"],
    thickness_a: Float[ArrayLike, "*b"] = 0.0,
    thickness_b: Float[ArrayLike, "*b"] = 0.0,
) -> Float[Array, "*b"]:
    """How deep two convex plates overlap: the length of the shortest translation that separates
    them (0 when they are disjoint or only touch), length units.

    Each plate is the prism of a planar convex polygon (`a` `(…, v, 3)`, `b` `(…, w, 3)`, world
    coordinates, counter-clockwise, padded by repeating a vertex) and its thickness (centred on
    the polygon; 0: the polygon itself). Exact by the separating-axis theorem: the penetration depth
    of two convex polytopes is the least overlap of their projections over the directions normal to
    a face of either or to an edge of each, here the two normals, the in-plane edge normals and the
    cross products of edges and normals."""
    na, nb = polygon_normal(a), polygon_normal(b)
    ea = jnp.roll(a, -1, axis=-2) - a
    eb = jnp.roll(b, -1, axis=-2) - b
    directions_a = jnp.concatenate([ea, na[..., None, :]], axis=-2)  # (…, v + 1, 3)
    directions_b = jnp.concatenate([eb, nb[..., None, :]], axis=-2)
    crossed = jnp.cross(directions_a[..., :, None, :], directions_b[..., None, :, :])
    crossed = crossed.reshape(*crossed.shape[:-3], -1, 3)
    axes = jnp.concatenate(
        [
            na[..., None, :],
            nb[..., None, :],
            jnp.cross(na[..., None, :], ea),
            jnp.cross(nb[..., None, :], eb),
            crossed,
        ],
        axis=-2,
    )
    norm = jnp.linalg.norm(axes, axis=-1)
    scale = jnp.maximum(jnp.max(norm, axis=-1, keepdims=True), 1e-300)
    usable = norm > 1e-9 * scale
    axes = axes / jnp.where(usable, norm, 1.0)[..., None]
    pa = jnp.einsum("...vi,...ki->...kv", a, axes)
    pb = jnp.einsum("...wi,...ki->...kw", b, axes)
    half_a = 0.5 * jnp.asarray(thickness_a)[..., None] * jnp.abs(_dot(axes, na[..., None, :]))
    half_b = 0.5 * jnp.asarray(thickness_b)[..., None] * jnp.abs(_dot(axes, nb[..., None, :]))
    overlap = jnp.minimum(
        jnp.max(pa, axis=-1) + half_a - jnp.min(pb, axis=-1) + half_b,
        jnp.max(pb, axis=-1) + half_b - jnp.min(pa, axis=-1) + half_a,
    )
    overlap = jnp.where(usable, overlap, jnp.inf)
    return jnp.maximum(jnp.min(overlap, axis=-1), 0.0)


def additive_ccd(
    distance_sq,
    start: tuple[Array, ...],
    motion: tuple[Array, ...],
    separation: Float[Array, " k"],
    *,
    conservative: float = 0.1,
    max_iterations: int = 64,
) -> Float[Array, " k"]:
    """Conservative time of impact of `k` primitive pairs moving on straight paths over ``[0, 1]``
    (additive CCD, Li, Kaufman & Jiang, "Codimensional Incremental Potential Contact", 2021).

    **Arguments:**
    - `distance_sq`: ``(*points) ↦`` squared distances `(k,)` of the primitives' points.
    - `start`, `motion`: the points at ``t = 0`` and their displacements over the step, tuples of
      arrays `(k, …, 3)` (each primitive's points, world length units).
    - `separation`: ``ξ`` `(k,)`, the distance that counts as impact (length).
    - `conservative`: ``s``: a pair stops once its distance above ``ξ`` has shrunk to ``s`` times its
      value at the start.
    - `max_iterations`: pairs still advancing after this many steps are reported at their time so
      far (a conservative answer).

    **Returns:** a lower bound of each pair's time of impact in ``[0, 1]``, ``inf`` where the pair
    does not come within ``ξ`` over the step; 0 for pairs already within ``ξ`` at the start.

    The bound: with the mean displacement removed, no point moves further than ``l_p`` (the largest
    displacement of each primitive, added), so over ``Δt`` the distance shrinks at most ``l_p Δt``;
    each advance is a fraction of the distance left above ``ξ`` over ``l_p``. Several kinds of
    primitive pairs at once: `additive_ccd_groups`.
    """
    return additive_ccd_groups(
        [(distance_sq, start, motion, separation)],
        conservative=conservative,
        max_iterations=max_iterations,
    )


def _relative_moves(motion):
    """Each pair's points' displacements `(k, p, 3)` with the pair's mean displacement removed,
    and its reach ``l_p`` `(k,)`: the largest of each primitive's displacements, added (no point
    moves further relative to the other primitive)."""
    moves = [m.reshape(m.shape[0], -1, 3) for m in motion]
    mean = jnp.mean(jnp.concatenate(moves, axis=1), axis=1, keepdims=True)
    moves = [m - mean for m in moves]
    return moves, sum(jnp.max(jnp.linalg.norm(m, axis=-1), axis=-1) for m in moves)


def _clearance(d_sq, separation):
    """``d − ξ`` from squared distances, written as IPC's code does."""
    d = jnp.sqrt(jnp.maximum(d_sq, 0.0))
    return (d_sq - separation**2) / (d + separation)


def additive_ccd_groups(
    groups, *, conservative: float = 0.1, max_iterations: int = 64
) -> Float[Array, " k"]:
    """`additive_ccd` of several groups of primitive pairs (each ``(distance_sq, start, motion,
    separation)`` as its arguments; e.g. vertex–face and edge–edge pairs) in one loop, their times
    of impact concatenated in order: each pair's answer is the one `additive_ccd` gives it alone
    (every pair advances on its own; the loop runs until the slowest is done), at the cost of one
    loop rather than one per group.

    A pair whose first advance already passes the end of the step (clear over the whole step by the
    bound) gets ``inf`` without iterating; when every pair is clear the loop does not run."""
    return _additive_ccd(groups, None, conservative, max_iterations)


def _additive_ccd(groups, known, conservative: float, max_iterations: int):
    """`additive_ccd_groups`, given for each group what its caller computed already (`known`: per
    group its pairs' clearances at the start `(k,)` and `_relative_moves`; `None`: computed
    here)."""
    shapes, reaches, points_all, moves_all, separations = [], [], [], [], []
    for g, (_, start, motion, separation) in enumerate(groups):
        points = [x.reshape(x.shape[0], -1, 3) for x in start]
        moves, reach = _relative_moves(motion) if known is None else known[g][1:]
        reaches.append(reach)
        shapes.append([x.shape for x in start])
        points_all.append(points)
        moves_all.append(moves)
        separations.append(separation)
    reach = jnp.concatenate(reaches)  # l_p, (k,)
    separation = jnp.concatenate(separations)
    sizes = np.cumsum([0] + [len(r) for r in reaches])

    def clearance(t):
        gaps = []
        for g, (distance_sq, *_) in enumerate(groups):
            tg = t[sizes[g] : sizes[g + 1]]
            positions = [
                (x + tg[:, None, None] * m).reshape(shape)
                for x, m, shape in zip(points_all[g], moves_all[g], shapes[g], strict=True)
            ]
            gaps.append(distance_sq(*positions))
        return _clearance(jnp.concatenate(gaps), separation)

    if known is None:
        first = clearance(jnp.zeros_like(separation))
    else:
        first = jnp.concatenate([clear for clear, _, _ in known])
    target = conservative * first
    moving = reach > 0
    already = first <= 0
    safe_reach = jnp.where(moving, reach, 1.0)

    def cond(state):
        _, _, active, iteration = state
        return jnp.any(active) & (iteration < max_iterations)

    def body(state):
        t, advance, active, iteration = state
        t_next = jnp.where(active, t + advance, t)
        gap = clearance(t_next)
        hit = active & (gap < target)
        done = active & (t_next > 1.0)
        toi = jnp.where(hit, t, t_next)
        advance = 0.9 * jnp.maximum(gap, 0.0) / safe_reach
        return toi, advance, active & ~hit & ~done, iteration + 1

    initial_advance = (1 - conservative) * jnp.maximum(first, 0.0) / safe_reach
    # Clear over the whole step: the first advance ends past it, where the bound keeps the gap
    # above the target (a hit there, by rounding, would report t = 0, which counts as clear too).
    clear = initial_advance > 1.0
    active = moving & ~already & ~clear
    t, _, still, _ = jax.lax.while_loop(
        cond, body, (jnp.zeros_like(separation), initial_advance, active, jnp.asarray(0))
    )
    # Stopped on an impact: t; ran past the step: inf; undecided after the cap: t (conservative).
    finished = ~still & (t > 1.0)
    toi = jnp.where(already, 0.0, jnp.where(~moving | finished | clear, jnp.inf, t))
    return toi


def earliest_impact(
    groups, *, limit: int = 32, conservative: float = 0.1, max_iterations: int = 64
) -> Float[Array, ""]:
    """The earliest conservative time of impact over several groups of primitive pairs (arguments
    as `additive_ccd_groups`'s), ignoring pairs already within ``ξ`` at the start (``inf`` where no
    pair comes within ``ξ`` over the step): the least of `additive_ccd_groups`'s answers that are
    positive, bounded from below at the cost of iterating at most `limit` pairs per group.

    Every pair's first advance is a lower bound of its time of impact (the distance above ``ξ``
    cannot shrink faster than the pair's reach). Only the `limit` pairs of each group with the
    smallest such bound are iterated (`additive_ccd_groups`); any other pair is either clear over
    the whole step or contributes its first advance, itself a lower bound. The answer is therefore
    conservative always, and the same as iterating every pair whenever at most `limit` pairs of a
    group are undecided by their first advance. Iterating a few pairs rather than every one is
    what keeps the check cheap under `vmap`, where the loop runs until the slowest member's pairs
    are done."""
    subgroups, known, rest = [], [], []
    for distance_sq, start, motion, separation in groups:
        k = separation.shape[0]
        moves, reach = _relative_moves(motion)
        first = _clearance(distance_sq(*start), separation)
        advance = (1 - conservative) * jnp.maximum(first, 0.0) / jnp.where(reach > 0, reach, 1.0)
        undecided = (reach > 0) & (first > 0) & (advance <= 1.0)
        key = jnp.where(undecided, advance, jnp.inf)
        chosen = min(limit, k)
        smallest, index = jax.lax.top_k(-key, min(chosen + 1, k))
        if k > chosen:
            rest.append(-smallest[chosen])
        index = index[:chosen]
        subgroups.append(
            (
                distance_sq,
                tuple(x[index] for x in start),
                tuple(m[index] for m in motion),
                separation[index],
            )
        )
        # The chosen pairs' clearances and moves, computed above: not again in the loop's setup.
        known.append((first[index], [m[index] for m in moves], reach[index]))
    toi = _additive_ccd(subgroups, known, conservative, max_iterations)
    earliest = jnp.min(jnp.where(toi > 0, toi, jnp.inf), initial=jnp.inf)
    for bound in rest:
        earliest = jnp.minimum(earliest, bound)
    return earliest
