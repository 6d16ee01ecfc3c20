"""`origami-jax sweep CONFIG.toml --out DIR [--resume]`, config parsing and summary plots.

The model is the engine tests' damped-oscillator fixture, registered for these tests only.
"""

import pytest
import xarray as xr

from origami_jax.cli import main
from origami_jax.sweep import _kernels, load_config
from tests.test_sweep_engine import KERNEL, same_sweep

CONFIG = """
[model]
name = "test-oscillator"

[sweep]
kind = "{kind}"
{extra}

[parameters]
zeta = {{ min = -0.1, max = 1.2, num = 6 }}
omega = {{ min = 0.5, max = 5.0, num = 3, scale = "log" }}

[plots]
metrics = ["rise_time", "overshoot"]
"""


def _register(monkeypatch):
    model = _kernels._Model("test fixture", lambda: KERNEL)
    monkeypatch.setitem(_kernels.MODELS, "test-oscillator", model)


def test_cli_sweep_writes_dataset_plots_and_resumes(tmp_path, monkeypatch, capsys):
    _register(monkeypatch)
    config = tmp_path / "sweep.toml"
    config.write_text(CONFIG.format(kind="grid", extra="chunk_size = 5"))
    out = tmp_path / "out"
    argv = ["sweep", str(config), "--out", str(out), "--no-progress"]
    assert main(argv) == 1  # ran, but some designs (zeta <= 0, zeta >= 1) failed
    ds = xr.load_dataset(out / "sweep.nc")
    assert ds.sizes["design"] == 18 and ds.attrs["n_failed"] == 6
    assert ds["omega"].attrs["units"] == "rad/s"
    plots = sorted(p.name for p in (out / "plots").glob("*.png"))
    assert "rise_time_vs_zeta.png" in plots and "overshoot_map_zeta_omega.png" in plots
    summary = (out / "summary.txt").read_text()
    assert "result 1 (invalid_input): 3 designs" in summary
    assert "computing and storing chunks" in summary
    assert main(argv) == 2  # refuses to overwrite
    assert "resume" in capsys.readouterr().err
    assert main(argv + ["--resume", "--no-plots"]) == 1
    same_sweep(xr.load_dataset(out / "sweep.nc"), ds)


def test_config_samples_are_crossed_with_listed_values(tmp_path, monkeypatch):
    _register(monkeypatch)
    config = tmp_path / "lhs.toml"
    text = CONFIG.format(kind="lhs", extra="n = 10\nseed = 4").replace(
        'omega = { min = 0.5, max = 5.0, num = 3, scale = "log" }',
        "omega = { values = [1.0, 2.0] }",
    )
    config.write_text(text)
    parsed = load_config(config)
    assert parsed.space.size == 20 and parsed.space.names == ("omega", "zeta")
    assert parsed.space.units == {"omega": "rad/s", "zeta": "1"}


def test_cli_reports_models_and_bad_configs(tmp_path, capsys):
    assert main(["sweep", "--list-models"]) == 0
    listing = capsys.readouterr().out
    assert "accordion-step:" in listing and "vertex-unfold:" in listing
    bad = tmp_path / "bad.toml"
    bad.write_text('[model]\nname = "no-such-model"\n[parameters]\nx = { values = [1] }\n')
    assert main(["sweep", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "unknown model" in capsys.readouterr().err
    assert main(["sweep"]) == 2
    for text, message in (
        ('model = "accordion"\n', "[model] must be a table (a [model] header and its keys), got"),
        (
            '[model]\nname = "accordion"\ninput = "step"\ntend = 5\n[parameters]\nk_scale = { values = [1] }\n',
            "unknown setting 'tend' (did you mean t_end?); its settings are n_flaps,",
        ),
        ("[space]\n", f"bad config {bad}: unknown section(s) ['space']."),  # the file named once
    ):
        bad.write_text(text)
        assert main(["sweep", str(bad), "--out", str(tmp_path / "o")]) == 2
        assert message in capsys.readouterr().err


@pytest.mark.slow  # a whole program of its own to compile; the default run stays under 10 min
def test_every_example_config_loads():
    # The shipped examples name real models, settings and parameters (they are run in full by
    # the slow test below and by users).
    from pathlib import Path

    examples = sorted((Path(__file__).parent.parent / "examples").glob("sweep_*.toml"))
    assert len(examples) >= 4
    for path in examples:
        load_config(path)


@pytest.mark.slow
def test_the_waterbomb_example_sweeps_a_closed_loop_pattern_with_contact(tmp_path):
    # A closed-loop pattern with contact through the command line: every design folds.
    from pathlib import Path

    example = Path(__file__).parent.parent / "examples" / "sweep_waterbomb.toml"
    out = tmp_path / "out"
    assert main(["sweep", str(example), "--out", str(out), "--no-progress", "--no-plots"]) == 0
    ds = xr.load_dataset(out / "sweep.nc")
    assert ds.sizes["design"] == 6 and (ds["verdict"].values == 0).all()
