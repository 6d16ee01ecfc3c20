"""The FOLD data model: a file of frames, each a crease pattern or folded state in flat arrays.

Plain dataclasses over numpy arrays: this is file I/O, not something to trace through. The model keeps
what the file says, in the file's units (coordinates in `frame_unit`, fold angles in **degrees**); the
geometry functions (`single_vertex_geometry`, `chain_geometry`) hand out radians.

Frame inheritance (`frame_parent` / `frame_inherit`, FOLD 1.2 "Multiple Frames") is kept as written, so
that a file written back out is the file read in; `FoldFile.frame(i)` returns frame `i` with every
inherited property filled in.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ._errors import FoldFormatError

# FOLD spec versions this reader understands. 1.0 used `edges_foldAngles` / `edges_lengths`.
SUPPORTED_SPECS = (1, 1.1, 1.2)
WRITTEN_SPEC = 1.2

ASSIGNMENTS = {
    "B": "boundary",
    "M": "mountain",
    "V": "valley",
    "F": "flat",
    "U": "unassigned",
    "C": "cut",
    "J": "join",
}
# "C" (cut) edges separate the faces on either side (`net_geometry` reads them; the single-vertex
# and chain readers refuse them); "J" (join) edges are rejected on reading.
SUPPORTED_ASSIGNMENTS = frozenset("BMVFUC")

# Default fold angle (degrees) for an edge that has an assignment but no fold angle.
# "U" is free: NaN, which becomes `null` in the file. A cut "C" joins nothing: 0, like a boundary.
DEFAULT_FOLD_ANGLE_DEG = {"M": -180.0, "V": 180.0, "F": 0.0, "B": 0.0, "C": 0.0, "U": math.nan}

# frame_unit values defined by FOLD 1.2, with their length in metres ("unit": no physical meaning).
FRAME_UNITS_M = {
    "unit": None,
    "in": 0.0254,
    "pt": 0.0254 / 72,
    "m": 1.0,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "nm": 1e-9,
}


def length_scale_from_unit(unit: str | None, metre_per_length: float) -> float:
    """Design length units per FOLD unit for a file whose `frame_unit` is `unit` (missing: FOLD's
    default, "unit"), with `metre_per_length` metres per design length unit. `ValueError` for
    "unit", which has no physical length: the caller must be given the scale."""
    metres = FRAME_UNITS_M.get(unit or "unit")
    if metres is None:
        given = "gives no frame_unit" if unit is None else f"gives frame_unit {unit!r}"
        raise ValueError(
            f"the FOLD file {given}, which has no physical length: give "
            "length_scale= (origami-jax fold --length-scale), the design's length units per FOLD "
            "unit, e.g. 1.0 for µm."
        )
    return metres / metre_per_length


# Frame properties the model has fields for; everything else is kept verbatim in `extra`.
_FRAME_FIELDS = {
    "vertices_coords": "vertices_coords",
    "edges_vertices": "edges_vertices",
    "edges_assignment": "edges_assignment",
    "edges_foldAngle": "edges_fold_angle_deg",
    "faces_vertices": "faces_vertices",
    "frame_unit": "frame_unit",
    "frame_classes": "frame_classes",
    "frame_attributes": "frame_attributes",
    "frame_parent": "frame_parent",
    "frame_inherit": "frame_inherit",
}
# Properties that describe the mesh and are therefore inherited by `frame_inherit` (all but links).
_NOT_INHERITED = {"frame_parent", "frame_inherit"}


@dataclasses.dataclass(frozen=True, eq=False)
class FoldFrame:
    """One frame of a FOLD file. Every field may be `None` (absent); arrays are read-only copies.

    **Fields:**
    - `vertices_coords`: float64 `(V, d)`, `d` = 2 or 3, in `frame_unit`.
    - `edges_vertices`: int64 `(E, 2)`.
    - `edges_assignment`: one of `B M V F U C` per edge (`J` is rejected on reading).
    - `edges_fold_angle_deg`: float64 `(E,)`, **degrees**, valley +, mountain −; NaN where the file
      has `null`. `None` when the file gives no fold angles: see `FoldFile.fold_angles_deg`.
    - `faces_vertices`: vertex ids of each face, counter-clockwise.
    - `frame_unit`, `frame_classes`, `frame_attributes`, `frame_parent`, `frame_inherit`: as in FOLD.
    - `extra`: every other property of the frame, verbatim (e.g. `frame_title`, `vertices_vertices`,
      and custom `namespace:key` data such as ours, `origami_jax:...`).
    """

    vertices_coords: np.ndarray | None = None
    edges_vertices: np.ndarray | None = None
    edges_assignment: tuple[str, ...] | None = None
    edges_fold_angle_deg: np.ndarray | None = None
    faces_vertices: tuple[tuple[int, ...], ...] | None = None
    frame_unit: str | None = None
    frame_classes: tuple[str, ...] | None = None
    frame_attributes: tuple[str, ...] | None = None
    frame_parent: int | None = None
    frame_inherit: bool | None = None
    extra: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("vertices_coords", "edges_vertices", "edges_fold_angle_deg"):
            value = getattr(self, name)
            if value is not None:
                dtype = np.int64 if name == "edges_vertices" else np.float64
                array = np.array(value, dtype=dtype)
                array.setflags(write=False)
                object.__setattr__(self, name, array)

    @property
    def n_vertices(self) -> int | None:
        return None if self.vertices_coords is None else int(self.vertices_coords.shape[0])

    @property
    def n_edges(self) -> int | None:
        return None if self.edges_vertices is None else int(self.edges_vertices.shape[0])

    @property
    def coords3(self) -> np.ndarray:
        """Vertex coordinates padded to 3D (FOLD: missing trailing coordinates are zero), `(V, 3)`."""
        if self.vertices_coords is None:
            raise FoldFormatError("the frame has no vertices_coords")
        coords = self.vertices_coords
        return np.concatenate([coords, np.zeros((coords.shape[0], 3 - coords.shape[1]))], axis=1)

    def to_dict(self) -> dict[str, Any]:
        """The frame as FOLD JSON-ready data (degrees, `null` for unknown fold angles)."""
        out: dict[str, Any] = {}
        for key, name in _FRAME_FIELDS.items():
            value = getattr(self, name)
            if value is None:
                continue
            if name == "edges_fold_angle_deg":
                value = [None if math.isnan(x) else _plain_number(x) for x in value.tolist()]
            elif name == "vertices_coords":
                value = [[_plain_number(x) for x in row] for row in value.tolist()]
            elif isinstance(value, np.ndarray):
                value = value.tolist()
            elif isinstance(value, tuple):
                value = [list(v) if isinstance(v, tuple) else v for v in value]
            out[key] = value
        out.update(_copy_json(dict(self.extra)))
        return out

    def replace(self, **changes: Any) -> FoldFrame:
        """A copy with some fields changed (`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)


@dataclasses.dataclass(frozen=True, eq=False)
class FoldFile:
    """A whole FOLD file: file metadata and its frames (`frames[0]` is the key frame).

    **Fields:**
    - `frames`: the key frame followed by `file_frames`, as written (inheritance not applied).
    - `file_spec`: the FOLD version the file declares (`None` if it declares none; read as 1.2).
    - `file_metadata`: the other `file_...` properties (`file_creator`, `file_title`, ...).

    Two `FoldFile`s are equal when they serialise to the same JSON data.
    """

    frames: tuple[FoldFrame, ...]
    file_spec: int | float | None = WRITTEN_SPEC
    file_metadata: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if len(self.frames) == 0:
            raise FoldFormatError("a FOLD file needs at least its key frame")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FoldFile):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]

    @property
    def n_frames(self) -> int:
        return len(self.frames)

    @property
    def key_frame(self) -> FoldFrame:
        return self.frames[0]

    def frame(self, index: int = 0) -> FoldFrame:
        """Frame `index` (0 = key frame) with the properties it inherits filled in.

        A frame inherits when it has `frame_inherit: true` and a `frame_parent` (as in the reference
        FOLD library); inheritance is recursive.
        """
        if not 0 <= index < len(self.frames):
            raise FoldFormatError(
                f"frame {index} does not exist: the file has {len(self.frames)} frame(s), "
                f"numbered 0 (key frame) to {len(self.frames) - 1}"
            )
        chain = [index]
        current = self.frames[index]
        while current.frame_inherit and current.frame_parent is not None:
            parent = current.frame_parent
            if parent in chain:
                raise FoldFormatError(f"frame_parent links form a cycle: {chain + [parent]}")
            if not 0 <= parent < len(self.frames):
                raise FoldFormatError(
                    f"frame {chain[-1]} has frame_parent {parent}, which does not exist "
                    f"(frames 0 to {len(self.frames) - 1})"
                )
            chain.append(parent)
            current = self.frames[parent]
        merged: dict[str, Any] = {}
        extra: dict[str, Any] = {}
        for frame_id in reversed(chain):
            frame = self.frames[frame_id]
            for name in _FRAME_FIELDS.values():
                value = getattr(frame, name)
                if value is not None and (frame_id == index or name not in _NOT_INHERITED):
                    merged[name] = value
            extra.update(frame.extra)
        for name in _NOT_INHERITED:
            merged[name] = getattr(self.frames[index], name)
        return FoldFrame(**merged, extra=extra)

    def fold_angles_deg(self, index: int = 0) -> np.ndarray:
        """Fold angles of frame `index` in degrees, with defaults from the assignment where missing.

        `edges_foldAngle` wins where it is given; elsewhere M → −180, V → +180, F, B and C → 0 and
        U → NaN (free). An edge with neither an angle nor an assignment is NaN.
        """
        frame = self.frame(index)
        n_edges = frame.n_edges or 0
        angles = (
            np.full(n_edges, np.nan)
            if frame.edges_fold_angle_deg is None
            else np.array(frame.edges_fold_angle_deg)
        )
        if frame.edges_assignment is not None:
            defaults = np.array([DEFAULT_FOLD_ANGLE_DEG[a] for a in frame.edges_assignment])
            angles = np.where(np.isnan(angles), defaults, angles)
        return angles

    def to_dict(self) -> dict[str, Any]:
        """The file as FOLD JSON-ready data: file metadata, key frame, then `file_frames`."""
        out: dict[str, Any] = {}
        if self.file_spec is not None:
            out["file_spec"] = self.file_spec
        out.update(_copy_json(dict(self.file_metadata)))
        out.update(self.frames[0].to_dict())
        if len(self.frames) > 1:
            out["file_frames"] = [frame.to_dict() for frame in self.frames[1:]]
        return out


def _plain_number(x: float) -> int | float:
    """Integral floats as ints, so that hand-written files keep `1` rather than gaining `1.0`."""
    if float(x).is_integer() and abs(x) < 2**53:
        return int(x)
    return float(x)


def _copy_json(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _copy_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_copy_json(v) for v in value]
    return value
