"""`origami-jax paper`, the main job: its cheap part in the default suite, the whole command as a slow case."""

import json

import pytest

from origami_jax.cli import main


@pytest.mark.slow  # the catalogue's certificates run by default
def test_unfolding_part_certifies_the_fig3_examples(tmp_path):
    from origami_jax.cli import _paper_unfolding

    lines = _paper_unfolding.run(tmp_path)
    figures = [line for line in lines if line.startswith("Fig. 3")]
    assert len(figures) == 4  # corner cube and waterbomb, both energies
    for line in figures:
        assert "flat-unfolded" in line and "certificate OK" in line, line
    folder = tmp_path / "unfolding"
    for stem in ("corner_cube", "waterbomb"):
        assert (folder / f"{stem}_separable_strip.png").stat().st_size > 0
        assert (folder / f"{stem}_separable_path.csv").stat().st_size > 0


@pytest.mark.slow
def test_paper_command_end_to_end(tmp_path, capsys):
    # ~3 min on 2 cores for the paper's parts, plus the extended model's comparison and its
    # plausible calibration (one fit per model variant: tens of minutes on 2 cores).
    assert main(["paper", "--extended", "--out", str(tmp_path)]) == 0
    summary = (tmp_path / "summary.txt").read_text()
    for part in (
        "single-vertex unfolding",
        "accordion dynamics",
        "hinge calibration to Fig. 7",
        "the paper's model and the extended one",
    ):
        assert f"## {part}" in summary
    metrics = json.loads((tmp_path / "dynamics_metrics.json").read_text())
    assert {"step_air", "step_koh", "fast_ramp_air", "fast_ramp_koh", "slow_ramp_koh"} <= set(
        metrics
    )
    calibration = json.loads((tmp_path / "calibration" / "fig7_calibration.json").read_text())
    # The paper's Fig. 7 (rise 37 / 101 / 38 µs, overshoot 39 %) is reached to within 10 % per target
    # (SPEC: identical hinges cannot meet all four exactly; the best compromise misses by ≤ 7 %).
    assert calibration["cost"] < 0.01
    assert (tmp_path / "calibration" / "fig7_calibration_response.png").stat().st_size > 0
    extended = json.loads((tmp_path / "calibration" / "extended_fig7.json").read_text())
    assert set(extended["variants"]) == {"paper", "viscous", "added_mass", "arc", "all"}
    for fit in extended["variants"].values():
        for value in fit["parameters"].values():
            assert value["lower"] <= value["value"] <= value["upper"]
    comparison = json.loads((tmp_path / "paper_vs_extended.json").read_text())
    assert {"step_air", "step_koh", "ramp_koh"} <= set(comparison)
    assert (tmp_path / "paper_vs_extended.png").stat().st_size > 0


def test_extended_part_runs_only_when_asked():
    from origami_jax.cli._paper import _parts

    assert "the paper's model and the extended one" not in [title for title, _ in _parts()]
    assert "the paper's model and the extended one" in [title for title, _ in _parts(extended=True)]
