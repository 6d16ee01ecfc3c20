"""FOLD files as scenes: every frame with the key frame's faces, folded states drawn as given.

A frame that stores its own 3D `vertices_coords` is drawn as stored. A frame whose coordinates are a
flat crease pattern (the key frame, or a frame that inherits only the coordinates and changes the
fold angles, as Origami Simulator's and Rabbit Ear's animations may) is folded rigidly by its fold
angles: faces are visited breadth-first from face 0 and each one is turned about the crease it shares
with its parent face (`fold_crease_pattern`).
"""

from __future__ import annotations

import math
import os
from collections import deque
from pathlib import Path

import numpy as np

from ..fold import FoldFile, fold_angles_from_coords, normalise_fold, read_fold
from ._scene import Scene

# A frame is a flat crease pattern when its z extent is below this fraction of its size.
FLAT_TOL = 1e-9


# Banner level of the verdicts files carry: a single vertex's unfolding verdicts and a folding's.
FILE_VERDICT_LEVELS = {
    "flat-unfolded": "ok",
    "flat-folded": "warn",
    "folded": "ok",
    "unfinished": "warn",
}


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about the unit `axis` by `angle` (right-hand rule)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + s * k + (1 - c) * (k @ k)


def fold_crease_pattern(
    coords: np.ndarray,
    faces: tuple[tuple[int, ...], ...],
    edges: np.ndarray,
    angles: np.ndarray,
) -> list[np.ndarray]:
    """Fold a flat crease pattern rigidly by its fold angles; returns each face's 3D polygon.

    **Arguments:** `coords` `(V, 2 or 3)` flat in the xy plane; `faces` counter-clockwise; `edges`
    `(E, 2)`; `angles` `(E,)` radians, valley positive (FOLD), NaN taken as 0.

    Face 0 stays in place. Crossing the crease u → v from the face that runs u → v (its left) to
    the face on its right turns the right face by −ρ about u → v, which is the FOLD sign convention
    (`origami_jax.fold.fold_angles_from_coords` reads ρ back). Where the pattern has cycles (interior
    vertices) the breadth-first tree decides, so inconsistent angles show as a gap, not an error.
    """
    coords = np.asarray(coords, dtype=float)
    if coords.shape[1] == 2:
        coords = np.concatenate([coords, np.zeros((len(coords), 1))], axis=1)
    angle_of: dict[tuple[int, int], float] = {}
    for (u, w), rho in zip(np.asarray(edges).tolist(), np.asarray(angles).tolist(), strict=True):
        rho = 0.0 if not math.isfinite(rho) else rho
        angle_of[(u, w)] = angle_of[(w, u)] = rho
    face_of: dict[tuple[int, int], int] = {}
    for f, face in enumerate(faces):
        for u, w in zip(face, (*face[1:], face[0]), strict=True):
            face_of[(u, w)] = f
    rotations: list[np.ndarray | None] = [None] * len(faces)
    shifts: list[np.ndarray | None] = [None] * len(faces)
    queue: deque[int] = deque()
    for start in range(len(faces)):
        if rotations[start] is not None:
            continue
        rotations[start], shifts[start] = np.eye(3), np.zeros(3)
        queue.append(start)
        while queue:
            f = queue.popleft()
            face = faces[f]
            rot_f, shift_f = rotations[f], shifts[f]
            assert rot_f is not None and shift_f is not None
            for u, w in zip(face, (*face[1:], face[0]), strict=True):
                g = face_of.get((w, u))
                if g is None or rotations[g] is not None:
                    continue
                axis = coords[w] - coords[u]
                turn = _rotation(axis / np.linalg.norm(axis), -angle_of.get((u, w), 0.0))
                # x ↦ R_f (turn (x − p_u) + p_u) + s_f
                rotations[g] = rot_f @ turn
                shifts[g] = rot_f @ (coords[u] - turn @ coords[u]) + shift_f
                queue.append(g)
    out = []
    for f, face in enumerate(faces):
        rot, shift = rotations[f], shifts[f]
        assert rot is not None and shift is not None
        out.append(coords[list(face)] @ rot.T + shift)
    return out


def _is_flat(coords: np.ndarray) -> bool:
    if coords.shape[1] < 3:
        return True
    size = float(np.ptp(coords, axis=0).max()) or 1.0
    return float(np.ptp(coords[:, 2])) <= FLAT_TOL * size


def scene_from_fold(source, *, title: str | None = None) -> Scene:
    """A scene of a FOLD file's frames (a `FoldFile` or a path to a `.fold` file).

    - Frames drawn: `file_frames` when the key frame is a crease pattern with frames after it
      (the writers here and Origami Simulator put the states there), otherwise every frame; a frame
      with other vertices or faces than the key frame is skipped (listed in `Scene.notes`).
    - Panels: the key frame's faces (`normalise_fold` traces them when the file has none).
    - Hinges: edges shared by two faces that are not boundary edges; fold angles from the 3D
      coordinates (`fold_angles_from_coords`) or, for a folded crease pattern, the frame's.
    - Times: `origami_jax:time` of every frame drawn (unit `origami_jax:time_unit`), else the frame
      number; the verdict: `origami_jax:verdict` (and `origami_jax:verdict_reason`) of the key
      frame, the creases outside tolerance: its `origami_jax:off_target_edges` (FOLD edge ids).
    - Contacts: `origami_jax:contact_points` of each frame drawn (`(k, 3)`, the frame's unit), as
      `origami-jax fold` writes them.
    """
    if isinstance(source, str | os.PathLike):
        path = Path(source)
        fold = read_fold(path)
        title = title or path.name
    elif isinstance(source, FoldFile):
        fold = source
    else:
        raise TypeError(
            f"expected a FoldFile or a path to a .fold file, got {type(source).__name__}"
        )
    fold = normalise_fold(fold)
    key = fold.frame(0)
    faces = key.faces_vertices
    assert faces is not None and key.edges_vertices is not None  # normalise_fold fills them
    edges = key.edges_vertices
    n_vertices = key.n_vertices
    key_classes = key.frame_classes or ()
    if fold.n_frames > 1 and "creasePattern" in key_classes:
        candidates = list(range(1, fold.n_frames))
    else:
        candidates = list(range(fold.n_frames))
    notes: list[str] = []
    used: list[int] = []
    for index in candidates:
        frame = fold.frame(index)
        same_faces = frame.faces_vertices is None or tuple(
            map(tuple, frame.faces_vertices)
        ) == tuple(map(tuple, faces))
        if frame.n_vertices != n_vertices or not same_faces or frame.vertices_coords is None:
            notes.append(f"frame {index} skipped: other vertices or faces than the key frame")
            continue
        used.append(index)
    if not used:
        raise ValueError("no frame of the FOLD file has the key frame's vertices and faces")

    assignment = key.edges_assignment or ("U",) * len(edges)
    face_of: dict[tuple[int, int], int] = {}
    corner_of: dict[tuple[int, int], int] = {}
    for f, face in enumerate(faces):
        for c, (u, w) in enumerate(zip(face, (*face[1:], face[0]), strict=True)):
            face_of[(u, w)] = f
            corner_of[(u, w)] = c
    offsets = np.concatenate([[0], np.cumsum([len(f) for f in faces])]).astype(np.int64)
    hinge_edges, segments, names = [], [], []
    for e, (u, w) in enumerate(edges.tolist()):
        if assignment[e] == "B" or (u, w) not in face_of or (w, u) not in face_of:
            continue
        f, c = face_of[(u, w)], corner_of[(u, w)]
        hinge_edges.append(e)
        segments.append([offsets[f] + c, offsets[f] + (c + 1) % len(faces[f])])
        names.append(f"edge {e} ({assignment[e]})")
    hinge_edges = np.array(hinge_edges, dtype=np.int64)

    vertices, angles, folded = [], [], 0
    for index in used:
        frame = fold.frame(index)
        coords = frame.coords3
        if _is_flat(coords):
            frame_angles = np.deg2rad(fold.fold_angles_deg(index))
            polygons = fold_crease_pattern(coords, faces, edges, frame_angles)
            if np.any(np.nan_to_num(frame_angles) != 0):
                folded += 1
            world = np.concatenate(polygons, axis=0)
            angles.append(frame_angles[hinge_edges] if len(hinge_edges) else np.zeros(0))
        else:
            world = np.concatenate([coords[list(face)] for face in faces], axis=0)
            all_angles = fold_angles_from_coords(coords, faces, edges)
            angles.append(all_angles[hinge_edges] if len(hinge_edges) else np.zeros(0))
        vertices.append(world)
    if folded:
        notes.append(f"{folded} crease-pattern frame(s) folded rigidly by their fold angles")

    extras = [fold.frames[i].extra for i in used]
    if all("origami_jax:time" in extra for extra in extras) and len(used) > 1:
        times = np.array([float(extra["origami_jax:time"]) for extra in extras])
        time_unit = str(key.extra.get("origami_jax:time_unit", ""))
        time_unit = "µs" if time_unit == "us" else time_unit
        time_label = "time"
    else:
        times = np.array(used, dtype=float)
        time_unit, time_label = "", "frame"
    unit = key.frame_unit or fold.frame(used[0]).frame_unit or "unit"
    verdict = key.extra.get("origami_jax:verdict")
    level, banner = "ok", None
    if verdict is not None:
        level = FILE_VERDICT_LEVELS.get(str(verdict), "fail")
        reason = key.extra.get("origami_jax:verdict_reason")
        banner = f"verdict: {verdict}" + (f" ({reason})" if reason else "")
    off_target = set(key.extra.get("origami_jax:off_target_edges", ()))
    highlight = None
    if off_target:
        highlight = np.array([int(e) in off_target for e in hinge_edges], dtype=bool)
        if banner is not None:
            banner += f"; {int(np.sum(highlight))} crease edge(s) outside tolerance highlighted"
    contact_frames, contact_points = [], []
    for position, extra in enumerate(extras):
        points = np.asarray(extra.get("origami_jax:contact_points", ()), dtype=float)
        if points.size:
            contact_points.append(points.reshape(-1, 3))
            contact_frames.extend([position] * len(contact_points[-1]))
    if contact_frames:
        notes.append("contacts: where panels touch (origami_jax:contact_points of each frame)")
    return Scene(
        vertices=np.stack(vertices),
        offsets=offsets,
        times=times,
        hinges=np.array(segments, dtype=np.int64).reshape(-1, 2),
        fold_angles=np.stack(angles).reshape(len(used), len(segments)),
        hinge_names=tuple(names),
        highlight_hinges=highlight,
        contact_frames=np.array(contact_frames, dtype=np.int64),
        contact_points=np.concatenate(contact_points) if contact_points else np.zeros((0, 3)),
        verdict=banner,
        verdict_level=level,
        title=title
        or str(fold.file_metadata.get("file_title") or key.extra.get("frame_title") or "FOLD file"),
        length_unit="" if unit == "unit" else ("µm" if unit == "um" else unit),
        time_unit=time_unit,
        time_label=time_label,
        notes=tuple(notes),
    )
