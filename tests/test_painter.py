"""The fold command's figure worker (`origami_jax.cli._painter`): the figures it draws in a process
of its own are the ones the command would draw itself, and where it cannot start or dies the
command draws them."""

from pathlib import Path

import numpy as np

from origami_jax.cli import _painter
from origami_jax.plotting.frames import FrameSet


def _job(out: Path, animation: bool = True) -> _painter.FoldFigures:
    square = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [100.0, 100.0, 0.0], [0.0, 100.0, 0.0]])

    def frames(n):
        angles = np.linspace(0.0, np.pi / 2, n)
        polygons = [
            [square, square @ np.array([[1, 0, 0], [0, np.cos(a), np.sin(a)], [0, 0, 1.0]])]
            for a in angles
        ]
        return FrameSet(np.linspace(0.0, 50.0, n), polygons, True)

    times = np.linspace(0.0, 100.0, 41)
    theta = np.column_stack([np.minimum(times / 50.0, 1.0) * np.pi / 2, 0.1 * np.sin(times)])
    return _painter.FoldFigures(
        out=out,
        title="test: folded",
        times=times,
        theta=theta,
        target=np.array([np.pi / 2, 0.0]),
        time_to_fold=50.0,
        frames=frames(3),
        animation=frames(5) if animation else None,
    )


def test_the_worker_draws_the_figures_the_command_would(tmp_path):
    here, there = tmp_path / "here", tmp_path / "there"
    here.mkdir()
    there.mkdir()
    names = _painter.paint(_job(here))
    assert names == ["angles.png", "frames.png", "animation.gif"]
    with _painter.Painter() as painter:
        assert painter._process is not None  # a worker of its own
        painter.send(_job(there))
        assert painter.finish() == names
    for name in names:  # the same bytes: the same drawing, whichever process drew it
        assert (here / name).read_bytes() == (there / name).read_bytes(), name
    png = tmp_path / "png"
    png.mkdir()
    with _painter.Painter() as painter:
        painter.send(_job(png, animation=False))
        assert painter.finish() == ["angles.png", "frames.png"]


def test_without_a_worker_the_command_draws_them(tmp_path, monkeypatch):
    with _painter.Painter(enabled=False) as painter:  # figures in this process, as asked
        painter.send(_job(tmp_path / "off"))
        (tmp_path / "off").mkdir()
        assert painter.finish() == ["angles.png", "frames.png", "animation.gif"]
    with _painter.Painter() as painter:  # a worker gone before its job
        painter._process.kill()
        painter._process.wait()
        (tmp_path / "gone").mkdir()
        painter.send(_job(tmp_path / "gone"))
        assert len(painter.finish()) == 3
    monkeypatch.setattr(_painter, "_start_worker", lambda: None)  # none could start
    with _painter.Painter() as painter:
        (tmp_path / "none").mkdir()
        painter.send(_job(tmp_path / "none"))
        assert len(painter.finish()) == 3
    for folder in ("off", "gone", "none"):
        assert (tmp_path / folder / "animation.gif").stat().st_size > 1000


def test_a_worker_without_a_job_ends_with_the_command():
    painter = _painter.Painter()
    process = painter._process
    with painter:
        pass  # the command failed before its figures
    assert process.poll() is not None
