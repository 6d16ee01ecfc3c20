"""A net of rigid panels out of a FOLD crease pattern, as plain numpy arrays (radians).

The faces of a flat crease pattern joined by its creases form a tree (a *net*: a corner-cube
reflector, the eleven nets of a cube, any polyhedron's unfolding); `net_geometry` reads it, checks
that it is one, and gives the tree (parents, hinge axes and points, target fold angles), rigid
forward kinematics (`NetGeometry.fold`), the seams a correctly folded net closes, and the
compactness measures of self-folding yield studies.

**Sign convention** (FOLD's: valley +, mountain −). The paper lies in a plane with unit normal `n`
(+z for a pattern in the xy plane), every face counter-clockwise seen from `n`. The hinge axis of a
crease is the crease's direction *as the child face runs it* counter-clockwise, so the child lies
on the left of the axis, in direction `n × axis`. Rotating the child by the fold angle `ρ` about the
axis (right-hand rule) turns that direction into `cos ρ (n × axis) + sin ρ n`: a valley (`ρ > 0`)
lifts the child to the side `n` points to, and the two faces' fronts close up, as FOLD defines a
valley; a mountain (`ρ < 0`) sends it to the back.
"""

from __future__ import annotations

import dataclasses
import functools
import os

import numpy as np
from numpy.typing import ArrayLike

from ._errors import FoldFormatError
from ._geometry import PARALLEL_TOL, _as_fold, flat_frame
from ._model import FoldFile
from ._net_build import build_net
from ._polygons import overlapping_pairs

# Seam ends closer than this, relative to the median side length, coincide when seams are found.
SEAM_REL_TOL = 1e-6
# Lengths below this, relative to the pattern's size, are zero in the overlap tests.
OVERLAP_REL_TOL = 1e-9


@dataclasses.dataclass(frozen=True, eq=False)
class Seams:
    """Pairs of boundary sides (of different faces) that meet when the net is folded.

    `S` seams; side `a` and side `b` of seam `s` are sides of faces `faces[s, 0]` and `faces[s, 1]`
    lying on FOLD edges `edges[s, 0]`, `edges[s, 1]` (a cut `C` edge can be both).

    **Fields:**
    - `faces`: int `(S, 2)`; `edges`: int `(S, 2)`.
    - `vertices`: int `(S, 2, 2)`: `vertices[s, e]` = (the FOLD vertex of side `a`, the vertex of
      side `b`) that come together at end `e` of the seam. Both the same vertex: the seam starts at
      a corner the two faces already share in the flat net (a vertex connection).
    - `corners`: int `(S, 2, 2)`, the same ends as flat indices `f * K + k` into the `(F, K)`
      corner grid of `NetGeometry.fold`'s output (face `f`, corner `k` of `faces_vertices[f]`).
    """

    faces: np.ndarray
    edges: np.ndarray
    vertices: np.ndarray
    corners: np.ndarray

    def __len__(self) -> int:
        return len(self.faces)


@dataclasses.dataclass(frozen=True, eq=False)
class NetGeometry:
    """A flat net of rigid panels (faces) joined by creases into a tree; see `net_geometry`.

    `F` faces with at most `K` corners, `m = F − 1` creases, `V` vertices; lengths in `unit`.

    **Faces** (FOLD face ids):
    - `vertices_coords`: float64 `(V, 3)`, the flat pattern.
    - `faces`: vertex ids of each face, counter-clockwise seen from `normal`.
    - `normal`: float64 `(3,)`, the paper's unit normal; `plane`: `(2, 3)` an orthonormal basis of
      the paper's plane with `plane[0] × plane[1] = normal`.
    - `face_areas`: `(F,)`; `face_centroids`: `(F, 3)` (area centroids of the polygons).
    - `face_coords`: `(F, K, 3)`, each face's corners in `faces` order, padded with NaN;
      `corner_mask`: bool `(F, K)`, which entries are corners.

    **Tree:**
    - `root`: the face that stays put; `order`: int `(F,)`, faces parents first (`order[0]` is the
      root); `parents`: int `(F,)`, each face's parent (−1 for the root); `face_crease`: int
      `(F,)`, the crease joining each face to its parent (−1 for the root).
    - Creases are numbered in `order`: crease `j` moves face `order[j + 1]`.
      `crease_child`, `crease_parent`: int `(m,)`; `crease_edges`: the FOLD edge ids of each
      crease (collinear edges between the same two faces make one crease).
    - `hinge_axes`: float64 `(m, 3)`, unit, along the crease as the child runs it
      counter-clockwise; `hinge_points`: `(m, 3)`, a point of each crease (the child's corner where
      the crease starts); `crease_lengths`: `(m,)`.
    - `targets`: float64 `(m,)`, **radians**, from `edges_foldAngle` (degrees in the file) or the
      assignment's default (M −π, V +π, F 0); NaN for a free (U) crease read with
      `require_targets=False`. `assignments`: each crease's assignment.
    - `unit`: `frame_unit` (or `None`).
    """

    vertices_coords: np.ndarray
    faces: tuple[tuple[int, ...], ...]
    normal: np.ndarray
    plane: np.ndarray
    face_areas: np.ndarray
    face_centroids: np.ndarray
    face_coords: np.ndarray
    corner_mask: np.ndarray
    root: int
    order: np.ndarray
    parents: np.ndarray
    face_crease: np.ndarray
    crease_child: np.ndarray
    crease_parent: np.ndarray
    crease_edges: tuple[tuple[int, ...], ...]
    hinge_axes: np.ndarray
    hinge_points: np.ndarray
    crease_lengths: np.ndarray
    targets: np.ndarray
    assignments: tuple[str, ...]
    unit: str | None
    # Boundary (B or C) sides as (face, corner k, edge): side k runs from corner k to corner k + 1.
    boundary_sides: np.ndarray
    # Triangles of the faces, (T, 3) flat corner indices f * K + k, and their faces (T,).
    triangles: np.ndarray
    triangle_faces: np.ndarray

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def n_creases(self) -> int:
        return len(self.crease_edges)

    @property
    def size(self) -> float:
        """The flat pattern's largest extent (in `unit`)."""
        return float(np.max(np.ptp(self.vertices_coords, axis=0)))

    @property
    def crease_midpoints(self) -> np.ndarray:
        """The midpoint of every crease, `(m, 3)` (in `unit`): where an etch front frees it."""
        return self.hinge_points + 0.5 * self.crease_lengths[:, None] * self.hinge_axes

    @property
    def body_parents(self) -> np.ndarray:
        """Parent indices `λ` `(F,)` with the faces renumbered in `order` (body `i` is face
        `order[i]`, `λ(0) = −1`, `λ(i) < i`), as Featherstone's tree algorithms take them."""
        position = np.empty(self.n_faces, dtype=np.int64)
        position[self.order] = np.arange(self.n_faces)
        parents = self.parents[self.order]
        return np.where(parents < 0, -1, position[np.maximum(parents, 0)])

    # --- kinematics -------------------------------------------------------------------------

    def transforms(self, angles: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Each face's rigid motion from the flat pattern at fold angles `angles`.

        **Arguments:** `angles`: float `(..., m)`, radians, one per crease (crease order).

        **Returns:** `(R, t)`: rotations float64 `(..., F, 3, 3)` and translations `(..., F, 3)`
        such that a point `x` of face `f` in the flat pattern goes to `R[f] @ x + t[f]`; the root
        does not move. Composed along the tree: `R_f = R_parent · Rot(axis, ρ)`.
        """
        angles = np.asarray(angles, dtype=float)
        if angles.shape[-1:] != (self.n_creases,):
            raise ValueError(
                f"angles must have shape (..., {self.n_creases}), one per crease, "
                f"not {angles.shape}"
            )
        batch = angles.shape[:-1]
        local = _rotations(self.hinge_axes, angles)  # (..., m, 3, 3)
        shift = self.hinge_points - np.einsum("...mij,mj->...mi", local, self.hinge_points)
        rotations = np.empty((*batch, self.n_faces, 3, 3))
        translations = np.empty((*batch, self.n_faces, 3))
        rotations[..., self.root, :, :] = np.eye(3)
        translations[..., self.root, :] = 0.0
        for j, (child, parent) in enumerate(
            zip(self.crease_child.tolist(), self.crease_parent.tolist(), strict=True)
        ):
            r_parent = rotations[..., parent, :, :]
            rotations[..., child, :, :] = r_parent @ local[..., j, :, :]
            translations[..., child, :] = (
                np.einsum("...ij,...j->...i", r_parent, shift[..., j, :])
                + translations[..., parent, :]
            )
        return rotations, translations

    def fold(self, angles: ArrayLike) -> np.ndarray:
        """Corner positions of every face folded rigidly to `angles` (radians, `(..., m)`).

        **Returns:** float64 `(..., F, K, 3)`: face `f`'s corners in `faces[f]` order, padded with
        NaN (see `corner_mask`). `fold(zeros)` is `face_coords`.
        """
        rotations, translations = self.transforms(angles)
        return (
            np.einsum("...fij,fkj->...fki", rotations, self.face_coords)
            + translations[..., None, :]
        )

    def normals(self, angles: ArrayLike) -> np.ndarray:
        """Each face's unit normal (its front side) folded to `angles`: float64 `(..., F, 3)`."""
        rotations, _ = self.transforms(angles)
        return rotations @ self.normal

    # --- seams and overlaps ----------------------------------------------------------------

    def seams(self, angles: ArrayLike | None = None, *, tol: float | None = None) -> Seams:
        """The boundary sides (B or C edges) of different faces that meet when folded to `angles`.

        Two sides meet when their ends coincide pairwise (either way round) within `tol`, and the
        faces lie on different sides of the meeting line (sides of faces stacked flat on each
        other, with their interiors on the same side, do not count).

        **Arguments:**
        - `angles`: radians `(m,)`; default `targets` (the seams a correctly folded net closes).
        - `tol`: length; default `1e-6 ×` the median side length.

        **Returns:** a `Seams`.
        """
        if angles is None:
            if np.any(np.isnan(self.targets)):
                raise ValueError(
                    "some creases have no target fold angle (U, read with require_targets=False); "
                    "pass angles= to find the seams"
                )
            angles = self.targets
        rotations, translations = self.transforms(angles)
        positions = (
            np.einsum("fij,fkj->fki", rotations, self.face_coords) + translations[:, None, :]
        )
        sides = self.boundary_sides
        f, k = sides[:, 0], sides[:, 1]
        sizes = self.corner_mask.sum(axis=1)
        k_next = (k + 1) % sizes[f]
        start, end = positions[f, k], positions[f, k_next]
        lengths = np.linalg.norm(self.face_coords[f, k_next] - self.face_coords[f, k], axis=-1)
        if tol is None:
            tol = SEAM_REL_TOL * float(np.median(lengths)) if len(lengths) else 0.0
        # In-plane direction into each face from its side, folded.
        inward = np.cross(self.normal, self.face_coords[f, k_next] - self.face_coords[f, k])
        inward = np.einsum("sij,sj->si", rotations[f], inward / lengths[:, None])
        d_opposite = np.maximum(
            np.linalg.norm(start[:, None] - end[None], axis=-1),
            np.linalg.norm(end[:, None] - start[None], axis=-1),
        )
        d_same = np.maximum(
            np.linalg.norm(start[:, None] - start[None], axis=-1),
            np.linalg.norm(end[:, None] - end[None], axis=-1),
        )
        stacked = inward @ inward.T > 1 - 1e-9
        meet = (np.minimum(d_opposite, d_same) <= tol) & (f[:, None] != f[None]) & ~stacked
        a, b = np.nonzero(np.triu(meet, 1))
        opposite = d_opposite[a, b] <= d_same[a, b]
        width = self.corner_mask.shape[1]
        # end 0: side a's start with side b's end (opposite) or start (same); end 1 likewise.
        kb0 = np.where(opposite, k_next[b], k[b])
        kb1 = np.where(opposite, k[b], k_next[b])
        ka = np.stack([k[a], k_next[a]], axis=-1)
        kb = np.stack([kb0, kb1], axis=-1)
        grid = np.full(self.corner_mask.shape, -1, dtype=np.int64)
        for face, ids in enumerate(self.faces):
            grid[face, : len(ids)] = ids
        fa, fb = f[a][:, None], f[b][:, None]
        return Seams(
            faces=np.stack([f[a], f[b]], axis=-1),
            edges=np.stack([sides[a, 2], sides[b, 2]], axis=-1),
            vertices=np.stack([grid[fa, ka], grid[fb, kb]], axis=-1).reshape(-1, 2, 2),
            corners=np.stack([fa * width + ka, fb * width + kb], axis=-1).reshape(-1, 2, 2),
        )

    @functools.cached_property
    def target_seams(self) -> Seams:
        """`seams()` at the targets (computed once)."""
        return self.seams()

    def seam_gaps(self, positions: ArrayLike, seams: Seams | None = None) -> np.ndarray:
        """The larger of the two end distances of each seam, in a folded state.

        **Arguments:** `positions`: float `(..., F, K, 3)` as `fold` returns them; `seams`: default
        `target_seams`.

        **Returns:** float64 `(..., S)`, in `unit`: 0 where a seam is closed.
        """
        seams = self.target_seams if seams is None else seams
        positions = np.asarray(positions, dtype=float)
        flat = positions.reshape(*positions.shape[:-3], -1, 3)
        a = flat[..., seams.corners[:, :, 0], :]
        b = flat[..., seams.corners[:, :, 1], :]
        return np.linalg.norm(a - b, axis=-1).max(axis=-1)

    def face_overlaps(
        self, positions: ArrayLike | None = None, *, tol: float | None = None
    ) -> list[tuple[int, int]]:
        """Pairs of faces whose interiors intersect (faces that only touch do not count).

        **Arguments:** `positions`: `(F, K, 3)` as `fold` returns them (default: the flat
        pattern); `tol`: length, default `1e-9 ×` the pattern's size.

        **Returns:** sorted `(f, g)` face pairs, `f < g`. Faces folded flat onto each other (a
        ±180° crease) are coplanar and overlap.
        """
        where = self.face_coords if positions is None else np.asarray(positions, dtype=float)
        if where.shape != self.face_coords.shape:
            raise ValueError(
                f"positions must have shape {self.face_coords.shape} (faces, corners, 3), "
                f"not {where.shape}"
            )
        tol = OVERLAP_REL_TOL * self.size if tol is None else tol
        flat = where.reshape(-1, 3)
        return overlapping_pairs(flat[self.triangles], self.triangle_faces, tol)

    # --- compactness ------------------------------------------------------------------------

    def radius_of_gyration(self, *, weighted: bool = False) -> float:
        """Radius of gyration of the flat net's face centroids, in `unit`.

        `sqrt(Σ w_f |c_f − c̄|² / Σ w_f)` with `c̄ = Σ w_f c_f / Σ w_f`, `c_f` the face centroids
        and `w_f = 1` (default; the "compactness" of Azam et al., PLoS ONE 4, e4451, 2009, for the
        cube and octahedron nets, and of Pandey et al., PNAS 108, 2011, for higher polyhedra, whose
        faces are all alike) or `w_f` = the face areas (`weighted=True`: the radius of gyration of
        the flat membrane as a uniform plate, up to each face's own spread).
        """
        w = self.face_areas if weighted else np.ones(self.n_faces)
        centre = w @ self.face_centroids / w.sum()
        return float(np.sqrt(w @ np.sum((self.face_centroids - centre) ** 2, axis=-1) / w.sum()))

    def vertex_connections(self, seams: Seams | None = None) -> np.ndarray:
        """The net's vertex connections: flat vertices where a seam starts between two faces that
        already share that corner in the flat net.

        Azam et al. (PLoS ONE 4, e4451, 2009) found that cube and octahedron nets with more vertex
        connections fold with higher yield, as Pandey et al. (PNAS 108, 2011) did for higher
        polyhedra; Araújo et al. (Phys. Rev. Lett. 120, 188001, 2018) restate the measure as the
        polyhedron's vertices that have only two of their faces cut apart in the net. Such a vertex
        is one point of the flat net, with its faces joined around it by creases except across one
        cut: its two boundary sides there close onto each other as one seam, which is what this
        counts (the corner cube's shared corner; a cube-net corner where all three faces meet).

        **Arguments:** `seams`: default `target_seams`.

        **Returns:** int `(n,)`, the FOLD vertex ids, sorted; the measure is `len` of it.
        """
        seams = self.target_seams if seams is None else seams
        same = seams.vertices[:, :, 0] == seams.vertices[:, :, 1]  # (S, 2)
        return np.unique(seams.vertices[:, :, 0][same])


def _rotations(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rodrigues: rotations `(..., m, 3, 3)` by `angles` `(..., m)` about unit `axes` `(m, 3)`."""
    x, y, z = axes[:, 0], axes[:, 1], axes[:, 2]
    zero = np.zeros_like(x)
    skew = np.stack(
        [np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)],
        axis=-2,
    )  # (m, 3, 3)
    s = np.sin(angles)[..., None, None]
    c = np.cos(angles)[..., None, None]
    return np.eye(3) + s * skew + (1 - c) * (skew @ skew)


def net_geometry(
    fold_or_path: FoldFile | str | os.PathLike[str],
    *,
    root: int | None = None,
    frame: int = 0,
    require_targets: bool = True,
) -> NetGeometry:
    """The net of rigid panels drawn by a flat FOLD crease pattern.

    **Arguments:**
    - `fold_or_path`: a `FoldFile` or a path to a `.fold` file.
    - `root`: the face that stays put (the substrate side). Default: the face with the largest
      area, the lowest index among equals.
    - `frame`: which frame (0 = key frame); it must be flat (in any plane).
    - `require_targets`: raise for a crease without a target fold angle (`U` without
      `edges_foldAngle`); with `False` its target is NaN.

    Faces come from `faces_vertices`, or are traced from the planar edge graph when the file has
    none. Creases are the `M`, `V`, `F` and `U` edges (each shared by exactly two faces); `B` edges
    are the paper's boundary; `C` (cut) edges separate the faces on either side.

    **Returns:** a `NetGeometry` (radians; lengths in `frame_unit`).

    **Raises:** `FoldFormatError`, one line saying what and how to fix, when the frame is not flat,
    a face is clockwise or not simple, a crease borders one face only, the creases close a loop
    (around an interior vertex, or a hole: closed-loop patterns need the closed-loop engine), some
    faces are not joined to the root, two faces overlap in the flat pattern, two faces share
    creases that are not on one line, or a crease has no target.
    """
    fold = _as_fold(fold_or_path)
    resolved, where, assignment, coords, plane = flat_frame(
        fold,
        frame,
        "the vertices do not lie in one plane; a net is read from its flat crease pattern (the "
        "membrane before folding): pass the flat frame",
    )
    net = build_net(
        coords=coords,
        plane=plane,
        edges=resolved.edges_vertices.tolist(),  # type: ignore[union-attr]
        assignment=assignment,
        faces=resolved.faces_vertices,
        angles_deg=fold.fold_angles_deg(frame),
        root=root,
        require_targets=require_targets,
        where=where,
        parallel_tol=PARALLEL_TOL,
    )
    geometry = NetGeometry(**net, unit=resolved.frame_unit)
    overlaps = geometry.face_overlaps()
    if overlaps:
        f, g = overlaps[0]
        more = f" (and {len(overlaps) - 1} more pair(s))" if len(overlaps) > 1 else ""
        raise FoldFormatError(
            f"{where}: faces {f} and {g} overlap in the flat pattern{more}; a net is cut from one "
            "flat membrane, so faces may touch but not cover each other: fix their coordinates"
        )
    return geometry
