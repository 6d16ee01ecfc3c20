"""`--solver`, `--dt` and `--newton-iterations` of `fold`, `yield`, `sweep` and `design`: one place turns them
into the solve (`cli._common.solver_choice`, `with_solver`), bad values are refused in one line
before anything compiles, the choice is recorded, and a resume with another solver is refused.
"""

import dataclasses
import json
from pathlib import Path

import diffrax
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.cli import main
from origami_jax.cli._common import (
    DEFAULT_NEWTON_ITERATIONS,
    FIXED_STEP_CHOICES,
    SOLVER_CHOICES,
    with_solver,
)
from origami_jax.sweep import get_model

NET_FOLD_TOML = """
[model]
name = "net-fold"
net = "corner_cube"
contact = false
added_mass = false  # the paper's dynamics in the bath: released at once, 60 µs is a run
viscous = false
t_end = 60.0
n_save = 21
{extra}
[sweep]
kind = "grid"

[parameters]
k_scale = {{ values = [1.0, 2.0] }}
"""


PAPER = {"net": "corner_cube", "added_mass": False, "viscous": False}


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def _no_compiling(*args, **kwargs):
    raise AssertionError("a bad flag was not refused before the run")


def _config(tmp_path: Path, extra: str = "") -> Path:
    path = tmp_path / "net_fold.toml"
    path.write_text(NET_FOLD_TOML.format(extra=extra))
    return path


def test_the_flags_name_the_librarys_solvers_and_defaults():
    """The command line spells the solvers and the Newton default without importing JAX: the same
    as the library's."""
    assert SOLVER_CHOICES == sim.SOLVER_NAMES
    assert FIXED_STEP_CHOICES == tuple(sim.FIXED_STEP_SOLVERS)
    field = {f.name: f for f in dataclasses.fields(sim.ImplicitStep)}["newton_iterations"]
    assert DEFAULT_NEWTON_ITERATIONS == field.default


def test_one_place_makes_the_choice_a_solve():
    base = sim.SolveOptions(t1=100.0, rtol=1e-6)
    fixed = {"solver": "implicit-step", "dt_us": 2.5, "newton_iterations": 9}
    solver = with_solver(base, fixed).solver
    assert isinstance(solver, sim.ImplicitStep)
    assert (solver.dt, solver.newton_iterations, solver.scheme) == (2.5, 9, "euler")
    bdf2 = with_solver(base, {**fixed, "solver": "implicit-bdf2"}).solver
    assert (bdf2.dt, bdf2.newton_iterations, bdf2.scheme) == (2.5, 9, "bdf2")
    assert isinstance(with_solver(base, {"solver": "kvaerno5"}).solver, diffrax.Kvaerno5)
    assert isinstance(with_solver(base, {"solver": "tsit5"}).solver, diffrax.Tsit5)
    # The command's own default is left unnamed (a sweep store of it resumes either way).
    assert with_solver(base, {"solver": "tsit5"}, default="tsit5") is base
    assert with_solver(base, None) is base
    with pytest.raises(ValueError, match="needs dt"):
        sim.named_solver("implicit-step")
    with pytest.raises(ValueError, match="chooses its own steps"):
        sim.named_solver("tsit5", dt=1.0)
    with pytest.raises(ValueError, match="unknown solver"):
        sim.named_solver("euler")


BAD = [
    (["--dt", "2"], "--dt sets the implicit-step engine's fixed steps: add --solver"),
    (["--solver", "tsit5", "--newton-iterations", "3"], "--newton-iterations sets"),
    (["--solver", "implicit-step"], "--solver implicit-step needs --dt"),
    (["--solver", "implicit-step", "--dt", "0"], "--dt must be a positive finite number"),
    (["--solver", "implicit-step", "--dt", "nan"], "--dt must be a positive finite number"),
    (["--solver", "implicit-step", "--dt", "5000"], "--dt 5000 µs is longer than the run"),
    (["--solver", "implicit-step", "--dt", "2", "--newton-iterations", "0"], "between 1 and"),
    (["--solver", "implicit-step", "--dt", "1e-6"], "fixed steps, more than the 500,000"),
    (["--solver", "implicit-bdf2"], "--solver implicit-bdf2 needs --dt"),
    (["--solver", "implicit-bdf2", "--dt", "5000"], "--dt 5000 µs is longer than the run"),
]


@pytest.mark.parametrize("flags, message", BAD)
def test_fold_refuses_bad_solver_flags_in_one_line(flags, message, tmp_path, capsys, monkeypatch):
    import origami_jax.cli._fold as fold_cli

    monkeypatch.setattr(fold_cli, "_run", _no_compiling)
    out = tmp_path / "fold"
    assert main(["fold", "corner_cube", *flags, "--out", str(out)]) == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not out.exists()


def test_fold_refuses_an_explicit_run_past_its_step_budget(tmp_path, capsys, monkeypatch):
    """`--t1 1e12` ran 16 minutes: Tsit5's steps are at most ~4/ω_max long (the stiffest hinge's
    rest frequency), so the floor of its steps is known up front; a long but possible run says
    so in one line and runs."""
    import origami_jax.cli._fold as fold_cli

    monkeypatch.setattr(fold_cli, "_run", _no_compiling)
    out = tmp_path / "f"
    assert main(["fold", "corner_cube", "--t1", "1e12", "--release-ramp", "0", "--out", str(out)]) == 2  # fmt: skip
    line = _one_line(capsys.readouterr().err)
    assert "needs at least" in line and "explicit steps" in line and "implicit --solver" in line
    assert not out.exists()
    code = main(["yield", "corner_cube", "--t-end", "1e12", "--release-ramp", "0", "--out", str(out)])  # fmt: skip
    assert code == 2 and "more than the 200,000 a yield may take" in capsys.readouterr().err
    flags = ["--t1", "1e8", "--release-ramp", "0", "--out", str(out)]
    main(["fold", "corner_cube", *flags])
    assert "[fold] note: the stiffest hinge rings with a" in capsys.readouterr().out
    flags = ["--solver", "kvaerno5", "--t1", "1e12", "--release-ramp", "0", "--out", str(out)]
    main(["fold", "corner_cube", *flags, "--overwrite"])
    assert "explicit steps" not in capsys.readouterr().err  # implicit: no stability limit


def test_fold_refuses_a_step_longer_than_its_t1(tmp_path, capsys, monkeypatch):
    import origami_jax.cli._fold as fold_cli

    monkeypatch.setattr(fold_cli, "_run", _no_compiling)
    flags = ["--solver", "implicit-step", "--dt", "20", "--t1", "10"]
    assert main(["fold", "corner_cube", *flags, "--out", str(tmp_path / "f")]) == 2
    assert "longer than the run (--t1: 10 µs)" in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize(
    "flags, message",
    [
        *BAD,
        (
            ["--solver", "implicit-step", "--dt", "2", "--rtol", "1e-5"],
            "--rtol is for the adaptive",
        ),
        (
            ["--solver", "implicit-step", "--dt", "2", "--step-budget", "100"],
            "--step-budget is for",
        ),
    ],
)
def test_yield_refuses_bad_solver_flags_in_one_line(flags, message, tmp_path, capsys, monkeypatch):
    import origami_jax.cli._yield as yield_cli

    monkeypatch.setattr(yield_cli, "_run", _no_compiling)
    out = tmp_path / "yield"
    code = main(["yield", "corner_cube", "--samples", "2", *flags, "--no-progress", "--out", str(out)])  # fmt: skip
    assert code == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("flags, message", BAD[:3])
def test_sweep_refuses_bad_solver_flags_in_one_line(flags, message, tmp_path, capsys):
    out = tmp_path / "sweep"
    assert main(["sweep", str(_config(tmp_path)), *flags, "--out", str(out)]) == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not (out / "sweep.json").exists()


def test_sweep_takes_the_solver_once_and_for_the_net_fold_model(tmp_path, capsys):
    flags = ["--solver", "implicit-step", "--dt", "100"]
    assert main(["sweep", str(_config(tmp_path)), *flags, "--out", str(tmp_path / "o")]) == 2
    assert "longer than the run (the config's t_end: 60 µs)" in _one_line(capsys.readouterr().err)
    both = _config(tmp_path, 'solver = "kvaerno5"\n')
    assert main(["sweep", str(both), "--solver", "tsit5", "--out", str(tmp_path / "o")]) == 2
    assert "not both" in _one_line(capsys.readouterr().err)
    accordion = Path(__file__).parent.parent / "examples" / "sweep_accordion.toml"
    assert (
        main(["sweep", str(accordion), "--solver", "kvaerno5", "--out", str(tmp_path / "a")]) == 2
    )
    assert "net-fold model's solver" in _one_line(capsys.readouterr().err)


@pytest.mark.slow  # builds and compiles a whole system; keeps the default suite short
def test_closed_loops_fold_on_the_fixed_steps_from_a_pre_fold(tmp_path, capsys):
    """The fixed steps hold a crease pattern's loops closed but cannot choose its branch when
    released at once from the flat state: the fold command and the fold kernel start it
    pre-folded by `FIXED_STEP_PRE_FOLD` (said, and recorded), and `simulate` refuses a flat start
    at rest under a sudden release."""
    from origami_jax.loops import load_pattern
    from origami_jax.net import fold_kernel

    pattern = load_pattern("waterbomb_base")
    fixed = sim.SolveOptions(saveat=sim.SaveAt(n=3), solver=sim.ImplicitStep(dt=1.0))
    kernel = fold_kernel(pattern, solve=fixed)
    assert kernel.settings["bias"] == sim.FIXED_STEP_PRE_FOLD
    assert fold_kernel(pattern, solve=fixed, bias=0.01).settings["bias"] == 0.01
    with pytest.raises(ValueError, match="cannot choose a closed-loop pattern's folding branch"):
        bare = pattern.with_model(contact=False, check_rigid=False)
        sim.simulate(bare.system(bare.default_design()), sim.Step(), fixed, t1=2.0)
    out = tmp_path / "o"
    flags = ["--solver", "implicit-step", "--dt", "2.5", "--t1", "400", "--release-ramp", "0"]
    flags += ["--no-figures"]
    assert main(["fold", "vertex_degree4", *flags, "--out", str(out)]) in (0, 1)
    said = capsys.readouterr().out
    assert f"pre-folded by {sim.FIXED_STEP_PRE_FOLD:g} rad" in said
    result = json.loads((out / "result.json").read_text())
    assert result["bias"] == sim.FIXED_STEP_PRE_FOLD and result["solver"] == "implicit-step"
    assert result["closure_drift"] < 1e-5
    # Where the hinges aimed: the pattern's own angles, without --targets.
    assert result["hinge_targets"] == pytest.approx(result["intended_angles"], abs=1e-12)
    # A yield's samples likewise, and its result.json records the pre-fold they started from.
    out = tmp_path / "y"
    flags = ["--solver", "implicit-step", "--dt", "2.5", "--samples", "1", "--no-progress"]
    assert main(["yield", "vertex_degree4", *flags, "--out", str(out)]) in (0, 1)
    assert f"pre-folded by {sim.FIXED_STEP_PRE_FOLD:g} rad" in capsys.readouterr().out
    assert json.loads((out / "result.json").read_text())["bias_rad"] == sim.FIXED_STEP_PRE_FOLD


def test_the_net_fold_model_records_its_solver_and_keeps_older_stores_resumable():
    """The sweep's settings (what a resume compares) name the fixed-step engine with its settings;
    Tsit5 named or not is the kernel's default, recorded as before (the paper's dynamics in the
    bath: released at once, 60 µs runs)."""
    default = get_model("net-fold", **PAPER, t_end=60.0).settings
    assert "solver" not in default
    assert get_model("net-fold", **PAPER, t_end=60.0, solver="tsit5").settings == default
    fixed = get_model(
        "net-fold", **PAPER, t_end=60.0, solver="implicit-step", dt=2.0,
        newton_iterations=8,
    ).settings  # fmt: skip
    assert fixed["solver"].startswith("ImplicitStep(dt=2.0, newton_iterations=8")
    assert {k: v for k, v in fixed.items() if k != "solver"} == default
    bdf2 = get_model("net-fold", **PAPER, t_end=60.0, solver="implicit-bdf2", dt=2.0).settings
    assert bdf2["solver"].endswith("scheme='bdf2')") and "scheme" not in fixed["solver"]
    assert get_model("net-fold", **PAPER, solver="kvaerno5").settings["solver"] == ("Kvaerno5")
    with pytest.raises(ValueError, match="longer than the run"):
        get_model("net-fold", **PAPER, t_end=60.0, solver="implicit-step", dt=61.0)
    with pytest.raises(ValueError, match="chooses its own steps"):
        get_model("net-fold", **PAPER, dt=2.0)


def test_yield_resume_refuses_another_solver(tmp_path, capsys):
    """A finished estimate (result.json without a solver: the adaptive default) is not resumed with
    the fixed-step engine, nor one run with it at another step."""
    folder = tmp_path / "y"
    folder.mkdir()
    (folder / "result.json").write_text(json.dumps({"yield": 0.5, "n_samples": 2}))
    base = ["yield", "corner_cube", "--samples", "2", "--no-progress", "--out", str(folder)]
    flags = ["--solver", "implicit-step", "--dt", "2.5"]
    assert main([*base, "--resume", *flags]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "with --solver implicit-step --dt 2.5 --newton-iterations 10" in line, line
    assert "was run with --solver tsit5" in line, line
    stored = {"yield": 0.5, "n_samples": 2, "solver": "implicit-step", "dt_us": 2.5}
    (folder / "result.json").write_text(json.dumps({**stored, "newton_iterations": 6}))
    assert main([*base, "--resume", "--solver", "implicit-step", "--dt", "1"]) == 2
    assert "was run with --solver implicit-step --dt 2.5" in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize(
    "flags, message",
    [
        BAD[0],
        BAD[2],
        (["--solver", "implicit-step", "--dt", "500"], "longer than the run (the run"),
    ],
)
def test_design_refuses_bad_solver_flags_in_one_line(flags, message, tmp_path, capsys, monkeypatch):
    """`design` takes the same flags (its run length from the targets: 6 × 37 µs here)."""
    import origami_jax.design as ojd

    monkeypatch.setattr(ojd, "design", _no_compiling)
    out = tmp_path / "design"
    assert main(["design", "--target-rise", "37e-6", *flags, "--out", str(out)]) == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not (out / "design.json").exists()


@pytest.mark.slow  # a short fit through the fixed steps: ~15 s on an idle 2-core machine
def test_design_through_the_fixed_step_engine_records_it(tmp_path, capsys):
    out = tmp_path / "design"
    flags = ["--solver", "implicit-step", "--dt", "0.5", "--starts", "1", "--max-steps", "2"]
    assert main(["design", "--target-rise", "37e-6", *flags, "--out", str(out)]) in (0, 1)
    result = json.loads((out / "design.json").read_text())
    assert result["solver"] == {"solver": "implicit-step", "dt_us": 0.5, "newton_iterations": 10}


@pytest.mark.slow  # a whole fold command: ~12 s on an idle 2-core machine
@pytest.mark.parametrize("engine", ["implicit-step", "implicit-bdf2"])
def test_fold_with_the_fixed_step_engine_records_it(engine, tmp_path, capsys):
    """`origami-jax fold` of the corner cube (no contact, 40 µs) in steps of 1 µs: result.json
    names the engine, its step and Newton iterations, and the steps it took are those the step
    sets (20 sample intervals of 2 µs, two steps each)."""
    out = tmp_path / "fold"
    flags = ["--solver", engine, "--dt", "1", "--newton-iterations", "4"]
    argv = ["fold", "corner_cube", "--no-contact", "--t1", "40", "--n-save", "21", *flags]
    argv += ["--no-fluid-inertia"]  # released at once: 40 µs is a run
    assert main([*argv, "--figures", "none", "--out", str(out)]) in (0, 1)
    result = json.loads((out / "result.json").read_text())
    assert result["solver"] == engine
    assert (result["dt_us"], result["newton_iterations"]) == (1.0, 4)
    assert result["stats"]["num_steps"] == 40
    assert 0 <= result["stats"]["newton_error"] < 1e-6
    assert np.isfinite(result["final_angles_deg"]).all()
