"""Geometry out of a FOLD crease pattern, as plain numpy arrays (radians), for our two physics halves.

- `single_vertex_geometry`: the creases around one vertex in cyclic order, their sector angles and
  fold angles, closed (interior vertex) or open (boundary vertex, with its two boundary rays).
- `chain_geometry` (in `_chain_geometry`): an accordion / hinged chain, i.e. parallel creases
  across a strip of paper, in order along the strip, with flap lengths and widths.

Neither imports the physics packages; `origami_jax.vertex.load_single_vertex` and
`origami_jax.chain.load_chain` build their objects from these. Conventions: fold angles in radians,
valley +, mountain − (FOLD's sign).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from ._errors import FoldFormatError
from ._model import FoldFile, FoldFrame
from ._read import read_fold

# Directions closer than this (radians) are "the same"; coordinates within this (relative to the
# paper size) of a plane are "in it"; creases within this of parallel are "parallel".
ANGLE_TOL = 1e-9
PLANAR_REL_TOL = 1e-9
PARALLEL_TOL = 1e-7


@dataclasses.dataclass(frozen=True)
class VertexInfo:
    """One vertex of a crease pattern, as listed for the user to pick from.

    **Fields:** `index`; `coords` (3,); `degree` (incident edges); `n_creases` (incident M/V/F/U
    edges); `boundary` (`True` if an incident edge is a boundary `B` or cut `C` edge).
    """

    index: int
    coords: tuple[float, float, float]
    degree: int
    n_creases: int
    boundary: bool

    @property
    def kind(self) -> str:
        return "boundary" if self.boundary else "interior"

    def __str__(self) -> str:
        x, y, z = self.coords
        return (
            f"vertex {self.index:>3}  ({x:.6g}, {y:.6g}, {z:.6g})  degree {self.degree}, "
            f"{self.n_creases} crease(s), {self.kind}"
        )


@dataclasses.dataclass(frozen=True, eq=False)
class VertexGeometry:
    """A single-vertex origami read from a FOLD frame (the charge model's "nodes" are the rays here).

    **Fields:**
    - `vertex_index`: the FOLD vertex.
    - `closed`: `True` for an interior vertex (closed chain), `False` for a boundary vertex.
    - `ray_edges`: FOLD edge ids of the `n` rays in cyclic (counter-clockwise) order. Closed: all
      creases. Open: first boundary ray, the creases, last boundary ray (the chain ends).
    - `directions`: float64 `(n, 3)` unit vectors of the rays in the frame's coordinates.
    - `sector_angles`: float64, radians, `(n,)` closed or `(n - 1,)` open; sector `i` lies between
      rays `i` and `i + 1`.
    - `fold_angles`: float64, radians, valley +, mountain −: `(n,)` closed, `(n - 2,)` open (the
      interior creases); NaN where the file leaves a crease free (`U` without a fold angle).
    - `assignments`: the creases' `edges_assignment`, parallel to `fold_angles`.
    - `crease_edges`: FOLD edge ids of the creases, parallel to `fold_angles`.
    - `boundary_rays`: float64 `(2, 3)` for an open vertex (first and last ray), else `None`.
    - `flat`: whether the frame lies in one plane (a crease pattern rather than a folded state).
    - `unit`: the frame's `frame_unit` (or `None`).
    """

    vertex_index: int
    closed: bool
    ray_edges: tuple[int, ...]
    directions: np.ndarray
    sector_angles: np.ndarray
    fold_angles: np.ndarray
    assignments: tuple[str, ...]
    crease_edges: tuple[int, ...]
    boundary_rays: np.ndarray | None
    flat: bool
    unit: str | None

    @property
    def n_rays(self) -> int:
        return len(self.ray_edges)


def _as_fold(fold: FoldFile | str | os.PathLike[str]) -> FoldFile:
    if isinstance(fold, FoldFile):
        return fold

    return read_fold(Path(fold))


def _assignment(frame: FoldFrame, where: str) -> tuple[str, ...]:
    if frame.edges_assignment is None:
        raise FoldFormatError(
            f"{where}: missing key edges_assignment; it is needed to tell creases (M, V, F, U) "
            "from the paper's boundary (B)"
        )
    return frame.edges_assignment


class FlatFrame(NamedTuple):
    """A frame a pattern is read from, checked flat (`flat_frame`)."""

    frame: FoldFrame
    where: str  # "key frame" or "frame k", for messages
    assignment: tuple[str, ...]
    coords: np.ndarray  # (v, 3)
    plane: np.ndarray  # (2, 3), an orthonormal basis of the paper's plane


def flat_frame(fold: FoldFile, frame: int, folded: str) -> FlatFrame:
    """Frame `frame` of `fold` with its assignment and plane; `FoldFormatError` "`where`: `folded`"
    when its vertices do not lie in one plane."""
    resolved = fold.frame(frame)
    where = "key frame" if frame == 0 else f"frame {frame}"
    assignment = _assignment(resolved, where)
    coords = resolved.coords3
    plane = paper_plane(coords, resolved.faces_vertices)
    if plane is None:
        raise FoldFormatError(f"{where}: {folded}")
    return FlatFrame(resolved, where, assignment, coords, plane)


def paper_plane(
    coords: np.ndarray, faces: tuple[tuple[int, ...], ...] | None = None
) -> np.ndarray | None:
    """An orthonormal basis `(2, 3)` of the plane the vertices lie in, or `None` if they do not.

    The xy plane (FOLD's 2D case) gives exactly `e_x, e_y`. Any other plane (Origami Simulator, for
    one, stores flat patterns as `(x, 0, y)`) gets a basis oriented so that the faces run
    counter-clockwise in it, or, without faces, so that its normal's largest component is positive.
    """
    coords = np.asarray(coords, dtype=float)
    if len(coords) == 0:
        return None
    size = max(float(np.max(np.ptp(coords, axis=0))), 1e-300)
    if np.all(np.abs(coords[:, 2] - coords[0, 2]) <= PLANAR_REL_TOL * size):
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    centred = coords - coords.mean(axis=0)
    _, singular, vt = np.linalg.svd(centred, full_matrices=False)
    if singular[-1] > PLANAR_REL_TOL * size * np.sqrt(len(coords)):
        return None
    basis = vt[:2]
    normal = np.cross(basis[0], basis[1])
    if faces:
        area = 0.0
        for face in faces:
            xy = centred[list(face)] @ basis.T
            area += float(
                np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
            )
        flip = area < 0
    else:
        flip = normal[np.argmax(np.abs(normal))] < 0
    if flip:
        basis = np.stack([basis[0], -basis[1]])
    return basis


def list_vertices(
    fold: FoldFile | str | os.PathLike[str], *, frame: int = 0
) -> tuple[VertexInfo, ...]:
    """Every vertex of a FOLD frame with its degree, number of creases and interior/boundary kind."""
    fold = _as_fold(fold)
    resolved = fold.frame(frame)
    assignment = _assignment(resolved, f"frame {frame}")
    coords = resolved.coords3
    degree = np.zeros(len(coords), dtype=int)
    creases = np.zeros(len(coords), dtype=int)
    boundary = np.zeros(len(coords), dtype=bool)
    for (u, v), a in zip(resolved.edges_vertices.tolist(), assignment, strict=True):  # type: ignore[union-attr]
        for w in (u, v):
            degree[w] += 1
            creases[w] += a not in "BC"
            boundary[w] |= a in "BC"
    return tuple(
        VertexInfo(
            index=i,
            coords=(float(coords[i, 0]), float(coords[i, 1]), float(coords[i, 2])),
            degree=int(degree[i]),
            n_creases=int(creases[i]),
            boundary=bool(boundary[i]),
        )
        for i in range(len(coords))
    )


TABLE_LIMIT = 20
"""Most vertices `format_vertex_table` lists (a large pattern has thousands)."""


def format_vertex_table(
    vertices: tuple[VertexInfo, ...] | list[VertexInfo], limit: int | None = TABLE_LIMIT
) -> str:
    """One line per vertex (see `VertexInfo`), for messages and the CLI; at most `limit` lines
    (`None`: all), then a line saying how many more there are."""
    shown = vertices if limit is None else vertices[:limit]
    lines = [f"  {v}" for v in shown]
    if len(vertices) > len(shown):
        lines.append(
            f"  ... and {len(vertices) - len(shown)} more (list_vertices() lists them all)"
        )
    return "\n".join(lines)


def candidate_vertices(vertices: tuple[VertexInfo, ...]) -> tuple[VertexInfo, ...]:
    """The vertices a single-vertex origami can be built at, best first.

    Interior vertices where three or more creases meet; if there are none, boundary vertices where
    two or more creases meet (a crease running into the boundary alone is a single hinge).
    """
    interior = tuple(v for v in vertices if not v.boundary and v.n_creases >= 3)
    if interior:
        return interior
    return tuple(v for v in vertices if v.boundary and v.n_creases >= 2)


def pick_vertex(fold: FoldFile, vertex_index: int | None, *, frame: int = 0) -> int:
    """`vertex_index` checked, or the pattern's only single-vertex candidate (see `candidate_vertices`).

    **Raises:** `FoldFormatError` listing the vertices when the choice is ambiguous or impossible.
    """
    vertices = list_vertices(fold, frame=frame)
    if vertex_index is not None:
        if not 0 <= vertex_index < len(vertices):
            raise FoldFormatError(
                f"vertex_index {vertex_index} does not exist: the pattern has {len(vertices)} "
                f"vertices:\n{format_vertex_table(vertices)}"
            )
        if vertices[vertex_index].n_creases == 0:
            raise FoldFormatError(
                f"vertex {vertex_index} has no creases (only boundary edges); pick a vertex where "
                f"creases meet:\n{format_vertex_table(vertices)}"
            )
        return vertex_index
    candidates = candidate_vertices(vertices)
    if len(candidates) == 1:
        return candidates[0].index
    if not candidates:
        raise FoldFormatError(
            "no vertex where creases meet (an interior vertex with 3 or more creases, or a boundary "
            f"vertex with 2 or more); the pattern's vertices:\n{format_vertex_table(vertices)}"
        )
    listing = format_vertex_table(candidates)
    raise FoldFormatError(
        f"the pattern has {len(candidates)} vertices where creases meet, so it is not a "
        f"single-vertex origami; pick one with vertex_index= (CLI: --vertex-index N):\n{listing}"
    )


def single_vertex_geometry(
    fold: FoldFile | str | os.PathLike[str],
    vertex_index: int | None = None,
    *,
    frame: int = 0,
) -> VertexGeometry:
    """The single-vertex origami at one vertex of a FOLD crease pattern or folded state.

    **Arguments:**
    - `fold`: a `FoldFile` or a path to a `.fold` file.
    - `vertex_index`: the vertex; `None` picks the pattern's only interior vertex with 3+ creases
      (or, lacking one, its only boundary vertex with 2+ creases) and raises, listing the vertices,
      when there is more than one.
    - `frame`: which frame to read (0 = key frame; inheritance applied). A flat frame gives sector
      angles from the crease pattern; a folded 3D frame gives crease directions in space, with its
      cyclic order taken from `faces_vertices`.

    **Returns:** a `VertexGeometry` (radians).

    **Raises:** `FoldFormatError` for a vertex with no creases, more than two boundary edges, creases
    on both sides of its boundary, a folded frame without faces, or an ambiguous choice.
    """
    fold = _as_fold(fold)
    resolved = fold.frame(frame)
    where = "key frame" if frame == 0 else f"frame {frame}"
    assignment = _assignment(resolved, where)
    v = pick_vertex(fold, vertex_index, frame=frame)
    coords = resolved.coords3
    plane = paper_plane(coords, resolved.faces_vertices)
    flat = plane is not None
    edges = resolved.edges_vertices.tolist()  # type: ignore[union-attr]
    incident = [e for e, (a, b) in enumerate(edges) if v in (a, b)]
    other = {e: edges[e][1] if edges[e][0] == v else edges[e][0] for e in incident}
    vectors = {e: coords[other[e]] - coords[v] for e in incident}
    for e, vec in vectors.items():
        if np.linalg.norm(vec) == 0:
            raise FoldFormatError(f"{where}: edge {e} has zero length (its ends coincide)")
    cuts = [e for e in incident if assignment[e] == "C"]
    if cuts:
        raise FoldFormatError(
            f"{where}: vertex {v} has cut (C) edges {cuts}; a single-vertex origami reads creases "
            "and boundary edges only: read the pattern with net_geometry, or pick another vertex"
        )
    boundary = [e for e in incident if assignment[e] == "B"]
    if len(boundary) not in (0, 2):
        raise FoldFormatError(
            f"{where}: vertex {v} has {len(boundary)} boundary (B) edges; a single-vertex origami "
            "needs 0 (interior vertex) or 2 (on the boundary)"
        )
    if plane is not None:
        # In-plane coordinates of each ray: sorting by angle gives the counter-clockwise order.
        planar = {e: plane @ vectors[e] for e in incident}
        cyclic = sorted(incident, key=lambda e: np.arctan2(planar[e][1], planar[e][0]))
    else:
        cyclic = _cyclic_from_faces(resolved, v, incident, other, bool(boundary), where)
    if boundary:
        cyclic = _open_order(cyclic, boundary, resolved, v, other, flat, where)
    else:
        # A closed chain has no natural first crease: start at the lowest edge id, for stability.
        first = cyclic.index(min(cyclic))
        cyclic = cyclic[first:] + cyclic[:first]
    directions = np.stack([vectors[e] / np.linalg.norm(vectors[e]) for e in cyclic])
    closed = not boundary
    pairs = range(len(cyclic)) if closed else range(len(cyclic) - 1)
    in_plane = directions if plane is None else directions @ plane.T
    sectors = np.array([_sector(in_plane[i], in_plane[(i + 1) % len(cyclic)], flat) for i in pairs])
    crease_edges = tuple(cyclic if closed else cyclic[1:-1])
    if closed and len(crease_edges) < 3:
        raise FoldFormatError(
            f"{where}: interior vertex {v} has {len(crease_edges)} crease(s); a closed "
            "single-vertex origami needs at least 3"
        )
    if not crease_edges:
        raise FoldFormatError(f"{where}: vertex {v} has no creases")
    angles_deg = fold.fold_angles_deg(frame)[list(crease_edges)]
    fold_angles = np.deg2rad(angles_deg)
    if not flat and np.any(np.isnan(fold_angles)):
        geometric = vertex_fold_angles(directions, closed=closed)
        fold_angles = np.where(np.isnan(fold_angles), geometric, fold_angles)
    return VertexGeometry(
        vertex_index=v,
        closed=closed,
        ray_edges=tuple(cyclic),
        directions=directions,
        sector_angles=sectors,
        fold_angles=fold_angles,
        assignments=tuple(assignment[e] for e in crease_edges),
        crease_edges=crease_edges,
        boundary_rays=None if closed else directions[[0, -1]],
        flat=flat,
        unit=resolved.frame_unit,
    )


def _sector(a: np.ndarray, b: np.ndarray, flat: bool) -> float:
    if flat:
        # Counter-clockwise angle from a to b in the paper's plane (a, b given in it as (u, v)),
        # in (0, 2π): reflex sectors allowed.
        angle = np.arctan2(b[1], b[0]) - np.arctan2(a[1], a[0])
        return float(np.mod(angle, 2 * np.pi))
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b)))


def _cyclic_from_faces(
    frame: FoldFrame,
    v: int,
    incident: list[int],
    other: dict[int, int],
    on_boundary: bool,
    where: str,
) -> list[int]:
    if frame.faces_vertices is None:
        raise FoldFormatError(
            f"{where}: the frame is folded (not flat) and has no faces_vertices, so the cyclic "
            "order of the creases around the vertex is unknown; add faces_vertices"
        )
    edge_to = {other[e]: e for e in incident}
    successor: dict[int, int] = {}
    for face in frame.faces_vertices:
        for k, w in enumerate(face):
            if w != v:
                continue
            prev, nxt = face[k - 1], face[(k + 1) % len(face)]
            if prev in edge_to and nxt in edge_to:
                successor[edge_to[nxt]] = edge_to[prev]
    start = next((e for e in incident if e not in successor.values()), incident[0])
    order = [start]
    while order[-1] in successor and successor[order[-1]] not in order:
        order.append(successor[order[-1]])
    if len(order) != len(incident):
        raise FoldFormatError(
            f"{where}: the faces around vertex {v} do not link its {len(incident)} edges into one "
            "fan; check faces_vertices"
        )
    return order


def _open_order(
    cyclic: list[int],
    boundary: list[int],
    frame: FoldFrame,
    v: int,
    other: dict[int, int],
    flat: bool,
    where: str,
) -> list[int]:
    """Rotate a cyclic order to start at a boundary ray and run over the paper to the other one."""
    if not flat:
        # From faces: the fan already starts at the ray with no predecessor and ends at the other.
        if cyclic[0] in boundary and cyclic[-1] in boundary:
            return cyclic
        raise FoldFormatError(f"{where}: the faces around boundary vertex {v} are inconsistent")
    i, j = sorted(cyclic.index(b) for b in boundary)
    arc_a = cyclic[i : j + 1]
    arc_b = cyclic[j:] + cyclic[: i + 1]
    creases_a, creases_b = arc_a[1:-1], arc_b[1:-1]
    if creases_a and creases_b:
        raise FoldFormatError(
            f"{where}: boundary vertex {v} has creases on both sides of its boundary edges "
            f"{boundary}; that is two flaps of paper meeting at a point, not one vertex"
        )
    if frame.faces_vertices is not None:
        # The paper side is the one the faces at the vertex cover.
        side_a = _covered(frame, v, other[arc_a[0]], other[arc_a[1]])
        return arc_a if side_a else arc_b
    return arc_a if creases_a else arc_b


def _covered(frame: FoldFrame, v: int, first: int, second: int) -> bool:
    for face in frame.faces_vertices or ():
        for k, w in enumerate(face):
            if w == v and face[(k + 1) % len(face)] == first and face[k - 1] == second:
                return True
    return False


def vertex_fold_angles(directions: ArrayLike, *, closed: bool) -> np.ndarray:
    """Signed fold angles (radians) of a single vertex from its crease directions.

    For crease `i` between sectors `a = (x_{i-1}, x_i)` and `b = (x_i, x_{i+1})`, with the sector
    normals `n_a = x_{i-1} × x_i`, `n_b = x_i × x_{i+1}` (the paper's front side when the rays run
    counter-clockwise seen from the front): `ρ_i = atan2((n_a × n_b) · x_i, n_a · n_b)`. Positive
    when sector `b` turns toward `n_a`, i.e. the front sides close up: a valley (FOLD's sign).

    **Returns:** `(n,)` for a closed vertex, `(n - 2,)` (interior creases) for an open one.
    """
    x = np.asarray(directions, dtype=float)
    n = len(x)
    idx = range(n) if closed else range(1, n - 1)
    out = []
    for i in idx:
        a = np.cross(x[i - 1], x[i])
        b = np.cross(x[i], x[(i + 1) % n])
        a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
        out.append(np.arctan2(np.dot(np.cross(a, b), x[i]), np.dot(a, b)))
    return np.array(out)


def fold_angles_from_coords(
    coords: ArrayLike,
    faces: Sequence[Sequence[int]],
    edges: ArrayLike,
) -> np.ndarray:
    """Signed dihedral fold angles (radians) of every edge of a folded mesh, NaN on boundary edges.

    For an edge u → v shared by faces `f` (runs u → v, so it lies on the edge's left) and `g` (runs
    v → u, on its right), both counter-clockwise: `ρ = atan2((n_g × n_f) · t, n_g · n_f)` with `t`
    the unit edge direction and `n` the Newell normals; positive (valley) when `f` turns toward
    `g`'s front side. Same formula as `vertex_fold_angles` with `g` as sector `a`, `f` as `b`.
    """
    coords = np.asarray(coords, dtype=float)
    if coords.shape[1] == 2:
        coords = np.concatenate([coords, np.zeros((len(coords), 1))], axis=1)
    normals = []
    side_face: dict[tuple[int, int], int] = {}
    for f, face in enumerate(faces):
        p = coords[list(face)]
        q = np.roll(p, -1, axis=0)
        normal = np.sum(np.cross(p, q), axis=0)
        normals.append(normal / np.linalg.norm(normal))
        for u, w in zip(face, list(face[1:]) + [face[0]], strict=True):
            side_face[(u, w)] = f
    out = np.full(len(edges), np.nan)  # pyright: ignore[reportArgumentType] (a sequence)
    for e, (u, w) in enumerate(np.asarray(edges).tolist()):
        if (u, w) in side_face and (w, u) in side_face:
            nf, ng = normals[side_face[(u, w)]], normals[side_face[(w, u)]]
            t = coords[w] - coords[u]
            t = t / np.linalg.norm(t)
            out[e] = np.arctan2(np.dot(np.cross(ng, nf), t), np.dot(ng, nf))
    return out
