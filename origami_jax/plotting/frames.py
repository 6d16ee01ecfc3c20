"""A folding's frames as plain arrays, computed without matplotlib: each frame's panel outlines
from one compiled poses program (`frame_set`), for the figures `origami_jax.plotting.chain`
draws (and the fold command's figure worker, which imports no JAX)."""

from typing import NamedTuple

import numpy as np

from .._exported import exported_jit


def _mechanism(obj):
    """The mechanism of a `FoldingSystem`, or the mechanism itself."""
    return getattr(obj, "mechanism", obj)


def _poses_of(mechanism, states):
    import jax

    return jax.vmap(mechanism.body_poses)(states)


def _batched_poses(mechanism, states):
    # Compiled, and in a command read from disk as a traced program (`exported_jit`): tracing and
    # lowering it took a warm `origami-jax fold` ~0.9 s per frame count. The states are padded to
    # a multiple of `_POSE_BUCKET` rows, so that the frames strip and the animation (6 and 24
    # frames) share one program: one compilation (~0.5 s) and one load fewer per command.
    global _BATCHED_POSES
    if _BATCHED_POSES is None:
        _BATCHED_POSES = exported_jit("batched_poses")(_poses_of)
    n = len(states)
    padding = -n % _POSE_BUCKET
    padded = (
        np.concatenate([states, np.repeat(states[-1:], padding, axis=0)]) if padding else states
    )
    return np.asarray(_BATCHED_POSES(mechanism, padded))[:n]


_BATCHED_POSES = None
_POSE_BUCKET = 32


def _polygon_frames(mechanism, states) -> list[list[np.ndarray]]:
    """Every panel's world-frame outline (the fixed base first, if any) at each row of `states`.

    The body poses of all frames come from one compiled, `vmap`ped program (one compilation per
    mechanism structure and multiple of `_POSE_BUCKET` frames, kept by the persistent compilation
    cache), instead of one pass of eager JAX operations per frame (~75 ms each on 2 cores)."""
    poses = _batched_poses(mechanism, np.asarray(states, dtype=float))
    outlines = [np.asarray(o) for o in mechanism.outlines()]
    base = mechanism.base_outline()
    frames = []
    for frame in poses:
        polygons = [o @ p[:3, :3].T + p[:3, 3] for o, p in zip(outlines, frame, strict=True)]
        frames.append(polygons if base is None else [np.asarray(base), *polygons])
    return frames


def _polygons(mechanism, q) -> list[np.ndarray]:
    return _polygon_frames(mechanism, np.asarray(q)[None])[0]


def _states(trajectory, indices) -> np.ndarray:
    q = trajectory.theta if trajectory.state is None else trajectory.state[0]
    return np.asarray(q)[indices]


def _frame_indices(
    trajectory, n_frames: int, t_max: float | None, *, by_motion: bool = False
) -> np.ndarray:
    """Sample indices of `n_frames` frames up to `t_max`: evenly spread in time, or with
    `by_motion` evenly spread in an equal blend of time and of the distance travelled in
    coordinates (frames crowd where the panels move fast, fewer where they rest), both ends kept."""
    times = np.asarray(trajectory.times)
    last = len(times) - 1 if t_max is None else int(np.searchsorted(times, t_max))
    last = min(last, len(times) - 1)
    if not by_motion or last < 2:
        return np.unique(np.linspace(0, last, n_frames).round().astype(int))
    q = _states(trajectory, np.arange(last + 1))
    q = np.where(np.isfinite(q), q, 0.0)
    travelled = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    elapsed = times[: last + 1] - times[0]
    progress = 0.5 * elapsed / max(elapsed[-1], 1e-300)
    progress = progress + 0.5 * (travelled / travelled[-1] if travelled[-1] > 0 else progress * 2)
    wanted = np.linspace(0.0, progress[-1], n_frames)
    indices = np.searchsorted(progress, wanted).clip(0, last)
    indices[0], indices[-1] = 0, last
    return np.unique(indices)


class FrameSet(NamedTuple):
    """Frames of a folding, ready to draw without JAX (`frame_set`): `times` `(f,)` (time units),
    `polygons` each frame's panel outlines in world coordinates (length; the fixed base first, if
    any), `has_base` (the base is drawn grey)."""

    times: np.ndarray
    polygons: list[list[np.ndarray]]
    has_base: bool


def frame_set(
    system, trajectory, n_frames: int, t_max: float | None = None, *, by_motion: bool = False
) -> FrameSet:
    """`n_frames` frames of `trajectory` (a `Trajectory` of `system`, a `FoldingSystem` or its
    mechanism) up to `t_max` (time units), evenly spread in time or with `by_motion` over an equal
    blend of time and of the distance the panels travel; the panels' poses come from one compiled
    program for every frame."""
    mechanism = _mechanism(system)
    indices = _frame_indices(trajectory, n_frames, t_max, by_motion=by_motion)
    polygons = _polygon_frames(mechanism, _states(trajectory, indices))
    times = np.asarray(trajectory.times)[indices]
    return FrameSet(times, polygons, mechanism.base_outline() is not None)
