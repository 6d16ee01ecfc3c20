"""Animated GIFs drawn once per frame and written with Pillow.

matplotlib's `FuncAnimation.save(writer=PillowWriter(...))` draws every frame twice (once for the
animation's own update, once more to grab it); drawing into the Agg canvas and handing its pixels
to Pillow draws each frame once.
"""

from collections.abc import Callable
from pathlib import Path

import numpy as np


def save_gif(
    fig,
    draw: Callable[[int], object],
    n_frames: int,
    path: str | Path,
    *,
    fps: int = 12,
    hold_last_s: float = 0.0,
    colours: int = 64,
) -> Path:
    """Call `draw(k)` for each frame `k`, render `fig` once and write the frames as a looping GIF
    (`fps` frames per second, the last one shown at least `hold_last_s` seconds, a palette of
    `colours` colours per frame). Closes nothing: the caller owns `fig`.

    **Returns:** the path written.
    """
    from PIL import Image

    path = Path(path)
    images = []
    for k in range(n_frames):
        draw(k)
        fig.canvas.draw()
        rgb = Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3])  # pyright: ignore
        images.append(rgb.quantize(colors=colours, method=Image.Quantize.FASTOCTREE))
    durations = [round(1000 / fps)] * len(images)
    durations[-1] = max(durations[-1], round(1000 * hold_last_s))
    images[0].save(
        path, save_all=True, append_images=images[1:], duration=durations, loop=0, optimize=False
    )
    return path
