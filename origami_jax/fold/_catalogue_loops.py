"""Crease patterns with closed loops shipped in the catalogue (single vertices, Miura-ori, waterbombs).

Every pattern is a flat sheet in µm (`frame_unit` "um", faces counter-clockwise seen from +z) whose
`edges_foldAngle` is a folded state rigid panels can reach: every vertex loop closes (to 1e-12 rad).

- `vertex_degree4`: a flat-foldable degree-4 vertex, sectors 60°, 120°, 120°, 60° (a Miura-ori vertex),
  in a 400 µm square; the two major creases (between a 60° and a 120° sector) at 90° valley, the
  collinear minor creases at ∓53.13° (``tan(ρ_minor/2) = ½ tan(ρ_major/2)``).
- `vertex_degree6`: a degree-6 waterbomb vertex (sectors 45°, 90°, 45°, 45°, 90°, 45°) in a 400 × 200 µm
  rectangle: the four half-diagonals valley at 90°, the two halves of the midline mountain (solved).
- `waterbomb_base`: the degree-8 waterbomb base in a 400 µm square: diagonals valley at 100°, the
  midlines mountain (solved).
- `miura_3x3`: a 3 × 3 Miura-ori (parallelograms with 200 µm sides and a 60° angle), folded to the
  Schenk–Guest parameter ``θ = 45°``: straight creases ±90°, zigzag creases ±2 atan(2)... (closed
  form; see `miura_fold_angles`).
- `waterbomb_2x2`: a 2 × 2 waterbomb tessellation (right isosceles triangles with 200 µm hypotenuses):
  diagonals valley, horizontals mountain, partly folded (solved).
- `square_twist`: a square twist (central 200 µm square, 30° twist) folded flat: flat-foldable
  (Kawasaki and Maekawa hold at every vertex) but **not rigidly foldable**: rigid panels cannot leave
  the flat state towards it.
- `origami_simulator_miura`: a 2 × 2 Miura-ori cell in Origami Simulator's FOLD export format, as that
  program writes it (file_spec 1.1, unitless coordinates in its x–z plane, faces triangulated with
  `F` facet diagonals, `edges_foldAngle` in degrees with `null` on the boundary), folded flat (±180°).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from ._loop_geometry import loop_geometry
from ._model import FoldFile
from ._net_geometry import _rotations
from ._pattern_file import crease_pattern_file, edges_of
from ._read import loads_fold
from ._write import planar_faces

OS_CREATOR = "Origami Simulator: http://git.amandaghassaei.com/OrigamiSimulator/"
MIURA_ALPHA_DEG = 60.0
MIURA_THETA_DEG = 45.0  # Schenk & Guest's folding parameter of the shipped Miura-ori


def miura_fold_angles(alpha: float, theta: float) -> tuple[float, float]:
    """Fold angles (rad, magnitudes) of a Miura-ori with parallelogram angle `alpha` at Schenk and
    Guest's folding parameter `theta` (PNAS 110, 2013; ``θ = π/2`` flat, 0 folded flat): the straight
    (collinear) creases ``π − 2θ``, the zigzag creases ``2 atan(tan(π/2 − θ) / cos α)``."""
    straight = math.pi - 2 * theta
    zigzag = 2 * math.atan(math.tan(straight / 2) / math.cos(alpha))
    return straight, zigzag


def _pattern(
    *,
    title: str,
    frame_title: str,
    description: str,
    coords: np.ndarray,
    edges: list[tuple[int, int]],
    assignment: list[str],
    angles: list[float],
    faces: list[tuple[int, ...]],
) -> FoldFile:
    return crease_pattern_file(
        title=title,
        frame_title=frame_title,
        description=description,
        coords=np.asarray([[_clean(x) for x in p] for p in coords]),
        edges=edges,
        assignment=assignment,
        angles=angles,
        faces=faces,
    )


def _clean(x: float) -> float:
    x = float(x)
    return float(round(x)) if abs(x - round(x)) < 1e-9 else round(x, 12)


def _closure_vectors(geometry, angles: np.ndarray) -> np.ndarray:
    """``P − I`` around every vertex, flattened (zero only at closure; ``vee(P − Pᵀ)`` also vanishes
    at half-turns)."""
    out = []
    for creases, directions in zip(geometry.loop_creases, geometry.loop_directions, strict=True):
        rotations = _rotations(directions, angles[list(creases)])
        product = np.eye(3)
        for r in rotations:
            product = product @ r
        out.extend((product - np.eye(3)).ravel())
    return np.asarray(out)


def _solve_closure(fold: FoldFile, guess: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Fold angles near `guess` (rad, per crease of `loop_geometry(fold)`) that close every loop,
    moving only the `free` creases (minimum-norm Gauss–Newton, finite-difference Jacobian)."""
    geometry = loop_geometry(fold, require_targets=False)
    theta = np.asarray(guess, dtype=float).copy()
    columns = np.flatnonzero(free)
    for _ in range(60):
        residual = _closure_vectors(geometry, theta)
        if np.max(np.abs(residual)) < 1e-15:
            break
        jac = np.zeros((len(residual), len(columns)))
        for k, j in enumerate(columns):
            step = np.zeros_like(theta)
            step[j] = 1e-7
            jac[:, k] = (
                _closure_vectors(geometry, theta + step) - _closure_vectors(geometry, theta - step)
            ) / 2e-7
        theta[columns] -= np.linalg.lstsq(jac, residual, rcond=1e-6)[0]
    if np.max(np.abs(_closure_vectors(geometry, theta))) > 1e-12:
        raise RuntimeError("the catalogue pattern's fold angles do not close")
    return theta


def _with_angles(fold: FoldFile, per_crease: np.ndarray) -> FoldFile:
    """`fold` with `edges_foldAngle` from per-crease angles (rad, `loop_geometry` order)."""

    geometry = loop_geometry(fold, require_targets=False)
    key = fold.frames[0]
    degrees = np.array(key.edges_fold_angle_deg, dtype=float)
    assignment = list(key.edges_assignment)
    for j, line in enumerate(geometry.crease_edges):
        for e in line:
            degrees[e] = math.degrees(per_crease[j])
            assignment[e] = "V" if per_crease[j] > 0 else "M" if per_crease[j] < 0 else "F"
    frame = dataclasses.replace(
        key, edges_fold_angle_deg=degrees, edges_assignment=tuple(assignment)
    )
    return dataclasses.replace(fold, frames=(frame,))


def _fan(
    rays_deg: list[float], box: tuple[float, float], signs: list[int], **text
) -> tuple[FoldFile, list[float]]:
    """A single interior vertex at the origin with creases along `rays_deg` to the boundary of the
    box ``[−w, w] × [−h, h]``; returns the pattern (angles ±180 by `signs`) and the ray angles."""
    w, h = box
    coords = [(0.0, 0.0)]
    ends = []
    for ray in rays_deg:
        c, s = math.cos(math.radians(ray)), math.sin(math.radians(ray))
        t = min(
            w / abs(c) if abs(c) > 1e-12 else math.inf, h / abs(s) if abs(s) > 1e-12 else math.inf
        )
        ends.append((t * c, t * s))
    corners = [(w, h), (-w, h), (-w, -h), (w, -h)]
    boundary = []
    for p in ends + corners:
        key = (round(p[0], 9), round(p[1], 9))
        if key not in {(round(q[0], 9), round(q[1], 9)) for q in boundary}:
            boundary.append(p)
    boundary.sort(key=lambda p: math.atan2(p[1], p[0]) % (2 * math.pi))
    coords += boundary
    index = {(round(p[0], 9), round(p[1], 9)): i + 1 for i, p in enumerate(boundary)}
    ray_vertices = [index[(round(p[0], 9), round(p[1], 9))] for p in ends]
    faces = []
    n_b = len(boundary)
    for k, start in enumerate(ray_vertices):
        stop = ray_vertices[(k + 1) % len(ray_vertices)]
        face = [0, start]
        i = start
        while i != stop:
            i = i % n_b + 1
            face.append(i)
        faces.append(tuple(face))
    edges, count = edges_of(faces)
    assignment, angles = [], []
    for u, v in edges:
        if count[frozenset((u, v))] == 1:
            assignment.append("B")
            angles.append(0.0)
        else:
            k = ray_vertices.index(v if u == 0 else u)
            assignment.append("V" if signs[k] > 0 else "M")
            angles.append(180.0 * signs[k])
    fold = _pattern(
        coords=np.asarray(coords),
        edges=edges,
        assignment=assignment,
        angles=angles,
        faces=faces,
        **text,
    )
    return fold, rays_deg


def _fan_angles(fold: FoldFile, rays_deg: list[float], by_ray: list[float]) -> np.ndarray:
    """Per-crease angles (rad) from per-ray ones."""
    geometry = loop_geometry(fold, require_targets=False)
    key = fold.frames[0]
    xy = np.asarray(key.vertices_coords)[:, :2]
    out = np.zeros(geometry.n_creases)
    for j, line in enumerate(geometry.crease_edges):
        u, v = key.edges_vertices[line[0]]
        tip = xy[v] if u == 0 else xy[u]
        ray = math.degrees(math.atan2(tip[1], tip[0])) % 360
        k = int(np.argmin([abs((ray - r + 180) % 360 - 180) for r in rays_deg]))
        out[j] = by_ray[k]
    return out


def _degree4() -> FoldFile:
    rays = [0.0, 60.0, 180.0, 300.0]
    minor = 2 * math.atan(0.5)  # tan(ρ_minor/2) = ½ tan(90°/2)
    by_ray = [-minor, math.pi / 2, minor, math.pi / 2]
    fold, rays = _fan(
        rays,
        (200.0, 200.0),
        [-1, 1, 1, 1],
        title="Flat-foldable degree-4 vertex (60/120/120/60)",
        frame_title="crease pattern: one degree-4 vertex in a 400 um square",
        description=(
            "One interior vertex with creases at 0, 60, 180 and 300 degrees (sectors 60, 120, 120, "
            "60: opposite sectors sum to 180, flat-foldable). Major creases (60 and 300 degrees) "
            "fold 90 degrees valley; the collinear minor creases fold -53.13 (0 degrees, between "
            "the 60-degree sectors) and +53.13 (180 degrees): tan(minor/2) = 0.5 tan(major/2)."
        ),
    )
    return _with_angles(fold, _fan_angles(fold, rays, by_ray))


def _degree6() -> FoldFile:
    rays = [0.0, 45.0, 135.0, 180.0, 225.0, 315.0]
    fold, rays = _fan(
        rays,
        (200.0, 100.0),
        [-1, 1, 1, -1, 1, 1],
        title="Degree-6 waterbomb vertex",
        frame_title="crease pattern: one degree-6 vertex in a 400 x 200 um rectangle",
        description=(
            "The vertex of the waterbomb tessellation: the horizontal midline (mountain) and the "
            "four half-diagonals to the rectangle's corners (valley), sectors 45, 90, 45, 45, 90, "
            "45 degrees. Diagonals at 90 degrees valley; the midline's two halves solved so that "
            "the faces close."
        ),
    )
    guess = _fan_angles(
        fold, rays, [-1.0, math.pi / 2, math.pi / 2, -1.0, math.pi / 2, math.pi / 2]
    )
    free = _fan_angles(fold, rays, [1.0, 0.0, 0.0, 1.0, 0.0, 0.0])
    return _with_angles(fold, _solve_closure(fold, guess, free))


def _waterbomb_base() -> FoldFile:
    rays = [45.0 * k for k in range(8)]
    valley = math.radians(100.0)
    signs = [-1 if k % 2 == 0 else 1 for k in range(8)]
    fold, rays = _fan(
        rays,
        (200.0, 200.0),
        signs,
        title="Waterbomb base",
        frame_title="crease pattern: the degree-8 waterbomb base in a 400 um square",
        description=(
            "The classic waterbomb base: both diagonals valley, both midlines mountain, eight "
            "45-degree sectors around the centre. Diagonals at 100 degrees valley; the midlines "
            "solved so that the faces close (partly folded: one opposite pair of midlines near -33, the "
            "other near -54 degrees)."
        ),
    )
    # The mountain midlines pair up (two fold more than the other two): start near that state.
    mountains = [-math.radians(33.0), -math.radians(54.0)]
    guess = _fan_angles(
        fold, rays, [mountains[(k // 2) % 2] if s < 0 else valley for k, s in enumerate(signs)]
    )
    free = _fan_angles(fold, rays, [1.0 if s < 0 else 0.0 for s in signs])
    return _with_angles(fold, _solve_closure(fold, guess, free))


def _miura_geometry(columns: int, rows: int, a: float, b: float, alpha_deg: float):
    """Vertices `(i, j)` of a Miura-ori (`columns` × `rows` parallelograms, straight creases along x of
    length `b`, zigzag segments of length `a` at `alpha` to them) and its faces."""
    alpha = math.radians(alpha_deg)
    coords, index = [], {}
    for j in range(rows + 1):
        for i in range(columns + 1):
            index[(i, j)] = len(coords)
            coords.append((i * b + (j % 2) * a * math.cos(alpha), j * a * math.sin(alpha)))
    faces = [
        (index[(i, j)], index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)])
        for j in range(rows)
        for i in range(columns)
    ]
    return np.asarray(coords), faces, index


def miura_sheet(
    columns: int,
    rows: int,
    *,
    a: float = 200.0,
    b: float = 200.0,
    alpha_deg: float = MIURA_ALPHA_DEG,
    theta_deg: float = MIURA_THETA_DEG,
    title: str | None = None,
) -> FoldFile:
    """A Miura-ori sheet of `columns` × `rows` parallelograms (µm), its creases at Schenk and Guest's
    folding parameter `theta_deg` (`miura_fold_angles`): zigzag lines alternate valley and mountain
    from column to column, straight lines alternate at every vertex."""
    coords, faces, index = _miura_geometry(columns, rows, a, b, alpha_deg)
    straight, zigzag = miura_fold_angles(math.radians(alpha_deg), math.radians(theta_deg))
    edges, count = edges_of(faces)
    where = {v: k for k, v in index.items()}
    assignment, angles = [], []
    for u, v in edges:
        if count[frozenset((u, v))] == 1:
            assignment.append("B")
            angles.append(0.0)
            continue
        (iu, ju), (iv, jv) = where[u], where[v]
        column_sign = 1 if min(iu, iv) % 2 else -1
        if ju == jv:  # straight crease from column i to i + 1 in row j
            i = min(iu, iv)
            sign = (1 if i % 2 else -1) * (1 if ju % 2 else -1)
            value = sign * straight
        else:  # zigzag segment in column i
            value = column_sign * zigzag
        assignment.append("V" if value > 0 else "M")
        angles.append(math.degrees(value))
    return _pattern(
        title=title or f"Miura-ori {columns} x {rows}",
        frame_title=f"crease pattern: {columns} x {rows} Miura-ori parallelograms",
        description=(
            f"{columns} x {rows} parallelograms with {a:g} um zigzag and {b:g} um straight sides at "
            f"{alpha_deg:g} degrees, folded to Schenk and Guest's parameter theta = {theta_deg:g} "
            f"degrees: straight creases +-{math.degrees(straight):.6g}, zigzag creases "
            f"+-{math.degrees(zigzag):.6g} degrees (tan(straight/2) = cos(alpha) tan(zigzag/2))."
        ),
        coords=coords,
        edges=edges,
        assignment=assignment,
        angles=angles,
        faces=faces,
    )


def _waterbomb_tessellation(units: int = 2) -> FoldFile:
    """Right isosceles triangles between rows of degree-6 vertices shifted by half a hypotenuse."""
    h = 200.0
    width, n_rows = units * h, 2 * units
    coords: list[tuple[float, float]] = []
    index: dict[tuple[float, float], int] = {}

    def vertex(x: float, y: float) -> int:
        key = (round(x, 9), round(y, 9))
        if key not in index:
            index[key] = len(coords)
            coords.append((x, y))
        return index[key]

    def row(j: int) -> list[float]:
        xs = [i * h + (j % 2) * h / 2 for i in range(units + 1)]
        xs = [x for x in xs if x <= width + 1e-9]
        return sorted(set([0.0, width] + xs))

    faces = []
    for j in range(n_rows):
        lower, upper = row(j), row(j + 1)
        y0, y1 = j * h / 2, (j + 1) * h / 2
        a, b = 0, 0
        while a < len(lower) - 1 or b < len(upper) - 1:
            if b == len(upper) - 1:
                advance_lower = True
            elif a == len(lower) - 1:
                advance_lower = False
            else:  # the shorter new edge (the lattice's diagonals, not a long skew one)
                to_upper = math.hypot(lower[a + 1] - upper[b], h / 2)
                to_lower = math.hypot(upper[b + 1] - lower[a], h / 2)
                advance_lower = to_upper < to_lower - 1e-9 or (
                    abs(to_upper - to_lower) <= 1e-9 and lower[a + 1] <= upper[b + 1]
                )
            if advance_lower:
                faces.append((vertex(lower[a], y0), vertex(lower[a + 1], y0), vertex(upper[b], y1)))
                a += 1
            else:
                faces.append((vertex(lower[a], y0), vertex(upper[b + 1], y1), vertex(upper[b], y1)))
                b += 1
    edges, count = edges_of(faces)
    xy = np.asarray(coords)
    assignment, angles = [], []
    for u, v in edges:
        if count[frozenset((u, v))] == 1:
            assignment.append("B")
            angles.append(0.0)
        elif abs(xy[u, 1] - xy[v, 1]) < 1e-9:
            assignment.append("M")
            angles.append(-180.0)
        else:
            assignment.append("V")
            angles.append(180.0)
    fold = _pattern(
        title=f"Waterbomb tessellation {units} x {units}",
        frame_title=f"crease pattern: {units} x {units} waterbomb units",
        description=(
            f"A {units} x {units} waterbomb tessellation: rows of degree-6 vertices shifted by half a "
            "unit, right isosceles triangles with 200 um hypotenuses; horizontal creases mountain, "
            "diagonals valley, partly folded (every loop closes)."
        ),
        coords=xy,
        edges=edges,
        assignment=assignment,
        angles=angles,
        faces=faces,
    )

    geometry = loop_geometry(fold)
    horizontal = np.array([a_ == "M" for a_ in geometry.assignments])
    guess = np.where(horizontal, -math.radians(60.0), math.radians(50.0))
    free = horizontal | True
    return _with_angles(fold, _solve_closure(fold, guess, free))


def _square_twist() -> FoldFile:
    """A central 200 µm square twisted by 30°, pleats to the sheet's edge, folded flat."""
    s, beta, half = 100.0, math.radians(30.0), 300.0
    corners = [(-s, -s), (s, -s), (s, s), (-s, s)]
    coords: list[tuple[float, float]] = list(corners)
    edges: list[tuple[int, int]] = [(0, 1), (1, 2), (2, 3), (3, 0)]
    kinds = ["V", "V", "V", "V"]
    ends = []
    for k, (x, y) in enumerate(corners):
        for offset, kind in ((180.0, "V"), (270.0, "M")):
            angle = math.radians(offset + 90.0 * k) + beta
            c, si = math.cos(angle), math.sin(angle)
            t = min((half - x * np.sign(c)) / abs(c), (half - y * np.sign(si)) / abs(si))
            coords.append((x + t * c, y + t * si))
            edges.append((k, len(coords) - 1))
            kinds.append(kind)
            ends.append(len(coords) - 1)
    box = [(half, half), (-half, half), (-half, -half), (half, -half)]
    for p in box:
        coords.append(p)
    rim = list(range(4, len(coords)))
    rim.sort(key=lambda i: math.atan2(coords[i][1], coords[i][0]))
    for a_, b_ in zip(rim, rim[1:] + rim[:1], strict=True):
        edges.append((a_, b_))
        kinds.append("B")
    xy = np.asarray(coords)
    faces = planar_faces(np.column_stack([xy, np.zeros(len(xy))]), np.asarray(edges))
    angles = [180.0 if k == "V" else -180.0 if k == "M" else 0.0 for k in kinds]
    return _pattern(
        title="Square twist (not rigidly foldable)",
        frame_title="crease pattern: a 200 um square twisted by 30 degrees",
        description=(
            "A central 200 um square (valley) with four pleats (valley and mountain) leaving its "
            "corners at 30 degrees of twist, in a 600 um square sheet, folded flat (+-180). Every "
            "vertex obeys Kawasaki's and Maekawa's theorems, but rigid panels cannot fold it: the "
            "facets must bend (the square twist is the classic example)."
        ),
        coords=xy,
        edges=edges,
        assignment=kinds,
        angles=angles,
        faces=[tuple(f) for f in faces],
    )


def origami_simulator_text() -> str:
    """A 2 × 2 Miura-ori cell written the way Origami Simulator's "Save FOLD" writes a pattern (its
    `saveFOLD`, triangulated export, angles exported, unitless): JSON indented by 4 spaces,
    `file_spec` 1.1, the folded-form frame at top level, vertices `(x, 0, z)` in float32 precision,
    cut edges as `B`, facet diagonals `F` at 0, `edges_foldAngle` null on the boundary."""
    coords, faces, _ = _miura_geometry(2, 2, 1.0, 1.0, MIURA_ALPHA_DEG)
    coords = coords - coords.mean(axis=0)
    coords = coords / np.max(np.abs(coords))
    # Origami Simulator lays a pattern in its x–z plane (y up) and keeps float32 positions.
    vertices = [[float(np.float32(x)), 0, float(np.float32(z))] for x, z in coords]
    triangles = []
    for a_, b_, c_, d_ in faces:
        triangles += [(a_, b_, c_), (a_, c_, d_)]
    # Wound counter-clockwise seen from +y (the program's up), the other way round in (x, z).
    triangles = [(t[0], t[2], t[1]) for t in triangles]
    straight, zigzag = math.pi, math.pi
    edges, count = edges_of(triangles)
    xy = coords
    assignment, angles = [], []
    for u, v in edges:
        if count[frozenset((u, v))] == 1:
            assignment.append("B")
            angles.append(None)
            continue
        du = xy[v] - xy[u]
        if abs(du[1]) < 1e-9:
            # straight crease: mountain/valley alternate at the centre vertex
            x_mid = 0.5 * (xy[u, 0] + xy[v, 0])
            value = straight if x_mid > 0 else -straight
        elif _is_diagonal(faces, u, v):
            assignment.append("F")
            angles.append(0)
            continue
        else:
            value = zigzag
        assignment.append("V" if value > 0 else "M")
        angles.append(int(round(math.degrees(value))))
    data = {
        "file_spec": 1.1,
        "file_creator": OS_CREATOR,
        "file_author": "",
        "file_classes": ["singleModel"],
        "frame_title": "miura-ori 2x2",
        "frame_classes": ["foldedForm"],
        "frame_attributes": ["3D"],
        "frame_unit": "unit",
        "vertices_coords": vertices,
        "edges_vertices": [list(e) for e in edges],
        "edges_assignment": assignment,
        "faces_vertices": [list(t) for t in triangles],
        "edges_foldAngle": angles,
    }
    return json.dumps(data, indent=4) + "\n"


def _is_diagonal(faces, u: int, v: int) -> bool:
    """Whether `u`–`v` is a diagonal (not a side) of one of the quadrilateral `faces`."""
    for face in faces:
        if u in face and v in face:
            k = face.index(u)
            return face[(k + 2) % 4] == v
    return False


def loop_patterns() -> dict[str, FoldFile]:
    """The closed-loop patterns of the catalogue by name (as generated), the Origami Simulator export
    as parsed."""
    return {
        "vertex_degree4": _degree4(),
        "vertex_degree6": _degree6(),
        "waterbomb_base": _waterbomb_base(),
        "miura_3x3": miura_sheet(3, 3),
        "waterbomb_2x2": _waterbomb_tessellation(2),
        "square_twist": _square_twist(),
        "origami_simulator_miura": loads_fold(origami_simulator_text()),
    }


# Catalogue entries written verbatim as text (not through `write_fold`).
VERBATIM = {"origami_simulator_miura": origami_simulator_text}
