"""Mass, centre of gravity and inertia of a uniform polygonal plate (a panel of a net).

A panel is a right prism: a simple polygon (any number of vertices, convex or not) in a plane,
extruded by the thickness ``t`` symmetrically about that plane (the polygon is the mid-surface), of
uniform density ``ρ``. In plate coordinates ``(x, y)`` in the plane and ``z`` along the normal, with
``k`` vertices ``(x_i, y_i)`` counter-clockwise and ``a_i = x_i y_{i+1} − x_{i+1} y_i`` (Green's
theorem over the edges; e.g. Bourke, "Calculating the area and centroid of a polygon", 1988, and the
second moments in Steger, "On the calculation of arbitrary moments of polygons", 1996):

    A = ½ Σ a_i,                  x̄ = Σ (x_i + x_{i+1}) a_i / (6A),   ȳ likewise,
    ∫x² dA = Σ (x_i² + x_i x_{i+1} + x_{i+1}²) a_i / 12,               ∫y² dA likewise,
    ∫xy dA = Σ (x_i y_{i+1} + 2 x_i y_i + 2 x_{i+1} y_{i+1} + x_{i+1} y_i) a_i / 24.

With ``m = ρ t A`` and the second moments taken about the centroid, the inertia about the CG is

    I_xx = ρ t ∫y² dA + m t²/12,   I_yy = ρ t ∫x² dA + m t²/12,   I_zz = ρ t ∫(x² + y²) dA,
    I_xy = −ρ t ∫xy dA,            I_xz = I_yz = 0   (the prism is symmetric about its mid-plane),

exact for any thickness (a rectangle gives `origami_jax.chain.plate_inertia`'s cuboid formulas).
Everything is JAX, differentiable in the vertices, the thickness and the density.
"""

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validate import as_float_array, check_shape, is_traced

# A polygon is planar when no vertex is farther than this, relative to its diameter, from the plane
# through its centroid with its area normal: drawing noise of a flat pattern is far smaller.
PLANARITY_TOLERANCE = 1e-6


class Plate(NamedTuple):
    """A plate's mass properties.

    - `mass`: ``ρ t A``, mass units, shape `()`.
    - `frame`: pose of the plate frame in the polygon's coordinates, `(4, 4)`: origin at the CG (the
      polygon's centroid), ``z`` along the normal (the polygon is counter-clockwise seen from ``+z``),
      ``x`` along `x_axis` (projected into the plane) or the first edge.
    - `inertia`: inertia about the CG in the plate frame's axes, `(3, 3)`, mass·length².
    - `area`: ``A``, length², shape `()`.
    """

    mass: Float[Array, ""]
    frame: Float[Array, "4 4"]
    inertia: Float[Array, "3 3"]
    area: Float[Array, ""]


def polygon_normal(vertices: Float[ArrayLike, "k 3"]) -> Float[Array, "3"]:
    """Area vector ``½ Σ v_i × v_{i+1}`` (Newell's method): normal to the polygon, length = area,
    pointing to the side from which the vertices run counter-clockwise."""
    return _area_vector(jnp.asarray(vertices), jnp)


def _area_vector(v, xp):
    """`polygon_normal` with the array module `xp` (`jax.numpy`, or `numpy` for known vertices)."""
    return 0.5 * xp.sum(xp.cross(v, xp.roll(v, -1, axis=0)), axis=0)


def polygon_plate(
    vertices: Float[ArrayLike, "k 3"],
    *,
    thickness: Float[ArrayLike, ""],
    density: Float[ArrayLike, ""],
    x_axis: Float[ArrayLike, "3"] | None = None,
) -> Plate:
    """Mass, CG frame and inertia of a uniform plate on a simple polygon (module docstring).

    **Arguments:**
    - `vertices`: the polygon's corners in 3D, `(k, 3)`, ``k ≥ 3``, all in one plane, in order
      (either orientation: the normal is chosen so that they run counter-clockwise about it), length.
    - `thickness` ``t`` (length), `density` ``ρ`` (mass/length³): scalars.
    - `x_axis`: direction of the plate frame's ``x`` (projected into the plane; e.g. the hinge axis),
      `(3,)`; default the first edge.

    **Returns:** a `Plate`.

    **Raises:** `ValueError` (for known vertices) for fewer than 3 vertices, zero area, a polygon
    that is not planar or that crosses itself, or an `x_axis` along the normal.
    """
    v = as_float_array(vertices, "vertices")
    check_shape(v, (None, 3), "vertices", "Give the polygon's corners as (k, 3) points.")
    if v.shape[0] < 3:
        raise ValueError(f"a polygon needs at least 3 vertices, got {v.shape[0]}.")
    if not is_traced(v):
        _check_polygon(np.asarray(v))
    given = [v, thickness, density] + ([] if x_axis is None else [x_axis])
    xp = jnp
    if not any(is_traced(value) for value in given):
        # Known numbers: the same formulas in NumPy on the host (op by op in JAX, every new shape
        # would compile a program of its own: seconds for a net's panels).
        xp = np
        v = np.asarray(v)
    area_vector = _area_vector(v, xp)
    z = area_vector / xp.linalg.norm(area_vector)
    x = (v[1] - v[0]) if x_axis is None else xp.asarray(as_float_array(x_axis, "x_axis"))
    x = x - xp.dot(x, z) * z
    if not is_traced(x) and float(xp.linalg.norm(x)) < 1e-9 * float(xp.linalg.norm(v[1] - v[0])):
        raise ValueError("x_axis is along the polygon's normal; give a direction in its plane.")
    x = x / xp.linalg.norm(x)
    y = xp.cross(z, x)
    rel = v - v[0]
    px, py = rel @ x, rel @ y
    nx, ny = xp.roll(px, -1), xp.roll(py, -1)
    a = px * ny - nx * py
    area = 0.5 * xp.sum(a)
    cx = xp.sum((px + nx) * a) / (6 * area)
    cy = xp.sum((py + ny) * a) / (6 * area)
    # Second moments about the centroid: shift the vertices first (better conditioned than the
    # parallel-axis theorem for a panel far from the first vertex).
    px, py, nx, ny = px - cx, py - cy, nx - cx, ny - cy
    a = px * ny - nx * py
    sxx = xp.sum((px * px + px * nx + nx * nx) * a) / 12  # ∫x² dA
    syy = xp.sum((py * py + py * ny + ny * ny) * a) / 12  # ∫y² dA
    sxy = xp.sum((px * ny + 2 * px * py + 2 * nx * ny + nx * py) * a) / 24  # ∫xy dA
    thickness = xp.asarray(thickness)
    areal = xp.asarray(density) * thickness  # mass per area
    mass = areal * area
    flat = mass * thickness**2 / 12
    zero = xp.zeros_like(mass)
    inertia = xp.stack(
        [
            xp.stack([areal * syy + flat, -areal * sxy, zero]),
            xp.stack([-areal * sxy, areal * sxx + flat, zero]),
            xp.stack([zero, zero, areal * (sxx + syy)]),
        ]
    )
    centroid = v[0] + cx * x + cy * y
    rotation = xp.stack([x, y, z], axis=-1)
    top = xp.concatenate([rotation, centroid[:, None]], axis=-1)
    frame = xp.concatenate([top, xp.array([[0.0, 0.0, 0.0, 1.0]], dtype=top.dtype)], axis=0)
    return Plate(*(jnp.asarray(value) for value in (mass, frame, inertia, area)))


def _check_polygon(v: np.ndarray) -> None:
    area_vector = 0.5 * np.sum(np.cross(v, np.roll(v, -1, axis=0)), axis=0)
    diameter = float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))
    area = float(np.linalg.norm(area_vector))
    if diameter == 0 or area <= 1e-12 * diameter**2:
        raise ValueError("the polygon has zero area (collinear or repeated vertices).")
    normal = area_vector / area
    off = np.abs((v - v.mean(axis=0)) @ normal)
    if off.max() > PLANARITY_TOLERANCE * diameter:
        raise ValueError(
            f"the polygon is not planar: a vertex lies {off.max():.3g} from its plane "
            f"(diameter {diameter:.3g}); a panel is flat."
        )
    # Simple polygon: no two non-adjacent edges meet (k² checks; panels have a handful of corners).
    k = len(v)
    basis = np.linalg.svd(np.eye(3) - np.outer(normal, normal))[0][:, :2]
    p = (v - v[0]) @ basis
    for i in range(k):
        for j in range(i + 1, k):
            if j == i + 1 or (i == 0 and j == k - 1):
                continue
            if _segments_meet(p[i], p[(i + 1) % k], p[j], p[(j + 1) % k]):
                raise ValueError(
                    f"the polygon crosses itself (edges {i} and {j} meet); give a simple polygon "
                    "with its vertices in order around it."
                )


def _segments_meet(a, b, c, d) -> bool:
    """Closed segments ``ab`` and ``cd`` (2D) intersect or touch."""

    a, b, c, d = (tuple(float(x) for x in point) for point in (a, b, c, d))

    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    def on_segment(p, q, r):  # r, collinear with pq, lies within its bounding box
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(
            p[1], q[1]
        )

    d1, d2, d3, d4 = orient(c, d, a), orient(c, d, b), orient(a, b, c), orient(a, b, d)
    if d1 * d2 < 0 and d3 * d4 < 0:
        return True
    return (
        (d1 == 0 and on_segment(c, d, a))
        or (d2 == 0 and on_segment(c, d, b))
        or (d3 == 0 and on_segment(a, b, c))
        or (d4 == 0 and on_segment(a, b, d))
    )
