"""Nets laid out for bending-arc hinges: each crease's strip as a fillet between its panels.

A net drawn for point creases folds into a polyhedron whose faces meet at sharp creases. A bending
strip of radius ``ρ`` turning by ``θ`` cannot make a sharp crease; it rounds it. Drawn at its
crease (the `"drawn"` layout: the strip starts at the drawn crease and the child hangs at its end),
each child ends up displaced from where the point crease puts it (``ρ`` outwards and ``(1 − π/2) ρ``
down at 90°), and a cube's walls stand apart: their seams cannot close.

**The fillet layout** (`fillet_layout`). An arc of radius ``ρ`` turning by ``|θ|`` is tangent to
both planes of a sharp crease of angle ``θ`` at the points ``d = ρ tan(|θ|/2)`` from the crease
line on either side. So each panel is trimmed by ``d_j`` at each of its creases ``j`` (the edge on
the crease moved ``d_j`` into the panel, its neighbours slid along their edges), and the strip, of
arc length ``l_j = ρ |θ_j|``, joins the two trimmed edges: in the flat net the child's subtree
moves by ``l_j − 2 d_j`` along the crease's normal ``d̂_j`` (into the child; at 90°,
``l − 2d = (π/2 − 2) ρ < 0``: closer). Folded to ``θ_j``, every trimmed panel lies exactly where the
point-crease folding puts it, and its seams are the point-crease seams cut back where they meet a
crease: they close. The layout is lithography: it is drawn once, for the nominal design's ``ρ`` and
the pattern's angles; a film that bends more or less then misses.

Lengths here are the design's (the FOLD coordinates times the net's `length_scale`).
"""

import dataclasses

import numpy as np

from .._validate import is_traced
from ..contact import PlateContact
from ..fold import NetGeometry

# A vertex is on a crease's line within this fraction of the net's size.
_ON_LINE = 1e-9


def arc_length(radius, angle):
    """The strip's arc length ``l = ρ |θ|`` (length units of `radius`)."""
    return np.asarray(radius, dtype=float) * np.abs(np.asarray(angle, dtype=float))


def fillet_trim(radius, angle):
    """How far the fillet's tangent points lie from a sharp crease of angle `angle` (rad):
    ``d = ρ tan(|θ|/2)``; infinite at ``|θ| = π`` (a semicircle meets no plane of the crease)."""
    return np.asarray(radius, dtype=float) * np.tan(0.5 * np.abs(np.asarray(angle, dtype=float)))


@dataclasses.dataclass(frozen=True, eq=False)
class ArcLayout:
    """A net laid out for bending strips of radius `radius` folding to `angles` (module docstring).

    **Fields** (design length units; `F` faces, `K` corners, `m` creases, `s` seams):
    - `radius` ``ρ`` and `angles`, `(m,)` each (length, rad): what it is drawn for.
    - `lengths` `(m,)`: each strip's arc length ``l = ρ|θ|``; `trims` `(m,)`: ``d = ρ tan(|θ|/2)``.
    - `shifts` `(F, 3)`: how far each face moved in the flat net (the sum of ``(l − 2d) d̂`` of
      the creases from the root to it).
    - `face_coords` `(F, K, 3)`: the trimmed faces where they lie in the flat net (NaN padding as
      `NetGeometry.face_coords`), corner ``k`` the drawn face's corner ``k``.
    - `hinge_points` `(m, 3)`: where each strip leaves its parent (on the parent's trimmed edge).
    - `seam_points` `(s, 2, 2, 3)`: each seam's ends on each side (as `Seams.corners`), where both
      sides still have material: the drawn corner moved along the seam by the larger of the two
      sides' trims there, in the flat net.
    """

    radius: np.ndarray
    angles: np.ndarray
    lengths: np.ndarray
    trims: np.ndarray
    shifts: np.ndarray
    face_coords: np.ndarray
    hinge_points: np.ndarray
    seam_points: np.ndarray

    def outlines(self, geometry: NetGeometry) -> tuple[np.ndarray, list[np.ndarray]]:
        """The root face's polygon and the other faces' (body order), `(k, 3)` each."""
        order = np.asarray(geometry.order)
        polygons = [self.face_coords[f][geometry.corner_mask[f]] for f in order]
        return polygons[0], polygons[1:]


def fillet_layout(
    geometry: NetGeometry, length_scale: float, radius, angles, seams=None
) -> ArcLayout:
    """The fillet layout of `geometry` (module docstring) for strips of radius `radius` (design
    length units, one or one per crease) folding to `angles` (rad, `(m,)`); `seams`
    (`NetGeometry.target_seams` by default) for `ArcLayout.seam_points`.

    **Raises:** `ValueError` for a non-positive radius, an angle of ``|θ| ≥ π`` (the strip is then a
    semicircle or more: no trim puts the panels in the planes of a sharp crease; use the `"drawn"`
    layout) or a trim that eats a panel (a neighbouring edge shorter than the trim reaches).
    """
    g = geometry
    angles = np.asarray(angles, dtype=float)
    radius = np.asarray(radius, dtype=float)
    if radius.shape not in ((), (1,), (g.n_creases,)) or not np.all(
        np.isfinite(radius) & (radius > 0)
    ):
        raise ValueError(
            f"the strips' bending radius must be positive, one or one per crease, got {radius}."
        )
    radius = np.broadcast_to(radius.reshape(-1) if radius.ndim else radius, (g.n_creases,))
    if angles.shape != (g.n_creases,) or not np.all(np.isfinite(angles)):
        raise ValueError(f"angles must be {g.n_creases} finite fold angles (rad), got {angles}.")
    if np.any(np.abs(angles) >= np.pi * (1 - 1e-9)):
        j = int(np.argmax(np.abs(angles)))
        raise ValueError(
            f"crease {j} folds by {np.degrees(angles[j]):.1f}°: a strip bent by |θ| ≥ 180° cannot "
            "be a fillet between two panels (it leaves them 2ρ or more apart); lay the net out "
            "with arc_layout='drawn'."
        )
    lengths = arc_length(radius, angles)
    trims = fillet_trim(radius, angles)
    scale = float(length_scale)
    drawn = np.asarray(g.face_coords, dtype=float) * scale
    mask = np.asarray(g.corner_mask)
    points = np.asarray(g.hinge_points, dtype=float) * scale
    axes = np.asarray(g.hinge_axes, dtype=float)
    normals = np.cross(np.asarray(g.normal, dtype=float), axes)  # d̂: into the child
    child = np.asarray(g.crease_child)
    parent = np.asarray(g.crease_parent)
    size = float(np.nanmax(np.ptp(drawn[mask], axis=0)))

    # The trimmed faces, in the drawn positions.
    trimmed = drawn.copy()
    for f in range(g.n_faces):
        polygon = drawn[f][mask[f]]
        for j in np.flatnonzero((child == f) | (parent == f)):
            inward = normals[j] if child[j] == f else -normals[j]
            polygon = _trim(polygon, points[j], inward, trims[j], size, face=f, crease=j)
        trimmed[f, : len(polygon)] = polygon

    # Each face's move in the flat net: the sum along its creases from the root.
    shifts = np.zeros((g.n_faces, 3))
    crease_of = np.asarray(g.face_crease)
    for f in np.asarray(g.order)[1:]:
        j = crease_of[f]
        shifts[f] = shifts[parent[j]] + (lengths[j] - 2 * trims[j]) * normals[j]
    face_coords = trimmed + shifts[:, None, :]
    hinge_points = points - trims[:, None] * normals + shifts[parent]

    seams = g.target_seams if seams is None else seams
    seam_points = _seam_points(drawn, trimmed, shifts, seams, g.face_coords.shape[1])
    return ArcLayout(radius, angles, lengths, trims, shifts, face_coords, hinge_points, seam_points)


def _trim(
    polygon, point, inward, depth, size, *, face: int | np.integer, crease: int | np.integer
) -> np.ndarray:
    """`polygon` `(k, 3)` with its corners on the line through `point` (perpendicular to `inward`,
    in the polygon's plane) moved `depth` into it: a corner whose both sides lie on the line along
    `inward`, one with a side off the line along that side."""
    offset = (polygon - point) @ inward
    on = np.abs(offset) < _ON_LINE * size
    out = polygon.copy()
    k = len(polygon)
    for i in np.flatnonzero(on):
        before, after = (i - 1) % k, (i + 1) % k
        if on[before] and on[after]:
            out[i] = polygon[i] + depth * inward
            continue
        if not (on[before] or on[after]):
            continue  # a corner that touches the crease's line only: not on the crease
        other = polygon[after] if on[before] else polygon[before]
        side = other - polygon[i]
        rise = float(side @ inward)
        if rise <= 0 or depth >= rise * (1 - 1e-12):
            raise ValueError(
                f"the fillet trim of crease {crease} ({depth:.4g} length units) reaches across "
                f"face {face}'s side next to it: the panel is too small for a strip of this radius "
                "at this angle; lay the net out with arc_layout='drawn' or a smaller radius."
            )
        out[i] = polygon[i] + (depth / rise) * side
    return out


def _seam_points(drawn, trimmed, shifts, seams, width: int) -> np.ndarray:
    """`ArcLayout.seam_points` (its docstring)."""
    corners = np.asarray(seams.corners)
    out = np.zeros((*corners.shape, 3))
    for s in range(corners.shape[0]):
        for e in range(2):
            along, slides, starts = [], [], []
            for side in range(2):
                f, k = divmod(int(corners[s, e, side]), width)
                _, k_far = divmod(int(corners[s, 1 - e, side]), width)
                edge = drawn[f, k_far] - drawn[f, k]
                unit = edge / np.linalg.norm(edge)
                along.append(unit)
                slides.append(float((trimmed[f, k] - drawn[f, k]) @ unit))
                starts.append(drawn[f, k] + shifts[f])
            common = max(slides)
            for side in range(2):
                out[s, e, side] = starts[side] + common * along[side]
    return out


def seam_contact_exclusions(tables, layout: ArcLayout, seams, bodies, rest_poses):
    """`tables` (`PlateTables` of the fillet layout's panels) with the seams' shared corners
    treated as the point-crease net's: where a seam's two sides meet at one vertex of the drawn
    net, the primitive pairs of that corner (its vertex against the other side's polygon, the
    edges at it against the other side's edges at it) are left out and the two bodies are joined,
    as `build_plate_tables` does for the corner the two panels share in the drawn flat net. The
    trimmed panels no longer touch there in the flat net; folded to the targets their corners
    meet again, by construction, as the shared vertex does with point creases.

    `bodies` `(F,)`: each face's body (the base ``tables.n_bodies``); `rest_poses` `(n, 4, 4)`: the
    bodies' rest poses (the base's is `tables.base_pose`)."""
    n = tables.n_bodies
    poses = np.concatenate([np.asarray(rest_poses, dtype=float), tables.base_pose[None]])
    width = layout.face_coords.shape[1]
    corners = np.asarray(seams.corners)
    vertices = np.asarray(seams.vertices)
    tolerance = 1e-9 * tables.scale
    plate_body = tables.bodies_of_plates
    # Corners left out, as (plate, vertex index, the other body) with the other body's plates.
    drop_vertex, drop_edge = set(), set()
    joined = tables.joined.copy()
    for s in range(corners.shape[0]):
        for e in range(2):
            if vertices[s, e, 0] != vertices[s, e, 1]:
                continue  # the two sides meet at no vertex of the drawn net
            found = []
            for side in range(2):
                f, k = divmod(int(corners[s, e, side]), width)
                body = int(bodies[f])
                pose = poses[body if body < n else n]
                local = (layout.face_coords[f, k] - pose[:3, 3]) @ pose[:3, :3]
                at = set()
                for plate in np.flatnonzero(plate_body == body):
                    index = np.flatnonzero(
                        np.linalg.norm(tables.vertices[plate] - local, axis=-1) < tolerance
                    )
                    at |= {(int(plate), int(i)) for i in index}
                found.append((body, at))
            (a, ia), (b, ib) = found
            if not ia or not ib:
                continue
            drop_vertex |= {(p, i, b) for p, i in ia} | {(p, i, a) for p, i in ib}
            drop_edge |= {(*x, *y) for x in ia for y in ib} | {(*y, *x) for x in ia for y in ib}
            joined[a, b] = joined[b, a] = True
    vertex_face = np.asarray(tables.vertex_face)
    keep = np.array(
        [(int(r[0]), int(r[1]), int(plate_body[r[2]])) not in drop_vertex for r in vertex_face],
        dtype=bool,
    )
    edge_edge = np.asarray(tables.edge_edge)
    keep_edge = np.array(
        [
            not any(
                (int(r[0]), int(i), int(r[3]), int(j)) in drop_edge for i in r[1:3] for j in r[4:6]
            )
            for r in edge_edge
        ],
        dtype=bool,
    )
    return dataclasses.replace(
        tables,
        vertex_face=vertex_face[keep].reshape(-1, 3),
        edge_edge=edge_edge[keep_edge].reshape(-1, 6),
        joined=joined,
    )


def fillet_plate_tables(tree, layout: ArcLayout, geometry: NetGeometry, seams):
    """The plate contact geometry (`PlateTables`) of `tree`, a panel tree on `layout`'s panels,
    with the seams' corners shared in the drawn net treated as with point creases
    (`seam_contact_exclusions`)."""
    order = np.asarray(geometry.order)
    bodies = np.empty(len(order), dtype=np.int64)
    bodies[order] = np.arange(len(order)) - 1
    bodies[order[0]] = len(order) - 1  # the base: body n
    frames = np.asarray(getattr(tree, "panels", tree).frames)
    tables = PlateContact.tables_for(tree)
    return seam_contact_exclusions(tables, layout, seams, bodies, frames)


def layout_of(layouts, geometry: NetGeometry, mechanism) -> ArcLayout | None:
    """The one of `layouts` whose panels `mechanism` has (its base polygon and its strips' starts
    where the layout puts them in the flat net), or `None` (the drawn panels, or traced ones)."""
    base = mechanism.base_outline()
    joints = getattr(getattr(mechanism, "panels", mechanism), "joints", None)
    if base is None or joints is None or is_traced(joints.points):
        return None
    points = np.asarray(joints.points)
    tolerance = 1e-9 * float(np.max(np.ptp(base, axis=0)))
    for layout in layouts:
        root, _ = layout.outlines(geometry)
        if (
            root.shape == base.shape
            and np.allclose(root, base, rtol=0, atol=tolerance)
            and np.allclose(layout.hinge_points, points, rtol=0, atol=tolerance)
        ):
            return layout
    return None
