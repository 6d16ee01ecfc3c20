"""The command line never loses or mixes results and never answers with a traceback.

- Outputs: every command writes into `--out` as one unit (a staging folder, moved into place at the
  end); a folder holding results of an earlier run is refused unless `--overwrite`, which replaces
  them all; a run killed or failing midway leaves the earlier results as they were.
- Errors: bad numbers are refused with one line (exit 2) before anything compiles; any other
  exception becomes one line naming the input (`--debug` shows the traceback); Ctrl-C exits 130.
- JSON outputs are strict JSON: NaN is written as `null`.
- A hypothesis fuzz over `simulate`'s numeric flags: exit 0 with finite results, or one line.
"""

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from origami_jax._folder_lock import lock_folder
from origami_jax._limits import MAX_FLAPS
from origami_jax.cli import _main, main
from origami_jax.cli._common import (
    STAGING_PREFIX,
    CLIError,
    OutputFolder,
    dumps_json,
)

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data" / "fold"


def _strict(text: str):
    """Parse JSON refusing NaN and infinities (as strict readers do)."""

    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# Output folder -------------------------------------------------------------------------------


def test_rerun_is_refused_and_overwrite_replaces_every_earlier_file(tmp_path):
    with OutputFolder(tmp_path, command="demo", owns=("*.txt", "plots/*")) as output:
        (output.dir / "a.txt").write_text("first a")
        (output.dir / "b.txt").write_text("first b")
        (output.dir / "plots").mkdir()
        (output.dir / "plots" / "p.png").write_text("first plot")
    assert (tmp_path / "a.txt").read_text() == "first a"
    with pytest.raises(CLIError, match="already holds results .* --overwrite"):
        OutputFolder(tmp_path, command="demo", owns=("*.txt",))
    with OutputFolder(tmp_path, command="demo", owns=("*.txt", "plots/*"), overwrite=True) as out:
        (out.dir / "a.txt").write_text("second a")
    # One run's results only: b.txt and the plot belonged to the first run.
    assert (tmp_path / "a.txt").read_text() == "second a"
    assert not (tmp_path / "b.txt").exists() and not (tmp_path / "plots" / "p.png").exists()
    assert not list(tmp_path.glob(f"{STAGING_PREFIX}*"))


def test_a_run_that_fails_midway_keeps_the_earlier_results(tmp_path):
    with OutputFolder(tmp_path, command="demo", owns=("*.txt",)) as output:
        (output.dir / "a.txt").write_text("good")
    with pytest.raises(KeyboardInterrupt):
        with OutputFolder(tmp_path, command="demo", owns=("*.txt",), overwrite=True) as output:
            (output.dir / "a.txt").write_text("half")
            raise KeyboardInterrupt
    assert (tmp_path / "a.txt").read_text() == "good"
    assert not list(tmp_path.glob(f"{STAGING_PREFIX}*"))


def test_a_killed_runs_staging_folder_is_removed_by_the_next_run(tmp_path):
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        text=True,
        capture_output=True,
        check=True,
    )
    stale = tmp_path / f"{STAGING_PREFIX}demo-{int(dead.stdout)}-deadbeef"
    stale.mkdir()
    (stale / "a.txt").write_text("half")
    OutputFolder(tmp_path, command="demo", owns=("*.txt",)).discard()
    assert not stale.exists()


def _started_staging(argv, env, out: Path) -> subprocess.Popen:
    """A command line run started in a process of its own, once it has staged its results folder
    in `out` (at most 2 minutes)."""
    process = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not list(out.glob(f"{STAGING_PREFIX}*")) and time.monotonic() < deadline:
        assert process.poll() is None, process.stderr.read() if process.stderr else ""
        time.sleep(0.05)
    return process


def test_a_simulation_killed_midway_leaves_the_earlier_results_untouched(tmp_path):
    """The audit's case: a rerun into a folder with results, killed while it runs, used to leave a
    truncated trajectory beside the earlier metrics. Here the rerun (with --overwrite) is killed
    once it has staged its folder; the earlier files are byte for byte what they were."""
    (tmp_path / "metrics.json").write_text('{"earlier": true}\n')
    (tmp_path / "trajectory.csv").write_text("time [us]\n0\n")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    argv = [
        sys.executable,
        "-m",
        "origami_jax",
        "simulate",
        "--flaps",
        "1",
        "--t1",
        "5",
        "--n-save",
        "11",
        "--no-figures",
        "--out",
        str(tmp_path),
        "--overwrite",
    ]
    process = _started_staging(argv, env, tmp_path)
    process.kill()
    process.communicate()
    # The folder's lock file (`.lock`, not a result) stays; the results are as they were.
    after = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    assert {name: data for name, data in after.items() if name != ".lock"} == before


def test_a_terminated_run_exits_143_removes_its_staging_and_the_folder_it_created(tmp_path):
    """SIGTERM (`timeout`, a batch system's kill) is handled as Ctrl-C is: one line, nothing written,
    and the `--out` folder the run created is gone again (it held only the lock)."""
    out = tmp_path / "new"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    argv = [sys.executable, "-m", "origami_jax", "simulate", "--flaps", "1", "--t1", "5"]
    argv += ["--n-save", "11", "--no-figures", "--out", str(out)]
    process = _started_staging(argv, env, out)
    process.terminate()
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143, err
    assert err.decode().strip().splitlines() == [
        "origami-jax simulate: terminated (SIGTERM); nothing was written to --out."
    ]
    assert not out.exists()


def test_a_lost_interrupt_stops_the_commit(tmp_path):
    """A Ctrl-C whose `KeyboardInterrupt` was raised in a garbage collector's callback is lost to
    the run (Python prints and drops it); the signal is remembered, and the results it would have
    committed are dropped instead."""
    import signal

    from origami_jax.cli import _interrupt

    (tmp_path / "earlier.txt").write_text("earlier")
    output = OutputFolder(tmp_path, command="demo", owns=("*.txt",), overwrite=True)
    (output.dir / "a.txt").write_text("new")
    _interrupt._received.append(signal.SIGINT)
    try:
        with pytest.raises(KeyboardInterrupt):
            output.commit()
    finally:
        _interrupt._received.clear()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".lock", "earlier.txt"]
    lock_folder(tmp_path, command="demo").close()  # released


def test_a_sweep_or_yield_stopped_by_sigterm_exits_143():
    """`sweep` and `yield` turn the interrupt into their own message (what chunks are kept); its
    exit code says which signal stopped them."""
    import signal

    from origami_jax.cli import _interrupt
    from origami_jax.cli._common import Interrupted

    assert Interrupted("kept").code == 130
    _interrupt._received.append(signal.SIGTERM)
    try:
        assert Interrupted("kept").code == 143
    finally:
        _interrupt._received.clear()


def test_a_folder_the_run_created_is_removed_when_it_refuses_late(tmp_path, capsys):
    """Bad input found after the output folder was opened (here `design`'s target) leaves no
    folder behind that holds only the lock; a folder that existed before is kept."""
    out = tmp_path / "new"
    assert main(["design", "--target-rise", "-1", "--out", str(out)]) == 2
    assert not out.exists()
    out.mkdir()
    assert main(["design", "--target-rise", "-1", "--out", str(out)]) == 2
    assert out.is_dir()
    capsys.readouterr()


# One-line errors ------------------------------------------------------------------------------


def _minimal_argv(command: str, tmp_path: Path) -> list[str]:
    config = tmp_path / "sweep.toml"
    config.write_text('[model]\nname = "accordion-step"\n[parameters]\nk_scale = {values=[1.0]}\n')
    return {
        "simulate": ["simulate", "--flaps", "1"],
        "unfold": ["unfold", "open-chain"],
        "design": ["design", "--target-rise", "37e-6"],
        "export": ["export", "corner-cube"],
        "paper": ["paper"],
        "sweep": ["sweep", str(config)],
        "view": ["view", str(DATA / "frames.fold")],
    }[command]


@pytest.mark.parametrize(
    "command", ["simulate", "unfold", "design", "export", "paper", "sweep", "view"]
)
def test_out_that_is_a_file_or_cannot_be_created_is_one_line(command, tmp_path, capsys):
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder")
    argv = _minimal_argv(command, tmp_path)
    assert main([*argv, "--out", str(a_file)]) == 2
    assert "is a file" in _one_line(capsys.readouterr().err)
    assert main([*argv, "--out", str(a_file / "below")]) == 2
    assert "cannot create" in _one_line(capsys.readouterr().err)
    assert a_file.read_text() == "not a folder"


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
def test_a_folder_that_takes_no_files_is_refused_before_the_work(capsys):
    """/proc passes a permission check (for root) but takes no files: `view` found out only when
    writing its page, naming a temporary file."""
    assert main(["view", "cube_net_01", "--out", "/proc/page.html"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("origami-jax view: cannot write into the output folder /proc:"), line


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--t1", "-5"], "--t1 must be a positive finite number"),
        (["--t1", "0"], "--t1 must be a positive finite number"),
        (["--t1", "nan"], "--t1 must be a positive finite number"),
        (["--t1", "inf"], "--t1 must be a positive finite number"),
        (["--rtol", "-1"], "--rtol must be a positive finite number"),
        (["--rtol", "nan"], "--rtol must be a positive finite number"),
        (["--atol", "0"], "--atol must be a positive finite number"),
        (["--n-save", "0"], "--n-save must be between 2 and"),
        (["--n-save", "1"], "--n-save must be between 2 and"),
        (["--band", "nan"], "--band must lie strictly between 0 and 1"),
        (["--band", "1.5"], "--band must lie strictly between 0 and 1"),
        (["--flaps", "10000"], f"--flaps must be between 1 and {MAX_FLAPS}"),
        (["--flaps", "0"], f"--flaps must be between 1 and {MAX_FLAPS}"),
        (["--param", "units=1"], "'units' is not a hinge parameter"),
        (["--param", "k_scale=abc"], "the value must be a number"),
        (["--param", "k_scale=nan"], "the value must be finite"),
        (["--param", "k_scale=1,2"], "give one value (every hinge of the chain takes it)"),
        (["--param", "k_scale=-1"], "k_scale must be positive"),
        (["--param", "theta_final=100"], "at most π"),
        (["--param", "flap_length=-1"], "flap_length must be finite and positive"),
        (["--param", "flap_width=1,2"], "give one value (every hinge of the chain takes it)"),
    ],
)
def test_simulate_refuses_bad_numbers_in_one_line(flags, message, tmp_path, capsys):
    assert main(["simulate", *flags, "--no-figures", "--out", str(tmp_path)]) == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not list(tmp_path.iterdir())  # nothing written, not even a staging folder


@pytest.mark.parametrize(
    "argv, message",
    [
        (["design", "--curve", "missing.csv"], "--curve missing.csv: no such file"),
        (["design", "--target-rise", "37e-6", "--starts", "0"], "--starts must be between"),
        (["design", "--target-rise", "inf"], "is not finite"),
        (["design", "--target-rise", "37e-6", "--tolerance", "nan"], "--tolerance must be"),
        (["unfold", "open-chain", "--p", "nan"], "--p must be a positive finite"),
        (["unfold", "open-chain", "--p", "-2"], "--p must be a positive finite"),
        (["unfold", "open-chain", "--max-steps", "0"], "--max-steps must be at least 1"),
        (["export", "corner-cube", "--name", "../up"], "--name must be a plain file name"),
        (["view", "missing.fold"], "no such file"),
        (["design", "--target-rise", "-1"], "--target-rise: -1 s is not a positive time"),
        (["fold", "cubenet01"], "(did you mean cube_net_01?); origami-jax fold --list lists them."),
        (["fold", "cube_net_01", "--param", "hinge_widht=3"], "(did you mean hinge_width?)"),
        (["fold", "cube_net_01", "--adhesion", "-1"], "the work of adhesion W must be finite"),
        (["fold", "cube_net_01", "--friction", "-1"], "the friction coefficient MU must be"),
        (["fold", "cube_net_01", "--param", "theta_final=10"], "Give radians (degrees × π/180)."),
        (
            ["fold", "cube_net_01", "--no-contact", "--friction", "0.3"],
            "they need the plate contact (--contact plate), not --no-contact.",
        ),
    ],
)
def test_other_commands_refuse_bad_input_in_one_line(argv, message, tmp_path, capsys):
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    assert message in _one_line(capsys.readouterr().err)


def test_an_unexpected_error_is_one_line_naming_the_input(tmp_path, capsys, monkeypatch):
    def boom(args):
        raise RuntimeError("the solver exploded\nwith many lines of detail")

    parser = _main.build_parser()
    monkeypatch.setattr(_main, "build_parser", lambda: _set_func(parser, "unfold", boom))
    assert main(["unfold", "corner-cube", "--out", str(tmp_path)]) == 1
    line = _one_line(capsys.readouterr().err)
    assert "corner-cube" in line and "RuntimeError: the solver exploded" in line
    assert "--debug" in line
    with pytest.raises(RuntimeError, match="exploded"):
        main(["unfold", "corner-cube", "--out", str(tmp_path), "--debug"])
    with pytest.raises(RuntimeError, match="exploded"):
        main(["--debug", "unfold", "corner-cube", "--out", str(tmp_path)])


def test_ctrl_c_exits_130_with_one_line(tmp_path, capsys, monkeypatch):
    def interrupted(args):
        raise KeyboardInterrupt

    parser = _main.build_parser()
    monkeypatch.setattr(_main, "build_parser", lambda: _set_func(parser, "export", interrupted))
    assert main(["export", "corner-cube", "--out", str(tmp_path)]) == 130
    assert "interrupted" in _one_line(capsys.readouterr().err)


def _set_func(parser, command, func):
    subparsers = next(a for a in parser._actions if a.dest == "command")
    subparsers.choices[command].set_defaults(func=func)
    return parser


def test_json_outputs_write_nan_as_null():
    text = dumps_json(
        {"a": math.nan, "b": [1.0, math.inf], "c": np.float64("nan"), "d": np.array([1.0, -np.inf])}
    )
    assert _strict(text) == {"a": None, "b": [1.0, None], "c": None, "d": [1.0, None]}


# Simulate end to end and the fuzz (one compiled structure: 1 flap, 11 samples, Tsit5) ----------

CHEAP = ["--flaps", "1", "--n-save", "11", "--solver", "tsit5", "--no-figures"]


def _simulate(flags: list[str], capsys) -> tuple[int, str, Path]:
    out = Path(tempfile.mkdtemp(prefix="origami_cli_fuzz_"))
    code = main(["simulate", *flags, "--out", str(out / "run")])
    return code, capsys.readouterr().err, out / "run"


def test_simulate_writes_strict_json_and_refuses_a_rerun(capsys):
    # 5 µs is too short to reach 90 % of the fold: the rise time is undefined, written as null.
    code, _, out = _simulate([*CHEAP, "--t1", "5"], capsys)
    assert code == 0
    report = _strict((out / "metrics.json").read_text())
    assert report["metrics"]["rise_time"] == [None] and report["metrics"]["t90"] == [None]
    assert main(["simulate", *CHEAP, "--t1", "5", "--out", str(out)]) == 2
    assert "--overwrite" in _one_line(capsys.readouterr().err)
    # The flap size is the accordion pattern's, set by --param as before: the paper's drag
    # C_D ν (L w) L³ / 16 of a 100 × 50 µm flap in air (1e-6: the float32 of the run's arrays).
    flaps = ["--param", "flap_length=100", "--param", "flap_width=50"]
    assert main(["simulate", *CHEAP, *flaps, "--t1", "6", "--out", str(out), "--overwrite"]) == 0
    capsys.readouterr()
    report = _strict((out / "metrics.json").read_text())
    assert report["stats"]["num_steps"] > 0
    assert report["drag"][0] == pytest.approx(1.17 * 1.204e-6 * 100 * 50 * 100**3 / 16, rel=1e-6)


_GOOD = {
    "t1": st.floats(1.0, 40.0),
    "rtol": st.floats(1e-10, 1e-3),
    "atol": st.floats(1e-12, 1e-4),
    "band": st.floats(1e-3, 0.5),
    "k_scale": st.floats(0.3, 3.0),
    "n_save": st.just(11),
    "flaps": st.just(1),
}
_NOT_POSITIVE = st.one_of(
    st.floats(max_value=0.0), st.sampled_from([math.nan, math.inf, -math.inf])
)
_BAD = {
    "t1": _NOT_POSITIVE,
    "rtol": _NOT_POSITIVE,
    "atol": _NOT_POSITIVE,
    "band": st.one_of(_NOT_POSITIVE, st.floats(min_value=1.0)),
    "k_scale": st.one_of(_NOT_POSITIVE, st.sampled_from([1e300])),
    "n_save": st.sampled_from([-1, 0, 1, 10**9]),
    "flaps": st.sampled_from([-2, 0, MAX_FLAPS + 1, 10**6]),
}


@st.composite
def _simulate_flags(draw):
    """Every flag from a cheap valid range, except (most of the time) one or two drawn bad."""
    bad = draw(st.sets(st.sampled_from(sorted(_GOOD)), max_size=2))
    values = {name: draw(_BAD[name] if name in bad else _GOOD[name]) for name in _GOOD}
    flags = [f"--{name.replace('_', '-')}={values[name]!r}" for name in ("t1", "band")]
    flags += [f"--n-save={values['n_save']}", f"--flaps={values['flaps']}"]
    for name in ("rtol", "atol"):
        if name in bad or draw(st.booleans()):
            flags.append(f"--{name}={values[name]!r}")
    flags += ["--param", f"k_scale={values['k_scale']!r}"]
    return flags, bad


@settings(
    max_examples=15,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(case=_simulate_flags())
def test_fuzz_simulate_numeric_flags(case, capsys):
    """Exit 0 with finite results, or one line (exit 2 for a bad number; exit 1 only for a solve
    that ran and failed). Valid draws share one compiled structure (1 flap, 11 samples, Tsit5)
    and stay cheap (short runs); invalid ones are refused before anything compiles."""
    flags, bad = case
    code, err, out = _simulate([*flags, "--solver", "tsit5", "--no-figures"], capsys)
    assert code in (0, 1, 2), (code, err)
    if code == 0:
        assert not bad, flags
        trajectory = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
        assert trajectory.shape == (11, 4) and np.isfinite(trajectory).all()
        report = _strict((out / "metrics.json").read_text())
        assert report["succeeded"]
        return
    line = _one_line("\n".join(s for s in err.splitlines() if "%|" not in s))  # no progress bar
    if code == 1:
        assert "solve failed" in line
    else:
        assert bad, (flags, line)
        assert not out.exists() or not any(out.iterdir())


def test_usage_errors_are_one_line(capsys):
    with pytest.raises(SystemExit) as excinfo:
        main(["simulate", "--band"])
    assert excinfo.value.code == 2
    assert "--help" in _one_line(capsys.readouterr().err)


def test_a_negative_value_reaches_its_own_check(tmp_path, capsys):
    """argparse reads ``-1e-300`` and ``-5,0,0`` after a flag as unknown flags ("expected one
    argument"): they are joined to their flag, so the value's own check names what is wrong."""
    from origami_jax.cli._main import negative_lists_attached

    assert negative_lists_attached(["fold", "x", "--release", "-5,0,0", "--t1", "-1e-3"]) == [
        "fold", "x", "--release=-5,0,0", "--t1=-1e-3"
    ]  # fmt: skip
    assert negative_lists_attached(["fold", "--no-contact", "-x"]) == ["fold", "--no-contact", "-x"]
    assert main(["simulate", "--band", "-1e-300", "--out", str(tmp_path / "s")]) == 2
    assert "--band" in _one_line(capsys.readouterr().err)
    out = str(tmp_path / "f")
    assert main(["fold", "cube_net_01", "--release", "-5,0,0,0,0", "--out", out]) == 2
    assert "release_time must be >= 0" in _one_line(capsys.readouterr().err)


def test_unfold_names_the_vertices_on_one_line(tmp_path, capsys):
    """A vertex that does not exist is one line naming the first few vertices (the library's
    message lists them in a table, a line each)."""
    from origami_jax.fold import catalogue_path

    out = tmp_path / "u"
    path = str(catalogue_path("cube_net_01"))
    assert main(["unfold", path, "--vertex-index", "9999", "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "vertex_index 9999 does not exist" in line and line.count("; ") >= 3
    assert line.endswith("more") and not out.exists()
