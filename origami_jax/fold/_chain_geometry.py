"""An accordion (hinged flap chain) out of a FOLD crease pattern, as plain numpy arrays (radians).

Parallel creases across a strip of paper, in order along the strip, with flap lengths and widths;
`origami_jax.chain.load_chain` builds an `origami_jax.chain.Chain` from it.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from ._errors import FoldFormatError
from ._geometry import PARALLEL_TOL, _as_fold, flat_frame
from ._model import FoldFile


@dataclasses.dataclass(frozen=True, eq=False)
class ChainGeometry:
    """A strip of paper crossed by parallel creases: the flaps and hinges of an accordion.

    The first flap (lowest along `direction`) is the **base**: it stays fixed (the substrate side),
    so `m` creases move `m` flaps. The paper's 3-flap accordion is a FOLD strip of 4 flaps.

    **Fields:**
    - `crease_edges`: FOLD edge ids of each crease line, in order along the strip.
    - `axis`: float64 `(3,)`, the creases' common direction (the hinge axis ω); `direction` is
      `n × axis`, across the creases, `n` the paper's normal (+z for a pattern in the xy plane).
      With faces counter-clockwise seen from `n`, a positive
      rotation about `axis` lifts the next flap toward +z: a valley, so hinge angle = fold angle.
    - `hinge_points`: float64 `(m, 3)`, a point of each crease line (the one nearest the strip's
      start edge), in frame coordinates.
    - `hinge_offsets`: float64 `(m,)`, positions of the creases along `direction`.
    - `flap_lengths`: float64 `(m + 1,)`, the base first; `flap_widths` likewise (extent along
      `axis`); `crease_lengths`: float64 `(m,)`, the hinge widths.
    - `fold_angles`: float64 `(m,)`, radians; `assignments`: the creases' assignments.
    - `unit`: `frame_unit` (or `None`).
    """

    crease_edges: tuple[tuple[int, ...], ...]
    axis: np.ndarray
    direction: np.ndarray
    hinge_points: np.ndarray
    hinge_offsets: np.ndarray
    flap_lengths: np.ndarray
    flap_widths: np.ndarray
    crease_lengths: np.ndarray
    fold_angles: np.ndarray
    assignments: tuple[str, ...]
    unit: str | None

    @property
    def n_hinges(self) -> int:
        return len(self.crease_edges)


def chain_geometry(fold: FoldFile | str | os.PathLike[str], *, frame: int = 0) -> ChainGeometry:
    """The accordion (hinged flap chain) drawn by parallel creases across a flat strip of paper.

    **Arguments:**
    - `fold`: a `FoldFile` or a path; its frame must be flat (a crease pattern, in any plane).
    - `frame`: which frame (0 = key frame).

    **Returns:** a `ChainGeometry`: creases in order along the strip, flap lengths (base first),
    widths, fold angles (radians).

    **Raises:** `FoldFormatError` if the frame is folded, has no creases, or its creases are not all
    parallel straight lines, or a crease line carries different fold angles along its length.
    """
    fold = _as_fold(fold)
    resolved, where, assignment, coords, plane = flat_frame(
        fold, frame, "a chain is read from a flat crease pattern, and this frame is folded in 3D"
    )
    edges = resolved.edges_vertices.tolist()  # type: ignore[union-attr]
    cuts = [e for e, a in enumerate(assignment) if a == "C"]
    if cuts:
        raise FoldFormatError(
            f"{where}: cut (C) edges {cuts}; a chain (accordion) is a strip crossed by creases "
            "only: read the pattern with net_geometry"
        )
    creases = [e for e, a in enumerate(assignment) if a != "B"]
    if not creases:
        raise FoldFormatError(f"{where}: no creases (every edge is a boundary B edge)")
    first = coords[edges[creases[0]][1]] - coords[edges[creases[0]][0]]
    axis = first / np.linalg.norm(first)
    direction = np.cross(np.cross(plane[0], plane[1]), axis)
    if direction @ (plane[0] + plane[1]) < 0:
        # Orient the strip so that it runs toward +y (or +x): hinge angle = fold angle either way.
        axis, direction = -axis, -direction
    size = float(np.max(np.ptp(coords, axis=0)))
    lines: list[list[int]] = []
    offsets: list[float] = []
    for e in creases:
        a, b = coords[edges[e][0]], coords[edges[e][1]]
        along = (b - a) / np.linalg.norm(b - a)
        if np.linalg.norm(np.cross(along, axis)) > PARALLEL_TOL:
            raise FoldFormatError(
                f"{where}: crease edge {e} is not parallel to crease edge {creases[0]}; a chain "
                "(accordion) needs parallel creases. For creases meeting at a vertex, read a "
                "single vertex instead"
            )
        offset = float(a @ direction)
        if abs(float(b @ direction) - offset) > PARALLEL_TOL * size:
            raise FoldFormatError(f"{where}: crease edge {e} is not straight across the strip")
        for k, known in enumerate(offsets):
            if abs(known - offset) <= PARALLEL_TOL * size:
                lines[k].append(e)
                break
        else:
            offsets.append(offset)
            lines.append([e])
    order = np.argsort(offsets)
    lines = [lines[k] for k in order]
    hinge_offsets = np.array(offsets)[order]
    along_all = coords @ axis
    across_all = coords @ direction
    start, end = float(across_all.min()), float(across_all.max())
    bounds = np.concatenate([[start], hinge_offsets, [end]])
    flap_lengths = np.diff(bounds)
    if np.any(flap_lengths <= PARALLEL_TOL * size):
        raise FoldFormatError(f"{where}: a crease lies on the strip's edge (a flap of zero length)")
    angles_deg = fold.fold_angles_deg(frame)
    fold_angles = []
    assignments = []
    crease_lengths = []
    hinge_points = []
    for line in lines:
        values = angles_deg[line]
        if not (np.allclose(values, values[0], equal_nan=True)):
            raise FoldFormatError(
                f"{where}: the crease line made of edges {line} has different fold angles "
                f"{values.tolist()} along its length; a rigid hinge has one"
            )
        kinds = {assignment[e] for e in line}
        if len(kinds) > 1:
            raise FoldFormatError(
                f"{where}: the crease line made of edges {line} mixes assignments {sorted(kinds)}"
            )
        fold_angles.append(np.deg2rad(values[0]))
        assignments.append(kinds.pop())
        ends = np.array([coords[w] @ axis for e in line for w in edges[e]])
        crease_lengths.append(float(ends.max() - ends.min()))
        point = coords[edges[line[0]][0]]
        hinge_points.append(point - (point @ axis - ends.min()) * axis)
    width = float(along_all.max() - along_all.min())
    return ChainGeometry(
        crease_edges=tuple(tuple(line) for line in lines),
        axis=axis,
        direction=direction,
        hinge_points=np.stack(hinge_points),
        hinge_offsets=hinge_offsets,
        flap_lengths=flap_lengths,
        flap_widths=np.full(len(flap_lengths), width),
        crease_lengths=np.array(crease_lengths),
        fold_angles=np.array(fold_angles),
        assignments=tuple(assignments),
        unit=resolved.frame_unit,
    )
