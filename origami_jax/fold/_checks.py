"""Structural checks of a `FoldFile`, frame by frame with inheritance applied.

These run on every read and write, with or without `jsonschema`: the schema checks types and shapes of
the JSON; these check what a schema cannot (vertex ids in range, parallel arrays of equal length,
counter-clockwise faces, fold-angle signs against assignments).
"""

from __future__ import annotations

import numpy as np

from ._errors import FoldFormatError
from ._model import FoldFile, FoldFrame

# Tolerances: a fold angle of magnitude below this (degrees) counts as 0 for the sign checks, and a
# face whose signed area is below this fraction of its squared size counts as degenerate.
ANGLE_SIGN_TOL_DEG = 1e-9
AREA_REL_TOL = 1e-12


def check_fold(fold: FoldFile) -> None:
    """Check every frame of `fold`; raise `FoldFormatError` on the first problem found.

    Checked per frame (inheritance applied): `vertices_coords` and `edges_vertices` present; parallel
    `edges_...` arrays as long as `edges_vertices`; vertex ids in range; in a frame lying in the xy
    plane every face counter-clockwise (positive signed area); faces consistently oriented (no side
    run in the same direction by two faces); fold angles whose sign matches the assignment
    (M ≤ 0 ≤ V, B and F at 0; a cut C joins nothing and may take any angle); frame-parent links that exist and form no cycle. A flat frame whose
    `frame_classes` include `"foldedForm"` is a flat-folded state: its flipped faces are allowed to
    run clockwise.
    """
    for index in range(fold.n_frames):
        frame = fold.frame(index)
        where = "key frame" if index == 0 else f"frame {index}"
        check_frame(frame, where)


def check_frame(frame: FoldFrame, where: str) -> None:
    """Check one resolved frame (see `check_fold`)."""
    inherit_hint = (
        ""
        if where == "key frame"
        else " (or set frame_inherit: true and frame_parent to inherit it)"
    )
    for key, value in (
        ("vertices_coords", frame.vertices_coords),
        ("edges_vertices", frame.edges_vertices),
    ):
        if value is None:
            raise FoldFormatError(f"{where}: missing key {key}: add it{inherit_hint}")
    n_vertices = frame.n_vertices or 0
    n_edges = frame.n_edges or 0
    if n_edges and int(frame.edges_vertices.max()) >= n_vertices:  # type: ignore[union-attr]
        bad = int(np.argmax(frame.edges_vertices.max(axis=1)))  # type: ignore[union-attr]
        raise FoldFormatError(
            f"{where}: edges_vertices[{bad}] = {frame.edges_vertices[bad].tolist()} refers to a "  # type: ignore[index]
            f"vertex that does not exist (there are {n_vertices} vertices)"
        )
    for key, value in (
        ("edges_assignment", frame.edges_assignment),
        ("edges_foldAngle", frame.edges_fold_angle_deg),
    ):
        if value is not None and len(value) != n_edges:
            raise FoldFormatError(
                f"{where}: {key} has {len(value)} entries but there are {n_edges} edges "
                "(edges_vertices); FOLD arrays are parallel"
            )
    if frame.edges_assignment is not None and frame.edges_fold_angle_deg is not None:
        _check_signs(frame.edges_assignment, frame.edges_fold_angle_deg, where)
    if frame.faces_vertices is not None:
        _check_faces(frame, where)


def _check_signs(assignment: tuple[str, ...], angles: np.ndarray, where: str) -> None:
    for i, (a, angle) in enumerate(zip(assignment, angles, strict=True)):
        if np.isnan(angle):
            continue
        wrong = (
            (a == "M" and angle > ANGLE_SIGN_TOL_DEG)
            or (a == "V" and angle < -ANGLE_SIGN_TOL_DEG)
            or (a in "BF" and abs(angle) > ANGLE_SIGN_TOL_DEG)
        )
        if wrong:
            expected = {"M": "<= 0 (mountain)", "V": ">= 0 (valley)", "B": "0", "F": "0"}[a]
            raise FoldFormatError(
                f"{where}: edge {i} is assigned {a!r} but edges_foldAngle[{i}] = {angle:g} degrees; "
                f"it must be {expected}. FOLD: valley +, mountain -, flat and boundary 0. "
                "Fix the assignment or the sign."
            )


def _check_faces(frame: FoldFrame, where: str) -> None:
    faces = frame.faces_vertices or ()
    n_vertices = frame.n_vertices or 0
    sides: dict[tuple[int, int], int] = {}
    for f, face in enumerate(faces):
        if max(face) >= n_vertices:
            raise FoldFormatError(
                f"{where}: faces_vertices[{f}] = {list(face)} refers to a vertex that does not "
                f"exist (there are {n_vertices} vertices)"
            )
        for u, v in zip(face, face[1:] + face[:1], strict=True):
            if u == v:
                continue
            if (u, v) in sides:
                raise FoldFormatError(
                    f"{where}: faces {sides[(u, v)]} and {f} both run along the side {u} -> {v}; "
                    "faces sharing a side must run along it in opposite directions (all "
                    "counter-clockwise, FOLD faces_vertices)"
                )
            sides[(u, v)] = f
    coords = frame.coords3
    if not np.allclose(coords[:, 2], coords[0, 2] if len(coords) else 0.0):
        return  # a 3D folded state: orientation is checked by consistency above
    if "foldedForm" in (frame.frame_classes or ()):
        return  # a flat-folded state: flipped faces are legitimately clockwise seen from +z
    for f, face in enumerate(faces):
        xy = coords[list(face), :2]
        area = 0.5 * float(
            np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
        )
        size = float(np.max(np.ptp(xy, axis=0))) ** 2
        if area <= AREA_REL_TOL * size:
            state = "degenerate (zero area)" if abs(area) <= AREA_REL_TOL * size else "clockwise"
            raise FoldFormatError(
                f"{where}: faces_vertices[{f}] = {list(face)} is {state}; FOLD faces are listed "
                "counter-clockwise seen from +z: reverse its vertex order"
            )
