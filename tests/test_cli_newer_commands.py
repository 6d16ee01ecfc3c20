"""The newer commands (`fold`, `yield`, `view`), FOLD files and the library under bad input and
faults (issue 50): nothing mixed or lost, no hang, no silent wrong answer, one line for bad input.

Every refusal here comes before anything compiles (exit 2, one line on stderr, no traceback, the
folder's earlier results untouched), so each test costs about a second.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from origami_jax._folder_lock import FolderBusyError, lock_folder
from origami_jax.cli import main
from origami_jax.cli._common import CLIError, OutputFolder

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data" / "fold"


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under `folder` but the lock file (not a result), by relative path."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in folder.rglob("*")
        if p.is_file() and p.name != ".lock"
    }


# 1. One output-folder lock, held by every command while it writes --------------------------------


@pytest.fixture(scope="module")
def held_folder(tmp_path_factory):
    """A folder whose lock another process holds (a `fold` run, as far as the lock says), with an
    earlier run's results in it."""
    folder = tmp_path_factory.mktemp("held")
    (folder / "result.json").write_text('{"earlier": true}\n')
    (folder / "trajectory.csv").write_text("time [us]\n0\n")
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from origami_jax._folder_lock import lock_folder; "
            "lock = lock_folder(sys.argv[1], command='fold'); print('held', flush=True); "
            "sys.stdin.read()",
            str(folder),
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
    )
    assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
    yield folder
    holder.communicate("")


@pytest.mark.parametrize(
    "argv",
    [
        ["fold", "cube_net_01", "--t1", "1", "--release-ramp", "0", "--overwrite"],
        ["simulate", "--flaps", "1", "--overwrite"],
        ["unfold", "open-chain", "--overwrite"],
        ["export", "corner-cube", "--overwrite"],
        ["design", "--target-rise", "37e-6", "--overwrite"],
        ["paper", "--overwrite"],
        ["yield", "cube_net_01", "--samples", "2", "--resume"],
    ],
    ids=lambda argv: argv[0],
)
def test_a_folder_in_use_by_another_run_is_refused_by_every_command(argv, held_folder, capsys):
    """Two runs into one --out used to both print "wrote" and leave one's result.json beside the
    other's figures: the second is refused (one line naming the holder), the folder untouched."""
    before = _snapshot(held_folder)
    assert main([*argv, "--out", str(held_folder)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "is in use by another fold run" in line and "choose another --out" in line, line
    assert _snapshot(held_folder) == before


def test_a_fold_into_a_busy_folder_is_refused_before_the_net_is_read(held_folder, capsys):
    """The fold command builds (and compiles) its system for seconds before it writes: a busy
    --out is said first, before the net is even read (a name that is no net is not reached)."""
    before = _snapshot(held_folder)
    assert main(["fold", "no_such_net", "--out", str(held_folder)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "is in use by another fold run" in line and "no_such_net" not in line, line
    assert _snapshot(held_folder) == before


def test_the_sweep_refuses_a_folder_a_command_is_writing(held_folder, tmp_path, capsys):
    config = tmp_path / "sweep.toml"
    config.write_text('[model]\nname = "accordion-step"\n[parameters]\nk_scale = {values=[1.0]}\n')
    before = _snapshot(held_folder)
    assert main(["sweep", str(config), "--out", str(held_folder), "--resume"]) == 2
    assert "is in use by another fold run" in _one_line(capsys.readouterr().err)
    assert _snapshot(held_folder) == before


def test_the_lock_is_held_until_the_results_are_in_place_and_lent_only_when_asked(tmp_path):
    with OutputFolder(tmp_path, command="fold", owns=("*.txt",)) as output:
        (output.dir / "a.txt").write_text("first")
        # Not lent: a second writer in this process too is refused (a library sweep, a command).
        with pytest.raises(FolderBusyError, match="in use by another fold run"):
            lock_folder(tmp_path, command="sweep")
        with pytest.raises(CLIError, match="in use by another fold run"):
            OutputFolder(tmp_path, command="fold", owns=("*.txt",), overwrite=True)
    assert (tmp_path / "a.txt").read_text() == "first"
    # Released at commit (and at discard): the next run may write.
    OutputFolder(tmp_path, command="fold", owns=("*.txt",), overwrite=True).discard()
    lock_folder(tmp_path, command="sweep").close()
    with OutputFolder(tmp_path / "yield", command="yield", owns=(), lend=True):
        lock_folder(tmp_path / "yield", command="sweep").close()  # lent: its store shares it


# A relative of 2: every run records which command wrote which files, so that another command's
# results are never mixed with a new run's, and a yield's or sweep's folder is no one else's.


def _run_of(folder: Path, command: str, files: dict[str, str], **options) -> None:
    with OutputFolder(folder, command=command, owns=tuple(files), **options) as output:
        for name, text in files.items():
            (output.dir / name).write_text(text)


def test_another_commands_results_are_replaced_whole_or_refused(tmp_path):
    _run_of(tmp_path, "simulate", {"metrics.json": "{}", "trajectory.csv": "simulate"})
    with pytest.raises(
        CLIError,
        match=r"earlier `simulate` run \(metrics.json, trajectory.csv\); "
        "pass --overwrite",
    ):
        _run_of(tmp_path, "fold", {"result.json": "{}", "trajectory.csv": "fold"})
    # With --overwrite the whole earlier run goes (its metrics.json would have made view draw the
    # fold's angles as an accordion).
    _run_of(tmp_path, "fold", {"result.json": "{}", "trajectory.csv": "fold"}, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(".")) == [
        "result.json",
        "trajectory.csv",
    ]
    assert (tmp_path / "trajectory.csv").read_text() == "fold"
    # The same command's other files stay listed (exports of other names side by side).
    _run_of(tmp_path / "exports", "export", {"a.fold": "a"})
    _run_of(tmp_path / "exports", "export", {"b.fold": "b"})
    _run_of(tmp_path / "exports", "fold", {"result.json": "{}"}, overwrite=True)
    assert not (tmp_path / "exports" / "a.fold").exists()
    assert not (tmp_path / "exports" / "b.fold").exists()


def test_a_yield_or_sweep_folder_is_no_other_commands_and_takes_no_others(tmp_path):
    _run_of(tmp_path / "y", "yield", {"result.json": "yield"}, exclusive=True)
    with pytest.raises(CLIError, match="earlier `yield` run .*; choose another --out"):
        _run_of(tmp_path / "y", "fold", {"result.json": "fold"}, overwrite=True)
    assert (tmp_path / "y" / "result.json").read_text() == "yield"
    _run_of(tmp_path / "f", "fold", {"angles.png": "fold"})
    with pytest.raises(CLIError, match="earlier `fold` run .*; choose another --out"):
        _run_of(tmp_path / "f", "sweep", {"summary.txt": "s"}, overwrite=True, exclusive=True)
    assert (tmp_path / "f" / "angles.png").read_text() == "fold"


# 2. and 3. `yield` never replaces results, nor drops a finished run's parts on --resume ---------


def _results(folder: Path, result: dict) -> dict[str, bytes]:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "result.json").write_text(json.dumps(result))
    (folder / "angles.png").write_bytes(b"figure")
    return _snapshot(folder)


YIELD = ["yield", "cube_net_01", "--samples", "2", "--no-progress"]


def test_yield_refuses_a_folder_holding_another_commands_results(tmp_path, capsys):
    before = _results(tmp_path, {"verdict": "folded", "net": "cube_net_01"})
    assert main([*YIELD, "--out", str(tmp_path)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "already holds results" in line and "choose another --out" in line, line
    assert main([*YIELD, "--out", str(tmp_path), "--resume"]) == 2
    assert "not a yield estimate's" in _one_line(capsys.readouterr().err)
    assert _snapshot(tmp_path) == before


def test_yield_resume_refuses_to_drop_a_finished_ascent_or_widths(tmp_path, capsys):
    finished = {"yield": 0.5, "n_samples": 2, "improve": {"iterates": []}}
    before = _results(tmp_path / "improved", finished)
    (tmp_path / "improved" / "improve.png").write_bytes(b"figure")
    before = _snapshot(tmp_path / "improved")
    assert main([*YIELD, "--out", str(tmp_path / "improved"), "--resume"]) == 2
    assert "--improve ascent, which --resume cannot" in _one_line(capsys.readouterr().err)
    assert _snapshot(tmp_path / "improved") == before
    widths = {"yield": 0.5, "n_samples": 2, "widths": [{"factor": 0.5}, {"factor": 1.0}]}
    before = _results(tmp_path / "widths", widths)
    assert main([*YIELD, "--out", str(tmp_path / "widths"), "--resume", "--widths", "1"]) == 2
    assert "without --widths 0.5" in _one_line(capsys.readouterr().err)
    assert _snapshot(tmp_path / "widths") == before
    seeded = {"yield": 0.5, "n_samples": 2, "seed": 3}
    before = _results(tmp_path / "seeded", seeded)
    assert main([*YIELD, "--out", str(tmp_path / "seeded"), "--resume", "--seed", "4"]) == 2
    assert "with --seed 4: its estimate was drawn with --seed 3" in _one_line(
        capsys.readouterr().err
    )
    assert _snapshot(tmp_path / "seeded") == before


# 4. Vertices no edge or face uses: read without them; writing a long animation stays fast --------


def test_unused_vertices_are_left_out_and_the_animation_writes_fast(tmp_path):
    import time

    import numpy as np

    from origami_jax.fold import dumps_fold, read_fold
    from origami_jax.fold._catalogue import source_and_label
    from origami_jax.loops import load_pattern

    data = json.loads(Path(source_and_label("cube_net_01")[0]).read_text())
    used = len(data["vertices_coords"])
    data["vertices_coords"] += [[1000.0 + i, 2000.0] for i in range(20_000)]
    path = tmp_path / "unused.fold"
    path.write_text(json.dumps(data))
    with pytest.warns(UserWarning, match="20000 of the 20014 vertices belong to no edge or face"):
        net = load_pattern(read_fold(path))
    start = time.perf_counter()
    angles = np.linspace(0.0, 1.0, 200)[:, None] * np.ones(net.n_creases)
    text = dumps_fold(net.to_fold(angles=angles, times=np.arange(200.0)))
    assert time.perf_counter() - start < 10  # was minutes: the schema walked every coordinate
    written = json.loads(text)
    assert len(written["vertices_coords"]) == used
    assert all(len(f["vertices_coords"]) == used for f in written["file_frames"])


# 5. Every size-like option has an upper limit, refused in one line before anything compiles ------


@pytest.mark.parametrize(
    "argv, message",
    [
        (["fold", "cube_net_01", "--contact-sampling", "100000,100000"], "at most 32 points"),
        (["fold", "cube_net_01", "--contact-sampling", "4,33"], "at most 32 points"),
        (["yield", "cube_net_01", "--contact-sampling", "33,2"], "at most 32 points"),
        (["fold", "cube_net_01", "--n-save", str(10**9)], "--n-save must be between 21 and"),
        (["yield", "cube_net_01", "--samples", str(10**9)], "--samples must be between 1 and"),
        (["yield", "cube_net_01", "--chunk-size", str(10**9)], "--chunk-size must be between"),
        (["yield", "cube_net_01", "--workers", str(10**6)], "--workers must be between 1 and"),
        (["yield", "cube_net_01", "--improve", str(10**6)], "--improve must be between 1 and"),
        (["yield", "cube_net_01", "--widths", ",".join(["1"] * 17)], "1 to 16 factors"),
        (["view", str(DATA / "frames.fold"), "--frames", str(10**9)], "--frames must be 0"),
    ],
)
def test_size_like_options_have_an_upper_limit(argv, message, tmp_path, capsys):
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_the_sweep_kernel_limits_the_contact_sampling():
    from origami_jax.sweep import get_model

    with pytest.raises(ValueError, match="at most 32 points per edge"):
        get_model("net-fold", net="cube_net_01", contact_sampling=(100_000, 100_000))


# 8. and 9. `fold` refuses what it would ignore or misreport (as `yield` does) --------------------


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--etch-front", "1,0,0.5", "--release", "0,0,0,0,0"], "--release or --etch-front, not"),
        (["--bias", "0.05"], "--bias pre-folds closed-loop patterns; cube_net_01 is a net"),
        (["--bias", "100"], "--bias must be a pre-fold angle in [0, 1) rad"),
        (["--length-scale", "2"], "gives its lengths in 'um': --length-scale is for unitless"),
        (["--length-scale", "0"], "--length-scale must be a positive finite number"),
        (["--length-scale", "nan"], "--length-scale must be a positive finite number"),
        (["--n-save", "2"], "--n-save must be between 21 and"),
    ],
)
def test_fold_refuses_options_it_would_ignore(flags, message, tmp_path, capsys):
    assert main(["fold", "cube_net_01", *flags, "--out", str(tmp_path)]) == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("command", ["fold", "yield", "simulate", "sweep", "view"])
def test_an_empty_out_is_refused(command, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = {
        "fold": ["fold", "cube_net_01"],
        "yield": ["yield", "cube_net_01"],
        "simulate": ["simulate", "--flaps", "1"],
        "sweep": ["sweep", "config.toml"],
        "view": ["view", str(DATA / "frames.fold")],
    }[command]
    with pytest.raises(SystemExit) as exit_:
        main([*argv, "--out", ""])
    assert exit_.value.code == 2
    assert "argument --out: empty: give a folder" in _one_line(capsys.readouterr().err)
    assert not any(tmp_path.iterdir())


def test_a_frame_parent_that_names_no_frame_is_refused():
    from origami_jax.fold import FoldFormatError, loads_fold

    data = json.loads((DATA / "frames.fold").read_text())
    data["file_frames"][0]["frame_parent"] = 7
    data["file_frames"][0]["frame_inherit"] = False
    with pytest.raises(FoldFormatError, match="frame 1 has frame_parent 7, which does not exist"):
        loads_fold(json.dumps(data))


# 10. and 12. The library's loaders and seam gaps name a bad argument --------------------------


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"length_scale": -1.0}, "length_scale must be a positive finite number"),
        ({"length_scale": float("nan")}, "length_scale must be a positive finite number"),
        ({"length_scale": 0}, "length_scale must be a positive finite number"),
        ({"root": 1.5}, "root must be a face index"),
    ],
)
def test_loaders_refuse_a_bad_scale_or_root(kwargs, message):
    from origami_jax.loops import load_pattern
    from origami_jax.net import load_net

    for load in (load_net, load_pattern):
        with pytest.raises(ValueError, match=message):
            load("cube_net_01", **kwargs)


def test_seam_gaps_refuse_nan_angles():
    from origami_jax.net import load_net

    net = load_net("cube_net_01")
    with pytest.raises(ValueError, match="angles must be finite"):
        net.seam_gaps([float("nan")] * net.n_creases)
    with pytest.raises(ValueError, match="one fold angle per crease"):
        net.seam_gaps([0.0])


# 6. A yield whose creases are released after the run's end is refused (it could only be 0) -------


def test_yield_refuses_a_release_at_or_after_the_end(tmp_path, capsys):
    import origami_jax.fab_yield as ojy
    from origami_jax.net import FOLD_KERNEL_SOLVE

    n = 5  # cube_net_01's creases
    release = ",".join(["0"] * (n - 1) + ["2000"])
    argv = [*YIELD, "--release", release, "--t-end", "1500", "--out", str(tmp_path)]
    assert main(argv) == 2
    line = _one_line(capsys.readouterr().err)
    assert "--release: crease 4 is released at 2000 µs, at or after --t-end 1500 µs" in line
    assert main([*YIELD, "--etch-front", "1,0,0.001", "--out", str(tmp_path)]) == 2
    assert "--etch-front: crease" in _one_line(capsys.readouterr().err)
    assert not any(tmp_path.iterdir())
    with pytest.raises(ValueError, match="at or after t_end 100 µs"):
        ojy.yield_estimate(
            "cube_net_01",
            release_times=[0, 0, 0, 0, 200.0],
            solve=FOLD_KERNEL_SOLVE.replace(t1=100.0),
        )
    # 11: a NaN release time is named as such (it was reported as a shape error).
    with pytest.raises(ValueError, match=r"release_times must be finite \(µs\), got \[nan"):
        ojy.yield_estimate("cube_net_01", release_times=[float("nan"), 0, 0, 0, 0])


# 7. and 11. `view` refuses another command's trajectory, a file cut short, a folder -------------


def _fold_result(folder: Path) -> Path:
    """A `fold` result folder as the command writes it (result.json, trajectory.csv of hinge
    angles numbered from 0, trajectory.fold)."""
    folder.mkdir()
    (folder / "result.json").write_text(json.dumps({"verdict": "folded", "creases": 2}))
    rows = "\n".join(f"{t},{0.01 * t},{0.02 * t}" for t in range(5))
    (folder / "trajectory.csv").write_text("time [us],theta_0 [rad],theta_1 [rad]\n" + rows + "\n")
    (folder / "trajectory.fold").write_text((DATA / "frames.fold").read_text())
    return folder


def _simulate_result(folder: Path, rows: int, samples: int) -> Path:
    """A `simulate` result folder: metrics.json saying `samples` samples to 10 µs, and a CSV of
    the first `rows` of them (a copy cut at a row boundary when fewer)."""
    import numpy as np

    folder.mkdir()
    metrics = {"flaps": 1, "fluid": "KOH", "params": {}, "succeeded": True, "samples": samples}
    metrics["t1"] = 10.0
    (folder / "metrics.json").write_text(json.dumps(metrics))
    times = np.linspace(0.0, 10.0, samples)[:rows]
    header = "time [us],theta_1 [rad],theta_dot_1 [rad/us],tau_1 [pN*m]"
    data = np.column_stack([times, 0.1 * times, 0.1 + 0 * times, 0 * times])
    np.savetxt(folder / "trajectory.csv", data, delimiter=",", header=header, comments="")
    return folder


def _view(path: Path, tmp_path: Path, capsys) -> str:
    assert main(["view", str(path), "--out", str(tmp_path / "page.html")]) == 2
    assert not (tmp_path / "page.html").exists()
    return _one_line(capsys.readouterr().err)


def test_view_refuses_a_fold_runs_trajectory_csv(tmp_path, capsys):
    out = _fold_result(tmp_path / "fold_out")
    line = _view(out / "trajectory.csv", tmp_path, capsys)
    assert "hinge angles of a `fold` run" in line and str(out / "trajectory.fold") in line


def test_view_refuses_a_result_folder_and_names_the_file_in_it(tmp_path, capsys):
    out = _fold_result(tmp_path / "fold_out")
    line = _view(out, tmp_path, capsys)
    assert "is a folder: give the result file in it" in line, line
    assert str(out / "trajectory.fold") in line


def test_view_names_a_dangling_link(tmp_path, capsys):
    (tmp_path / "link.fold").symlink_to(tmp_path / "gone.fold")
    assert "is a link to" in _view(tmp_path / "link.fold", tmp_path, capsys)


def test_view_refuses_files_cut_short(tmp_path, capsys):
    cut = _simulate_result(tmp_path / "cut", rows=6, samples=11)
    line = _view(cut / "trajectory.csv", tmp_path, capsys)
    assert "holds 6 samples to 5 µs but metrics.json says 11 samples to 10 µs" in line, line
    mid_row = _simulate_result(tmp_path / "mid_row", rows=11, samples=11)
    text = (mid_row / "trajectory.csv").read_text()
    (mid_row / "trajectory.csv").write_text(text[: len(text) - 40])  # the last row: 2 columns
    assert "cannot read" in _view(mid_row / "trajectory.csv", tmp_path, capsys)
    metrics = _simulate_result(tmp_path / "metrics", rows=11, samples=11) / "metrics.json"
    metrics.write_text(metrics.read_text()[:20])
    assert "cannot read" in _view(metrics.with_name("trajectory.csv"), tmp_path, capsys)
    import numpy as np

    npz = tmp_path / "npz" / "trajectory.npz"
    npz.parent.mkdir()
    np.savez(npz, times=np.linspace(0, 1, 50), theta=np.zeros((50, 1)))
    npz.write_bytes(npz.read_bytes()[:300])
    assert "cannot read" in _view(npz, tmp_path, capsys)


# 11. Messages that name the real cause and the fix ---------------------------------------------


def _cube_net(tmp_path: Path, name: str, change) -> Path:
    """cube_net_01's FOLD data changed by `change` (in place), written to `tmp_path/name`."""
    from origami_jax.fold._catalogue import source_and_label

    data = json.loads(Path(source_and_label("cube_net_01")[0]).read_text())
    change(data)
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def _scaled(factor):
    def change(data):
        data["vertices_coords"] = [[x * factor for x in v] for v in data["vertices_coords"]]

    return change


def _first_face(transform):
    def change(data):
        data["faces_vertices"][0] = transform(data["faces_vertices"][0])

    return change


def _flat_creases(data):
    data["edges_foldAngle"] = [
        0 if a in "MV" else angle
        for a, angle in zip(data["edges_assignment"], data["edges_foldAngle"], strict=True)
    ]


def _nearly_flat_creases(data):
    """Creases aimed at 1e-9°: hinges ~1e-9 µm long (a 1/angle stiffness) ran for minutes."""
    data["edges_foldAngle"] = [
        1e-9 if a in "MV" else angle
        for a, angle in zip(data["edges_assignment"], data["edges_foldAngle"], strict=True)
    ]


def _one_face(data):
    data.update(
        vertices_coords=[[0, 0], [200, 0], [200, 200], [0, 200]],
        edges_vertices=[[0, 1], [1, 2], [2, 3], [3, 0]],
        edges_assignment=["B"] * 4,
        edges_foldAngle=[0] * 4,
        faces_vertices=[[0, 1, 2, 3]],
    )


def _collinear(data):
    coords = data["vertices_coords"]
    face = data["faces_vertices"][0]
    for k, v in enumerate(face):
        coords[v] = [float(k), 0.0]


@pytest.mark.parametrize(
    "change, commands, message",
    [
        (_scaled(1e-12), ("fold", "yield"), "wide (2·area/perimeter), not wider than the panels'"),
        (_scaled(1e10), ("fold", "yield"), "float64 cannot resolve the film against it"),
        (_first_face(lambda f: [f[0] + 0.0, *f[1:]]), ("fold",), "0.0 is not one (whole numbers"),
        (_first_face(lambda f: [*f[:2], f[1], *f[2:]]), ("fold",), "lists vertex"),
        (_flat_creases, ("fold", "yield"), "folds to 0°: a stressed hinge folds to a non-zero"),
        (_nearly_flat_creases, ("fold", "yield"), "folds to 1e-09°, so its hinge would be"),
        (_one_face, ("fold", "yield"), "has no creases (one face): nothing folds"),
        (_collinear, ("fold",), "has zero area (its corners are on one line or at one point)"),
    ],
    ids=[
        "tiny",
        "huge",
        "float-index",
        "repeated-vertex",
        "zero-target",
        "tiny-target",
        "one-face",
        "zero-area",
    ],
)
def test_bad_geometry_is_named_before_anything_compiles(
    change, commands, message, tmp_path, capsys
):
    path = _cube_net(tmp_path, "net.fold", change)
    for command in commands:
        out = tmp_path / f"out_{command}"
        assert main([command, str(path), "--out", str(out)]) == 2, command
        line = _one_line(capsys.readouterr().err)
        assert message in line, (command, line)
        assert line.count("net.fold:") <= 1, line  # the file named once
        assert not out.exists() or not any(out.iterdir())


def test_a_folder_or_a_dangling_link_given_as_fold_is_named(tmp_path, capsys):
    (tmp_path / "folder.fold").mkdir()
    (tmp_path / "link.fold").symlink_to(tmp_path / "gone.fold")
    for name, message in (("folder.fold", "is a folder"), ("link.fold", "which does not exist")):
        assert main(["fold", str(tmp_path / name), "--out", str(tmp_path / "out")]) == 2
        line = _one_line(capsys.readouterr().err)
        assert message in line and "no shipped net" not in line, line


def test_a_net_without_faces_in_its_file_writes_its_faces():
    """A FOLD file without faces_vertices was simulated in full and refused only when its
    animation was written: the net's key frame gets the faces its geometry traced."""
    import numpy as np

    from origami_jax.fold import dumps_fold, loads_fold
    from origami_jax.fold._catalogue import source_and_label
    from origami_jax.net import load_net

    data = json.loads(Path(source_and_label("cube_net_01")[0]).read_text())
    faces = data.pop("faces_vertices")
    net = load_net(loads_fold(json.dumps(data)))
    written = json.loads(dumps_fold(net.to_fold(angles=np.zeros((2, net.n_creases)))))
    assert sorted(map(sorted, written["faces_vertices"])) == sorted(map(sorted, faces))


def test_resume_with_other_settings_says_which_differ_in_one_line(tmp_path):
    from origami_jax.sweep._store import Store

    manifest = {"model": "net-fold", "settings": {"t_end": 1500.0}, "space": {"sha256": "a"}}
    Store.open(tmp_path, manifest, resume=False, writer=True).close()
    other = {"model": "net-fold", "settings": {"t_end": 1000.0}, "space": {"sha256": "b"}}
    with pytest.raises(ValueError) as error:
        Store.open(tmp_path, other, resume=True, writer=True)
    message = str(error.value)
    assert "\n" not in message
    assert "settings.t_end: stored 1500.0, new 1000.0" in message
    assert "the design space's values differ: for a yield estimate, --samples, --seed" in message
    assert "sha256" not in message


# 12. A per-crease design value of the wrong length names its field ------------------------------


@pytest.mark.parametrize("name", ["cube_net_01", "vertex_degree4"])
def test_a_per_crease_value_of_the_wrong_length_is_named(name):
    from origami_jax.loops import load_pattern
    from origami_jax.system import HingeDesign

    pattern = load_pattern(name)
    design = HingeDesign.literature(hinge_width=[1.0, 2.0])
    with pytest.raises(ValueError, match=r"design.hinge_width has shape \(2,\) for \d creases"):
        pattern.system(design)


# The fuzz: fold, yield and view under drawn flags and FOLD files, interrupted, side by side ------

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_FUZZ = settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
_NOT_FINITE = st.sampled_from(["nan", "inf", "-inf"])
# One bad value per flag (each refused before anything compiles).
_BAD_FOLD = {
    "--t1": st.one_of(_NOT_FINITE, st.sampled_from(["0", "-1"])),
    "--n-save": st.sampled_from(["-1", "0", "20", str(10**9)]),
    "--contact-sampling": st.sampled_from(["0,2", "33,2", "4,-1", "4", "a,b", "4,100000"]),
    "--bias": st.one_of(_NOT_FINITE, st.sampled_from(["-0.1", "1", "100", "0.05"])),
    "--tolerance": st.one_of(_NOT_FINITE, st.sampled_from(["0", "180", "-3"])),
    "--seam-tolerance": st.one_of(_NOT_FINITE, st.sampled_from(["0", "1", "-0.5"])),
    "--length-scale": st.one_of(_NOT_FINITE, st.sampled_from(["0", "-1", "2"])),
    "--release": st.sampled_from(["0", "nan,0,0,0,0", "0,0", "x"]),
    "--targets": st.sampled_from(["90", "inf,90,90,90,90", "0,90,90,90,90"]),
    "--root": st.sampled_from(["-1", "99"]),
    "--param": st.sampled_from(["k_scale=nan", "nope=1", "hinge_width=1,2"]),
}
_BAD_YIELD = {
    "--samples": st.sampled_from(["0", "-3", str(10**9)]),
    "--t-end": st.one_of(_NOT_FINITE, st.sampled_from(["0", "-5"])),
    "--t-settle": st.one_of(_NOT_FINITE, st.sampled_from(["-1", "-8000"])),
    "--contact-sampling": st.sampled_from(["0,2", "33,2", "9,x"]),
    "--chunk-size": st.sampled_from(["0", str(10**9)]),
    "--workers": st.sampled_from(["0", str(10**6)]),
    "--release": st.sampled_from(["0", "nan,0,0,0,0", "0,0,0,0,1e9"]),
    "--confidence": st.sampled_from(["0", "1", "nan"]),
    "--widths": st.sampled_from(["0", "-1,1", "nan"]),
    "--bias": st.sampled_from(["0.05", "-1", "nan"]),
    "--step-budget": st.sampled_from(["0", "200000"]),
}


@st.composite
def _bad_flags(draw, table):
    names = draw(st.lists(st.sampled_from(sorted(table)), min_size=1, max_size=3, unique=True))
    flags = []
    for name in names:
        flags += [f"{name}={draw(table[name])}"]
    return flags


@_FUZZ
@given(flags=_bad_flags(_BAD_FOLD))
def test_fuzz_fold_refuses_bad_flags_before_compiling(flags, tmp_path, capsys, monkeypatch):
    import origami_jax.cli._fold as fold_cli

    monkeypatch.setattr(fold_cli, "_run", _no_compiling)
    out = tmp_path / "fold_fuzz"
    code = main(["fold", "cube_net_01", *flags, "--out", str(out)])
    assert code == 2, (flags, capsys.readouterr())
    _one_line(capsys.readouterr().err)
    assert not out.exists() or not any(out.iterdir())


@_FUZZ
@given(flags=_bad_flags(_BAD_YIELD))
def test_fuzz_yield_refuses_bad_flags_before_compiling(flags, tmp_path, capsys, monkeypatch):
    import origami_jax.cli._yield as yield_cli

    monkeypatch.setattr(yield_cli, "_run", _no_compiling)
    out = tmp_path / "yield_fuzz"
    code = main(["yield", "cube_net_01", *flags, "--no-progress", "--out", str(out)])
    assert code == 2, (flags, capsys.readouterr())
    _one_line(capsys.readouterr().err)
    assert not out.exists() or not any(out.iterdir())


def _no_compiling(*args, **kwargs):
    raise AssertionError("a bad flag was not refused before the run")


# FOLD data drawn by mutating a net: fold (stopped where it would compile) and view read it,
# and either accept it or refuse it in one line (exit 2), never a traceback.
_VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-3, 40),
    st.floats(allow_nan=False),
    st.sampled_from([1e-12, 1e12, 0.5, -0.0, "x", [], {}, [0, 1], [[0, 1, 2]]]),
)
_KEYS = st.sampled_from(
    [
        "vertices_coords",
        "edges_vertices",
        "edges_assignment",
        "edges_foldAngle",
        "faces_vertices",
        "frame_unit",
        "frame_parent",
        "file_frames",
    ]
)


@st.composite
def _mutated_net(draw):
    from origami_jax.fold._catalogue import source_and_label

    data = json.loads(Path(source_and_label("cube_net_01")[0]).read_text())
    for _ in range(draw(st.integers(1, 3))):
        key = draw(_KEYS)
        value = data.get(key)
        if isinstance(value, list) and value and draw(st.booleans()):
            i = draw(st.integers(0, len(value) - 1))
            entry = value[i]
            if isinstance(entry, list) and entry and draw(st.booleans()):
                entry[draw(st.integers(0, len(entry) - 1))] = draw(_VALUES)
            else:
                value[i] = draw(_VALUES)
        elif draw(st.booleans()):
            data.pop(key, None)
        else:
            data[key] = draw(_VALUES)
    return data


@_FUZZ
@given(data=_mutated_net())
def test_fuzz_fold_and_view_of_drawn_fold_files(data, tmp_path, capsys, monkeypatch):
    import origami_jax.cli._fold as fold_cli

    monkeypatch.setattr(fold_cli, "_run", lambda *a, **k: 0)  # accepted: stop before compiling
    path = tmp_path / "drawn.fold"
    path.write_text(json.dumps(data))
    for argv in (["fold", str(path)], ["view", str(path), "--overwrite"]):
        code = main([*argv, "--out", str(tmp_path / "out")])
        err = capsys.readouterr().err
        lines = [line for line in err.splitlines() if line.strip() and "warning:" not in line]
        assert "Traceback" not in err and code in (0, 2), (argv[0], code, err)
        if code == 2:
            assert len(lines) == 1, err


def test_fold_interrupted_keeps_the_earlier_results_and_no_staging(tmp_path, capsys, monkeypatch):
    import origami_jax.cli._fold as fold_cli
    from origami_jax.cli._common import STAGING_PREFIX

    before = _results(tmp_path, {"verdict": "folded", "net": "cube_net_01"})

    def interrupted(*args, **kwargs):
        output = args[-2]
        (output.dir / "result.json").write_text("half")
        raise KeyboardInterrupt

    monkeypatch.setattr(fold_cli, "_run", interrupted)
    assert main(["fold", "cube_net_01", "--out", str(tmp_path), "--overwrite"]) == 130
    assert "interrupted" in _one_line(capsys.readouterr().err)
    assert _snapshot(tmp_path) == before
    assert not list(tmp_path.glob(f"{STAGING_PREFIX}*"))
    lock_folder(tmp_path, command="fold").close()  # released


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--improve-step", "0.3"], "--improve-step needs --improve STEPS"),
        (["--release-ramp", "0", "--t-end", "2000", "--t-settle", "100"], "ends at or before"),
    ],
)
def test_yield_refuses_options_that_would_do_nothing(flags, message, tmp_path, capsys, monkeypatch):
    import origami_jax.cli._yield as yield_cli

    monkeypatch.setattr(yield_cli, "_run", _no_compiling)
    out = tmp_path / "y"
    code = main(["yield", "cube_net_01", *flags, "--no-progress", "--out", str(out)])
    assert code == 2
    assert message in _one_line(capsys.readouterr().err)
    assert not out.exists()


def test_yield_resume_into_an_empty_folder_says_it_starts_afresh(tmp_path, capsys, monkeypatch):
    import origami_jax.cli._yield as yield_cli

    monkeypatch.setattr(yield_cli, "_run", lambda *a, **k: 0)
    out = tmp_path / "y"
    assert main(["yield", "cube_net_01", "--resume", "--no-progress", "--out", str(out)]) == 0
    assert "nothing is stored in" in capsys.readouterr().out
