"""`origami-jax unfold` and the pictures of an unfolding."""

import numpy as np
import pytest

from origami_jax.cli import main


def test_unfold_open_chain_writes_path(tmp_path, capsys):
    code = main(["unfold", "open-chain", "--out", str(tmp_path), "--no-pictures"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "verdict: flat-unfolded" in text
    data = np.load(tmp_path / "path.npz")
    assert data["directions"].ndim == 3 and data["directions"].shape[2] == 3
    header = (tmp_path / "path.csv").read_text().splitlines()[0]
    assert header.startswith("step,path_length_rad,energy,fold_1_deg")


def test_unfold_unknown_target_is_a_usage_error(tmp_path, capsys):
    assert main(["unfold", "tesseract", "--out", str(tmp_path)]) == 2
    assert "unknown example" in capsys.readouterr().err


def test_unfold_missing_fold_file(tmp_path, capsys):
    code = main(["unfold", str(tmp_path / "missing.fold"), "--out", str(tmp_path)])
    assert code == 2


def test_pictures(tmp_path):
    pytest.importorskip("matplotlib")
    from origami_jax.plotting import vertex as vertex_plots
    from origami_jax.vertex import open_chain_vertex, unfold

    result = unfold(open_chain_vertex())
    written = vertex_plots.save_unfolding_pictures(result, tmp_path, stem="oc", gif_frames=4)
    assert [p.name for p in written] == ["oc_strip.png", "oc_energy.png", "oc.gif"]
    assert all(p.stat().st_size > 1000 for p in written)
