"""Writing FOLD: a checked `FoldFile` to JSON text, and `normalise_fold` to fill what importers need.

Origami Simulator refuses a file unless all four of `vertices_coords`, `edges_vertices`,
`edges_assignment` and `faces_vertices` are present (its `importer.js`), and so does Rabbit Ear's
documented import path; `write_fold` therefore insists on them in the key frame, and `normalise_fold`
derives the missing ones where it can.
"""

from __future__ import annotations

import json
import math
import os
import uuid
from pathlib import Path
from typing import Any

import numpy as np

from ._checks import check_fold
from ._errors import FoldFormatError
from ._model import WRITTEN_SPEC, FoldFile, FoldFrame
from ._read import _without_parsed_arrays
from ._schema import validate_schema_once

REQUIRED_KEYS = ("vertices_coords", "edges_vertices", "edges_assignment", "faces_vertices")
CREATOR = "origami_jax"


def write_fold(path: str | os.PathLike[str], fold: FoldFile) -> Path:
    """Check `fold` and write it to `path` as FOLD JSON (UTF-8). Returns the path written.

    **Raises:** `FoldFormatError` if the key frame lacks any of `vertices_coords`, `edges_vertices`,
    `edges_assignment`, `faces_vertices` (run `normalise_fold` first), or fails `check_fold` or the
    schema.
    """
    path = Path(path)
    text = dumps_fold(fold)
    # Through a temporary file and a rename: `path` holds the old file or the whole new one.
    tmp = path.with_name(f".tmp-{os.getpid()}-{uuid.uuid4().hex[:12]}-{path.name}")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def dumps_fold(fold: FoldFile) -> str:
    """FOLD JSON text of `fold` (see `write_fold`); one array element per line for readability."""
    missing = [
        key
        for key, name in zip(REQUIRED_KEYS, _REQUIRED_FIELDS, strict=True)
        if getattr(fold.key_frame, name) is None
    ]
    if missing:
        raise FoldFormatError(
            f"cannot write a FOLD file without {', '.join(missing)} in the key frame: Origami "
            "Simulator and Rabbit Ear need all four of " + ", ".join(REQUIRED_KEYS) + ". "
            "normalise_fold() derives missing assignments and faces of a flat crease pattern."
        )
    check_fold(fold)
    data = fold.to_dict()
    # The mesh arrays came from a checked `FoldFile` (and `check_fold` above): the schema checks
    # the rest. Validating whole arrays against it took minutes on a file of many vertices (each
    # frame of an animation repeats them), where reading it takes a second.

    validate_schema_once(_without_parsed_arrays(data))
    return _format(data, 0) + "\n"


_REQUIRED_FIELDS = ("vertices_coords", "edges_vertices", "edges_assignment", "faces_vertices")


def normalise_fold(fold: FoldFile, *, creator: str = CREATOR) -> FoldFile:
    """A copy of `fold` ready for other tools: FOLD spec 1.2, every default made explicit.

    - `file_spec` 1.2 and `file_creator` (kept if the file names one);
    - key frame: `faces_vertices` traced from the planar graph if missing (the key frame must then
      be flat, in the xy plane), `edges_assignment` derived if missing (B for edges on one face,
      otherwise M/V/F from the sign of the fold angle, U if unknown), `edges_foldAngle` written out
      with the defaults (M → −180, V → +180, F/B → 0, U → null);
    - frames that inherit keep inheriting; a frame that overrides `edges_assignment` gets its fold
      angles made explicit too.
    """
    key = fold.key_frame
    if key.vertices_coords is None or key.edges_vertices is None:
        raise FoldFormatError("the key frame needs vertices_coords and edges_vertices")
    faces = key.faces_vertices
    if faces is None:
        faces = planar_faces(key.coords3, key.edges_vertices)
    assignment = key.edges_assignment
    if assignment is None:
        assignment = _derive_assignment(key, faces)
    key = key.replace(faces_vertices=faces, edges_assignment=assignment)
    frames = [key, *fold.frames[1:]]
    draft = FoldFile(frames=tuple(frames), file_spec=WRITTEN_SPEC, file_metadata=fold.file_metadata)
    out_frames = []
    for index, frame in enumerate(draft.frames):
        if (
            index == 0
            or frame.edges_assignment is not None
            or frame.edges_fold_angle_deg is not None
        ):
            frame = frame.replace(edges_fold_angle_deg=draft.fold_angles_deg(index))
        out_frames.append(frame)
    metadata = dict(fold.file_metadata)
    metadata.setdefault("file_creator", creator)
    return FoldFile(frames=tuple(out_frames), file_spec=WRITTEN_SPEC, file_metadata=metadata)


def planar_faces(coords: np.ndarray, edges: np.ndarray) -> tuple[tuple[int, ...], ...]:
    """Counter-clockwise faces of a planar straight-line graph in the xy plane (outer face dropped).

    Each face is traced by keeping it on the left: from half-edge u → v, continue along the edge of
    v that comes next clockwise after the edge back to u. Bounded faces come out counter-clockwise
    (positive area); the unbounded face comes out clockwise and is dropped.

    **Raises:** `FoldFormatError` if the coordinates are not all in one plane z = const.
    """
    coords = np.asarray(coords, dtype=float)
    if coords.shape[1] == 3 and not np.allclose(coords[:, 2], coords[0, 2]):
        raise FoldFormatError(
            "cannot derive faces_vertices: the key frame is not a flat crease pattern in the xy "
            "plane; give faces_vertices in the file"
        )
    neighbours: dict[int, list[int]] = {}
    for u, v in edges.tolist():
        neighbours.setdefault(u, []).append(v)
        neighbours.setdefault(v, []).append(u)
    order: dict[int, list[int]] = {}
    for u, nbrs in neighbours.items():
        d = coords[nbrs, :2] - coords[u, :2]
        order[u] = [nbrs[i] for i in np.argsort(np.arctan2(d[:, 1], d[:, 0]), kind="stable")]
    seen: set[tuple[int, int]] = set()
    faces = []
    for u, v in [(u, v) for u, v in edges.tolist()] + [(v, u) for u, v in edges.tolist()]:
        if (u, v) in seen:
            continue
        face = []
        a, b = u, v
        while (a, b) not in seen:
            seen.add((a, b))
            face.append(a)
            around = order[b]
            w = around[(around.index(a) - 1) % len(around)]
            a, b = b, w
        xy = coords[face, :2]
        area = 0.5 * np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
        if area > 0:
            faces.append(tuple(face))
    return tuple(faces)


def _derive_assignment(frame: FoldFrame, faces: tuple[tuple[int, ...], ...]) -> tuple[str, ...]:
    count: dict[frozenset[int], int] = {}
    for face in faces:
        for u, v in zip(face, face[1:] + face[:1], strict=True):
            count[frozenset((u, v))] = count.get(frozenset((u, v)), 0) + 1
    angles = frame.edges_fold_angle_deg
    out = []
    for i, (u, v) in enumerate(frame.edges_vertices.tolist()):  # type: ignore[union-attr]
        if count.get(frozenset((u, v)), 0) <= 1:
            out.append("B")
            continue
        angle = math.nan if angles is None else float(angles[i])
        out.append("U" if math.isnan(angle) else "V" if angle > 0 else "M" if angle < 0 else "F")
    return tuple(out)


def _format(value: Any, depth: int) -> str:
    """JSON with objects indented and arrays of scalars kept on one line."""
    pad = "  " * depth
    if isinstance(value, dict):
        if not value:
            return "{}"
        items = [f"{pad}  {json.dumps(k)}: {_format(v, depth + 1)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + f"\n{pad}}}"
    if isinstance(value, list) and any(isinstance(v, dict | list) for v in value):
        items = [f"{pad}  {_format(v, depth + 1)}" for v in value]
        return "[\n" + ",\n".join(items) + f"\n{pad}]"
    return json.dumps(value, allow_nan=False, separators=(", ", ": "))
