"""Reading FOLD: JSON text or a dictionary into a checked `FoldFile`.

Every problem becomes a `FoldFormatError` that names the key, the index and the fix; nothing in a file
can make the reader crash with another exception (deeply nested JSON, numbers too large for their
type and the like included: `_guarded`).

The mesh arrays (`vertices_coords`, `edges_...`, `faces_vertices`) are checked and converted in bulk
(type sets and NumPy), falling back to an element-by-element pass only to name the first bad entry,
and the JSON schema is applied to everything else; the parsers below check those arrays at least as
strictly as the schema does. This reads ~10⁵–10⁶ vertices per second, where validating whole arrays
against the schema managed ~2·10³.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import itertools
import json
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from ._checks import check_fold
from ._errors import FoldFormatError
from ._model import (
    _FRAME_FIELDS,
    ASSIGNMENTS,
    SUPPORTED_ASSIGNMENTS,
    SUPPORTED_SPECS,
    FoldFile,
    FoldFrame,
)
from ._pattern_file import edges_of
from ._schema import validate_schema_once

# Legacy (FOLD 1.0) names, read and rewritten under their 1.1+ names.
_LEGACY = {"edges_foldAngles": "edges_foldAngle", "edges_lengths": "edges_length"}
# Coordinates beyond this magnitude are refused: their squares (face areas) would overflow float64.
MAX_COORDINATE = 1e100
# Vertex ids must fit in int64.
_MAX_INDEX = 2**63 - 1

_T = TypeVar("_T")


def _guarded(fn: Callable[..., _T]) -> Callable[..., _T]:
    """Turn any error other than a `FoldFormatError` into one, so that no file can crash a caller
    that catches `FoldFormatError` (JSON nested thousands deep, a number too large for its type)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except FoldFormatError:
            raise
        except RecursionError:
            raise FoldFormatError(
                "the JSON is nested too deeply to read (FOLD data is at most a few levels deep)"
            ) from None
        except (OverflowError, MemoryError, ValueError, TypeError, KeyError, IndexError) as error:
            message = str(error).splitlines()[0] if str(error) else ""
            raise FoldFormatError(
                f"could not read the data ({type(error).__name__}: {message[:200]})"
            ) from None

    return wrapper


def read_fold(path: str | os.PathLike[str]) -> FoldFile:
    """Read and check a `.fold` file.

    **Arguments:**
    - `path`: the file.

    **Returns:** the `FoldFile`, checked by `check_fold` (structure, indices, counter-clockwise faces,
    assignments against fold angles) and, when `jsonschema` is installed, against the shipped schema.
    A key frame of vertices and faces only (no edges, as mesh exporters write folded forms) gets
    its faces' sides as edges: `B` on the boundary, `U` where two faces meet.

    **Raises:** `FoldFormatError` for anything unreadable or unsupported (bad JSON, missing keys,
    `J` (join) edges, a newer spec version, ...). A missing file raises `FileNotFoundError`.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise FoldFormatError(f"{path}: not a text (UTF-8) file: {error}") from None
    try:
        return loads_fold(text)
    except FoldFormatError as error:
        raise FoldFormatError(f"{path}: {error}") from None


@_guarded
def loads_fold(text: str) -> FoldFile:
    """Parse FOLD JSON text (see `read_fold`)."""
    with _no_gc():
        return _loads_fold(text)


@contextlib.contextmanager
def _no_gc():
    """The cyclic garbage collector paused: parsing allocates millions of small objects (no cycles)
    and the collector's passes over them took more than half of `json.loads`' time."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _loads_fold(text: str) -> FoldFile:
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as error:
        raise FoldFormatError(
            f"not valid JSON (line {error.lineno}, column {error.colno}: {error.msg}); "
            "a .fold file is a JSON object"
        ) from None
    except FoldFormatError:  # a NaN or an infinity (`_reject_constant`): its own message
        raise
    except ValueError as error:  # e.g. an integer with more digits than Python converts
        raise FoldFormatError(f"not valid JSON for FOLD ({str(error)[:200]})") from None
    return fold_from_dict(data)


@_guarded
def fold_from_dict(data: Any, *, validate_schema: bool = True) -> FoldFile:
    """Build and check a `FoldFile` from decoded FOLD JSON data (see `read_fold`)."""
    if not isinstance(data, Mapping):
        raise FoldFormatError(
            f"the top level of a FOLD file must be a JSON object, not {type(data).__name__}"
        )
    original = data
    data = dict(data)
    spec = _read_spec(data.pop("file_spec", None))
    file_metadata = {
        k: data.pop(k) for k in list(data) if k.startswith("file_") and k != "file_frames"
    }
    frames_data = data.pop("file_frames", None)
    frames = [_frame_from_dict(data, 0)]
    if frames_data is not None:
        if not isinstance(frames_data, list):
            raise FoldFormatError("file_frames must be an array of frame objects")
        for i, frame_data in enumerate(frames_data, start=1):
            if not isinstance(frame_data, Mapping):
                raise FoldFormatError(f"file_frames[{i - 1}] (frame {i}) must be a JSON object")
            frame_data = dict(frame_data)
            misplaced = [k for k in frame_data if k.startswith("file_")]
            if misplaced:
                raise FoldFormatError(
                    f"frame {i} has file-level keys {misplaced}: file_... properties belong at the "
                    "top level only (FOLD 1.2, Multiple Frames)"
                )
            frames.append(_frame_from_dict(frame_data, i))
    frames[0] = _with_edges_from_faces(frames[0])
    for i, frame in enumerate(frames):
        # Inheriting or not, a parent must be a frame of the file (checked on inheritance only, a
        # dangling link was read and exported again).
        if frame.frame_parent is not None and not frame.frame_parent < len(frames):
            raise FoldFormatError(
                f"frame {i} has frame_parent {frame.frame_parent}, which does not exist (the file "
                f"has frames 0 to {len(frames) - 1}): fix the link or remove it"
            )
    fold = FoldFile(frames=tuple(frames), file_spec=spec, file_metadata=file_metadata)
    check_fold(fold)
    if validate_schema:
        # After our own parsing, whose messages are more specific; the schema is a second net for
        # what the parsers do not cover (the mesh arrays they checked are left out: module docstring).

        validate_schema_once(_without_parsed_arrays(original))
    return fold


def _with_edges_from_faces(frame: FoldFrame) -> FoldFrame:
    """A key frame of vertices and faces only (a mesh exporter's folded form) with the faces' sides
    as its edges: `B` on the boundary (a side of one face), `U` where two faces meet (FOLD leaves
    `edges_vertices` optional; the geometry needs the edges)."""
    if (
        frame.edges_vertices is not None
        or frame.edges_assignment is not None
        or frame.edges_fold_angle_deg is not None
        or frame.faces_vertices is None
        or frame.vertices_coords is None
    ):
        return frame
    edges, count = edges_of([tuple(face) for face in frame.faces_vertices])
    assignment = tuple("B" if count[frozenset(e)] == 1 else "U" for e in edges)
    return frame.replace(
        edges_vertices=np.asarray(edges, dtype=np.int64).reshape(-1, 2),
        edges_assignment=assignment,
    )


# Frame keys whose values the parsers check at least as strictly as the schema.
_PARSED_ARRAYS = frozenset(
    {
        "vertices_coords",
        "edges_vertices",
        "edges_assignment",
        "edges_foldAngle",
        "edges_foldAngles",
        "faces_vertices",
        "edges_length",
        "edges_lengths",
    }
)


def _without_parsed_arrays(data: Mapping[str, Any]) -> dict[str, Any]:
    def strip(frame: Any) -> Any:
        if not isinstance(frame, Mapping):
            return frame
        return {k: v for k, v in frame.items() if k not in _PARSED_ARRAYS}

    out = strip(data)
    frames = out.get("file_frames")
    if isinstance(frames, list):
        out["file_frames"] = [strip(frame) for frame in frames]
    return out


def _reject_constant(name: str) -> None:
    raise FoldFormatError(
        f"not valid JSON: {name} is not a JSON number (coordinates and angles must be finite)"
    )


def _read_spec(value: Any) -> int | float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FoldFormatError(f"file_spec must be a number such as 1.2, not {value!r}")
    if value not in SUPPORTED_SPECS:
        supported = ", ".join(str(s) for s in SUPPORTED_SPECS)
        raise FoldFormatError(
            f"unsupported FOLD spec version file_spec = {value}: this reader understands "
            f"{supported}. Convert the file with the FOLD tools, or set file_spec to 1.2 if it "
            "only uses 1.2 features."
        )
    return value


def _frame_from_dict(data: dict[str, Any], index: int) -> FoldFrame:
    where = "key frame" if index == 0 else f"frame {index}"
    data = dict(data)
    for old, new in _LEGACY.items():
        if old in data:
            legacy = data.pop(old)
            if new in data and data[new] != legacy:
                raise FoldFormatError(
                    f"{where} has both {new} and the legacy {old}, and they differ: keep one"
                )
            data.setdefault(new, legacy)
    fields: dict[str, Any] = {}
    for key, name in _FRAME_FIELDS.items():
        if key in data:
            fields[name] = _PARSERS[key](data.pop(key), where)
    if "edges_length" in data:
        _lengths(data["edges_length"], where)  # kept verbatim in `extra`, checked here
    if index == 0 and "frame_parent" in fields:
        raise FoldFormatError("the key frame (frame 0) cannot have a frame_parent")
    return FoldFrame(**fields, extra=data)


def _flat_types(rows: list) -> set[type]:
    return set(map(type, itertools.chain.from_iterable(rows)))


def _uniform_rows(rows: list, lengths: set[int]) -> bool:
    """Every row a list, of one of `lengths`."""
    return set(map(type, rows)) <= {list} and set(map(len, rows)) <= lengths


def _bulk(rows: list, width: int, dtype) -> np.ndarray | None:
    """`rows` (lists of `width` entries, types checked by the caller) as a `(len, width)` array,
    or `None` when a value does not fit `dtype` (the element pass then names it)."""
    try:
        flat = np.fromiter(
            itertools.chain.from_iterable(rows), dtype=dtype, count=len(rows) * width
        )
    except (OverflowError, ValueError, TypeError):
        return None
    return flat.reshape(len(rows), width)


def _coords(value: Any, where: str) -> np.ndarray:
    rows = _list(value, "vertices_coords", where)
    out = None
    if rows and _uniform_rows(rows, {2, 3}) and len(set(map(len, rows))) == 1:
        if _flat_types(rows) <= {int, float}:
            out = _bulk(rows, len(rows[0]), np.float64)
    if out is not None and np.all(np.isfinite(out)) and np.all(np.abs(out) <= MAX_COORDINATE):
        return out
    dimension = 2
    for i, row in enumerate(rows):
        row = _list(row, f"vertices_coords[{i}]", where)
        if len(row) not in (2, 3):
            raise FoldFormatError(
                f"{where}: vertices_coords[{i}] has {len(row)} coordinates; only 2D and 3D "
                "coordinates are supported"
            )
        for x in row:
            if not _is_number(x) or not _finite_coordinate(x):
                raise FoldFormatError(
                    f"{where}: vertices_coords[{i}] = {_short(row)} must hold finite numbers of "
                    f"magnitude at most {MAX_COORDINATE:g} (rescale the pattern, or set frame_unit)"
                )
        dimension = max(dimension, len(row))
    out = np.zeros((len(rows), dimension))
    for i, row in enumerate(rows):
        out[i, : len(row)] = row
    return out


def _finite_coordinate(x: int | float) -> bool:
    try:
        return math.isfinite(x) and abs(float(x)) <= MAX_COORDINATE
    except OverflowError:
        return False


def _edges(value: Any, where: str) -> np.ndarray:
    rows = _list(value, "edges_vertices", where)
    if _uniform_rows(rows, {2}) and _flat_types(rows) <= {int}:
        out = _bulk(rows, 2, np.int64)  # ids beyond int64 give None
        if out is not None and (len(out) == 0 or out.min() >= 0):
            if not np.any(out[:, 0] == out[:, 1]):
                return out
    out = np.zeros((len(rows), 2), dtype=np.int64)
    for i, row in enumerate(rows):
        if not (isinstance(row, list) and len(row) == 2 and all(_is_index(v) for v in row)):
            raise FoldFormatError(
                f"{where}: edges_vertices[{i}] = {_short(row)} must be a pair [u, v] of vertex ids "
                "(whole numbers >= 0)"
            )
        if row[0] == row[1]:
            raise FoldFormatError(f"{where}: edges_vertices[{i}] = {row!r} is a loop (u = v)")
        out[i] = row
    return out


def _assignments(value: Any, where: str) -> tuple[str, ...]:
    rows = _list(value, "edges_assignment", where)
    if set(map(type, rows)) <= {str}:
        upper = {a: a.upper() for a in set(rows)}
        if set(upper.values()) <= SUPPORTED_ASSIGNMENTS:
            return tuple(map(upper.__getitem__, rows))
    out = []
    for i, a in enumerate(rows):
        if not isinstance(a, str) or a.upper() not in ASSIGNMENTS:
            raise FoldFormatError(
                f"{where}: edges_assignment[{i}] = {_short(a)} is not one of B, M, V, F, U, C, J"
            )
        a = a.upper()
        if a not in SUPPORTED_ASSIGNMENTS:
            raise FoldFormatError(
                f"{where}: edges_assignment[{i}] is {a!r} ({ASSIGNMENTS[a]} edge), which "
                "origami_jax does not support: merge the faces on either side into one face and "
                "drop the edge"
            )
        out.append(a)
    return tuple(out)


def _fold_angles(value: Any, where: str) -> np.ndarray:
    rows = _list(value, "edges_foldAngle", where)
    if set(map(type, rows)) <= {int, float, type(None)}:
        try:
            out = np.array(rows, dtype=np.float64)  # null -> NaN
        except OverflowError:
            out = None
        if out is not None and not np.any(np.abs(out) > 180):  # NaN compares False: kept
            return out.reshape(len(rows))
    out = np.full(len(rows), np.nan)
    for i, x in enumerate(rows):
        if x is None:
            continue
        if not _is_number(x) or not -180 <= x <= 180:
            raise FoldFormatError(
                f"{where}: edges_foldAngle[{i}] = {_short(x)} must be a number of degrees in "
                "[-180, 180] (valley +, mountain -) or null"
            )
        out[i] = x
    return out


def _lengths(value: Any, where: str) -> None:
    rows = _list(value, "edges_length", where)
    if set(map(type, rows)) <= {int, float}:
        try:
            ok = bool(np.all(np.array(rows, dtype=np.float64) >= 0))
        except OverflowError:
            ok = False
        if ok:
            return
    for i, x in enumerate(rows):
        if not _is_number(x) or not x >= 0:
            raise FoldFormatError(f"{where}: edges_length[{i}] = {_short(x)} must be a number >= 0")


def _faces(value: Any, where: str) -> tuple[tuple[int, ...], ...]:
    rows = _list(value, "faces_vertices", where)
    if set(map(type, rows)) <= {list} and (not rows or min(map(len, rows)) >= 3):
        if _flat_types(rows) <= {int}:
            total = sum(map(len, rows))
            try:
                flat = np.fromiter(itertools.chain.from_iterable(rows), np.int64, count=total)
            except OverflowError:  # an id beyond int64: the element pass names it
                flat = None
            if flat is not None and (total == 0 or flat.min() >= 0):
                return tuple(map(tuple, rows))
    out = []
    for i, row in enumerate(rows):
        if not (isinstance(row, list) and len(row) >= 3 and all(_is_index(v) for v in row)):
            not_id = (
                next((v for v in row if not _is_index(v)), None) if isinstance(row, list) else None
            )
            why = (
                f": {_short(not_id)} is not one (whole numbers >= 0)" if not_id is not None else ""
            )
            raise FoldFormatError(
                f"{where}: faces_vertices[{i}] = {_short(row)} must list at least 3 vertex ids{why}"
            )
        out.append(tuple(row))
    return tuple(out)


def _string(key: str):
    def parse(value: Any, where: str) -> str:
        if not isinstance(value, str):
            raise FoldFormatError(f"{where}: {key} must be a string, not {value!r}")
        return value

    return parse


def _strings(key: str):
    def parse(value: Any, where: str) -> tuple[str, ...]:
        rows = _list(value, key, where)
        if not all(isinstance(s, str) for s in rows):
            raise FoldFormatError(f"{where}: {key} must be an array of strings")
        return tuple(rows)

    return parse


def _parent(value: Any, where: str) -> int:
    if not _is_index(value):
        raise FoldFormatError(f"{where}: frame_parent must be a frame id (integer >= 0)")
    return int(value)


def _inherit(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise FoldFormatError(f"{where}: frame_inherit must be true or false, not {value!r}")
    return value


_PARSERS = {
    "vertices_coords": _coords,
    "edges_vertices": _edges,
    "edges_assignment": _assignments,
    "edges_foldAngle": _fold_angles,
    "faces_vertices": _faces,
    "frame_unit": _string("frame_unit"),
    "frame_classes": _strings("frame_classes"),
    "frame_attributes": _strings("frame_attributes"),
    "frame_parent": _parent,
    "frame_inherit": _inherit,
}


def _list(value: Any, key: str, where: str) -> list:
    if not isinstance(value, list):
        raise FoldFormatError(f"{where}: {key} must be an array, not {type(value).__name__}")
    return value


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _is_index(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool) and 0 <= x <= _MAX_INDEX


def _short(value: Any, limit: int = 80) -> str:
    """`repr(value)`, cut to `limit` characters (a bad entry may be a huge nested array)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
