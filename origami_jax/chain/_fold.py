"""Chains from FOLD files and back: `load_chain`, `trajectory_to_fold`.

The FOLD package reads and writes plain arrays (`origami_jax.fold.chain_geometry`,
`origami_jax.fold.chain_fold`); this module builds a `Chain` from them and feeds them from a
simulated trajectory of a chain (or of a `FoldingSystem` whose mechanism is one).
"""

import os
from typing import Any

import numpy as np
from jaxtyping import ArrayLike

from ..fold import (
    FRAME_UNITS_M,
    ChainGeometry,
    FoldFile,
    FoldFormatError,
    chain_fold,
    chain_geometry,
)
from ..system import MICRO, FoldingSystem, UnitSystem
from ._chain import Chain, flap_chain


def load_chain(
    path: str | os.PathLike[str] | FoldFile,
    *,
    frame: int = 0,
    thickness: float | None = None,
    density: float | None = None,
    units: UnitSystem = MICRO,
) -> tuple[Chain, ChainGeometry]:
    """Read a FOLD accordion (parallel creases on a flat strip) as a `Chain`.

    The strip's first flap is the fixed base; each crease becomes a hinge carrying the flap after it
    (see `origami_jax.fold.ChainGeometry`). The chain is laid out as `accordion` builds it: hinges
    along +x through `(0, y_i, 0)`, hinge 1 at the origin, flaps along +y, CGs mid-flap.

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
    scale = 1.0
    if geometry.unit is not None and FRAME_UNITS_M.get(geometry.unit) is not None:
        scale = units.length(FRAME_UNITS_M[geometry.unit])
    chain = chain_from_geometry(
        geometry, scale=scale, thickness=thickness, density=density, units=units
    )
    return chain, geometry


def chain_from_geometry(
    geometry: ChainGeometry,
    *,
    scale: float = 1.0,
    thickness: float | None = None,
    density: float | None = None,
    units: UnitSystem = MICRO,
) -> Chain:
    """A `Chain` from an `origami_jax.fold.ChainGeometry` (see `load_chain`); lengths multiplied by
    `scale`."""
    thickness = units.length(200e-9) if thickness is None else thickness
    density = units.density(3100.0) if density is None else density
    m = geometry.n_hinges
    offsets = (geometry.hinge_offsets - geometry.hinge_offsets[0]) * scale
    lengths = geometry.flap_lengths[1:] * scale
    e_x = np.array([1.0, 0.0, 0.0])
    e_y = np.array([0.0, 1.0, 0.0])
    return flap_chain(
        np.tile(e_x, (m, 1)),
        offsets[:, None] * e_y,
        (offsets + lengths / 2)[:, None] * e_y,
        flap_length=lengths,
        flap_width=geometry.flap_widths[1:] * scale,
        thickness=thickness,
        density=density,
    )


def accordion_dimensions(chain: Chain) -> tuple[np.ndarray, float]:
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
    system: FoldingSystem | Chain | None = None,
    trajectory: Any = None,
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
    """A chain's folding (a simulated trajectory or plain hinge angles) as a FOLD animation.

    ```python
    trajectory = simulate(system, Step(), t1=2000.0)
    write_fold("accordion.fold", trajectory_to_fold(system, trajectory))
    ```

    **Arguments:**
    - `system`: the `FoldingSystem` that was simulated (its mechanism must be a `Chain`), or the
      `Chain` itself; flap lengths and width are read with `accordion_dimensions`. Or give
      `flap_lengths` `(m,)` and `width`.
    - `trajectory`: a `simulation.Trajectory` (`.times`, `.theta`), or give `hinge_angles` `(k, m)`
      and optionally `times` `(k,)`.
    - `unit` / `time_unit`: labels of the chain's length and time units (`MICRO`: um, us).
    - `every`: keep every `every`-th sample (the last one always).
    - `kwargs`: passed to `origami_jax.fold.chain_fold` (`base_length`, `title`, `extra`).

    Samples after a failed solve (non-finite angles) are dropped, and the count is recorded under
    `origami_jax:dropped_samples`.

    **Raises:** `FoldFormatError` for missing geometry or angles, a mechanism that is not a chain
    with parallel hinges, or no finite sample.
    """
    chain = system.mechanism if isinstance(system, FoldingSystem) else system
    if chain is not None and not isinstance(chain, Chain):
        raise FoldFormatError(
            f"trajectory_to_fold writes chains only; this system's mechanism is a "
            f"{type(chain).__name__}"
        )
    if trajectory is not None:
        hinge_angles = np.asarray(trajectory.theta, dtype=float)
        times = np.asarray(trajectory.times, dtype=float)
    if hinge_angles is None:
        raise FoldFormatError("trajectory_to_fold needs a trajectory or hinge_angles=(k, m)")
    hinge_angles = np.atleast_2d(np.asarray(hinge_angles, dtype=float))
    if chain is not None:
        lengths, chain_width = accordion_dimensions(chain)
        flap_lengths = lengths if flap_lengths is None else flap_lengths
        width = chain_width if width is None else width
    if flap_lengths is None or width is None:
        raise FoldFormatError(
            "trajectory_to_fold needs the system (or its chain) or both flap_lengths= and width="
        )
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
