"""Building a net's tree from a flat crease pattern (the checks and arrays behind `net_geometry`)."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from ._errors import FoldFormatError
from ._polygons import triangulate
from ._write import planar_faces

CREASES = frozenset("MVFU")
# Faces whose areas agree to this relative tolerance tie for the default root.
ROOT_AREA_REL_TOL = 1e-9


def build_net(
    *,
    coords: np.ndarray,
    plane: np.ndarray,
    edges: list[list[int]],
    assignment: tuple[str, ...],
    faces: tuple[tuple[int, ...], ...] | None,
    angles_deg: np.ndarray,
    root: int | None,
    require_targets: bool,
    where: str,
    parallel_tol: float,
) -> dict[str, Any]:
    """The fields of a `NetGeometry` (all but `unit`); see `net_geometry` for the checks."""
    normal = np.cross(plane[0], plane[1])
    size = max(float(np.max(np.ptp(coords, axis=0))), 1e-300)
    xy = (coords - coords[0]) @ plane.T
    if faces is None:
        faces = planar_faces(np.column_stack([xy, np.zeros(len(xy))]), np.asarray(edges))
    if not faces:
        raise FoldFormatError(f"{where}: the pattern has no faces; add faces_vertices")
    n_faces = len(faces)
    width = max(len(face) for face in faces)

    # Faces: counter-clockwise seen from the normal, simple; their triangles.
    face_coords = np.full((n_faces, width, 3), np.nan)
    corner_mask = np.zeros((n_faces, width), dtype=bool)
    triangles: list[tuple[int, int, int]] = []
    triangle_faces: list[int] = []
    areas = np.zeros(n_faces)
    centroids = np.zeros((n_faces, 3))
    for f, face in enumerate(faces):
        face_coords[f, : len(face)] = coords[list(face)]
        corner_mask[f, : len(face)] = True
        p = xy[list(face)]
        area = 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
        if area <= 1e-12 * size**2:
            state = "degenerate (zero area)" if abs(area) <= 1e-12 * size**2 else "clockwise"
            raise FoldFormatError(
                f"{where}: face {f} {list(face)} is {state} seen from the paper's normal "
                f"{np.round(normal, 12).tolist()}; list every face's vertices counter-clockwise"
            )
        try:
            local = triangulate(p)
        except ValueError:
            raise FoldFormatError(
                f"{where}: face {f} {list(face)} is not a simple polygon (its sides cross); fix "
                "its vertex order in faces_vertices"
            ) from None
        for i, j, k in local:
            triangles.append((f * width + i, f * width + j, f * width + k))
            triangle_faces.append(f)
            t = coords[[face[i], face[j], face[k]]]
            t_area = 0.5 * float(np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0])))
            centroids[f] += t_area * t.mean(axis=0)
        areas[f] = area
        centroids[f] /= area

    # Edges and the face sides along them.
    edge_of: dict[frozenset[int], int] = {}
    for e, (u, v) in enumerate(edges):
        key = frozenset((u, v))
        if key in edge_of:
            raise FoldFormatError(
                f"{where}: edges {edge_of[key]} and {e} both join vertices {u} and {v}; keep one"
            )
        edge_of[key] = e
    sides: dict[int, list[tuple[int, int]]] = {}
    for f, face in enumerate(faces):
        if len(set(face)) < len(face):
            twice = next(u for u in face if face.count(u) > 1)
            raise FoldFormatError(
                f"{where}: faces_vertices[{f}] = {list(face)} lists vertex {twice} more than once: "
                "a panel lists each corner once"
            )
        for k, u in enumerate(face):
            v = face[(k + 1) % len(face)]
            e = edge_of.get(frozenset((u, v)))
            if e is None:
                raise FoldFormatError(
                    f"{where}: side {u}-{v} of face {f} is not an edge; add [{u}, {v}] to "
                    "edges_vertices (with its assignment)"
                )
            sides.setdefault(e, []).append((f, k))
    boundary_sides: list[tuple[int, int, int]] = []
    pair_edges: dict[tuple[int, int], list[int]] = {}
    for e, a in enumerate(assignment):
        on = sides.get(e, [])
        if a in CREASES:
            if len(on) != 2 or on[0][0] == on[1][0]:
                raise FoldFormatError(
                    f"{where}: crease edge {e} (assignment {a}) borders {len(on)} face(s) "
                    f"{sorted({f for f, _ in on})}; a crease joins two faces: make it a boundary "
                    "edge (B) or add the face on its other side"
                )
            pair = (min(on[0][0], on[1][0]), max(on[0][0], on[1][0]))
            pair_edges.setdefault(pair, []).append(e)
        elif a == "B" and len(on) > 1:
            raise FoldFormatError(
                f"{where}: edge {e} is a boundary (B) edge but faces {[f for f, _ in on]} both have "
                "it as a side; assign C for a cut between them, or a crease M, V, F or U"
            )
        else:
            boundary_sides.extend((f, k, e) for f, k in on)

    _check_interior_loops(coords, edges, assignment, faces, where)
    hinge_lines = _hinge_lines(
        coords, edges, pair_edges, angles_deg, assignment, size, where, parallel_tol
    )

    # The tree, breadth first from the root.
    if root is None:
        best = areas.max()
        root = int(np.flatnonzero(areas >= best * (1 - ROOT_AREA_REL_TOL))[0])
    elif not 0 <= root < n_faces:
        raise FoldFormatError(
            f"root face {root} does not exist: the pattern has {n_faces} faces (0 to {n_faces - 1})"
        )
    neighbours: dict[int, list[int]] = {f: [] for f in range(n_faces)}
    for f, g in pair_edges:
        neighbours[f].append(g)
        neighbours[g].append(f)
    parents = np.full(n_faces, -1, dtype=np.int64)
    seen = {root}
    order = [root]
    queue = deque([root])
    while queue:
        f = queue.popleft()
        for g in sorted(neighbours[f]):
            if g == parents[f]:
                continue
            if g in seen:
                loop = _loop(parents, f, g)
                raise FoldFormatError(
                    f"{where}: the creases join faces {loop} in a closed loop (around a hole or "
                    "a cut-out in the paper); the panel-tree engine folds trees: cut one crease "
                    "of the loop (assignment C) to make the net a tree (the closed-loop engine, "
                    "origami_jax.loops.load_pattern, takes loops round interior vertices only)"
                )
            seen.add(g)
            parents[g] = f
            order.append(g)
            queue.append(g)
    if len(order) < n_faces:
        apart = sorted(set(range(n_faces)) - seen)
        raise FoldFormatError(
            f"{where}: faces {apart} are not joined to the root face {root} by creases; a net is "
            "one piece: join them with a crease (M, V, F or U), or read each piece on its own"
        )

    # Creases in order; the hinge axis runs along the crease as the child runs it.
    m = n_faces - 1
    crease_child = np.array(order[1:], dtype=np.int64)
    crease_parent = parents[crease_child]
    face_crease = np.full(n_faces, -1, dtype=np.int64)
    axes = np.zeros((m, 3))
    points = np.zeros((m, 3))
    lengths = np.zeros(m)
    targets = np.zeros(m)
    crease_edges = []
    kinds = []
    free = []
    for j, (child, parent) in enumerate(
        zip(crease_child.tolist(), crease_parent.tolist(), strict=True)
    ):
        face_crease[child] = j
        line_edges, kind, angle = hinge_lines[(min(child, parent), max(child, parent))]
        k = next(k for f, k in sides[line_edges[0]] if f == child)
        face = faces[child]
        u, v = face[k], face[(k + 1) % len(face)]
        axis = (coords[v] - coords[u]) / np.linalg.norm(coords[v] - coords[u])
        ends = np.array([coords[w] @ axis for e in line_edges for w in edges[e]])
        axes[j], points[j], lengths[j] = axis, coords[u], float(ends.max() - ends.min())
        targets[j] = np.deg2rad(angle)
        crease_edges.append(tuple(line_edges))
        kinds.append(kind)
        if np.isnan(angle):
            free.extend(line_edges)
    if free and require_targets:
        raise FoldFormatError(
            f"{where}: crease edge(s) {sorted(free)} are unassigned (U) with no edges_foldAngle, so "
            "they have no target fold angle: give their edges_foldAngle in degrees, assign M, V "
            "or F, or pass require_targets=False"
        )
    return dict(
        vertices_coords=coords,
        faces=tuple(tuple(int(v) for v in face) for face in faces),
        normal=normal,
        plane=plane,
        face_areas=areas,
        face_centroids=centroids,
        face_coords=face_coords,
        corner_mask=corner_mask,
        root=root,
        order=np.array(order, dtype=np.int64),
        parents=parents,
        face_crease=face_crease,
        crease_child=crease_child,
        crease_parent=crease_parent,
        crease_edges=tuple(crease_edges),
        hinge_axes=axes,
        hinge_points=points,
        crease_lengths=lengths,
        targets=targets,
        assignments=tuple(kinds),
        boundary_sides=np.array(boundary_sides, dtype=np.int64).reshape(-1, 3),
        triangles=np.array(triangles, dtype=np.int64).reshape(-1, 3),
        triangle_faces=np.array(triangle_faces, dtype=np.int64),
    )


def _check_interior_loops(
    coords: np.ndarray,
    edges: list[list[int]],
    assignment: tuple[str, ...],
    faces: tuple[tuple[int, ...], ...],
    where: str,
) -> None:
    """Raise for an interior vertex (creases only around it) whose faces close a loop."""
    all_creases = np.ones(len(coords), dtype=bool)
    has_edge = np.zeros(len(coords), dtype=bool)
    for (u, v), a in zip(edges, assignment, strict=True):
        for w in (u, v):
            has_edge[w] = True
            all_creases[w] &= a in CREASES
    around: dict[int, set[int]] = {}
    for f, face in enumerate(faces):
        for w in face:
            around.setdefault(w, set()).add(f)
    for w in np.flatnonzero(all_creases & has_edge).tolist():
        if len(around.get(w, ())) >= 3:
            x, y, z = (float(c) for c in coords[w])
            raise FoldFormatError(
                f"{where}: the creases around interior vertex {w} ({x:.6g}, {y:.6g}, {z:.6g}) "
                f"close a loop through faces {sorted(around[w])}; the panel-tree engine folds trees: "
                "read it with origami_jax.loops.load_pattern (the closed-loop engine), or cut one "
                f"crease at vertex {w} (assignment C) to fold it as a net"
            )


def _hinge_lines(
    coords: np.ndarray,
    edges: list[list[int]],
    pair_edges: dict[tuple[int, int], list[int]],
    angles_deg: np.ndarray,
    assignment: tuple[str, ...],
    size: float,
    where: str,
    parallel_tol: float,
) -> dict[tuple[int, int], tuple[list[int], str, float]]:
    """Each joined face pair's crease edges (one straight line), assignment and angle (degrees)."""
    out = {}
    for pair, line in pair_edges.items():
        line = sorted(line)
        first = coords[edges[line[0]][1]] - coords[edges[line[0]][0]]
        first = first / np.linalg.norm(first)
        origin = coords[edges[line[0]][0]]
        for e in line[1:]:
            for w in edges[e]:
                offset = coords[w] - origin
                if np.linalg.norm(offset - (offset @ first) * first) > parallel_tol * size:
                    raise FoldFormatError(
                        f"{where}: faces {pair[0]} and {pair[1]} are joined by creases {line} "
                        "that do not lie on one line, so they cannot hinge; cut all but one "
                        "(assignment C)"
                    )
        values = angles_deg[line]
        kinds = {assignment[e] for e in line}
        if len(kinds) > 1 or not np.allclose(values, values[0], equal_nan=True):
            raise FoldFormatError(
                f"{where}: the crease between faces {pair[0]} and {pair[1]} is made of edges "
                f"{line} with different assignments {sorted(kinds)} or fold angles "
                f"{values.tolist()}; one hinge has one fold angle: make them agree"
            )
        out[pair] = (line, kinds.pop(), float(values[0]))
    return out


def _loop(parents: np.ndarray, f: int, g: int) -> list[int]:
    """The faces of the loop closed by joining `f` and `g` (both already in the tree)."""

    def ancestry(x: int) -> list[int]:
        path = [x]
        while parents[path[-1]] >= 0:
            path.append(int(parents[path[-1]]))
        return path

    up_f, up_g = ancestry(f), ancestry(g)
    common = next(x for x in up_f if x in set(up_g))
    return up_f[: up_f.index(common) + 1] + list(reversed(up_g[: up_g.index(common)]))
