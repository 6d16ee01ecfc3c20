"""Figures of a folding: hinge angles with metrics (paper Figs. 7, 10) and the panels in 3D as an
animation and a strip of frames (Figs. 8, 11), for any mechanism (chains, panel trees).

Matplotlib only; imported explicitly (`from origami_jax.plotting import chain as chain_plots`).
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ._gif import save_gif
from .frames import (
    FrameSet,
    _mechanism,
    _polygons,
    frame_set,
)

_COLOURS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


def plot_joint_angles(
    trajectory,
    metrics=None,
    *,
    ax=None,
    time_scale: float = 1.0,
    time_label: str = "time [µs]",
    desired=None,
    title: str | None = None,
    name: str = "joint",
    number_from: int = 1,
):
    """Joint angles (degrees) against time, one line per joint, metrics annotated (paper Figs. 7, 10).

    **Arguments:**
    - `trajectory`: a [`origami_jax.simulation.Trajectory`][] (not batched).
    - `metrics`: its [`origami_jax.simulation.ResponseMetrics`][], or `None`: marks the 10 % and 90 %
      crossings, the peak with its overshoot, and the settling time; flags are shown in the legend.
    - `time_scale`: multiply times by this for the axis (e.g. 1e-3 for ms from µs); `time_label` to match.
    - `desired`: optional callable `t -> θ_des` drawn dashed (e.g. `EtchRamp.desired` returning a pair).
    - `title`: axis title.
    - `name`: what the lines are called in the legend and on the axis (`"crease"` for a net).
    - `number_from`: the first line's number: 1 for a chain's joints, as the paper numbers them;
      0 for a net's or a crease pattern's creases, as their arrays and verdicts number them.

    **Returns:** the matplotlib `Figure`.
    """
    if ax is None:
        fig, ax = plt.subplots(figsize=(7.5, 4.5), constrained_layout=True)
    else:
        fig = ax.figure
    unit = time_label[time_label.find("[") + 1 : time_label.find("]")] if "[" in time_label else ""
    times = np.asarray(trajectory.times)
    theta = np.degrees(np.asarray(trajectory.theta))
    target = np.degrees(np.asarray(trajectory.target))
    t_axis = times * time_scale
    for j in range(theta.shape[1]):
        colour = _COLOURS[j % len(_COLOURS)]
        label = f"{name} {j + number_from}"
        if metrics is not None:
            label += (
                f": rise {float(metrics.rise_time[j]) * time_scale:.3g} {unit}, "
                f"overshoot {float(metrics.overshoot[j]):.1f} %"
            )
            if bool(metrics.rise_ill_conditioned[j]):
                label += " (rise ill-conditioned)"
        ax.plot(t_axis, theta[:, j], color=colour, label=label)
        ax.axhline(target[j], color=colour, lw=0.6, ls=":")
        if desired is not None:
            des = np.degrees(
                np.asarray([np.asarray(desired(t))[j] for t in times[:: max(1, len(times) // 400)]])
            )
            ax.plot(t_axis[:: max(1, len(times) // 400)], des, color=colour, ls="--", lw=0.8)
        if metrics is not None:
            for name in ("t10", "t90"):
                t = float(getattr(metrics, name)[j])
                if np.isfinite(t):
                    level = 0.1 if name == "t10" else 0.9
                    ax.plot(t * time_scale, level * target[j], "o", color=colour, ms=4)
            t_peak = float(metrics.peak_time[j])
            peak = float(metrics.peak_value[j]) * target[j]
            if float(metrics.overshoot[j]) > 0.05:
                ax.annotate(
                    f"{float(metrics.overshoot[j]):.1f} %",
                    (t_peak * time_scale, peak),
                    textcoords="offset points",
                    xytext=(4, 4 if peak > 0 else -12),
                    color=colour,
                    fontsize=8,
                )
                ax.plot(t_peak * time_scale, peak, "v" if peak > 0 else "^", color=colour, ms=5)
            if bool(metrics.settled[j]) and not bool(metrics.settling_ill_posed[j]):
                ax.axvline(
                    float(metrics.settling_time[j]) * time_scale, color=colour, lw=0.6, ls="-."
                )
    ax.set_xlabel(time_label)
    ax.set_ylabel(f"{name} angle [deg]")
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    return fig


def _time_text(t: float) -> str:
    """A time for a title: four significant digits, without an exponent from 0.001 to 99,999
    (``1354``, not ``1.35e+03``)."""
    if t != 0 and not 1e-3 <= abs(t) < 1e5:
        return f"{t:.3g}"
    return f"{t:.4g}" if abs(t) < 1e4 else f"{t:.0f}"


def _limits_of(frames) -> tuple[np.ndarray, float]:
    points = np.concatenate([np.concatenate(polygons) for polygons in frames])
    centre = 0.5 * (points.max(0) + points.min(0))
    half = 0.55 * float(np.max(points.max(0) - points.min(0)))
    return centre, half


def _colours(has_base: bool, n_polygons: int) -> list:
    colours = [_COLOURS[i % len(_COLOURS)] for i in range(n_polygons - has_base)]
    return ["0.8", *colours] if has_base else colours


def _draw_polygons(ax, has_base, polygons, centre, half, alpha: float = 0.8, axes: bool = True):
    collection = Poly3DCollection(
        polygons,
        facecolors=_colours(has_base, len(polygons)),
        edgecolors="k",
        linewidths=0.5,
        alpha=alpha,
    )
    ax.add_collection3d(collection)
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, strict=True):
        setter(c - half, c + half)
    # Without axes (animations) the box is only room around the panels: zoom in on them.
    ax.set_box_aspect((1, 1, 1), zoom=1.0 if axes else 1.6)
    if axes:
        ax.set_xlabel("x [µm]")
        ax.set_ylabel("y [µm]")
        ax.set_zlabel("z [µm]")
    else:
        ax.set_axis_off()
    return collection


def draw_state(system, q, *, ax, centre=None, half=None, alpha: float = 0.8):
    """Draw every panel of a folding system (or mechanism) at coordinates `q` on a 3D axis (the fixed
    base, if the mechanism has one, in grey)."""
    mechanism = _mechanism(system)
    polygons = _polygons(mechanism, q)
    if centre is None:
        centre, half = _limits_of([polygons])
    _draw_polygons(ax, mechanism.base_outline() is not None, polygons, centre, half, alpha)


def folding_frames(
    system,
    trajectory,
    path: str | Path | None = None,
    *,
    n_frames: int = 6,
    t_max: float | None = None,
    time_scale: float = 1.0,
    time_unit: str = "µs",
    by_motion: bool = False,
):
    """A strip of 3D frames of a folding (paper Figs. 8, 11); saved as PNG when `path` is given.

    **Arguments:** `system`: the `FoldingSystem` (or its mechanism) that was simulated; `trajectory`:
    its `Trajectory`; `n_frames` frames evenly spread over the samples up to `t_max` (time units),
    or with `by_motion` spread over an equal blend of time and of the distance the panels travel
    (more frames where they move fast, as `animate_folding` does); `time_scale`, `time_unit`: how
    titles show times.

    **Returns:** the `Figure`.
    """
    frames = frame_set(system, trajectory, n_frames, t_max, by_motion=by_motion)
    return draw_frames(frames, path, time_scale=time_scale, time_unit=time_unit)


def draw_frames(
    frames: FrameSet, path: str | Path | None = None, *, time_scale=1.0, time_unit="µs"
):
    """`folding_frames` of a `FrameSet` (matplotlib only); saved as PNG when `path` is given.
    **Returns:** the `Figure`."""
    centre, half = _limits_of(frames.polygons)
    n = len(frames.polygons)
    fig = plt.figure(figsize=(2.6 * n, 3.0))
    # Fixed margins: a constrained layout measures every 3D axis' ticks and labels to place them,
    # most of the strip's drawing time, for the same even row of frames.
    fig.subplots_adjust(left=0.03, right=0.96, bottom=0.03, top=0.92, wspace=0.3)
    for i, (time, polygons) in enumerate(zip(frames.times, frames.polygons, strict=True)):
        ax = fig.add_subplot(1, n, i + 1, projection="3d")
        _draw_polygons(ax, frames.has_base, polygons, centre, half)
        ax.set_title(f"t = {_time_text(float(time) * time_scale)} {time_unit}", fontsize=9)
        ax.view_init(elev=20, azim=-30)
        ax.tick_params(labelsize=6)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def animate_folding(
    system,
    trajectory,
    path: str | Path,
    *,
    n_frames: int = 24,
    fps: int = 12,
    t_max: float | None = None,
    time_scale: float = 1.0,
    time_unit: str = "µs",
    size: float = 4.0,
    dpi: int = 90,
    axes: bool = False,
) -> Path:
    """Save a GIF of a folding (paper Figs. 8, 11).

    **Arguments:** as for `folding_frames`, and `fps` (frames per second), `size` (inches) and
    `dpi` of the square picture, `axes` (draw the 3D axes with their ticks; off by default, a third
    of each frame's drawing time). Frames are spread over time and motion alike (dense where the
    panels move fast), with the last frame held for a second.

    Each frame only moves the panels (the same `Poly3DCollection` throughout), is drawn once into
    matplotlib's Agg canvas and written with Pillow directly (matplotlib's animation writers draw
    every frame twice).

    **Returns:** the path written.
    """
    frames = frame_set(system, trajectory, n_frames, t_max, by_motion=True)
    return draw_animation(
        frames, path, fps=fps, time_scale=time_scale, time_unit=time_unit, size=size, dpi=dpi,
        axes=axes,
    )  # fmt: skip


def draw_animation(
    frames: FrameSet,
    path: str | Path,
    *,
    fps: int = 12,
    time_scale: float = 1.0,
    time_unit: str = "µs",
    size: float = 4.0,
    dpi: int = 90,
    axes: bool = False,
) -> Path:
    """`animate_folding` of a `FrameSet` (matplotlib and Pillow only). **Returns:** the path."""
    centre, half = _limits_of(frames.polygons)
    fig = plt.figure(figsize=(size, size), dpi=dpi)
    ax = fig.add_subplot(projection="3d")
    collection = _draw_polygons(ax, frames.has_base, frames.polygons[0], centre, half, axes=axes)
    ax.view_init(elev=20, azim=-30)
    title = ax.set_title("")

    def draw(k):
        collection.set_verts(frames.polygons[k])
        title.set_text(f"t = {_time_text(float(frames.times[k]) * time_scale)} {time_unit}")

    try:
        return save_gif(fig, draw, len(frames.polygons), path, fps=fps, hold_last_s=1.0)
    finally:
        plt.close(fig)
