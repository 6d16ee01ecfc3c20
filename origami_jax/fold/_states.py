"""Writing our results as FOLD: single-vertex states and unfolding paths, chain trajectories.

Both writers take plain arrays, so they work without the physics packages;
`origami_jax.vertex.unfolding_to_fold` and `origami_jax.chain.trajectory_to_fold` feed them from an
`UnfoldResult` / a simulated `Trajectory`.

Layout of a written file (FOLD 1.2):
- the **key frame** is the flat crease pattern (`frame_classes: ["creasePattern"]`), with
  `edges_foldAngle` set to the *first* state's fold angles, so that Origami Simulator, which folds a
  crease pattern toward its target angles, shows that state;
- `file_frames[k]` is state `k` (`["foldedForm"]`): 3D `vertices_coords` and `edges_foldAngle`,
  `frame_parent: 0`, `frame_inherit: true` (edges and faces come from the key frame), and its own
  `edges_assignment` only where a crease changed sign;
- our own data under `origami_jax:` keys.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from .._version import __version__
from ._errors import FoldFormatError
from ._geometry import vertex_fold_angles
from ._model import WRITTEN_SPEC, FoldFile, FoldFrame

CREATOR = f"origami_jax {__version__}"
# Given fold angles must agree with the ones the directions imply to this tolerance (radians).
FOLD_ANGLE_CHECK_TOL = 1e-6


def _assignment_for(angles_deg: np.ndarray) -> list[str]:
    return ["V" if a > 0 else "M" if a < 0 else "F" for a in angles_deg.tolist()]


def _frame_values(frame_data: dict | None, state: int, n_states: int) -> dict:
    """`origami_jax:<name>` entries of one frame from `{name: (k,) values}`."""
    out = {}
    for name, values in (frame_data or {}).items():
        values = np.asarray(values, dtype=float)
        if values.shape != (n_states,):
            raise FoldFormatError(
                f"frame_data[{name!r}] must have shape ({n_states},), one value per state, "
                f"not {values.shape}"
            )
        value = float(values[state])
        out[f"origami_jax:{name}"] = value if math.isfinite(value) else None
    return out


def _round_deg(angles_rad: np.ndarray) -> np.ndarray:
    """Radians to degrees, with values within 1e-9° of zero written as exactly 0 (a flat crease)."""
    deg = np.rad2deg(np.asarray(angles_rad, dtype=float))
    return np.where(np.abs(deg) < 1e-9, 0.0, deg)


def single_vertex_fold(
    directions: ArrayLike,
    *,
    closed: bool,
    sector_angles: ArrayLike | None = None,
    fold_angles: ArrayLike | None = None,
    times: ArrayLike | None = None,
    radius: float = 1.0,
    unit: str = "unit",
    check_fold_angles: bool = True,
    title: str | None = None,
    extra: dict | None = None,
    frame_data: dict | None = None,
) -> FoldFile:
    """A single-vertex state, or a path of states, as a `FoldFile` (see the module docstring).

    **Arguments:**
    - `directions`: unit crease directions, `(n, 3)` for one state or `(k, n, 3)` for a path, rays
      in cyclic order (counter-clockwise seen from the paper's front). Open chains include their
      two boundary rays first and last.
    - `closed`: interior vertex (`n` sectors) or boundary vertex (`n - 1` sectors).
    - `sector_angles`: radians, `(n,)` or `(n - 1,)`; default: measured on the first state.
    - `fold_angles`: radians, `(k, m)` or `(m,)` (`m = n` closed, `n - 2` open); default: computed
      from the directions (`vertex_fold_angles`). When given they are checked against the
      directions unless `check_fold_angles=False`: a mismatch means a different sign convention.
    - `times`: optional `(k,)` stored per frame as `origami_jax:time`.
    - `radius`: length of the drawn rays; `unit`: `frame_unit` of that length.
    - `title`: `frame_title` of the key frame; `extra`: more key-frame properties (use
      `origami_jax:` keys); `frame_data`: `{name: (k,) values}` stored per frame as
      `origami_jax:<name>` (e.g. energy, path length).

    **Returns:** a `FoldFile` with `1 + k` frames; vertex 0 is the apex, vertex `1 + i` the tip of
    ray `i`; edge `i` is ray `i`; each sector is one triangle (apex, tip i, tip i+1).

    **Raises:** `FoldFormatError` for inconsistent shapes, a sector not strictly between 0 and π
    (it cannot be drawn as one triangle), sectors of a closed vertex not summing to 2π, or fold
    angles that disagree with the directions.
    """
    path = np.asarray(directions, dtype=float)
    if path.ndim == 2:
        path = path[None]
    if path.ndim != 3 or path.shape[2] != 3 or path.shape[1] < 3:
        raise FoldFormatError(
            f"directions must have shape (n, 3) or (k, n, 3) with n >= 3, not {np.shape(directions)}"
        )
    k, n, _ = path.shape
    norms = np.linalg.norm(path, axis=-1)
    if np.any(norms == 0):
        raise FoldFormatError("a crease direction is the zero vector")
    path = path / norms[..., None]
    n_sectors = n if closed else n - 1
    if sector_angles is None:
        first = path[0]
        nxt = np.roll(first, -1, axis=0)
        sectors = np.arctan2(np.linalg.norm(np.cross(first, nxt), axis=-1), np.sum(first * nxt, -1))
        sectors = sectors[:n_sectors]
    else:
        sectors = np.asarray(sector_angles, dtype=float)
        if sectors.shape != (n_sectors,):
            raise FoldFormatError(
                f"sector_angles must have shape ({n_sectors},) for {n} rays "
                f"({'closed' if closed else 'open'}), not {sectors.shape}"
            )
    if np.any(sectors <= 0) or np.any(sectors >= np.pi):
        raise FoldFormatError(
            f"sector angles must lie strictly between 0 and π to be drawn as triangles; got "
            f"{np.round(sectors, 6).tolist()}"
        )
    if closed and not math.isclose(float(np.sum(sectors)), 2 * np.pi, abs_tol=1e-6):
        raise FoldFormatError(
            f"the sector angles of a closed (interior) vertex must sum to 2π, not {np.sum(sectors)}"
        )
    computed = np.stack([vertex_fold_angles(state, closed=closed) for state in path])
    if fold_angles is None:
        angles = computed
    else:
        angles = np.asarray(fold_angles, dtype=float)
        if angles.ndim == 1:
            angles = angles[None]
        if angles.shape != computed.shape:
            raise FoldFormatError(
                f"fold_angles must have shape {computed.shape} (states, creases), not {angles.shape}"
            )
        if check_fold_angles:
            diff = np.abs(np.angle(np.exp(1j * (angles - computed))))
            if np.max(diff) > FOLD_ANGLE_CHECK_TOL:
                s, c = np.unravel_index(np.argmax(diff), diff.shape)
                raise FoldFormatError(
                    f"fold_angles disagree with the crease directions (state {s}, crease {c}: "
                    f"given {angles[s, c]:.6g} rad, directions imply {computed[s, c]:.6g} rad). "
                    "FOLD's convention: rays counter-clockwise seen from the paper's front, "
                    "valley +, mountain -. Pass check_fold_angles=False to write them anyway."
                )
    if times is not None:
        times = np.asarray(times, dtype=float)
        if times.shape != (k,):
            raise FoldFormatError(f"times must have shape ({k},), not {times.shape}")

    # Crease pattern: ray i at the cumulative sector angle, counter-clockwise.
    theta = np.concatenate([[0.0], np.cumsum(sectors)])[:n]
    tips = np.stack([np.cos(theta), np.sin(theta)], -1)
    tips = np.where(np.abs(tips) < 1e-14, 0.0, tips)  # cos(π/2) = 6e-17 is 0 in the file
    cp = np.concatenate([[[0.0, 0.0]], radius * tips])
    crease_ids = list(range(n)) if closed else list(range(1, n - 1))
    edges = [[0, 1 + i] for i in range(n)]
    edges += [[1 + i, 1 + (i + 1) % n] for i in range(n_sectors)]
    faces = [(0, 1 + i, 1 + (i + 1) % n) for i in range(n_sectors)]
    n_edges = len(edges)

    def edge_angles(state_angles: np.ndarray) -> np.ndarray:
        out = np.zeros(n_edges)
        out[crease_ids] = _round_deg(state_angles)
        return out

    def edge_assignment(deg: np.ndarray) -> list[str]:
        out = ["B"] * n_edges
        for c in crease_ids:
            out[c] = _assignment_for(deg[[c]])[0]
        return out

    key_angles = edge_angles(angles[0])
    key_assignment = edge_assignment(key_angles)
    key_extra: dict = {
        "origami_jax:kind": "single_vertex",
        "origami_jax:closed": bool(closed),
        "origami_jax:sector_angles": [float(x) for x in sectors],
        "origami_jax:crease_edges": crease_ids,
    }
    if title is not None:
        key_extra["frame_title"] = title
    if extra:
        key_extra.update(extra)
    key = _crease_pattern_frame(cp, edges, key_assignment, key_angles, faces, unit, key_extra)
    frames = [key]
    for s in range(k):
        deg = edge_angles(angles[s])
        frame_extra: dict = {"origami_jax:state": s}
        if times is not None:
            frame_extra["origami_jax:time"] = float(times[s])
        frame_extra.update(_frame_values(frame_data, s, k))
        frames.append(
            _folded_frame(
                np.concatenate([np.zeros((1, 3)), radius * path[s]]),
                deg,
                edge_assignment(deg),
                key_assignment,
                frame_extra,
            )
        )
    metadata = {
        "file_creator": CREATOR,
        "file_classes": ["singleModel", "animation"] if k > 1 else ["singleModel"],
    }
    return FoldFile(frames=tuple(frames), file_spec=WRITTEN_SPEC, file_metadata=metadata)


def chain_fold(
    hinge_angles: ArrayLike,
    flap_lengths: ArrayLike,
    *,
    width: float,
    base_length: float | None = None,
    times: ArrayLike | None = None,
    unit: str = "um",
    time_unit: str | None = None,
    title: str | None = None,
    extra: dict | None = None,
    frame_data: dict | None = None,
) -> FoldFile:
    """An accordion (hinged chain with parallel hinges) state or trajectory as a `FoldFile`.

    The strip lies along +y with hinges along +x and the paper's front at +z: a fixed base flap
    from `y = -base_length` to 0, hinge 1 at `y = 0`, flap `i` after hinge `i`. A positive hinge
    angle lifts the next flap toward +z (a valley), as in `ChainGeometry`, so `chain_geometry`
    reads the key frame back as the same chain.

    **Arguments:**
    - `hinge_angles`: radians, `(m,)` or `(k, m)`, relative angle of each hinge. FOLD fold angles are
      limited to [−180°, 180°]: `edges_foldAngle` holds them wrapped, the unwrapped values go to
      `origami_jax:hinge_angles` (an overshoot past 180° stays visible).
    - `flap_lengths`: `(m,)` lengths of the moving flaps, in `unit`.
    - `width`: strip width (hinge length), in `unit`.
    - `base_length`: drawn length of the fixed base (default: the first flap's length).
    - `times`: optional `(k,)`, stored per frame as `origami_jax:time` (in `time_unit`).
    - `title`, `extra`, `frame_data`: as in `single_vertex_fold`.

    **Returns:** a `FoldFile`: key frame the flat strip (fold angles of the first state), then one
    frame per state. Vertices `2j`, `2j + 1` are the two ends (x = 0, x = width) of line `j`
    (0 = base end, 1..m = hinges, m + 1 = free end); edge `j - 1` is hinge `j`.
    """
    theta = np.asarray(hinge_angles, dtype=float)
    if theta.ndim == 1:
        theta = theta[None]
    lengths = np.asarray(flap_lengths, dtype=float)
    if theta.ndim != 2 or lengths.ndim != 1 or theta.shape[1] != lengths.shape[0]:
        raise FoldFormatError(
            f"hinge_angles (k, m) and flap_lengths (m,) must agree: got {np.shape(hinge_angles)} "
            f"and {np.shape(flap_lengths)}"
        )
    if not np.all(np.isfinite(theta)):
        raise FoldFormatError("hinge_angles must be finite")
    k, m = theta.shape
    base = float(lengths[0] if base_length is None else base_length)
    if np.any(lengths <= 0) or base <= 0 or width <= 0:
        raise FoldFormatError("flap lengths, base length and width must be positive")
    if times is not None:
        times = np.asarray(times, dtype=float)
        if times.shape != (k,):
            raise FoldFormatError(f"times must have shape ({k},), not {times.shape}")
    y = np.concatenate([[-base, 0.0], np.cumsum(lengths)])  # lines 0..m+1 in the crease pattern
    n_lines = m + 2
    cp = np.array([[x, yj] for yj in y for x in (0.0, width)])
    edges = [[2 * j, 2 * j + 1] for j in range(1, m + 1)]  # hinges first: edge j-1 is hinge j
    edges += [[0, 1], [2 * (n_lines - 1), 2 * (n_lines - 1) + 1]]  # the two ends
    edges += [[2 * j + s, 2 * (j + 1) + s] for j in range(n_lines - 1) for s in (0, 1)]  # sides
    faces = [(2 * j, 2 * j + 1, 2 * j + 3, 2 * j + 2) for j in range(n_lines - 1)]
    n_edges = len(edges)
    wrapped = np.arctan2(np.sin(theta), np.cos(theta))

    def edge_angles(state: np.ndarray) -> np.ndarray:
        out = np.zeros(n_edges)
        out[:m] = _round_deg(state)
        return out

    def edge_assignment(deg: np.ndarray) -> list[str]:
        return _assignment_for(deg[:m]) + ["B"] * (n_edges - m)

    def coords3(state: np.ndarray) -> np.ndarray:
        points = [np.array([0.0, -base, 0.0]), np.zeros(3)]
        heading = 0.0
        for i in range(m):
            heading += state[i]
            points.append(
                points[-1] + lengths[i] * np.array([0.0, np.cos(heading), np.sin(heading)])
            )
        return np.array([p + np.array([x, 0.0, 0.0]) for p in points for x in (0.0, width)])

    key_angles = edge_angles(wrapped[0])
    key_assignment = edge_assignment(key_angles)
    key_extra: dict = {
        "origami_jax:kind": "chain",
        "origami_jax:flap_lengths": [float(x) for x in lengths],
        "origami_jax:base_length": base,
        "origami_jax:width": float(width),
        "origami_jax:hinge_edges": list(range(m)),
    }
    if time_unit is not None:
        key_extra["origami_jax:time_unit"] = time_unit
    if title is not None:
        key_extra["frame_title"] = title
    if extra:
        key_extra.update(extra)
    frames = [_crease_pattern_frame(cp, edges, key_assignment, key_angles, faces, unit, key_extra)]
    for s in range(k):
        deg = edge_angles(wrapped[s])
        frame_extra: dict = {
            "origami_jax:state": s,
            "origami_jax:hinge_angles": [float(x) for x in theta[s]],
        }
        if times is not None:
            frame_extra["origami_jax:time"] = float(times[s])
        frame_extra.update(_frame_values(frame_data, s, k))
        frames.append(
            _folded_frame(coords3(theta[s]), deg, edge_assignment(deg), key_assignment, frame_extra)
        )
    metadata = {
        "file_creator": CREATOR,
        "file_classes": ["singleModel", "animation"] if k > 1 else ["singleModel"],
    }
    return FoldFile(frames=tuple(frames), file_spec=WRITTEN_SPEC, file_metadata=metadata)


def _crease_pattern_frame(cp, edges, assignment, angles_deg, faces, unit, extra) -> FoldFrame:
    """The key frame of a written state file: the flat crease pattern."""
    return FoldFrame(
        vertices_coords=cp,
        edges_vertices=np.array(edges),
        edges_assignment=tuple(assignment),
        edges_fold_angle_deg=angles_deg,
        faces_vertices=tuple(faces),
        frame_unit=unit,
        frame_classes=("creasePattern",),
        frame_attributes=("2D", "manifold", "orientable", "convexFaces"),
        extra=extra,
    )


def _folded_frame(coords, deg, assignment, key_assignment, extra) -> FoldFrame:
    """A folded state inheriting from the key frame (its assignment written only where it differs)."""
    return FoldFrame(
        vertices_coords=coords,
        edges_fold_angle_deg=deg,
        edges_assignment=None if assignment == key_assignment else tuple(assignment),
        frame_classes=("foldedForm",),
        frame_attributes=("3D",),
        frame_parent=0,
        frame_inherit=True,
        extra=extra,
    )
