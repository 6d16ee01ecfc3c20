"""Pictures of single-vertex unfoldings (paper Figs. 2, 3): flaps as 3D sectors, strips of frames,
an animation, and energy / fold angles against the path parameter. Needs matplotlib (and pillow
for GIFs)."""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ._gif import save_gif

__all__ = [
    "animate_unfolding",
    "draw_flaps",
    "plot_energy_and_folds",
    "plot_unfolding_strip",
    "save_unfolding_pictures",
]

_FRONT = "#f2c14e"
_BACK = "#4a90c2"


def _slerp(a, b, samples):
    angle = np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b))
    t = np.linspace(0.0, 1.0, samples)[:, None]
    return (np.sin((1 - t) * angle) * a + np.sin(t * angle) * b) / np.sin(angle)


def draw_flaps(ax, x, *, closed: bool, radius: float = 1.0, samples: int = 16, nodes: bool = True):
    """Draw a state as circular sectors from the vertex (paper Fig. 3) on a 3D axis.

    **Arguments:**
    - `ax`: a matplotlib 3D axis; `x`: `(n, 3)` unit crease directions; `closed`: chain kind.
    - `radius`: sector radius (unit sphere = 1); `samples`: points per arc.
    - `nodes`: mark the crease ends (the charges of Fig. 2) in red.
    Flaps alternate two colours so that neighbours can be told apart.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    polys, colours = [], []
    for i in range(n if closed else n - 1):
        arc = radius * _slerp(x[i], x[(i + 1) % n], samples)
        polys.append(np.vstack([np.zeros(3), arc]))
        colours.append(_FRONT if i % 2 == 0 else _BACK)
    ax.add_collection3d(
        Poly3DCollection(polys, facecolors=colours, edgecolors="k", linewidths=0.5, alpha=0.85)
    )
    for i in range(n):
        ax.plot([0, radius * x[i, 0]], [0, radius * x[i, 1]], [0, radius * x[i, 2]], "k-", lw=0.8)
    if nodes:
        ax.scatter(*(radius * x).T, color="crimson", s=12, depthshade=False)
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1, 1)
    ax.set_zlim(-1, 1)
    ax.set_box_aspect((1, 1, 1))
    ax.set_axis_off()


def _frames(result, fractions):
    s = np.asarray(result.path_length)
    total = s[-1] if s[-1] > 0 else 1.0
    return [int(np.argmin(np.abs(s / total - f))) for f in fractions]


def _aligned(result):
    """The path rotated so that its end state lies in the xy-plane (a steady view for pictures)."""
    end = np.asarray(result.path[-1])
    _, _, vt = np.linalg.svd(end)
    basis = vt.copy()
    if np.linalg.det(basis) < 0:
        basis[2] *= -1
    return np.asarray(result.path) @ basis.T


def plot_unfolding_strip(
    result, fractions=(0.0, 0.25, 0.5, 0.75, 1.0), *, title: str | None = None
):
    """A row of frames of the unfolding at the given path fractions (paper Fig. 3).

    **Returns:** the matplotlib figure.
    """
    path = _aligned(result)
    frames = _frames(result, fractions)
    fig = plt.figure(figsize=(2.6 * len(frames), 2.9))
    for k, (frac, idx) in enumerate(zip(fractions, frames, strict=True)):
        ax = fig.add_subplot(1, len(frames), k + 1, projection="3d")
        draw_flaps(ax, path[idx], closed=result.vertex.closed)
        ax.view_init(elev=25, azim=-60)
        ax.set_title(f"s = {frac:.2f}", fontsize=9)
    fig.suptitle(title or f"unfolding: {result.verdict.value}", fontsize=10)
    fig.tight_layout()
    return fig


def plot_energy_and_folds(result, *, title: str | None = None):
    """Energy (log scale) and every fold angle (degrees) against the path parameter.

    The path parameter is the cumulative largest node displacement, normalised to [0, 1].
    **Returns:** the matplotlib figure.
    """
    s = np.asarray(result.path_length)
    s = s / (s[-1] if s[-1] > 0 else 1.0)
    fig, (ax_u, ax_f) = plt.subplots(2, 1, figsize=(6.5, 5.5), sharex=True)
    energy = np.asarray(result.energy)
    ok = np.isfinite(energy) & (energy > 0)
    ax_u.semilogy(s[ok], energy[ok], "k-")
    ax_u.set_ylabel(f"energy U ({result.energy_kind}, p = {result.p:g})")
    folds = np.rad2deg(np.asarray(result.fold_angles))
    creases = result.crease_report.creases
    for j in range(folds.shape[1]):
        ax_f.plot(s, folds[:, j], label=f"crease {int(creases[j])}")
    ax_f.axhline(0, color="grey", lw=0.5)
    ax_f.set_ylabel("fold angle (deg; valley +)")
    ax_f.set_xlabel("path parameter s (fraction of node travel)")
    ax_f.legend(fontsize=7, ncol=4)
    fig.suptitle(title or f"verdict: {result.verdict.value}", fontsize=10)
    fig.tight_layout()
    return fig


def animate_unfolding(result, filename: str | Path, *, frames: int = 40, fps: int = 12) -> Path:
    """Save the unfolding as an animated GIF (each frame drawn once, written with Pillow); returns
    the path."""
    path = _aligned(result)
    indices = np.unique(_frames(result, np.linspace(0, 1, frames)))
    fig = plt.figure(figsize=(4, 4))
    ax = fig.add_subplot(projection="3d")

    def draw(k):
        ax.cla()
        draw_flaps(ax, path[indices[k]], closed=result.vertex.closed)
        ax.view_init(elev=25, azim=-60)
        ax.set_title(f"step {indices[k]} / {len(path) - 1}", fontsize=9)
        return ()

    try:
        return save_gif(fig, draw, len(indices), filename, fps=fps)
    finally:
        plt.close(fig)


def save_unfolding_pictures(
    result, out: str | Path, *, stem: str = "unfolding", gif_frames: int = 40
) -> list[Path]:
    """Write `<stem>_strip.png`, `<stem>_energy.png` and `<stem>.gif` into `out`; return paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    fig = plot_unfolding_strip(result)
    fig.savefig(out / f"{stem}_strip.png", dpi=110)
    plt.close(fig)
    written.append(out / f"{stem}_strip.png")
    fig = plot_energy_and_folds(result)
    fig.savefig(out / f"{stem}_energy.png", dpi=110)
    plt.close(fig)
    written.append(out / f"{stem}_energy.png")
    written.append(animate_unfolding(result, out / f"{stem}.gif", frames=gif_frames))
    return written
