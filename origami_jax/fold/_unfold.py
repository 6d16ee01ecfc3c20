"""A folded form unfolded to its flat crease pattern.

Many FOLD files hold a model's folded form only (`frame_classes` `foldedForm`, vertices in 3D): a
polyhedron designed in a CAD tool, a rigidly folded twist. The panels are rigid, so the flat sheet
is recovered by laying the faces out across their creases, each face turned about the crease it
shares with its parent in a spanning tree of the faces: the crease's fold angle is the dihedral
angle the folded form gives it (`fold_angles_from_coords`: valley +, mountain −).

A crease that the tree does not use closes a loop of faces. Where its two faces' flat images agree
(a vertex surrounded by creases, as in a Miura-ori) it is a crease of a closed loop; where they do
not (the edges of a closed polyhedron, which no flat sheet can keep joined) the sheet is cut there:
it becomes two boundary edges, a seam that the folding closes. For a polyhedron the cut depends on
the tree (breadth first from the root face, across coplanar faces first, so that a triangulated
face stays one piece), so `unfold_folded_form` returns one of its nets: the first, from the
largest face down, whose faces do not overlap in the plane (a net is cut from one sheet).
"""

from __future__ import annotations

import collections
import warnings

import numpy as np

from ._errors import FoldFormatError
from ._geometry import PLANAR_REL_TOL, fold_angles_from_coords, paper_plane
from ._model import FoldFile, FoldFrame
from ._net_build import CREASES
from ._polygons import overlapping_pairs, signed_area, triangulate

# Two flat images of one vertex closer than this (relative to the model's size) are one vertex of
# the flat sheet: folded forms are written with a few significant digits.
MERGE_REL_TOL = 1e-4
# A face whose corners leave its plane by more than this (relative to the model) is not a panel.
FACE_PLANAR_REL_TOL = 1e-4
# Two faces whose dihedral angle is within this of flat (rad, 0.06°) are coplanar (an `F` edge,
# unless the file says M or V): a form written to a few digits (`MERGE_REL_TOL`) gives a
# triangulated face's diagonals dihedrals of ~1e-6 (six digits) to ~1e-4 rad (four), and no
# stressed hinge folds so little (its arc, ρθ, would be shorter than its film).
FLAT_ANGLE = 1e-3
# Roots tried, largest face first, for a net of a polyhedron whose faces do not overlap: each try
# is a breadth-first layout and an overlap test, milliseconds for hundreds of faces.
ROOTS_TRIED = 32


def is_folded_form(frame: FoldFrame) -> bool:
    """Whether `frame` is a folded form to unfold: it has faces, and its vertices leave one plane,
    or it says `foldedForm` in its `frame_classes` while some face runs clockwise in the plane (a
    flat-folded form)."""
    if frame.faces_vertices is None or frame.vertices_coords is None:
        return False
    coords = frame.coords3
    plane = paper_plane(coords, frame.faces_vertices)
    if plane is None:
        return True
    if "foldedForm" not in (frame.frame_classes or ()):
        return False
    xy = (coords - coords.mean(axis=0)) @ plane.T
    return any(signed_area(xy[list(face)]) < 0 for face in frame.faces_vertices)


def flat_fold(fold: FoldFile, *, root: int | None = None) -> FoldFile:
    """`fold` itself, or, when its key frame is a folded form (`is_folded_form`), a file whose one
    frame is that form's flat crease pattern (`unfold_folded_form`; the other frames animate the
    form's vertices and are dropped). A key frame with vertices that no edge or face uses is read
    without them (a warning says how many; the outputs would carry every one, and writing them
    took minutes for thousands)."""
    fold = used_vertices_only(fold)
    if not is_folded_form(fold.key_frame):
        return fold
    frame = unfold_folded_form(fold.key_frame, root=root)
    return FoldFile(frames=(frame,), file_spec=fold.file_spec, file_metadata=fold.file_metadata)


def used_vertices_only(fold: FoldFile) -> FoldFile:
    """`fold` itself, or, when some vertices of its key frame belong to no edge and no face, a file
    of that key frame alone without them (the other ids renumbered in order; per-vertex properties
    the model does not know are dropped, and so are the other frames, which the loaders do not
    read), with a `UserWarning` naming how many."""
    frame = fold.key_frame
    if frame.vertices_coords is None or frame.edges_vertices is None:
        return fold
    n = len(frame.vertices_coords)
    used = np.zeros(n, dtype=bool)
    used[np.asarray(frame.edges_vertices, dtype=np.int64).reshape(-1)] = True
    for face in frame.faces_vertices or ():
        used[list(face)] = True
    if used.all():
        return fold
    new_id = np.cumsum(used) - 1
    warnings.warn(
        f"{n - int(used.sum())} of the {n} vertices belong to no edge or face: read without them "
        "(the outputs number the vertices without them)",
        stacklevel=3,
    )
    faces = frame.faces_vertices
    key = frame.replace(
        vertices_coords=np.asarray(frame.vertices_coords)[used],
        edges_vertices=new_id[np.asarray(frame.edges_vertices, dtype=np.int64)],
        faces_vertices=None
        if faces is None
        else tuple(tuple(int(new_id[v]) for v in face) for face in faces),
        extra={k: v for k, v in frame.extra.items() if not k.startswith("vertices_")},
    )
    return FoldFile(frames=(key,), file_spec=fold.file_spec, file_metadata=fold.file_metadata)


def unfold_folded_form(frame: FoldFrame, *, root: int | None = None) -> FoldFrame:
    """The flat crease pattern of a folded form, with each crease's fold angle from the form.

    **Arguments:** `frame`: a FOLD frame with `vertices_coords` (3D) and `faces_vertices`
    (counter-clockwise seen from each face's front), `edges_vertices` and `edges_assignment`
    optional (an edge shared by two faces is a crease unless assigned `B` or `C`); `root`: the face
    laid out first, which keeps its place and orientation (default: the largest face whose
    breadth-first net does not overlap itself, of the `ROOTS_TRIED` largest). Faces wound
    clockwise seen from the side the file's `M` and `V` refer to (every `M`/`V` crease folded the
    other way) are read reversed, and the sheet is seen from that side.

    **Returns:** a `FoldFrame` in the plane ``z = 0``, in the form's `frame_unit`: vertices (one per
    flat position, in the form's order; a vertex where the sheet is cut becomes several, the others
    numbered after the form's), every face side as an edge, `edges_foldAngle` (degrees) from the
    form's dihedral angles, assignments `M`/`V` by sign (`F`, at 0°, within `FLAT_ANGLE` of flat
    unless the file says `M` or `V`; folded flat, the file's `M` or `V`, else `V`), `B` on the
    boundary and where the sheet is cut apart, `C` for a shared side the file assigns `B` or `C`,
    `frame_classes` `creasePattern`, and `origami_jax:unfolded_from` ``"foldedForm"``. A form
    that closes on itself (a polyhedron) is cut along the creases the tree leaves, with a
    `UserWarning` naming them.

    **Raises:** `FoldFormatError` (one line) for a face that is not planar or degenerate, an edge
    of more than two faces, two faces that run a shared edge the same way (not orientable), faces
    not joined to the root by creases, `M`/`V` edges of which some agree with the form's folds
    and some do not, or a flat sheet whose faces overlap from every root tried.
    """
    if frame.faces_vertices is None or frame.vertices_coords is None:
        raise FoldFormatError(
            "a folded form needs vertices_coords and faces_vertices to be unfolded to its crease "
            "pattern"
        )
    coords = frame.coords3
    faces = [tuple(int(v) for v in face) for face in frame.faces_vertices]
    size = max(float(np.max(np.ptp(coords, axis=0))), 1e-300)
    sides = _sides(faces)
    assignment = _side_assignment(frame)
    faces = _oriented(coords, faces, assignment)
    runs: dict[tuple[int, int], int] = {}
    for f, face in enumerate(faces):
        for u, v in _face_sides(face):
            if (u, v) in runs:
                raise FoldFormatError(
                    f"faces {runs[(u, v)]} and {f} both run their shared edge {u}–{v} the same way: "
                    "list every face's vertices counter-clockwise seen from the same side of the sheet"
                )
            runs[(u, v)] = f
    local = [_face_plane(coords, face, f, size) for f, face in enumerate(faces)]
    areas = [signed_area(xy) for xy in local]
    if root is not None and not 0 <= int(root) < len(faces):
        raise FoldFormatError(
            f"root={root}: the form has {len(faces)} faces (0 to {len(faces) - 1})"
        )
    # Largest first; equal areas (a cube's faces) in the file's order.
    by_area = sorted(range(len(faces)), key=lambda f: -areas[f])
    roots = [int(root)] if root is not None else by_area[:ROOTS_TRIED]

    def crease(u: int, v: int) -> bool:
        side = frozenset((u, v))
        return len(sides[side]) == 2 and assignment.get(side, "U") in CREASES

    angles = fold_angles_from_coords(coords, faces, _side_array(faces))
    flat_sides = {
        frozenset(side)
        for side, angle in zip(_face_side_list(faces), angles, strict=True)
        if _crease_kind(assignment.get(frozenset(side), "U"), float(angle))[0] == "F"
    }
    triangles = [_triangles(xy, f) for f, xy in enumerate(local)]
    first_overlap = None
    for tried in roots:
        flat = _layout(faces, local, sides, crease, tried, flat_sides)
        overlaps = _overlapping_faces(flat, triangles, size)
        if not overlaps:
            break
        first_overlap = first_overlap or (tried, overlaps)
    else:
        first, (f, g) = first_overlap[0], first_overlap[1][0]
        if root is not None:
            raise FoldFormatError(
                f"the folded form's flat sheet unfolded from face {first} overlaps itself (faces "
                f"{f} and {g}): a net is cut from one sheet; pick another root=, or assign C to "
                "the creases to cut in the file"
            )
        raise FoldFormatError(
            f"the folded form's flat sheet overlaps itself unfolded from each of its "
            f"{len(roots)} largest faces (from face {first}: faces {f} and {g}): a net is cut "
            "from one sheet; assign C to the creases to cut in the file"
        )
    return _flat_frame(frame, faces, flat, sides, assignment, angles, size, tried)


def _layout(faces, local, sides, crease, root: int, flat_sides=frozenset()) -> list[np.ndarray]:
    """Each face's flat corners `(k, 2)`, breadth first from `root`: each face placed by the rigid
    map (rotation, translation) of its own plane that puts the side it shares with its parent onto
    the parent's flat side. A face placed brings the faces joined to it across `flat_sides`
    (coplanar faces: a triangulated face's diagonals) with it before the search goes on across
    folds, so the faces of one flat panel stay joined in the sheet and the cuts of a closed form
    fall between panels, never inside one. Without flat sides, the plain breadth-first tree."""
    flat: list[np.ndarray | None] = [None] * len(faces)
    queue: collections.deque[int] = collections.deque()

    def unplaced(f: int, flat_only: bool):
        """`(side index, face)` across each crease of placed face `f` to a face not yet placed
        (across its flat sides only where `flat_only`), checked as the caller goes on."""
        for k, (u, v) in enumerate(_face_sides(faces[f])):
            side = frozenset((u, v))
            if crease(u, v) and (not flat_only or side in flat_sides):
                g = next(h for h in sides[side] if h != f)
                if flat[g] is None:
                    yield k, g

    def put(g: int, f: int, k: int) -> None:
        """Face `g` placed across side `k` of placed face `f`."""
        u, v = _face_sides(faces[f])[k]
        a, b = flat[f][k], flat[f][(k + 1) % len(faces[f])]  # type: ignore[index]
        flat[g] = _rigid_onto(local[g], faces[g].index(u), faces[g].index(v), a, b)

    def queue_panel(f: int) -> None:
        """Placed face `f` queued for the search across folds, then the faces joined to it across
        flat sides, breadth first, each placed and queued."""
        queue.append(f)
        panel = collections.deque([f])
        while panel:
            h = panel.popleft()
            for j, g in unplaced(h, flat_only=True):
                put(g, h, j)
                queue.append(g)
                panel.append(g)

    flat[root] = local[root] - local[root][0]
    queue_panel(root)
    while queue:
        f = queue.popleft()
        for k, g in unplaced(f, flat_only=False):
            put(g, f, k)
            queue_panel(g)
    missing = [f for f, xy in enumerate(flat) if xy is None]
    if missing:
        raise FoldFormatError(
            f"faces {missing[:8]} are not joined to face {root} by creases: a folded form is "
            "unfolded across the edges its faces share"
        )
    return flat  # pyright: ignore[reportReturnType]


def _triangles(xy: np.ndarray, f: int) -> list[tuple[int, int, int]]:
    """`triangulate` of face `f`'s corners in its own plane, refused in one line."""
    try:
        return triangulate(xy)
    except ValueError as error:
        raise FoldFormatError(f"face {f}: {error}") from None


def _overlapping_faces(flat, triangles, size: float) -> list[tuple[int, int]]:
    """Pairs of faces whose flat images overlap by more than the vertices' merging tolerance
    (touching does not count; a form written to a few digits lays a loop's faces out a little
    apart or over each other)."""
    corners = np.concatenate(
        [
            np.pad(xy[list(t)], ((0, 0), (0, 1)))
            for xy, tris in zip(flat, triangles, strict=True)
            for t in tris
        ]
    ).reshape(-1, 3, 3)
    owners = np.repeat(np.arange(len(flat)), [len(t) for t in triangles])
    return overlapping_pairs(corners, owners, MERGE_REL_TOL * size)


def _flat_frame(frame, faces, flat, sides, assignment, angles, size, root: int) -> FoldFrame:
    """The flat frame: vertices merged where their images coincide, one edge per face side (a
    crease where both faces' images of it agree, a boundary edge per face otherwise)."""
    tolerance = MERGE_REL_TOL * size
    # A vertex keeps its id where the sheet is not cut (its first image); the other images of a
    # cut vertex are numbered after the form's vertices; ids are compacted at the end.
    points: dict[int, np.ndarray] = {}
    by_vertex: dict[int, list[int]] = collections.defaultdict(list)
    corner_id: list[list[int]] = []
    extra = int(frame.n_vertices)
    for face, xy in zip(faces, flat, strict=True):
        ids = []
        for v, p in zip(face, xy, strict=True):
            found = next(
                (n for n in by_vertex[v] if np.linalg.norm(points[n] - p) <= tolerance), None
            )
            if found is None:
                found = v if not by_vertex[v] else extra
                extra += found != v
                points[found] = p
                by_vertex[v].append(found)
            ids.append(found)
        corner_id.append(ids)
    compact = {old: new for new, old in enumerate(sorted(points))}
    corner_id = [[compact[n] for n in ids] for ids in corner_id]
    points = {compact[n]: p for n, p in points.items()}
    side_angle = dict(zip(_face_side_list(faces), angles, strict=True))
    edges, kinds, degrees = [], [], []
    seen: set[frozenset[int]] = set()
    cut: set[frozenset[int]] = set()
    for f, face in enumerate(faces):
        for k, (u, v) in enumerate(_face_sides(face)):
            a, b = corner_id[f][k], corner_id[f][(k + 1) % len(face)]
            key = frozenset((a, b))
            if key in seen:
                continue
            seen.add(key)
            shared = [
                g
                for g in sides[frozenset((u, v))]
                if g != f
                and {corner_id[g][faces[g].index(u)], corner_id[g][faces[g].index(v)]} == {a, b}
            ]
            given = assignment.get(frozenset((u, v)), "U")
            edges.append((a, b))
            if not shared and given in CREASES and len(sides[frozenset((u, v))]) == 2:
                cut.add(frozenset((u, v)))
            if not shared or given not in CREASES:
                # Apart in the flat sheet: its boundary (or a cut the folding closes); together
                # but not a crease: a cut between the two faces.
                kinds.append("C" if shared else "B")
                degrees.append(0.0)
                continue
            kind, angle = _crease_kind(given, float(side_angle[(u, v)]))
            kinds.append(kind)
            degrees.append(float(np.degrees(angle)))
    if cut:
        shown = ", ".join("–".join(map(str, sorted(side))) for side in list(cut)[:6])
        warnings.warn(
            f"the folded form closes on itself: the flat sheet is cut along {len(cut)} of its "
            f"creases ({shown}{' ...' if len(cut) > 6 else ''}), chosen by a breadth-first tree of "
            f"faces from face {root}; to choose the seams, assign them C in the file (or pick root=)",
            UserWarning,
            stacklevel=4,
        )
    coords = np.asarray([points[n] for n in range(len(points))])
    return FoldFrame(
        vertices_coords=coords,
        edges_vertices=np.asarray(edges, dtype=np.int64),
        edges_assignment=tuple(kinds),
        edges_fold_angle_deg=np.asarray(degrees),
        faces_vertices=tuple(tuple(ids) for ids in corner_id),
        frame_unit=frame.frame_unit,
        frame_classes=("creasePattern",),
        frame_attributes=("2D",),
        extra={
            **{k: v for k, v in frame.extra.items() if k in ("frame_title", "frame_description")},
            "origami_jax:unfolded_from": "foldedForm",
        },
    )


def _crease_kind(given: str, angle: float) -> tuple[str, float]:
    """The flat pattern's assignment of a crease the form folds by `angle` (rad) and the file
    assigns `given` (checked by `_oriented`), and its fold angle: folded flat (±180°, where the
    dihedral's sign is round-off) it takes the sign of the given `M` or `V`, valley for `U`."""
    flat = abs(angle) < FLAT_ANGLE
    if abs(angle) > np.pi - 1e-6:
        return ("M", -np.pi) if given == "M" else ("V", np.pi)
    if given in ("M", "V"):
        return given, angle
    if flat:
        return "F", 0.0
    return ("V" if angle > 0 else "M"), angle


def _oriented(coords, faces, assignment) -> list[tuple[int, ...]]:
    """`faces`, reversed when every `M`/`V` crease that the form folds neither flat nor through
    ±180° has the other sign (wound clockwise seen from the side the assignments refer to).
    `FoldFormatError` when some agree and some do not."""
    sides = _face_side_list(faces)
    angles = fold_angles_from_coords(coords, faces, np.asarray(sides).reshape(-1, 2))
    agree, against = [], []
    for (u, v), angle in zip(sides, angles, strict=True):
        given = assignment.get(frozenset((u, v)))
        if given not in ("M", "V") or not 1e-6 < abs(angle) < np.pi - 1e-6:
            continue
        (agree if (angle > 0) == (given == "V") else against).append((u, v, given, angle))
    if against and not agree:
        return [face[::-1] for face in faces]
    if against:
        u, v, given, angle = against[0]
        raise FoldFormatError(
            f"edge {u}–{v} is assigned {given} but the folded form folds it by "
            f"{np.degrees(angle):+.3g}° ({'valley' if angle > 0 else 'mountain'}: valley +) while "
            f"{len(agree)} other crease(s) agree with their assignment: fix its assignment"
        )
    return faces


def _face_plane(coords: np.ndarray, face: tuple[int, ...], f: int, size: float) -> np.ndarray:
    """The face's corners in its own plane `(k, 2)`: a right-handed basis with the face's (Newell)
    normal, so that the corners run counter-clockwise."""
    if len(face) < 3 or len(set(face)) != len(face):
        raise FoldFormatError(f"face {f} {list(face)} needs at least three distinct vertices")
    p = coords[list(face)]
    normal = np.sum(np.cross(p, np.roll(p, -1, axis=0)), axis=0)
    length = np.linalg.norm(normal)
    if length <= PLANAR_REL_TOL * size**2:
        raise FoldFormatError(f"face {f} {list(face)} has no area in the folded form")
    normal = normal / length
    off = np.abs((p - p.mean(axis=0)) @ normal)
    if np.max(off) > FACE_PLANAR_REL_TOL * size:
        raise FoldFormatError(
            f"face {f} {list(face)} is not planar in the folded form (a corner {np.max(off):.3g} "
            "units off its plane): rigid panels are planar; split it into planar faces"
        )
    e1 = p[1] - p[0]
    e1 = e1 / np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    return np.stack([(p - p[0]) @ e1, (p - p[0]) @ e2], axis=1)


def _rigid_onto(xy: np.ndarray, i: int, j: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`xy` turned and moved (no reflection) so that its points `i` and `j` land on `a` and `b`
    (the same distance apart: both are one edge of the folded form)."""
    d_from, d_to = xy[j] - xy[i], b - a
    angle = np.arctan2(d_to[1], d_to[0]) - np.arctan2(d_from[1], d_from[0])
    c, s = np.cos(angle), np.sin(angle)
    rotation = np.array([[c, -s], [s, c]])
    return (xy - xy[i]) @ rotation.T + a


def _face_sides(face: tuple[int, ...]) -> list[tuple[int, int]]:
    return list(zip(face, face[1:] + face[:1], strict=True))


def _face_side_list(faces) -> list[tuple[int, int]]:
    return [side for face in faces for side in _face_sides(face)]


def _side_array(faces) -> np.ndarray:
    return np.asarray(_face_side_list(faces), dtype=np.int64).reshape(-1, 2)


def _sides(faces) -> dict[frozenset[int], list[int]]:
    """The faces on each side (keyed by its two vertices); more than two is refused."""
    out: dict[frozenset[int], list[int]] = collections.defaultdict(list)
    for f, face in enumerate(faces):
        for u, v in _face_sides(face):
            out[frozenset((u, v))].append(f)
            if len(out[frozenset((u, v))]) > 2:
                raise FoldFormatError(
                    f"edge {u}–{v} is a side of more than two faces "
                    f"({out[frozenset((u, v))]}): not a sheet"
                )
    return out


def _side_assignment(frame: FoldFrame) -> dict[frozenset[int], str]:
    """The file's assignment of each edge, keyed by its two vertices (none: every shared side a
    crease)."""
    if frame.edges_vertices is None or frame.edges_assignment is None:
        return {}
    return {
        frozenset((int(u), int(v))): a
        for (u, v), a in zip(frame.edges_vertices.tolist(), frame.edges_assignment, strict=True)
    }
