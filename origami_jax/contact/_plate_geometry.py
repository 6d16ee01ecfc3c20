"""The plate model's geometry in JAX: a mechanism's plate tables, its plates' world vertices and their
overlaps (used by `PlateContact` and by `PanelContact`'s report)."""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..system import AbstractMechanism
from ._barrier import host_rest_poses
from ._plate_tables import PlateTables, build_plate_tables
from ._primitives import overlap_depth


def plate_tables_for(
    mechanism: AbstractMechanism, *, base_outline: np.ndarray | None = None
) -> PlateTables:
    """The plate geometry of a mechanism whose arrays are known (host; `PlateTables`): its
    outlines, rest poses and hinge layout."""
    base = mechanism.base_outline() if base_outline is None else base_outline
    rest = host_rest_poses(mechanism, "PlateTables", "PlateContact.tables_for")
    layout = mechanism.hinge_layout()
    return build_plate_tables(
        mechanism.outlines(), rest, base, layout.parent, layout.child, layout.ends
    )


def plate_vertices(tables: PlateTables, poses: Float[Array, "n 4 4"]) -> Float[Array, "p v 3"]:
    """World positions of every plate's polygon vertices (`tables.vertices`, padded) with world
    poses `poses` of the bodies (the base last), length units."""
    local = jnp.asarray(tables.vertices, poses.dtype)
    if tables.plate_body is not None:
        poses = poses[tables.plate_body]
    return jnp.einsum("nij,nvj->nvi", poses[:, :3, :3], local) + poses[:, None, :3, 3]


def plate_half_thickness(tables: PlateTables, half_thickness: Float[Array, " n"]) -> Array:
    """Each plate's half-thickness `(p,)` from its body's (`half_thickness` `(n,)`)."""
    if tables.plate_body is None:
        return half_thickness
    return half_thickness[tables.plate_body]


def plate_overlaps(
    tables: PlateTables, half_thickness: Float[Array, " n"], x: Float[Array, "n v 3"]
) -> Float[Array, " p"]:
    """The exact overlap of every pair of bodies (`(p,)` over `tables.body_pairs`, length) with
    world vertices `x` (`plate_vertices`) and half-thicknesses `half_thickness` `(n,)`: the depth
    of the prisms of their thicknesses for bodies apart in the flat state, of their mid-surfaces
    for bodies that touch there (a shared crease, corner or cut edge: their plates overlap along
    it by construction); `overlap_depth`. A panel of several convex plates (a non-convex outline)
    overlaps another by the deepest of its plates' overlaps (a lower bound of the translation that
    separates the two panels; their exact depth where each is one plate). Depths within rounding of
    zero (``1e-9`` × the largest panel) are 0."""
    pairs, owner = tables.plate_pairs
    a, b = pairs.T
    body = tables.bodies_of_plates
    joined = tables.joined[body[a], body[b]]
    thickness = 2 * plate_half_thickness(tables, half_thickness).astype(x.dtype)
    depth = overlap_depth(
        x[a], x[b], jnp.where(joined, 0.0, thickness[a]), jnp.where(joined, 0.0, thickness[b])
    )
    depth = jnp.where(depth > 1e-9 * tables.scale, depth, 0.0)
    if tables.plate_body is None:
        return depth
    return jnp.zeros(len(tables.body_pairs), x.dtype).at[owner].max(depth)
