"""The fold command's figures, drawn in a process of their own while the command writes its files.

Importing matplotlib (~0.3 s) and drawing a fold's angle plot, frames strip and GIF (~0.5 s) were
a fifth of a warm `origami-jax fold`. A `Painter` starts a second Python process as the fold
begins: it imports matplotlib while the command loads and runs its programs, then waits for a
`FoldFigures` job, plain arrays the command computed (the sample angles, each frame's panel
outlines: `origami_jax.plotting.frames.frame_set`), and draws it while the command writes its
result, trajectory and FOLD frames. The same `paint` draws in the command's own process where
the second one cannot start, fails, or is not wanted (`Painter(enabled=False)`): the figures are
the same either way.
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
from pathlib import Path
from typing import Any, NamedTuple

_WAIT_S = 300.0  # the worker's drawing takes about a second; beyond this it is stuck


class FoldFigures(NamedTuple):
    """What `paint` draws into `out`: `angles.png` (the crease angles `theta` `(t, m)` (rad) at
    `times` `(t,)` (µs) against their `target` `(m,)`, titled `title`, the time to fold marked
    where there is one), `frames.png` (`frames`, a `FrameSet`) and, with `animation` (a
    `FrameSet`), `animation.gif`."""

    out: Path
    title: str
    times: Any
    theta: Any
    target: Any
    time_to_fold: float | None
    frames: Any
    animation: Any = None


class _Angles(NamedTuple):
    times: Any
    theta: Any
    target: Any


def paint(job: FoldFigures) -> list[str]:
    """Draw `job` in this process; returns the names of the files written."""
    import matplotlib.pyplot as plt

    from origami_jax.plotting import chain as plots

    angles = _Angles(job.times, job.theta, job.target)
    fig = plots.plot_joint_angles(angles, None, title=job.title, name="crease", number_from=0)
    if job.time_to_fold is not None:
        fig.axes[0].axvline(job.time_to_fold, color="k", lw=0.8, ls="--")
        fig.axes[0].annotate(
            f" folded at {job.time_to_fold:.4g} µs",
            (job.time_to_fold, 0.02),
            xycoords=("data", "axes fraction"),
            fontsize=8,
        )
    fig.savefig(job.out / "angles.png", dpi=120)
    plt.close(fig)
    plt.close(plots.draw_frames(job.frames, job.out / "frames.png"))
    if job.animation is None:
        return ["angles.png", "frames.png"]
    plots.draw_animation(job.animation, job.out / "animation.gif")
    return ["angles.png", "frames.png", "animation.gif"]


class Painter:
    """Draws `FoldFigures` jobs in a worker process started at construction (module docstring);
    with `enabled=False`, or where it cannot start, in this process. Use as a context manager:
    leaving it ends a worker whose job was not finished (`finish`)."""

    def __init__(self, enabled: bool = True):
        self._process: subprocess.Popen | None = None
        self._job: FoldFigures | None = None
        if enabled:
            self._process = _start_worker()

    def __enter__(self) -> Painter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def send(self, job: FoldFigures) -> None:
        """Start drawing `job` (in the worker, where there is one: this returns at once)."""
        self._job = job
        if self._process is not None:
            stdin, self._process.stdin = self._process.stdin, None  # (`communicate` skips it)
            try:
                stdin.write(pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL))
                stdin.close()  # the end of the job: the worker draws
            except OSError:  # the worker is gone: `finish` draws here
                _close(stdin)
                self._stop()

    def finish(self) -> list[str]:
        """The names of the files the job wrote, once written (drawn here if the worker failed)."""
        job, self._job = self._job, None
        if job is None:
            return []
        process, self._process = self._process, None
        if process is not None:
            try:
                out, _ = process.communicate(timeout=_WAIT_S)
                if process.returncode == 0:
                    return json.loads(out.decode().strip().splitlines()[-1])
            except (subprocess.TimeoutExpired, ValueError, IndexError):
                _end(process)
        return paint(job)

    def close(self) -> None:
        """End the worker if it is still there: the command ended without its figures (failed
        or interrupted before `finish`)."""
        self._job = None
        self._stop()

    def _stop(self) -> None:
        process, self._process = self._process, None
        if process is not None:
            _end(process)


def _end(process: subprocess.Popen) -> None:
    """Kill the worker `process` if it still runs, close its pipes and reap it."""
    if process.poll() is None:
        process.kill()
    for stream in (process.stdin, process.stdout):
        _close(stream)
    process.wait()


def _close(stream) -> None:
    """Close a pipe whose other end may be gone."""
    if stream is not None:
        try:
            stream.close()
        except OSError:
            pass


def _start_worker() -> subprocess.Popen | None:
    """A Python process running `serve`, with this package importable as here; `None` where it
    cannot start."""
    root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ)  # (`serve` chooses matplotlib's Agg backend itself)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))
    try:
        return subprocess.Popen(
            [sys.executable, "-c", "from origami_jax.cli._painter import serve; serve()"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=env,
        )
    except OSError:
        return None


def serve() -> None:
    """The worker: import matplotlib, read one `FoldFigures` job from standard input (none: the
    command ended without figures), draw it, print the names of the files written (JSON)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401  (imported while the command folds)

    from origami_jax.plotting import chain  # noqa: F401

    data = sys.stdin.buffer.read()
    if not data:
        return
    print(json.dumps(paint(pickle.loads(data))), flush=True)
