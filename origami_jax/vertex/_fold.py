"""Single vertices from FOLD files and back: `load_single_vertex`, `single_vertex_to_fold`,
`unfolding_to_fold`.

The FOLD package reads and writes plain arrays (`origami_jax.fold.single_vertex_geometry`,
`origami_jax.fold.single_vertex_fold`); this module builds a `SingleVertex` from them and feeds
them from a `SingleVertex` or an `UnfoldResult`.
"""

import os
from typing import Any

import numpy as np
from jaxtyping import ArrayLike

from ..fold import (
    FoldFile,
    FoldFormatError,
    VertexGeometry,
    single_vertex_fold,
    single_vertex_geometry,
)
from ._model import SingleVertex, fold_angles

# |fold angle| at or above this (radians) is a fully folded crease: outside the charge model.
FLAT_FOLDED_TOL = 1e-9


def load_single_vertex(
    path: str | os.PathLike[str] | FoldFile,
    *,
    vertex_index: int | None = None,
    frame: int = 0,
) -> SingleVertex:
    """Read a FOLD file and build a `SingleVertex` at one of its vertices.

    **Arguments:**
    - `path`: a `.fold` file (or an already read `FoldFile`).
    - `vertex_index`: which vertex; `None` takes the only one where creases meet and raises a
      `FoldFormatError` listing the vertices when there are several (see
      `origami_jax.fold.single_vertex_geometry`).
    - `frame`: which frame's state (0 = key frame). A flat crease pattern gives sector angles and
      its `edges_foldAngle` (missing angles default from M/V); a folded 3D frame gives directions.

    **Returns:** a `SingleVertex` (`from_fold_angles` for a flat frame, `from_directions` for a
    folded one).

    **Raises:** `FoldFormatError` for an unreadable file, an ambiguous vertex, a free (`U`) crease
    without a fold angle, or fold angles of ±180° (fully folded, outside the charge model: give
    `edges_foldAngle` of a partly folded state).
    """
    geometry = single_vertex_geometry(path, vertex_index, frame=frame)
    return vertex_from_geometry(geometry)


def vertex_from_geometry(geometry: VertexGeometry) -> SingleVertex:
    """A `SingleVertex` from an `origami_jax.fold.VertexGeometry` (see `load_single_vertex`)."""
    where = f"vertex {geometry.vertex_index}"
    if geometry.flat:
        free = [
            e
            for e, a in zip(geometry.crease_edges, geometry.fold_angles, strict=True)
            if np.isnan(a)
        ]
        if free:
            raise FoldFormatError(
                f"{where}: creases {free} have no fold angle (assignment U and no "
                "edges_foldAngle); give edges_foldAngle in degrees for every crease"
            )
        folded = [
            e
            for e, a in zip(geometry.crease_edges, geometry.fold_angles, strict=True)
            if abs(a) >= np.pi - FLAT_FOLDED_TOL
        ]
        if folded:
            raise FoldFormatError(
                f"{where}: creases {folded} are fully folded (±180°, the default for M and V "
                "without edges_foldAngle). A flat-folded state is outside the charge model "
                '(docs/physics.md, "Single-vertex geometry"): give edges_foldAngle of a slightly '
                "opened state, e.g. ±170°"
            )
        return SingleVertex.from_fold_angles(
            geometry.sector_angles, geometry.fold_angles, closed=geometry.closed
        )
    return SingleVertex.from_directions(geometry.directions, closed=geometry.closed)


def single_vertex_to_fold(vertex: SingleVertex, **kwargs: Any) -> FoldFile:
    """One `SingleVertex` state as a `FoldFile`: the crease pattern, then the folded state.

    `kwargs` go to `origami_jax.fold.single_vertex_fold` (`fold_angles` defaults to the vertex's
    own, `title`, `radius`, `unit`, `extra`, ...).
    """
    given = kwargs.pop("fold_angles", None)
    angles = np.asarray(fold_angles(vertex)) if given is None else given
    return single_vertex_fold(
        np.asarray(vertex.directions),
        closed=bool(vertex.closed),
        sector_angles=np.asarray(vertex.sector_angles),
        fold_angles=angles,
        **kwargs,
    )


def unfolding_to_fold(
    result: Any = None,
    *,
    directions: ArrayLike | None = None,
    fold_angles: ArrayLike | None = None,
    closed: bool | None = None,
    sector_angles: ArrayLike | None = None,
    vertex: SingleVertex | None = None,
    **kwargs: Any,
) -> FoldFile:
    """An unfolding path as a FOLD animation: the crease pattern, then one frame per state.

    **Arguments:** either `result`, an `UnfoldResult` (its `.path` `(k, n, 3)` and `.fold_angles`
    `(k, m)`; any object with those attributes will do), or the plain arrays `directions`
    `(k, n, 3)` and optionally `fold_angles` (radians). `closed` and `sector_angles` come from the
    arguments, else from `vertex` (a `SingleVertex`), else from the result's own `closed` /
    `vertex` attributes. A result's `energy` and `path_length` `(k,)` are stored per frame
    (`origami_jax:energy`, `origami_jax:path_length`) and its `verdict` as
    `origami_jax:verdict`. Other `kwargs` go to `origami_jax.fold.single_vertex_fold` (`times`,
    `radius`, `unit`, `check_fold_angles`, `title`, `extra`, `frame_data`).

    **Returns:** the `FoldFile` (write it with `origami_jax.fold.write_fold`).
    """
    if result is not None:
        if directions is not None:
            raise FoldFormatError("pass either an UnfoldResult or directions=, not both")
        directions = np.asarray(result.path)
        if fold_angles is None and getattr(result, "fold_angles", None) is not None:
            fold_angles = np.asarray(result.fold_angles)
        if vertex is None:
            vertex = getattr(result, "vertex", None)
        if closed is None and getattr(result, "closed", None) is not None:
            closed = bool(result.closed)
        frame_data = dict(kwargs.pop("frame_data", None) or {})
        for name in ("energy", "path_length"):
            values = getattr(result, name, None)
            if values is not None and np.shape(values) == (len(directions),):
                frame_data.setdefault(name, np.asarray(values, dtype=float))
        kwargs["frame_data"] = frame_data or None
        extra = dict(kwargs.pop("extra", None) or {})
        verdict = getattr(result, "verdict", None)
        if verdict is not None:
            extra.setdefault("origami_jax:verdict", str(getattr(verdict, "value", verdict)))
        kwargs["extra"] = extra or None
    if directions is None:
        raise FoldFormatError("unfolding_to_fold needs an UnfoldResult or directions=(k, n, 3)")
    if vertex is not None:
        if closed is None:
            closed = bool(vertex.closed)
        if sector_angles is None and getattr(vertex, "sector_angles", None) is not None:
            sector_angles = np.asarray(vertex.sector_angles)
    if closed is None:
        raise FoldFormatError(
            "unfolding_to_fold cannot tell whether the vertex is closed (interior) or open "
            "(boundary): pass closed= or vertex="
        )
    return single_vertex_fold(
        np.asarray(directions),
        closed=closed,
        sector_angles=sector_angles,
        fold_angles=fold_angles,
        **kwargs,
    )
