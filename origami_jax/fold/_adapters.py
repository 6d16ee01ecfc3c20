"""Thin adapters between FOLD and the physics packages, imported lazily.

`origami_jax.vertex` (single vertex, unfolding) and `origami_jax.chain` / `origami_jax.simulation`
(hinged chains) are imported only when one of these functions runs, so the FOLD reader and writers
work without them; when one is missing the error says so and points at the plain-array function.
"""

from __future__ import annotations

import importlib
import os
from typing import Any

import numpy as np
from jaxtyping import ArrayLike

from ._chain_geometry import ChainGeometry, chain_geometry
from ._errors import FoldFormatError
from ._geometry import VertexGeometry, single_vertex_geometry
from ._model import FRAME_UNITS_M, FoldFile
from ._states import chain_fold, single_vertex_fold

# |fold angle| at or above this (radians) is a fully folded crease: outside the charge model.
FLAT_FOLDED_TOL = 1e-9


def _import(name: str, issue: int, instead: str, attribute: str) -> Any:
    """Import `name` and check that it offers `attribute` (a package under construction may not)."""
    try:
        module = importlib.import_module(name)
    except ImportError as error:
        reason = str(error)
    else:
        if hasattr(module, attribute):
            return module
        reason = f"it has no {attribute} yet"
    raise ImportError(
        f"{name} is not available ({reason}); it lands with issue #{issue}. "
        f"Meanwhile {instead} gives the same data as plain arrays."
    )


def load_single_vertex(
    path: str | os.PathLike[str] | FoldFile,
    *,
    vertex_index: int | None = None,
    frame: int = 0,
) -> Any:
    """Read a FOLD file and build an `origami_jax.vertex.SingleVertex` at one of its vertices.

    **Arguments:**
    - `path`: a `.fold` file (or an already read `FoldFile`).
    - `vertex_index`: which vertex; `None` takes the only one where creases meet and raises a
      `FoldFormatError` listing the vertices when there are several (see `single_vertex_geometry`).
    - `frame`: which frame's state (0 = key frame). A flat crease pattern gives sector angles and
      its `edges_foldAngle` (missing angles default from M/V); a folded 3D frame gives directions.

    **Returns:** a `SingleVertex` (`from_fold_angles` for a flat frame, `from_directions` for a
    folded one).

    **Raises:** `FoldFormatError` for an unreadable file, an ambiguous vertex, a free (`U`) crease
    without a fold angle, or fold angles of ±180° (fully folded, outside the charge model: give
    `edges_foldAngle` of a partly folded state); `ImportError` while `origami_jax.vertex` is missing.
    """
    geometry = single_vertex_geometry(path, vertex_index, frame=frame)
    return vertex_from_geometry(geometry)


def vertex_from_geometry(geometry: VertexGeometry) -> Any:
    """A `SingleVertex` from a `VertexGeometry` (see `load_single_vertex`)."""
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
                "without edges_foldAngle). A flat-folded state is outside the charge model (docs/physics.md, "
                "Part A): give edges_foldAngle of a slightly opened state, e.g. ±170°"
            )
    vertex = _import(
        "origami_jax.vertex",
        5,
        "origami_jax.fold.single_vertex_geometry(path, vertex_index)",
        "SingleVertex",
    )
    if geometry.flat:
        return vertex.SingleVertex.from_fold_angles(
            geometry.sector_angles, geometry.fold_angles, closed=geometry.closed
        )
    return vertex.SingleVertex.from_directions(geometry.directions, closed=geometry.closed)


def single_vertex_to_fold(vertex: Any, **kwargs: Any) -> FoldFile:
    """One `SingleVertex` state as a `FoldFile` (see `single_vertex_fold` for `kwargs`)."""
    fold_angles = kwargs.pop("fold_angles", None)
    if fold_angles is None:
        module = _import(
            "origami_jax.vertex", 5, "origami_jax.fold.single_vertex_fold(...)", "fold_angles"
        )
        fold_angles = np.asarray(module.fold_angles(vertex))
    return single_vertex_fold(
        np.asarray(vertex.directions),
        closed=bool(vertex.closed),
        sector_angles=np.asarray(vertex.sector_angles),
        fold_angles=fold_angles,
        **kwargs,
    )


def unfolding_to_fold(
    result: Any = None,
    *,
    directions: ArrayLike | None = None,
    fold_angles: ArrayLike | None = None,
    closed: bool | None = None,
    sector_angles: ArrayLike | None = None,
    vertex: Any = None,
    **kwargs: Any,
) -> FoldFile:
    """An unfolding path as a FOLD animation: the crease pattern, then one frame per state.

    **Arguments:** either `result`, an `UnfoldResult` (its `.path` `(k, n, 3)` and `.fold_angles`
    `(k, m)`), or the plain arrays `directions` `(k, n, 3)` and optionally `fold_angles` (radians).
    `closed` and `sector_angles` come from the arguments, else from `vertex` (a `SingleVertex`),
    else from the result's own `closed` / `vertex` attributes. A result's `energy` and
    `path_length` `(k,)` are stored per frame (`origami_jax:energy`, `origami_jax:path_length`) and
    its `verdict` as `origami_jax:verdict`. Other `kwargs` go to `single_vertex_fold` (`times`,
    `radius`, `unit`, `check_fold_angles`, `title`, `extra`, `frame_data`).

    **Returns:** the `FoldFile` (write it with `write_fold`).
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


def accordion_dimensions(chain: Any) -> tuple[np.ndarray, float]:
    """Flap lengths `(n,)` and width of a `Chain` whose hinges are parallel and whose flaps are plates.

    Lengths come from the spacing of the hinge points along the chain (the last flap from twice its
    CG's distance to its hinge); the width from the plate inertia, `w² = L² + 12 (I_yy − I_xx) / m`
    (`plate_inertia`'s cuboid formula, flap frames axis-aligned as `accordion` builds them).

    **Raises:** `FoldFormatError` if the hinges are not parallel.
    """
    axes = np.asarray(chain.axes, dtype=float)
    points = np.asarray(chain.points, dtype=float)
    if not np.allclose(np.cross(axes, axes[0]), 0.0, atol=1e-9):
        raise FoldFormatError(
            "only chains with parallel hinges (accordions) can be written as FOLD yet; this chain's "
            "hinge axes differ"
        )
    axis = axes[0]
    cg = np.asarray(chain.cg_poses, dtype=float)[:, :3, 3]
    if len(points) > 1:
        spacing = points[1:] - points[:-1]
        spacing = np.linalg.norm(spacing - np.outer(spacing @ axis, axis), axis=1)
    else:
        spacing = np.zeros(0)
    last = cg[-1] - points[-1]
    last = 2 * np.linalg.norm(last - (last @ axis) * axis)
    lengths = np.concatenate([spacing, [last]])
    masses = np.asarray(chain.masses, dtype=float)
    inertias = np.asarray(chain.inertias, dtype=float)
    width_sq = lengths**2 + 12 * (inertias[:, 1, 1] - inertias[:, 0, 0]) / masses
    width = float(np.sqrt(np.max(width_sq))) if np.all(width_sq > 0) else float(lengths[0])
    return lengths, width


def trajectory_to_fold(
    trajectory: Any = None,
    chain: Any = None,
    *,
    hinge_angles: ArrayLike | None = None,
    times: ArrayLike | None = None,
    flap_lengths: ArrayLike | None = None,
    width: float | None = None,
    unit: str = "um",
    time_unit: str | None = "us",
    every: int = 1,
    **kwargs: Any,
) -> FoldFile:
    """A chain's folding (a `Trajectory` or plain hinge angles) as a FOLD animation.

    **Arguments:**
    - `trajectory`: a `simulation.Trajectory` (`.times`, `.theta`), or give `hinge_angles` `(k, m)`
      and optionally `times` `(k,)`.
    - `chain`: the `Chain` that was simulated; its flap lengths and width are read with
      `accordion_dimensions`. Or give `flap_lengths` `(m,)` and `width`.
    - `unit` / `time_unit`: labels of the chain's length and time units (`MICRO`: um, us).
    - `every`: keep every `every`-th sample (the last one always).
    - `kwargs`: passed to `chain_fold` (`base_length`, `title`, `extra`).

    Samples after a failed solve (non-finite angles) are dropped, and the count is recorded under
    `origami_jax:dropped_samples`.
    """
    if trajectory is not None:
        hinge_angles = np.asarray(trajectory.theta, dtype=float)
        times = np.asarray(trajectory.times, dtype=float)
    if hinge_angles is None:
        raise FoldFormatError("trajectory_to_fold needs a Trajectory or hinge_angles=(k, m)")
    hinge_angles = np.atleast_2d(np.asarray(hinge_angles, dtype=float))
    if chain is not None:
        lengths, chain_width = accordion_dimensions(chain)
        flap_lengths = lengths if flap_lengths is None else flap_lengths
        width = chain_width if width is None else width
    if flap_lengths is None or width is None:
        raise FoldFormatError("trajectory_to_fold needs chain= or both flap_lengths= and width=")
    keep = np.arange(0, len(hinge_angles), max(int(every), 1))
    if keep[-1] != len(hinge_angles) - 1:
        keep = np.append(keep, len(hinge_angles) - 1)
    finite = np.all(np.isfinite(hinge_angles[keep]), axis=1)
    if times is not None:
        finite &= np.isfinite(np.asarray(times)[keep])
    dropped = int(np.sum(~finite))
    keep = keep[finite]
    if len(keep) == 0:
        raise FoldFormatError("no finite samples to write (the solve failed from the start)")
    extra = dict(kwargs.pop("extra", None) or {})
    if dropped:
        extra["origami_jax:dropped_samples"] = dropped
    return chain_fold(
        hinge_angles[keep],
        np.asarray(flap_lengths, dtype=float),
        width=float(width),
        times=None if times is None else np.asarray(times)[keep],
        unit=unit,
        time_unit=time_unit,
        extra=extra or None,
        **kwargs,
    )


def load_chain(
    path: str | os.PathLike[str] | FoldFile,
    *,
    frame: int = 0,
    thickness: float | None = None,
    density: float | None = None,
    units: Any = None,
) -> Any:
    """Read a FOLD accordion (parallel creases on a flat strip) as an `origami_jax.chain.Chain`.

    The strip's first flap is the fixed base; each crease becomes a hinge carrying the flap after it
    (see `ChainGeometry`). The chain is laid out as `accordion` builds it: hinges along +x through
    `(0, y_i, 0)`, hinge 1 at the origin, flaps along +y, CGs mid-flap.

    **Arguments:**
    - `path`: the file (or a `FoldFile`); `frame`: which frame (0 = key frame).
    - `thickness`, `density`: flap plate properties in `units` (defaults: 200 nm SiNx, as
      `accordion`).
    - `units`: the chain's `UnitSystem` (default `MICRO`). Coordinates are converted from the file's
      `frame_unit` when it is physical (`m`, `mm`, `um`, ...); without one they are taken as is.

    **Returns:** `(chain, geometry)`: the `Chain` and the `ChainGeometry` it came from (fold angles =
    the hinge angles of the frame's state, radians).
    """
    geometry = chain_geometry(path, frame=frame)
    chain_module = _import(
        "origami_jax.chain", 3, "origami_jax.fold.chain_geometry(path)", "flap_chain"
    )
    if units is None:
        units = chain_module.MICRO
    scale = 1.0
    if geometry.unit is not None and FRAME_UNITS_M.get(geometry.unit) is not None:
        scale = units.length(FRAME_UNITS_M[geometry.unit])
    return chain_from_geometry(
        geometry, scale=scale, thickness=thickness, density=density, units=units
    ), geometry


def chain_from_geometry(
    geometry: ChainGeometry,
    *,
    scale: float = 1.0,
    thickness: float | None = None,
    density: float | None = None,
    units: Any = None,
) -> Any:
    """A `Chain` from a `ChainGeometry` (see `load_chain`); lengths multiplied by `scale`."""
    chain_module = _import(
        "origami_jax.chain", 3, "origami_jax.fold.chain_geometry(path)", "flap_chain"
    )
    if units is None:
        units = chain_module.MICRO
    thickness = units.length(200e-9) if thickness is None else thickness
    density = units.density(3100.0) if density is None else density
    m = geometry.n_hinges
    offsets = (geometry.hinge_offsets - geometry.hinge_offsets[0]) * scale
    lengths = geometry.flap_lengths[1:] * scale
    e_x = np.array([1.0, 0.0, 0.0])
    e_y = np.array([0.0, 1.0, 0.0])
    return chain_module.flap_chain(
        np.tile(e_x, (m, 1)),
        offsets[:, None] * e_y,
        (offsets + lengths / 2)[:, None] * e_y,
        flap_length=lengths,
        flap_width=geometry.flap_widths[1:] * scale,
        thickness=thickness,
        density=density,
    )
