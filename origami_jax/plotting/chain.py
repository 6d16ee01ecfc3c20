"""Figures of a folding: hinge angles with metrics (paper Figs. 7, 10) and the panels in 3D as an
animation and a strip of frames (Figs. 8, 11), for any mechanism (chains, panel trees).

Matplotlib only; imported explicitly (`from origami_jax.plotting import chain as chain_plots`).
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

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
):
    """Joint angles (degrees) against time, one line per joint, metrics annotated (paper Figs. 7, 10).

    **Arguments:**
    - `trajectory`: a [`origami_jax.simulation.Trajectory`][] (not batched).
    - `metrics`: its [`origami_jax.simulation.ResponseMetrics`][], or `None`: marks the 10 % and 90 %
      crossings, the peak with its overshoot, and the settling time; flags are shown in the legend.
    - `time_scale`: multiply times by this for the axis (e.g. 1e-3 for ms from µs); `time_label` to match.
    - `desired`: optional callable `t -> θ_des` drawn dashed (e.g. `EtchRamp.desired` returning a pair).
    - `title`: axis title.

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
        label = f"joint {j + 1}"
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
                    f"{float(metrics.overshoot[j]):.0f} %",
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
    ax.set_ylabel("joint angle [deg]")
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    return fig


def _mechanism(obj):
    """The mechanism of a `FoldingSystem`, or the mechanism itself."""
    return getattr(obj, "mechanism", obj)


def _polygons(mechanism, q) -> list[np.ndarray]:
    polygons = list(mechanism.panel_polygons(np.asarray(q)))
    base = mechanism.base_outline()
    return polygons if base is None else [np.asarray(base), *polygons]


def _limits(mechanism, states) -> tuple[np.ndarray, float]:
    points = np.concatenate([np.concatenate(_polygons(mechanism, q)) for q in states])
    centre = 0.5 * (points.max(0) + points.min(0))
    half = 0.55 * float(np.max(points.max(0) - points.min(0)))
    return centre, half


def draw_state(system, q, *, ax, centre=None, half=None, alpha: float = 0.8):
    """Draw every panel of a folding system (or mechanism) at coordinates `q` on a 3D axis (the fixed
    base, if the mechanism has one, in grey)."""
    mechanism = _mechanism(system)
    polygons = _polygons(mechanism, q)
    has_base = mechanism.base_outline() is not None
    colours = [_COLOURS[i % len(_COLOURS)] for i in range(len(polygons) - has_base)]
    if has_base:
        colours = ["0.8", *colours]
    ax.add_collection3d(
        Poly3DCollection(polygons, facecolors=colours, edgecolors="k", linewidths=0.5, alpha=alpha)
    )
    if centre is None:
        centre, half = _limits(mechanism, [q])
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, strict=True):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x [µm]")
    ax.set_ylabel("y [µm]")
    ax.set_zlabel("z [µm]")


def _states(trajectory, indices) -> np.ndarray:
    q = trajectory.theta if trajectory.state is None else trajectory.state[0]
    return np.asarray(q)[indices]


def _frame_indices(trajectory, n_frames: int, t_max: float | None) -> np.ndarray:
    times = np.asarray(trajectory.times)
    last = len(times) - 1 if t_max is None else int(np.searchsorted(times, t_max))
    return np.unique(np.linspace(0, min(last, len(times) - 1), n_frames).round().astype(int))


def folding_frames(
    system,
    trajectory,
    path: str | Path | None = None,
    *,
    n_frames: int = 6,
    t_max: float | None = None,
    time_scale: float = 1.0,
    time_unit: str = "µs",
):
    """A strip of 3D frames of a folding (paper Figs. 8, 11); saved as PNG when `path` is given.

    **Arguments:** `system`: the `FoldingSystem` (or its mechanism) that was simulated; `trajectory`:
    its `Trajectory`; `n_frames` frames evenly spread over the samples up to `t_max` (time units);
    `time_scale`, `time_unit`: how titles show times.

    **Returns:** the `Figure`.
    """
    mechanism = _mechanism(system)
    indices = _frame_indices(trajectory, n_frames, t_max)
    states = _states(trajectory, indices)
    centre, half = _limits(mechanism, states)
    fig = plt.figure(figsize=(2.6 * len(indices), 3.0), constrained_layout=True)
    for i, (index, q) in enumerate(zip(indices, states, strict=True)):
        ax = fig.add_subplot(1, len(indices), i + 1, projection="3d")
        draw_state(mechanism, q, ax=ax, centre=centre, half=half)
        ax.set_title(
            f"t = {float(trajectory.times[index]) * time_scale:.3g} {time_unit}", fontsize=9
        )
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
    n_frames: int = 60,
    fps: int = 15,
    t_max: float | None = None,
    time_scale: float = 1.0,
    time_unit: str = "µs",
) -> Path:
    """Save a GIF of a folding (paper Figs. 8, 11) with matplotlib's `PillowWriter`; arguments as for
    `folding_frames`.

    **Returns:** the path written.
    """
    path = Path(path)
    mechanism = _mechanism(system)
    indices = _frame_indices(trajectory, n_frames, t_max)
    states = _states(trajectory, indices)
    centre, half = _limits(mechanism, states)
    fig = plt.figure(figsize=(4.5, 4.5))
    ax = fig.add_subplot(projection="3d")

    def update(i):
        ax.cla()
        draw_state(mechanism, states[i], ax=ax, centre=centre, half=half)
        ax.view_init(elev=20, azim=-30)
        ax.set_title(f"t = {float(trajectory.times[indices[i]]) * time_scale:.4g} {time_unit}")
        return ()

    animation = FuncAnimation(fig, update, frames=len(indices), blit=False)
    animation.save(path, writer=PillowWriter(fps=fps))
    plt.close(fig)
    return path
