"""`origami-jax design`: usage errors are fast and clear; a full run (slow) writes JSON and a figure."""

import json

import pytest

from origami_jax.cli import main


def test_bad_number_is_a_usage_error(tmp_path, capsys):
    assert main(["design", "--target-rise", "37e-6,abc", "--out", str(tmp_path)]) == 2
    assert "'abc' is not a number" in capsys.readouterr().err


def test_unknown_parameter_is_a_usage_error(tmp_path, capsys):
    code = main(["design", "--target-rise", "37e-6", "--free", "stiffness", "--out", str(tmp_path)])
    assert code == 2
    assert "not a free parameter" in capsys.readouterr().err


def test_no_target_is_a_usage_error(tmp_path, capsys):
    assert main(["design", "--out", str(tmp_path)]) == 2


@pytest.mark.slow
def test_design_writes_json_and_figure(tmp_path, capsys):
    code = main(
        [
            "design",
            "--target-rise", "40e-6,-,-",
            "--target-overshoot", "0.4",
            "--free", "k_scale,b_scale",
            "--bounds", "k_scale=0.1:100,b_scale=0.1:1000",
            "--starts", "2",
            "--out", str(tmp_path),
        ]
    )  # fmt: skip
    assert code in (0, 1)
    data = json.loads((tmp_path / "design.json").read_text())
    assert set(data["parameters"]) == {"k_scale", "b_scale"}
    assert data["targets"][0]["label"] == "rise_time[joint 1]"
    assert (tmp_path / "design_response.png").stat().st_size > 1000
    assert "Verdict" in capsys.readouterr().out
