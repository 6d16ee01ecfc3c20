"""Structural checks of a `FoldFile`, frame by frame with inheritance applied.

These run on every read and write, with or without `jsonschema`: the schema checks types and shapes of
the JSON; these check what a schema cannot (vertex ids in range, parallel arrays of equal length,
counter-clockwise faces, fold-angle signs against assignments).
"""

from __future__ import annotations

import itertools

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
    codes = {"M": 0, "V": 1, "B": 2, "F": 2}  # U and C take any angle
    kinds = np.fromiter(map(codes.get, assignment, itertools.repeat(3)), np.int8, len(assignment))
    angles = np.asarray(angles, dtype=np.float64)
    with np.errstate(invalid="ignore"):  # NaN (no angle given) is never wrong
        wrong = (
            ((kinds == 0) & (angles > ANGLE_SIGN_TOL_DEG))
            | ((kinds == 1) & (angles < -ANGLE_SIGN_TOL_DEG))
            | ((kinds == 2) & (np.abs(angles) > ANGLE_SIGN_TOL_DEG))
        )
    if np.any(wrong):
        i = int(np.argmax(wrong))
        a, angle = assignment[i], float(angles[i])
        expected = {"M": "<= 0 (mountain)", "V": ">= 0 (valley)", "B": "0", "F": "0"}[a]
        raise FoldFormatError(
            f"{where}: edge {i} is assigned {a!r} but edges_foldAngle[{i}] = {angle:g} degrees; "
            f"it must be {expected}. FOLD: valley +, mountain -, flat and boundary 0. "
            "Fix the assignment or the sign."
            + (f" ({int(wrong.sum()) - 1} more edges like it.)" if wrong.sum() > 1 else "")
        )


def _faces_by_size(faces) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Faces grouped by vertex count: `k -> (face indices (F_k,), vertex ids (F_k, k))`."""
    lengths = np.fromiter(map(len, faces), dtype=np.int64, count=len(faces))
    if len(lengths) and lengths.min() == lengths.max():  # the usual case: all triangles, say
        k = int(lengths[0])
        ids = np.fromiter(itertools.chain.from_iterable(faces), np.int64, count=k * len(faces))
        return {k: (np.arange(len(faces)), ids.reshape(-1, k))}
    groups: dict[int, list[int]] = {}
    for f, face in enumerate(faces):
        groups.setdefault(len(face), []).append(f)
    out = {}
    for k, index in groups.items():
        rows = [faces[f] for f in index]
        out[k] = (
            np.asarray(index, dtype=np.int64),
            np.asarray(rows, dtype=np.int64).reshape(-1, k),
        )
    return out


def _check_faces(frame: FoldFrame, where: str) -> None:
    faces = frame.faces_vertices or ()
    if not faces:
        return
    n_vertices = frame.n_vertices or 0
    groups = _faces_by_size(faces)
    for index, ids in groups.values():
        bad = np.flatnonzero(ids.max(axis=1) >= n_vertices)
        if len(bad):
            f = int(index[bad].min())
            raise FoldFormatError(
                f"{where}: faces_vertices[{f}] = {_short(list(faces[f]))} refers to a vertex that "
                f"does not exist (there are {n_vertices} vertices)"
            )
    # Directed sides u -> v of every face (repeated vertices, u == v, skipped): none may occur twice.
    tails, heads, owners = [], [], []
    for index, ids in groups.values():
        nxt = np.roll(ids, -1, axis=1)
        keep = ids != nxt
        tails.append(ids[keep])
        heads.append(nxt[keep])
        owners.append(np.broadcast_to(index[:, None], ids.shape)[keep])
    u, v, owner = (np.concatenate(x) for x in (tails, heads, owners))
    key = u * max(n_vertices, 1) + v
    ordered = np.sort(key)
    if np.any(ordered[1:] == ordered[:-1]):  # rare: then find the faces to name
        order = np.lexsort((owner, key))
        key, owner = key[order], owner[order]
        repeated = np.flatnonzero(key[1:] == key[:-1])
        # The first face (in file order) that runs along a side an earlier face already ran along.
        second = owner[repeated + 1]
        j = repeated[int(np.argmin(second))]
        side_u, side_v = divmod(int(key[j]), max(n_vertices, 1))
        raise FoldFormatError(
            f"{where}: faces {int(owner[j])} and {int(owner[j + 1])} both run along the side "
            f"{side_u} -> {side_v}; faces sharing a side must run along it in opposite directions "
            "(all counter-clockwise, FOLD faces_vertices)"
        )
    coords = frame.coords3
    with np.errstate(over="ignore", invalid="ignore"):
        coincident = _first_coincident_corners(groups, coords)
    if coincident is not None:
        f, a, b = coincident
        raise FoldFormatError(
            f"{where}: faces_vertices[{f}] = {_short(list(faces[f]))} has two corners at one "
            f"point (vertices {a} and {b}): give both corners one vertex, or move one apart"
        )
    if not np.allclose(coords[:, 2], coords[0, 2] if len(coords) else 0.0):
        return  # a 3D folded state: orientation is checked by consistency above
    if "foldedForm" in (frame.frame_classes or ()):
        return  # a flat-folded state: flipped faces are legitimately clockwise seen from +z
    with np.errstate(over="ignore", invalid="ignore"):
        worst = _first_bad_face(groups, coords)
    if worst is not None:
        face = faces[worst]
        xy = coords[list(face), :2] - coords[face[0], :2]
        area = 0.5 * float(
            np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
        )
        size = float(np.max(np.ptp(xy, axis=0))) ** 2
        crossing = _first_crossing(xy[:, :2])
        if crossing is not None:
            raise FoldFormatError(
                f"{where}: faces_vertices[{worst}] = {_short(list(face))} crosses itself (its "
                f"edges {crossing[0]} and {crossing[1]} cross): list its vertices in order around it"
            )
        if area < -AREA_REL_TOL * size:
            if len(faces) > 1 and _all_clockwise(groups, coords):
                raise FoldFormatError(
                    f"{where}: every face is listed clockwise seen from +z (as a drawing whose y "
                    "axis points down, SVG's, lists them); FOLD faces are listed counter-clockwise: "
                    "reverse every face's vertex order"
                )
            raise FoldFormatError(
                f"{where}: faces_vertices[{worst}] = {_short(list(face))} is clockwise; FOLD faces "
                "are listed counter-clockwise seen from +z: reverse its vertex order"
            )
        raise FoldFormatError(
            f"{where}: faces_vertices[{worst}] = {_short(list(face))} has zero area (its corners "
            "are on one line or at one point): fix its vertices_coords, or drop the face"
        )


def _first_crossing(xy: np.ndarray) -> tuple[int, int] | None:
    """The first two non-adjacent edges ``(i, j)`` of the polygon `xy` `(k, 2)` whose interiors
    cross (each edge's ends strictly on both sides of the other's line), or `None`: a bow-tie
    face, whose lobes' areas cancel."""
    k = len(xy)

    def side(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    for i in range(k):
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue
            a, b, c, d = xy[i], xy[(i + 1) % k], xy[j], xy[(j + 1) % k]
            if side(a, b, c) * side(a, b, d) < 0 and side(c, d, a) * side(c, d, b) < 0:
                return i, j
    return None


def _first_coincident_corners(groups, coords) -> tuple[int, int, int] | None:
    """The first face (file order) with two successive corners, different vertices, at one point
    (within `AREA_REL_TOL` of the face's size): ``(face, vertex, next vertex)``, or `None`."""
    found = None
    for index, ids in groups.values():
        nxt = np.roll(ids, -1, axis=1)
        points = coords[ids]  # (F_k, k, 3)
        apart = np.linalg.norm(points - coords[nxt], axis=-1)
        size = np.max(np.ptp(points, axis=1), axis=1)
        bad = (ids != nxt) & ~(apart > AREA_REL_TOL * size[:, None])
        rows = np.flatnonzero(np.any(bad, axis=1))
        if len(rows):
            row = rows[np.argmin(index[rows])]
            corner = int(np.argmax(bad[row]))
            candidate = (int(index[row]), int(ids[row, corner]), int(nxt[row, corner]))
            found = candidate if found is None or candidate[0] < found[0] else found
    return found


def _signed_areas(ids, coords) -> tuple[np.ndarray, np.ndarray]:
    """The signed areas in the xy plane of the faces `ids` `(F_k, k)` (counter-clockwise
    positive; the shoelace formula on coordinates relative to each face's first vertex, without
    cancellation) and the squares of their extents."""
    xy = coords[ids, :2]  # (F_k, k, 2)
    rel = xy - xy[:, :1, :]
    area = 0.5 * np.sum(
        rel[:, :, 0] * np.roll(rel[:, :, 1], -1, axis=1)
        - np.roll(rel[:, :, 0], -1, axis=1) * rel[:, :, 1],
        axis=1,
    )
    return area, np.max(np.ptp(xy, axis=1), axis=1) ** 2


def _all_clockwise(groups, coords) -> bool:
    """Whether every face is clockwise in the xy plane."""
    with np.errstate(over="ignore", invalid="ignore"):
        return all(
            bool(np.all(area < -AREA_REL_TOL * size))
            for area, size in (_signed_areas(ids, coords) for _, ids in groups.values())
        )


def _first_bad_face(groups, coords) -> int | None:
    """Index of the first face (file order) that is clockwise or degenerate in the xy plane."""
    worst = None
    for index, ids in groups.values():
        area, size = _signed_areas(ids, coords)
        bad = np.flatnonzero(~(area > AREA_REL_TOL * size))
        if len(bad):
            first = int(index[bad].min())
            worst = first if worst is None else min(worst, first)
    return worst


def _short(value, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
