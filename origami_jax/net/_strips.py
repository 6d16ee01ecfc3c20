"""Nets drawn with their hinge strips: read and written as the mask is drawn.

A mask designer draws the device as it is fabricated: rigid panels separated by hinge strips, each
strip a thin face whose two long sides are creases, as wide as the bilayer's arc ``l = ρ|θ|``.
Marked in FOLD by the face property ``faces_origami_jax:hinge`` (`HINGE_KEY`: per face `false` or
`null` for a panel, `true` for a strip whose fold angle is the sum of its two creases' angles, or
a number: the strip's fold angle in degrees, valley +), such a file is read as panels joined by arc
hinges of the strips' widths, not as extra panels with two point creases each.

**Reading** (`strip_drawing`). Each strip ``s`` of width ``w`` folding by ``θ`` is a bending arc of
radius ``ρ = w/|θ|``. Its two panels, each extended by ``d = ρ tan(|θ|/2)`` across the strip (the
edge on the strip moved out, its neighbouring sides' lines kept) and brought together by
``w − 2d`` along the strip, meet on one sharp crease: the net the drawing is the fillet layout of
(`origami_jax.net.fillet_layout`). That point-crease net is the `Net`'s geometry (its seams, its
verdict, its point-crease systems); its arc systems take the strips as drawn (`Net.drawn_layout`),
the panels where the file puts them. A drawing that is no fillet layout of any point-crease net
(the two panels of a strip, extended, do not meet along one edge: a cube of equal squares with
strips between them, whose walls then stand ``ρ`` apart) is refused, as is a strip that joins
other than two panels or that bends both ways.

**Writing** (`strip_fold`): a net's `ArcLayout` as such a drawing, panels and strips.
"""

import dataclasses
import math

import jax
import numpy as np

from .._validate import is_traced
from ..fold import FoldFile, FoldFormatError, FoldFrame, NetGeometry, net_geometry
from ._fillet import ArcLayout, _trim, fillet_layout

HINGE_KEY = "faces_origami_jax:hinge"
"""The FOLD face property that marks a net's hinge strips (FOLD's custom properties carry a
namespace and a colon): per face `false` or `null` (a panel), `true` (a strip folding by the sum of
its two creases' angles) or the strip's fold angle in degrees (valley +)."""
# A strip's width and the design's bending radius agree within this fraction of the radius:
# the drawing is lithography for one radius, and 1 % is a few tenths of a micron on ~100 µm strips.
STRIP_RADIUS_RTOL = 0.01
# Lengths closer than this fraction of the drawing's size are one (vertices merged, corners on a
# line, parallel creases): round-off of files written to ~7 significant digits.
_SAME = 1e-7


@dataclasses.dataclass(frozen=True, eq=False)
class StripDrawing:
    """A net drawn with hinge strips, read (module docstring); lengths in the file's unit.

    **Fields:** `geometry`: the point-crease net the drawing lays out (`NetGeometry`, faces the
    drawing's panels in file order); `radius` `(m,)`: each crease's strip radius ``w/|θ|``;
    `panel_coords` `(F, K, 3)`: the panels as drawn (corner ``k`` the geometry's face's corner
    ``k``, NaN padding); `key_frame`: the point-crease net as a FOLD frame; `panels`: each
    geometry face's face id in the file."""

    geometry: NetGeometry
    radius: np.ndarray
    panel_coords: np.ndarray
    key_frame: FoldFrame
    panels: tuple[int, ...]


def hinge_marks(frame: FoldFrame) -> np.ndarray | None:
    """`frame`'s hinge-strip marks (`HINGE_KEY`): `(F,)` float, NaN for a panel, ``inf`` for a
    strip whose angle is its creases' sum, else its declared angle (degrees); `None` when the
    frame marks no face. **Raises:** `FoldFormatError` for a malformed property."""
    marks = frame.extra.get(HINGE_KEY)
    if marks is None:
        return None
    n = len(frame.faces_vertices or ())
    if not isinstance(marks, list) or len(marks) != n:
        raise FoldFormatError(
            f"{HINGE_KEY} must list one entry per face ({n}: false or null for a panel, true or "
            f"a fold angle in degrees for a hinge strip), got {str(marks)[:80]}"
        )
    out = np.full(n, np.nan)
    for f, value in enumerate(marks):
        if value is None or value is False:
            continue
        if value is True:
            out[f] = np.inf
        elif isinstance(value, int | float) and math.isfinite(value):
            out[f] = float(value)
        else:
            raise FoldFormatError(
                f"{HINGE_KEY}[{f}] is {value!r}: give false or null (a panel), true (a strip "
                "folding by the sum of its creases' angles) or its fold angle in degrees"
            )
    return out if np.any(~np.isnan(out)) else None


def strip_drawing(fold: FoldFile, *, root: int | None = None) -> StripDrawing | None:
    """The net `fold`'s key frame draws with hinge strips (module docstring), or `None` when it
    marks none. `root`: the fixed panel, a face id of the file (default the largest panel of the
    point-crease net).

    **Raises:** `FoldFormatError`, one line, for a strip that borders other than two panels or
    another strip, whose creases are not parallel or fold opposite ways, that folds by 0° or by
    180° or more, a crease between two panels without a strip, a root that is a strip, and a
    drawing whose panels, extended across their strips, do not meet along one edge."""
    frame = fold.frame(0)
    marks = hinge_marks(frame)
    if marks is None:
        return None
    strip = ~np.isnan(marks)
    if root is not None and 0 <= root < len(marks) and strip[root]:
        raise FoldFormatError(
            f"root face {root} is a hinge strip ({HINGE_KEY}); the fixed face is a panel"
        )
    drawn = net_geometry(fold, require_targets=False)
    size = drawn.size
    normal = np.asarray(drawn.normal)
    neighbours: dict[int, list[int]] = {f: [] for f in range(drawn.n_faces)}
    for j, (a, b) in enumerate(zip(drawn.crease_child, drawn.crease_parent, strict=True)):
        a, b = int(a), int(b)
        if not strip[a] and not strip[b]:
            raise FoldFormatError(
                f"crease edge(s) {list(drawn.crease_edges[j])} join panels {min(a, b)} and "
                f"{max(a, b)} without a strip: in a net drawn with hinge strips ({HINGE_KEY}) "
                "every crease is a strip's side; draw the strip between them"
            )
        neighbours[a].append(j)
        neighbours[b].append(j)

    # Each strip: its two panels, its width and its angle.
    strips = {}  # frozenset(panels) -> (width, angle rad, [(panel, crease)])
    for s in np.flatnonzero(strip):
        creases = neighbours[int(s)]
        others = [int(drawn.crease_child[j] + drawn.crease_parent[j] - s) for j in creases]
        if len(creases) != 2 or any(strip[o] for o in others):
            raise FoldFormatError(
                f"face {s} is a hinge strip ({HINGE_KEY}) bordering faces {sorted(others)} across "
                f"creases; a strip joins exactly two panels along its two long sides: make its "
                "other sides boundary (B) edges, or mark it a panel"
            )
        (j0, j1), (p0, p1) = creases, others
        if np.linalg.norm(np.cross(drawn.hinge_axes[j0], drawn.hinge_axes[j1])) > _SAME:
            raise FoldFormatError(
                f"hinge strip {s}: its creases (to panels {p0} and {p1}) are not parallel; a "
                "strip is a band of constant width between two parallel creases"
            )
        across = np.cross(normal, drawn.hinge_axes[j0])
        width = abs(float((drawn.hinge_points[j1] - drawn.hinge_points[j0]) @ across))
        sides = drawn.targets[[j0, j1]]
        if np.isinf(marks[s]):
            if np.any(np.isnan(sides)):
                raise FoldFormatError(
                    f"hinge strip {s}: a crease without a fold angle; give both its creases' "
                    f"edges_foldAngle, or the strip's angle in degrees in {HINGE_KEY}[{s}]"
                )
            angle = float(np.sum(sides))
        else:
            angle = math.radians(marks[s])
            sides = np.append(sides, angle)
        signs = np.sign(sides[np.isfinite(sides) & (np.abs(sides) > 1e-12)])
        if signs.size and (np.any(signs > 0) and np.any(signs < 0)):
            raise FoldFormatError(
                f"hinge strip {s}: its creases fold opposite ways "
                f"({', '.join(f'{x:+.4g}°' for x in np.degrees(sides))}); a bilayer strip bends "
                "one way: assign both its creases M or both V"
            )
        if not 1e-9 < abs(angle) < math.pi * (1 - 1e-9) or width <= _SAME * size:
            raise FoldFormatError(
                f"hinge strip {s} folds by {math.degrees(angle):.4g}° over a width of {width:.4g}: "
                "a strip drawn as a bending arc folds by more than 0° and less than 180° over a "
                "width above zero"
            )
        strips[frozenset(others)] = (width, angle, [(p0, j0), (p1, j1)])

    # The panels extended across their strips (the fillet trim undone) and brought together.
    panels = tuple(int(f) for f in np.flatnonzero(~strip))
    index = {f: i for i, f in enumerate(panels)}
    polygons = {}
    on_crease = {}  # (panel, strip panels) -> corner indices on that strip's crease
    for pair, (width, angle, sides_) in strips.items():
        depth = width * math.tan(0.5 * abs(angle)) / abs(angle)
        for (panel, j), (_, other) in zip(sides_, sides_[::-1], strict=True):
            polygon = polygons.get(panel, drawn.face_coords[panel][drawn.corner_mask[panel]])
            point = drawn.hinge_points[j]
            # Into the panel: away from the strip's other side.
            inward = _across(drawn, j, other, normal)
            on_crease[(panel, pair)] = np.flatnonzero(
                np.abs((polygon - point) @ inward) < _SAME * size
            )
            try:
                polygons[panel] = _trim(polygon, point, inward, -depth, size, face=panel, crease=j)
            except ValueError:
                raise FoldFormatError(
                    f"panel {panel}: a corner on its hinge strip's side turns outwards; extended "
                    "across the strip it would not stay a simple polygon: draw it convex there"
                ) from None
    shifts = _strip_shifts(strips, panels, drawn)
    recon = {f: polygons.get(f, drawn.face_coords[f][drawn.corner_mask[f]]) - shifts[f]
             for f in panels}  # fmt: skip
    frame_ = _point_frame(recon, panels, strips, on_crease, drawn.unit, size)
    point_fold = FoldFile(frames=(frame_,))
    if root is not None and root not in index:
        raise FoldFormatError(
            f"root face {root} does not exist: the file has {len(marks)} faces (0 to "
            f"{len(marks) - 1}), panels {list(panels)}"
        )
    where = None if root is None else index[root]
    geometry = net_geometry(point_fold, root=where)
    origin = shifts[panels[geometry.root]]
    if np.any(origin):  # the fixed panel stays where it is drawn
        moved = frame_.replace(vertices_coords=frame_.vertices_coords + origin)
        frame_, geometry = moved, net_geometry(FoldFile(frames=(moved,)), root=geometry.root)
    radius = np.empty(geometry.n_creases)
    for j, (a, b) in enumerate(zip(geometry.crease_child, geometry.crease_parent, strict=True)):
        width, angle, _ = strips[frozenset((panels[int(a)], panels[int(b)]))]
        radius[j] = width / abs(angle)
    coords = np.full(geometry.face_coords.shape, np.nan)
    for i, f in enumerate(panels):
        coords[i, : int(drawn.corner_mask[f].sum())] = drawn.face_coords[f][drawn.corner_mask[f]]
    return StripDrawing(geometry, radius, coords, frame_, panels)


def _strip_shifts(strips, panels, drawn) -> dict[int, np.ndarray]:
    """How far each panel lies from its place in the point-crease net: the sum, along the strips
    from the first panel, of ``(w − 2d) n̂`` (``n̂`` across the strip, away from the first)."""
    normal = np.asarray(drawn.normal)
    shifts = {panels[0]: np.zeros(3)}
    queue = [panels[0]]
    while queue:
        p = queue.pop()
        for pair, (width, angle, sides_) in strips.items():
            if p not in pair:
                continue
            c = next(iter(pair - {p}))
            if c in shifts:
                continue
            (a, ja), (_, jb) = sides_
            across = _across(drawn, ja, jb, normal) * (1.0 if a == c else -1.0)  # p into c
            depth = width * math.tan(0.5 * abs(angle)) / abs(angle)
            shifts[c] = shifts[p] + (width - 2 * depth) * across
            queue.append(c)
    return shifts


def _across(drawn, j, other, normal) -> np.ndarray:
    """The unit normal to crease `j`'s line in the paper that points away from crease `other`'s
    (the strip's other side)."""
    across = np.cross(normal, drawn.hinge_axes[j])
    return across if (drawn.hinge_points[other] - drawn.hinge_points[j]) @ across < 0 else -across


def _point_frame(recon, panels, strips, on_crease, unit, size) -> FoldFrame:
    """The point-crease net of the extended panels `recon` as a flat FOLD frame: vertices merged
    within `_SAME` of `size`, each strip's two crease sides one crease (its angle), sides two
    panels share otherwise cuts (C), the rest boundary (B)."""
    vertices: list[np.ndarray] = []
    faces = []
    for f in panels:
        ids = []
        for x in recon[f]:
            near = [i for i, v in enumerate(vertices) if np.linalg.norm(v - x) < _SAME * size]
            if not near:
                vertices.append(x)
            ids.append(near[0] if near else len(vertices) - 1)
        faces.append(ids)
    crease_angle = {}
    for pair, (_, angle, sides_) in strips.items():
        (p0, _), (p1, _) = sides_
        ends = [
            frozenset(faces[panels.index(p)][k] for k in on_crease[(p, pair)]) for p in (p0, p1)
        ]
        if ends[0] != ends[1] or len(ends[0]) < 2:
            gap = _end_gap(recon, p0, p1, on_crease, pair)
            raise FoldFormatError(
                f"panels {p0} and {p1}, extended across their hinge strip to a sharp crease, do not "
                f"meet along one edge (their ends {gap:.4g} apart): draw each panel trimmed by "
                "ρ tan(|θ|/2) at its strip as a fillet layout is (origami_jax.net.strip_fold), "
                "else the folded net's seams cannot close"
            )
        crease_angle[ends[0]] = angle
    sides: dict[frozenset, list[int]] = {}
    for i, ids in enumerate(faces):
        for a, b in zip(ids, ids[1:] + ids[:1], strict=True):
            sides.setdefault(frozenset((a, b)), []).append(i)
    edges, assignment, degrees = [], [], []
    for key, on in sides.items():
        a, b = sorted(key)
        angle = next((t for ends, t in crease_angle.items() if key <= ends), None)
        edges.append([a, b])
        if len(on) == 2 and angle is not None:
            assignment.append("V" if angle > 0 else "M")
            degrees.append(math.degrees(angle))
        else:
            assignment.append("C" if len(on) == 2 else "B")
            degrees.append(0.0)
    return FoldFrame(
        vertices_coords=np.array(vertices),
        edges_vertices=np.array(edges),
        edges_assignment=tuple(assignment),
        edges_fold_angle_deg=np.array(degrees),
        faces_vertices=tuple(tuple(ids) for ids in faces),
        frame_unit=unit,
        frame_classes=("creasePattern",),
    )


def _end_gap(recon, p0, p1, on_crease, pair) -> float:
    """How far apart the two extended panels' crease sides end (the larger of the two ends)."""
    a = recon[p0][on_crease[(p0, pair)]]
    b = recon[p1][on_crease[(p1, pair)]]
    axis = a[-1] - a[0]
    axis = axis / np.linalg.norm(axis)
    ta, tb = np.sort(a @ axis), np.sort(b @ axis)
    return float(max(abs(ta[0] - tb[0]), abs(ta[-1] - tb[-1])))


def drawn_layout(drawing: StripDrawing, length_scale: float) -> ArcLayout:
    """The strips as drawn: the fillet layout (`fillet_layout`) of the drawing's point-crease net for its
    strips' radii and angles, the panels put exactly where the file draws them (checked to agree
    with the fillet's within round-off). **Raises:** `FoldFormatError` if they do not agree."""
    g = drawing.geometry
    scale = float(length_scale)
    layout = fillet_layout(g, scale, drawing.radius * scale, g.targets)
    drawn = drawing.panel_coords * scale
    off = np.nanmax(np.abs(layout.face_coords - drawn))
    if not off <= 1e-6 * g.size * scale:
        raise FoldFormatError(
            f"the hinge strips' layout puts the panels {off:.3g} away from where they are drawn; "
            "draw the panels as a fillet layout of a point-crease net (origami_jax.net.strip_fold)"
        )
    return dataclasses.replace(layout, face_coords=np.where(np.isnan(drawn), np.nan, drawn))


def check_strip_radius(layout: ArcLayout, design, name: str) -> None:
    """Refuse a design whose films bend to another radius than the strips of `layout` (drawn in
    a file) are drawn for, by more than `STRIP_RADIUS_RTOL`; a traced radius is not checked.

    **Raises:** `ValueError`, naming the crease, both radii and the fixes."""
    with jax.ensure_compile_time_eval():  # a concrete design's radius, even under `jit`
        radius = design.radius()
    if is_traced(radius):
        return
    radius = np.broadcast_to(np.asarray(radius, dtype=float), layout.radius.shape)
    off = np.abs(layout.radius - radius) / radius
    j = int(np.argmax(off))
    if off[j] > STRIP_RADIUS_RTOL:
        raise ValueError(
            f"{name}: the hinge strip of crease {j} is drawn {layout.lengths[j]:.4g} wide for a "
            f"fold of {math.degrees(layout.angles[j]):.4g}°, a radius of {layout.radius[j]:.4g}, "
            f"but the design's films bend to {radius[j]:.4g} ({100 * off[j]:.2g} % off, more than "
            f"{100 * STRIP_RADIUS_RTOL:g} %): give the design the strips are drawn for (its films, "
            "or layout_design=), or redraw them ρ|θ| wide"
        )


def strip_fold(net, layout: ArcLayout) -> FoldFile:
    """`net` (a `Net`) drawn as fabricated on `layout` (its `ArcLayout`, e.g. `net.arc_layout(
    design)`): the layout's panels and, for each crease, a strip face between its two panels'
    edges, marked in `HINGE_KEY`, its two sides creases of half the crease's angle each; lengths
    in the net's FOLD unit. `load_net` reads it back as `net` with `layout` as its drawn strips."""
    g = net.geometry
    scale = float(net.length_scale)
    size = g.size
    normal = np.asarray(g.normal)
    vertices: list[np.ndarray] = []

    def vertex(x):
        for i, v in enumerate(vertices):
            if np.linalg.norm(v - x) < _SAME * size:
                return i
        vertices.append(x)
        return len(vertices) - 1

    faces = [
        [vertex(x) for x in layout.face_coords[f][g.corner_mask[f]] / scale]
        for f in range(g.n_faces)
    ]
    strips = []
    for j in range(g.n_creases):
        point = layout.hinge_points[j] / scale
        axis = np.asarray(g.hinge_axes[j])
        across = np.cross(normal, axis)
        width = layout.lengths[j] / scale
        sides = []
        for face, offset in ((g.crease_parent[j], 0.0), (g.crease_child[j], width)):
            ids = [
                i for i in faces[int(face)]
                if abs((vertices[i] - point) @ across - offset) < _SAME * size
            ]  # fmt: skip
            sides.append(sorted(ids, key=lambda i: vertices[i] @ axis))
        strips.append(sides[0] + sides[1][::-1])
    all_faces = faces + strips
    sides_of: dict[frozenset, list[int]] = {}
    for f, ids in enumerate(all_faces):
        for a, b in zip(ids, ids[1:] + ids[:1], strict=True):
            sides_of.setdefault(frozenset((a, b)), []).append(f)
    edges, assignment, degrees = [], [], []
    for key, on in sides_of.items():
        edges.append(sorted(key))
        strip_of = [f - g.n_faces for f in on if f >= g.n_faces]
        if len(on) == 2 and len(strip_of) == 1:
            half = 0.5 * math.degrees(float(layout.angles[strip_of[0]]))
            assignment.append("V" if half > 0 else "M")
            degrees.append(half)
        else:
            assignment.append("C" if len(on) == 2 else "B")
            degrees.append(0.0)
    frame = FoldFrame(
        vertices_coords=np.array(vertices),
        edges_vertices=np.array(edges),
        edges_assignment=tuple(assignment),
        edges_fold_angle_deg=np.array(degrees),
        faces_vertices=tuple(tuple(ids) for ids in all_faces),
        frame_unit=g.unit,
        frame_classes=("creasePattern",),
        frame_attributes=("2D",) if np.allclose(normal, [0, 0, 1]) else None,
        extra={
            "frame_title": f"{net.name} drawn with its hinge strips",
            HINGE_KEY: [False] * g.n_faces + [True] * g.n_creases,
        },
    )
    return FoldFile(
        frames=(frame,),
        file_metadata={"file_creator": "origami_jax", "file_classes": ["singleModel"]},
    )
