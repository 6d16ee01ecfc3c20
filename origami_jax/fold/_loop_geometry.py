"""A crease pattern whose faces close loops around interior vertices, as plain numpy arrays (radians).

Every interior vertex of a crease pattern (creases all round it) closes a loop of faces: a
Miura-ori, a waterbomb, any single vertex folded in the middle of a sheet. `loop_geometry` reads
such a pattern and splits it into what a rigid-panel model needs:

- a **spanning tree** of its faces (a `NetGeometry`: the same tree a net has, with the creases that
  would close loops cut), whose creases are the *tree creases*;
- the *cut creases*, the creases left out of the tree, each joining two faces of it;
- the **vertex loops**: around every interior vertex, its creases in counter-clockwise order with
  their outward directions in the flat pattern. Folded rigidly, the faces close up around the vertex
  exactly when the product of the rotations about those directions by the fold angles is the
  identity (`closure_residual`); for a pattern cut from one disk of paper these loops are all the
  loops there are (Euler: creases − faces + 1 = interior vertices).

Crease `j` of the pattern is the tree's crease `j` for `j < m_T` and cut crease `j − m_T` after.
Fold angles are valley positive (FOLD's convention; see `origami_jax.fold.net_geometry` for how the
sign follows the faces' counter-clockwise order seen from the paper's normal).

Facet edges: crease patterns exported triangulated (Origami Simulator's FOLD export) mark the
diagonals that only triangulate a facet as flat `F` edges. With `flat_creases="panel"` (default) the
faces joined by `F` edges are merged back into one rigid panel; `"hinge"` keeps every `F` edge as a
crease with a 0° target.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from ._errors import FoldFormatError
from ._geometry import _as_fold, _assignment, paper_plane
from ._model import FoldFile, FoldFrame
from ._net_build import CREASES
from ._net_geometry import NetGeometry, Seams, _rotations, net_geometry
from ._polygons import signed_area
from ._write import planar_faces

# Sector angles around an interior vertex must sum to 2π within this (rad).
FAN_TOL = 1e-6


@dataclasses.dataclass(frozen=True, eq=False)
class LoopGeometry:
    """A crease pattern with closed loops (module docstring); lengths in `unit`, angles in radians.

    `F` faces (after merging facets), `m = m_T + m_C` creases, `n_v` interior vertices.

    **Fields:**
    - `tree`: the spanning tree as a `NetGeometry` (its creases are creases `0 … m_T − 1`; the cut
      creases appear there as cut `C` sides).
    - `faces`: vertex ids of each face (counter-clockwise, merged facets as one polygon);
      `vertices_coords` `(V, 3)`; `normal`, `plane` as in `NetGeometry`; `unit`.
    - `crease_faces`: int `(m, 2)`, the two faces of each crease (for a tree crease: parent, child;
      for a cut crease: the face that runs its `axis` clockwise, then the one that runs it
      counter-clockwise); `crease_edges`: FOLD edge ids of each crease (in the pattern after
      merging facets, `frame`); `axes` `(m, 3)` unit, `points` `(m, 3)`, `lengths` `(m,)`: each
      crease's line, oriented as its second face runs it counter-clockwise; `targets` `(m,)`;
      `assignments`.
    - `loop_vertices`: int `(n_v,)`, the interior vertices; `loop_creases`: for each, its creases in
      counter-clockwise order; `loop_directions`: for each, `(deg, 3)` outward unit directions of
      those creases; `loop_sectors`: for each, `(deg,)` sector angles (sector `i` from crease `i` to
      `i + 1`).
    - `seams`: boundary sides that meet at the targets (the tree's seams without the cut creases).
    - `frame`: the flat crease pattern as a FOLD frame (facets merged, edges renumbered).
    """

    tree: NetGeometry
    faces: tuple[tuple[int, ...], ...]
    vertices_coords: np.ndarray
    normal: np.ndarray
    plane: np.ndarray
    unit: str | None
    crease_faces: np.ndarray
    crease_edges: tuple[tuple[int, ...], ...]
    axes: np.ndarray
    points: np.ndarray
    lengths: np.ndarray
    targets: np.ndarray
    assignments: tuple[str, ...]
    loop_vertices: np.ndarray
    loop_creases: tuple[tuple[int, ...], ...]
    loop_directions: tuple[np.ndarray, ...]
    loop_sectors: tuple[np.ndarray, ...]
    seams: Seams
    frame: FoldFrame

    @property
    def n_creases(self) -> int:
        return len(self.crease_edges)

    @property
    def n_tree_creases(self) -> int:
        return self.tree.n_creases

    @property
    def n_cut_creases(self) -> int:
        return self.n_creases - self.tree.n_creases

    @property
    def n_loops(self) -> int:
        return len(self.loop_vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def closure_residual(self, angles: np.ndarray) -> np.ndarray:
        """How far the faces around each interior vertex are from closing up at fold angles `angles`
        (rad, `(..., m)`): the rotation angle (rad) of the product of the crease rotations around
        each vertex, `(..., n_v)` (0 where the loop closes)."""
        angles = np.asarray(angles, dtype=float)
        out = []
        for creases, directions in zip(self.loop_creases, self.loop_directions, strict=True):
            rotations = _rotations(directions, angles[..., list(creases)])
            product = np.broadcast_to(np.eye(3), rotations.shape[:-3] + (3, 3)).copy()
            for k in range(len(creases)):
                product = product @ rotations[..., k, :, :]
            cosine = np.clip((np.trace(product, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)
            skew = product - np.swapaxes(product, -1, -2)
            sine = 0.5 * np.linalg.norm(
                np.stack([skew[..., 2, 1], skew[..., 0, 2], skew[..., 1, 0]], -1), axis=-1
            )
            out.append(np.arctan2(sine, cosine))
        return np.stack(out, axis=-1) if out else np.zeros(angles.shape[:-1] + (0,))

    def fold(self, angles: np.ndarray) -> np.ndarray:
        """Corner positions of every face folded rigidly to `angles` (rad, `(..., m)`), from the
        tree creases (the cut creases follow when the loops close): float64 `(..., F, K, 3)` in
        `tree.faces` order (see `NetGeometry.fold`)."""
        angles = np.asarray(angles, dtype=float)
        return self.tree.fold(angles[..., : self.n_tree_creases])

    def kawasaki(self) -> np.ndarray:
        """Each interior vertex's alternating sector sum `|Σ (−1)^i α_i|` (rad, `(n_v,)`): 0 for a
        vertex that can fold flat (Kawasaki–Justin; an odd degree cannot)."""
        out = []
        for sectors in self.loop_sectors:
            if len(sectors) % 2:
                out.append(np.inf)
            else:
                out.append(abs(float(np.sum(sectors[0::2]) - np.sum(sectors[1::2]))))
        return np.asarray(out, dtype=float)


def loop_geometry(
    fold_or_path: FoldFile | str | os.PathLike[str],
    *,
    root: int | None = None,
    frame: int = 0,
    flat_creases: str = "panel",
    require_targets: bool = True,
) -> LoopGeometry:
    """The rigid panels, tree, cut creases and vertex loops of a flat FOLD crease pattern.

    **Arguments:** `fold_or_path`: a `FoldFile` or `.fold` path; `root`: the face that stays put
    (default the largest, as for nets; a face of the file: merged facets, the face it is part of);
    `frame`: which frame (it must be flat, in any plane); `flat_creases`: `"panel"` (merge faces
    joined by `F` edges into one rigid panel, default) or `"hinge"`; `require_targets`: raise for a
    crease without a target.

    **Returns:** a `LoopGeometry`. A pattern without interior vertices gives one with no loops (its
    `tree` is the net).

    **Raises:** `FoldFormatError` (one line, what and how to fix) for a frame that is not flat, an
    edge shared by more than two faces or a crease that borders one face (not a manifold sheet),
    facets that do not merge into a simple polygon, a loop of faces that goes round a hole rather
    than an interior vertex, and everything `net_geometry` raises.
    """
    if flat_creases not in ("panel", "hinge"):
        raise ValueError(f"flat_creases must be 'panel' or 'hinge', got {flat_creases!r}.")
    fold = _as_fold(fold_or_path)
    resolved = fold.frame(frame)
    where = "key frame" if frame == 0 else f"frame {frame}"
    if resolved.vertices_coords is None or resolved.edges_vertices is None:
        raise FoldFormatError(f"{where}: a crease pattern needs vertices_coords and edges_vertices")
    assignment = list(_assignment(resolved, where))
    coords = resolved.coords3
    plane = paper_plane(coords, resolved.faces_vertices)
    if plane is None:
        raise FoldFormatError(
            f"{where}: the vertices do not lie in one plane; a crease pattern is read from the flat "
            "sheet (before folding): pass its flat frame"
        )
    normal = np.cross(plane[0], plane[1])
    edges = [tuple(int(v) for v in e) for e in resolved.edges_vertices.tolist()]
    angles_deg = np.asarray(fold.fold_angles_deg(frame), dtype=float)
    faces = _frame_faces(resolved, coords, plane, edges)
    _check_manifold(edges, assignment, faces, where)
    if flat_creases == "panel":
        faces, keep, face_of = _merge_facets(edges, assignment, faces, where)
        edges = [edges[e] for e in keep]
        assignment = [assignment[e] for e in keep]
        angles_deg = angles_deg[keep]
        if root is not None and 0 <= root < len(face_of):
            root = face_of[root]  # the file's face, counted among the merged ones

    # Faces on either side of every edge; crease pairs; the spanning tree (breadth first, as nets).
    sides = _edge_sides(edges, faces)
    pairs: dict[tuple[int, int], list[int]] = {}
    for e, a in enumerate(assignment):
        on = sides.get(e, [])
        if a in CREASES and len(on) == 2 and on[0] != on[1]:
            pairs.setdefault((min(on), max(on)), []).append(e)
    areas = np.array([signed_area(coords[list(face)] @ plane.T) for face in faces])
    if root is None:
        root = int(np.flatnonzero(areas >= areas.max() * (1 - 1e-9))[0])
    elif not 0 <= root < len(faces):
        raise FoldFormatError(
            f"root face {root} does not exist: the pattern has {len(faces)} faces "
            f"(0 to {len(faces) - 1})"
        )
    neighbours: dict[int, list[int]] = {f: [] for f in range(len(faces))}
    for f, g in pairs:
        neighbours[f].append(g)
        neighbours[g].append(f)
    seen, queue, tree_pairs = {root}, [root], set()
    while queue:
        f = queue.pop(0)
        for g in sorted(neighbours[f]):
            if g not in seen:
                seen.add(g)
                queue.append(g)
                tree_pairs.add((min(f, g), max(f, g)))
    cut_pairs = sorted(set(pairs) - tree_pairs)

    # The tree: the same pattern with the loop-closing creases cut.
    cut_edges = {e for pair in cut_pairs for e in pairs[pair]}
    tree_assignment = tuple("C" if e in cut_edges else a for e, a in enumerate(assignment))
    tree_angles = np.where([e in cut_edges for e in range(len(edges))], 0.0, angles_deg)
    tree_frame = FoldFrame(
        vertices_coords=coords,
        edges_vertices=np.asarray(edges, dtype=np.int64),
        edges_assignment=tree_assignment,
        edges_fold_angle_deg=tree_angles,
        faces_vertices=tuple(faces),
        frame_unit=resolved.frame_unit,
    )
    tree = net_geometry(FoldFile(frames=(tree_frame,)), root=root, require_targets=require_targets)
    frame_out = dataclasses.replace(
        tree_frame,
        edges_assignment=tuple(assignment),
        edges_fold_angle_deg=np.where(np.isnan(angles_deg), np.nan, angles_deg),
        frame_classes=("creasePattern",),
        frame_attributes=("2D",) if np.allclose(normal, [0, 0, 1]) else ("3D",),
        extra=dict(resolved.extra),
    )

    # Cut creases: the face running the crease counter-clockwise is the second one.
    size = max(float(np.max(np.ptp(coords, axis=0))), 1e-300)
    cut_faces, cut_axes, cut_points, cut_lengths, cut_targets, cut_kinds = [], [], [], [], [], []
    for pair in cut_pairs:
        line = sorted(pairs[pair])
        values = angles_deg[line]
        kinds = {assignment[e] for e in line}
        if len(kinds) > 1 or not np.allclose(values, values[0], equal_nan=True):
            raise FoldFormatError(
                f"{where}: the crease between faces {pair[0]} and {pair[1]} is made of edges {line} "
                f"with different assignments {sorted(kinds)} or fold angles {values.tolist()}; one "
                "hinge has one fold angle: make them agree"
            )
        u, v = edges[line[0]]
        face_b = next(f for f in pair if _runs(faces[f], u, v))
        face_a = pair[0] if face_b == pair[1] else pair[1]
        k = faces[face_b].index(u)
        start, end = faces[face_b][k], faces[face_b][(k + 1) % len(faces[face_b])]
        axis = coords[end] - coords[start]
        axis = axis / np.linalg.norm(axis)
        ends = np.array([coords[w] @ axis for e in line for w in edges[e]])
        for e in line[1:]:
            for w in edges[e]:
                offset = coords[w] - coords[start]
                if np.linalg.norm(offset - (offset @ axis) * axis) > 1e-7 * size:
                    raise FoldFormatError(
                        f"{where}: faces {pair[0]} and {pair[1]} are joined by creases {line} that "
                        "do not lie on one line, so they cannot hinge"
                    )
        cut_faces.append((face_a, face_b))
        cut_axes.append(axis)
        cut_points.append(coords[start])
        cut_lengths.append(float(ends.max() - ends.min()))
        cut_targets.append(np.deg2rad(values[0]))
        cut_kinds.append(kinds.pop())
        if np.isnan(values[0]) and require_targets:
            raise FoldFormatError(
                f"{where}: crease edge(s) {line} are unassigned (U) with no edges_foldAngle: give "
                "their edges_foldAngle in degrees or assign M, V or F"
            )
    crease_edges = tuple(tree.crease_edges) + tuple(tuple(sorted(pairs[p])) for p in cut_pairs)
    crease_of_edge = {e: j for j, line in enumerate(crease_edges) for e in line}
    tree_faces = np.stack([tree.crease_parent, tree.crease_child], axis=-1).reshape(-1, 2)
    crease_faces = np.concatenate(
        [tree_faces, np.asarray(cut_faces, dtype=np.int64).reshape(-1, 2)]
    ).astype(np.int64)

    # Interior vertices: creases all round, faces closing a full turn.
    loop_vertices, loop_creases, loop_directions, loop_sectors = [], [], [], []
    incident: dict[int, list[int]] = {}
    for e, (u, v) in enumerate(edges):
        incident.setdefault(u, []).append(e)
        incident.setdefault(v, []).append(e)
    around: dict[int, set[int]] = {}
    for f, face in enumerate(faces):
        for w in face:
            around.setdefault(w, set()).add(f)
    for w in sorted(incident):
        on = incident[w]
        if not all(assignment[e] in CREASES for e in on) or len(on) < 3:
            continue
        if not all(e in crease_of_edge for e in on):
            continue
        directions = []
        for e in on:
            other = edges[e][1] if edges[e][0] == w else edges[e][0]
            d = coords[other] - coords[w]
            directions.append(d / np.linalg.norm(d))
        directions = np.asarray(directions)
        polar = np.arctan2(directions @ plane[1], directions @ plane[0])
        order = np.argsort(polar)
        sectors = np.diff(np.append(polar[order], polar[order][0] + 2 * np.pi))
        if abs(float(np.sum(sectors)) - 2 * np.pi) > FAN_TOL or len(around.get(w, ())) != len(on):
            continue
        loop_vertices.append(w)
        loop_creases.append(tuple(crease_of_edge[on[i]] for i in order))
        loop_directions.append(directions[order])
        loop_sectors.append(sectors)
    n_cut = len(cut_pairs)
    if n_cut != len(loop_vertices):
        raise FoldFormatError(
            f"{where}: the faces close {n_cut} independent loop(s) but only {len(loop_vertices)} go "
            "round an interior vertex; the others go round a hole or a cut-out in the paper, which "
            "the closed-loop engine does not model: cut one crease of each such loop (assignment C)"
        )
    cut_set = {tuple(sorted(pairs[p])) for p in cut_pairs}
    keep_seam = [
        s
        for s in range(len(tree.target_seams) if not np.any(np.isnan(tree.targets)) else 0)
        if not (
            tree.target_seams.edges[s, 0] == tree.target_seams.edges[s, 1]
            and any(int(tree.target_seams.edges[s, 0]) in line for line in cut_set)
        )
    ]
    seams = _select_seams(tree, keep_seam)
    return LoopGeometry(
        tree=tree,
        faces=tuple(faces),
        vertices_coords=coords,
        normal=normal,
        plane=plane,
        unit=resolved.frame_unit,
        crease_faces=crease_faces,
        crease_edges=crease_edges,
        axes=np.concatenate([tree.hinge_axes, np.asarray(cut_axes).reshape(-1, 3)]),
        points=np.concatenate([tree.hinge_points, np.asarray(cut_points).reshape(-1, 3)]),
        lengths=np.concatenate([tree.crease_lengths, np.asarray(cut_lengths)]),
        targets=np.concatenate([tree.targets, np.asarray(cut_targets, dtype=float)]),
        assignments=tuple(tree.assignments) + tuple(cut_kinds),
        loop_vertices=np.asarray(loop_vertices, dtype=np.int64),
        loop_creases=tuple(loop_creases),
        loop_directions=tuple(loop_directions),
        loop_sectors=tuple(loop_sectors),
        seams=seams,
        frame=frame_out,
    )


def _runs(face: tuple[int, ...], u: int, v: int) -> bool:
    """Whether the face's counter-clockwise outline runs from `u` to `v`."""
    k = face.index(u)
    return face[(k + 1) % len(face)] == v


def _check_manifold(edges, assignment, faces, where: str) -> None:
    """Every edge borders at most two faces, once each way (a sheet of paper, not a book)."""
    count: dict[frozenset[int], list[int]] = {}
    for f, face in enumerate(faces):
        for k, u in enumerate(face):
            count.setdefault(frozenset((u, face[(k + 1) % len(face)])), []).append(f)
    for e, (u, v) in enumerate(edges):
        on = count.get(frozenset((u, v)), [])
        if len(on) > 2:
            raise FoldFormatError(
                f"{where}: edge {e} ({u}-{v}) borders {len(on)} faces {on}; a sheet is a manifold, "
                "each edge bordering at most two faces: remove the extra face or split the edge"
            )


def _merge_facets(edges, assignment, faces, where: str):
    """Faces joined by `F` edges merged into one polygon each; returns the faces, the edges kept
    and each original face's merged face."""
    parent = list(range(len(faces)))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    sides = _edge_sides(edges, faces)
    internal = set()
    for e, a in enumerate(assignment):
        if a == "F" and len(sides.get(e, [])) == 2:
            f, g = sides[e]
            parent[find(f)] = find(g)
            internal.add(e)
    if not internal:
        return faces, list(range(len(edges))), list(range(len(faces)))
    groups: dict[int, list[int]] = {}
    for f in range(len(faces)):
        groups.setdefault(find(f), []).append(f)
    merged = []
    for members in sorted(groups.values()):
        if len(members) == 1:
            merged.append(faces[members[0]])
            continue
        directed = set()
        for f in members:
            face = faces[f]
            for k, u in enumerate(face):
                directed.add((u, face[(k + 1) % len(face)]))
        boundary = {(u, v) for u, v in directed if (v, u) not in directed}
        nxt: dict[int, int] = {}
        for u, v in boundary:
            if u in nxt:
                raise FoldFormatError(
                    f"{where}: faces {members} joined by flat (F) edges do not make one simple "
                    "polygon; read the pattern with flat_creases='hinge'"
                )
            nxt[u] = v
        start = min(nxt)
        loop = [start]
        while nxt[loop[-1]] != start:
            loop.append(nxt[loop[-1]])
            if len(loop) > len(boundary):
                break
        if len(loop) != len(boundary):
            raise FoldFormatError(
                f"{where}: faces {members} joined by flat (F) edges enclose a hole; read the "
                "pattern with flat_creases='hinge'"
            )
        merged.append(tuple(loop))
    keep = [e for e in range(len(edges)) if e not in internal]
    face_of = [0] * len(faces)
    for index, members in enumerate(sorted(groups.values())):
        for f in members:
            face_of[f] = index
    return merged, keep, face_of


def flat_faces_merged(fold: FoldFile, root: int | None = None) -> tuple[FoldFile, int | None]:
    """`fold`, or where flat (`F`) edges join faces of its flat key frame (a triangulated export's
    facet diagonals), a file of that frame alone with each group of joined faces one face
    (counter-clockwise, one simple polygon: the rigid panel a flat crease leaves; listed in the
    order of their first face in `fold`) and those edges dropped (the other edges renumbered in
    order; per-edge and per-face properties the model does not know are dropped, as are the other
    frames); and `root`, a face of `fold`'s key frame, as the face of the returned file it is part
    of (`None` stays `None`).

    **Raises:** `FoldFormatError` (one line) where joined faces do not make one simple polygon or
    enclose a hole, an edge borders more than two faces, or `root` is not a face of the file."""
    key = fold.key_frame
    if key.vertices_coords is None or key.edges_vertices is None or key.edges_assignment is None:
        return fold, root
    if "F" not in key.edges_assignment:
        return fold, root
    coords = key.coords3
    plane = paper_plane(coords, key.faces_vertices)
    if plane is None:  # not flat: nothing to merge here (a folded form is unfolded first)
        return fold, root
    edges = [tuple(int(v) for v in e) for e in np.asarray(key.edges_vertices).tolist()]
    faces = _frame_faces(key, coords, plane, edges)
    assignment = list(key.edges_assignment)
    _check_manifold(edges, assignment, faces, "key frame")
    merged, keep, face_of = _merge_facets(edges, assignment, faces, "key frame")
    if len(keep) == len(edges):
        return fold, root
    if root is not None and not 0 <= root < len(faces):
        raise FoldFormatError(f"root face {root} does not exist: the file has {len(faces)} faces")
    angles = key.edges_fold_angle_deg
    frame = key.replace(
        edges_vertices=np.asarray(key.edges_vertices)[keep].reshape(-1, 2),
        edges_assignment=tuple(assignment[e] for e in keep),
        edges_fold_angle_deg=None if angles is None else np.asarray(angles)[keep],
        faces_vertices=tuple(merged),
        extra={k: v for k, v in key.extra.items() if not k.startswith(("edges_", "faces_"))},
    )
    merged_fold = FoldFile(
        frames=(frame,), file_spec=fold.file_spec, file_metadata=fold.file_metadata
    )
    return merged_fold, None if root is None else face_of[root]


def _frame_faces(frame: FoldFrame, coords, plane, edges) -> list[tuple[int, ...]]:
    """`frame`'s faces as vertex tuples, traced from its planar edge graph where it lists none
    (`coords` `(V, 3)`, `plane` `(2, 3)` the paper's, `edges` the vertex pairs)."""
    faces = frame.faces_vertices
    if faces is None:
        xy = (coords - coords[0]) @ plane.T
        faces = planar_faces(np.column_stack([xy, np.zeros(len(xy))]), np.asarray(edges))
    return [tuple(int(v) for v in f) for f in faces]


def _select_seams(tree: NetGeometry, keep: list[int]) -> Seams:
    if not keep:
        empty = np.zeros((0, 2), dtype=np.int64)
        return Seams(empty, empty, np.zeros((0, 2, 2), np.int64), np.zeros((0, 2, 2), np.int64))
    s = tree.target_seams
    index = np.asarray(keep)
    return Seams(s.faces[index], s.edges[index], s.vertices[index], s.corners[index])


def _edge_sides(edges, faces) -> dict[int, list[int]]:
    """The faces on either side of every edge (by edge index; an edge on no face is absent)."""
    edge_of = {frozenset(e): i for i, e in enumerate(edges)}
    sides: dict[int, list[int]] = {}
    for f, face in enumerate(faces):
        for k, u in enumerate(face):
            e = edge_of.get(frozenset((u, face[(k + 1) % len(face)])))
            if e is not None:
                sides.setdefault(e, []).append(f)
    return sides
