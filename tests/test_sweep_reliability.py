"""A sweep neither loses nor duplicates results, and stops cleanly.

- A second sweep on a folder in use is refused (the folder's lock); the gathered dataset holds every
  design exactly once, with its parameter values; duplicate, foreign and corrupt chunk files are
  set aside by name and their designs computed again.
- Labels keep their full length in `sweep.nc`; a label given for a number, or a negative run length,
  is refused before anything runs.
- A full disk (a file-size limit in a child process) and Ctrl-C (SIGINT to a child) end with one
  line and keep every finished chunk, without a temporary file left or a crash; `--resume` completes.
- Several processes (`jax.distributed` with a localhost coordinator, CPU devices) give the dataset
  of one process; one of them killed midway, the sweep resumes without loss or duplicates.

The kernel is the engine tests' damped-oscillator fixture (`tests.test_sweep_engine.KERNEL`).
"""

import logging
import os
import shutil
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr

from origami_jax.cli import main
from origami_jax.sweep import Grid, Samples, SweepBusyError, get_model, sweep
from origami_jax.sweep._store import Store, _lock, netcdf_bytes
from tests.test_sweep_engine import KERNEL

ROOT = Path(__file__).resolve().parents[1]
# The space of CONFIG below, as `load_config` builds it (units from the kernel).
SPACE = Samples(
    {"zeta": (-0.1, 1.2), "omega": (0.5, 5.0)}, n=41, seed=3, units={"zeta": "1", "omega": "rad/s"}
)


def _same_data(a: xr.Dataset, b: xr.Dataset) -> None:
    """Same designs, parameters and outputs, bit for bit (attributes such as devices may differ)."""
    assert set(a.variables) == set(b.variables)
    for name in a.variables:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


@pytest.fixture(scope="module")
def reference():
    return sweep(KERNEL, SPACE, chunk_size=4, progress=False)


def _python(code: str, *args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code), *args],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


# The CLI with the test model registered, for child processes.
CLI = """
    import sys
    from origami_jax.sweep import _kernels
    from tests.test_sweep_engine import KERNEL
    _kernels.MODELS["test-oscillator"] = _kernels._Model("test fixture", lambda: KERNEL)
    from origami_jax.cli import main
    sys.exit(main(sys.argv[1:]))
"""
CONFIG = """
[model]
name = "test-oscillator"
[sweep]
kind = "lhs"
n = 41
seed = 3
chunk_size = 4
[parameters]
zeta = { min = -0.1, max = 1.2 }
omega = { min = 0.5, max = 5.0 }
"""


def _register(monkeypatch):
    from origami_jax.sweep import _kernels

    monkeypatch.setitem(_kernels.MODELS, "test-oscillator", _kernels._Model("t", lambda: KERNEL))


def test_labels_keep_their_full_length(tmp_path):
    def labelled(params):
        return {"y": params["x"] * (1.0 + params["material"]), "result": jnp.int32(0)}

    space = Grid({"material": ["a", "SiNx", "narrow"], "x": [1.0, 2.0]})
    in_memory = sweep(labelled, space, chunk_size=2, out=tmp_path, progress=False)
    stored = xr.load_dataset(tmp_path / "sweep.nc")
    assert stored["material"].values.tolist() == in_memory["material"].values.tolist()
    assert stored["material"].values.tolist() == ["a", "a", "SiNx", "SiNx", "narrow", "narrow"]


def test_a_label_for_a_number_is_refused():
    with pytest.raises(ValueError, match="'zeta' of model 'test-oscillator' takes numbers"):
        sweep(KERNEL, Grid({"zeta": ["wide", "narrow"], "omega": [1.0]}), progress=False)


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"t_end": -5.0}, "t_end must be finite and > 0"),
        ({"t_end": "2000"}, "t_end"),  # a string: refused by type
        ({"n_save": 1}, "n_save must be finite and >= 2"),
        ({"rtol": float("nan")}, "rtol must be finite"),
        ({"n_flaps": 10_000}, "n_flaps must be finite and >= 1 and <= 32"),
    ],
)
def test_bad_model_settings_are_refused(settings, message):
    with pytest.raises(ValueError, match=message):
        get_model("accordion-step", **settings)


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"rtol": 0.0}, "rtol must be finite and > 0"),
        ({"atol": float("inf")}, "atol must be finite"),
        ({"rtol": "1e-5"}, "rtol must be a number"),
        ({"t_end": -1.0}, "t_end must be finite and > 0"),
        ({"n_save": 1}, "n_save must be finite and >= 2"),
        ({"max_steps": 2.5}, "max_steps must be an integer"),
    ],
)
def test_bad_net_fold_settings_are_refused_before_the_net_is_built(settings, message):
    # The same checks as the accordion's kernel: a direct sweep over `net-fold` (not only
    # `yield_estimate`, which checks its own rtol) refuses them before loading or compiling anything.
    with pytest.raises(ValueError, match=message):
        get_model("net-fold", **settings)


def test_bad_settings_and_labels_in_a_config_are_one_line(tmp_path, capsys, monkeypatch):
    _register(monkeypatch)
    config = tmp_path / "bad.toml"
    config.write_text(
        '[model]\nname = "accordion-step"\nt_end = -5.0\n[parameters]\nk_scale = {values=[1.0]}\n'
    )
    assert main(["sweep", str(config), "--out", str(tmp_path / "a")]) == 2
    assert "t_end must be finite and > 0" in capsys.readouterr().err
    config.write_text(
        CONFIG.replace("zeta = { min = -0.1, max = 1.2 }", 'zeta = { values = ["wide"] }')
    )
    assert main(["sweep", str(config), "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert "takes numbers" in err and len(err.strip().splitlines()) == 1


def test_a_second_sweep_on_a_folder_in_use_is_refused(tmp_path, reference, capsys, monkeypatch):
    first = sweep(KERNEL, SPACE, chunk_size=4, out=tmp_path, progress=False)
    _same_data(first, reference)
    # A running sweep holds the folder: another process's --resume must not compute it again.
    lock = _lock(tmp_path)  # as a running sweep holds it
    try:
        with pytest.raises(SweepBusyError, match=f"pid {os.getpid()}"):
            sweep(KERNEL, SPACE, chunk_size=4, out=tmp_path, resume=True, progress=False)
        _register(monkeypatch)
        config = tmp_path.parent / "config.toml"
        config.write_text(CONFIG)
        assert main(["sweep", str(config), "--out", str(tmp_path), "--resume"]) == 2
        err = capsys.readouterr().err
        assert "in use by another sweep" in err and len(err.strip().splitlines()) == 1
    finally:
        lock.close()
    again = sweep(KERNEL, SPACE, chunk_size=4, out=tmp_path, resume=True, progress=False)
    assert again.sizes["design"] == SPACE.size


def test_duplicate_foreign_and_corrupt_chunks_are_set_aside_and_recomputed(
    tmp_path, reference, caplog
):
    sweep(KERNEL, SPACE, chunk_size=4, out=tmp_path, progress=False)
    chunks = tmp_path / "chunks"
    parts = sorted(chunks.glob("part-*.nc"))
    # A duplicate (a second file with designs 4..7), a corrupt file, and a chunk of another sweep
    # under this sweep's design indices.
    shutil.copy(parts[1], chunks / "part-000000004-000004x.nc")
    data = parts[2].read_bytes()
    parts[2].write_bytes(data[: len(data) // 2])
    other = xr.load_dataset(parts[3])
    other["zeta"] = other["zeta"] + 0.01
    parts[3].write_bytes(netcdf_bytes(other))
    with caplog.at_level(logging.WARNING, logger="origami_jax.sweep"):
        resumed = sweep(KERNEL, SPACE, chunk_size=4, out=tmp_path, resume=True, progress=False)
    messages = "\n".join(r.getMessage() for r in caplog.records)
    assert "part-000000004-000004x.nc is a duplicate" in messages
    assert f"{parts[2].name} is unreadable" in messages
    assert f"{parts[3].name} is not a chunk of this sweep (its 'zeta' values differ)" in messages
    assert sorted(p.name for p in chunks.glob("*.bad")) == sorted(
        f"{n}.bad" for n in ("part-000000004-000004x.nc", parts[2].name, parts[3].name)
    )
    _same_data(resumed, reference)
    _same_data(xr.load_dataset(tmp_path / "sweep.nc"), reference)


def test_gather_refuses_missing_or_repeated_designs(tmp_path):
    sweep(KERNEL, SPACE, chunk_size=4, out=tmp_path, progress=False)
    store = Store(tmp_path, {})
    columns = SPACE.columns()
    part = sorted((tmp_path / "chunks").glob("part-*.nc"))[3]
    shutil.copy(part, part.with_name("part-999999999-000004.nc"))
    with pytest.raises(ValueError, match="4 designs stored more than once"):
        store.gather(write=False, columns=columns)
    part.unlink()
    part.with_name("part-999999999-000004.nc").unlink()
    with pytest.raises(ValueError, match="4 designs missing"):
        store.gather(write=False, columns=columns)


def _no_temporary_files(out: Path) -> None:
    leftovers = [p for p in out.rglob("*") if p.name.startswith((".tmp-", ".partial-"))]
    assert not leftovers, leftovers


def test_a_full_disk_stops_with_one_line_and_resume_completes(tmp_path, reference):
    """The file-size limit (RLIMIT_FSIZE) lets the manifest and the chunk files through but not the
    gathered sweep.nc: the write fails as on a full disk. The process reports it in one line and
    exits 1 (it used to print a traceback, crash at exit and leave a temporary sweep.nc)."""
    config = tmp_path / "sweep.toml"
    config.write_text(CONFIG)
    out = tmp_path / "out"
    chunk_bytes = len(netcdf_bytes(reference.isel(design=slice(0, 4))))
    whole_bytes = len(netcdf_bytes(reference))
    assert whole_bytes > chunk_bytes + 1000
    limit = (chunk_bytes + whole_bytes) // 2  # above every chunk file, below the gathered dataset
    code = (
        "import resource, signal\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit}))\n" + textwrap.dedent(CLI)
    )
    child = _python(code, "sweep", str(config), "--out", str(out), "--no-progress", "--no-plots")
    stdout, stderr = child.communicate(timeout=300)
    assert child.returncode == 1, stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "could not write" in lines[0] and "resume" in lines[0], stderr
    _no_temporary_files(out)
    assert len(list((out / "chunks").glob("part-*.nc"))) == 11  # every chunk kept
    resumed = sweep(KERNEL, SPACE, chunk_size=4, out=out, resume=True, progress=False)
    _same_data(resumed, reference)


# Where the child interrupts itself (a real SIGINT, sent from its own main thread, so that it lands
# at a known point whatever the machine's load; waiting here for chunk files to appear raced the
# child, which may store several at once): after its second chunk file, or while it draws the
# summary plots once every chunk and sweep.nc are stored.
_INTERRUPTS = {
    "mid-sweep": (
        "    from origami_jax.sweep._store import Store\n"
        "    write = Store.write_chunk\n"
        "    def interrupting(self, chunk):\n"
        "        path = write(self, chunk)\n"
        "        if len(self.chunk_files()) == 2:\n"
        "            os.kill(os.getpid(), signal.SIGINT)\n"
        "        return path\n"
        "    Store.write_chunk = interrupting\n"
    ),
    "at-the-end": (
        "    from origami_jax.plotting import sweep as plots\n"
        "    plots.summary_plots = lambda *a, **k: os.kill(os.getpid(), signal.SIGINT)\n"
    ),
}


@pytest.mark.parametrize("when", sorted(_INTERRUPTS))
def test_ctrl_c_stops_with_one_line_and_resume_completes(tmp_path, reference, when):
    config = tmp_path / "sweep.toml"
    config.write_text(CONFIG)
    out = tmp_path / "out"
    code = CLI.replace(
        "from origami_jax.cli import main",
        # A Ctrl-C handler whatever the parent left: a shell's background job (`pytest ... &`)
        # starts with SIGINT ignored, which its children inherit, and then no KeyboardInterrupt.
        "import os, signal\n"
        "    signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        + _INTERRUPTS[when]
        + "    from origami_jax.cli import main",
    )
    child = _python(code, "sweep", str(config), "--out", str(out), "--no-progress")
    stdout, stderr = child.communicate(timeout=300)
    assert child.returncode == 130, (child.returncode, stdout[-2000:], stderr)
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "continue with --resume" in lines[0], stderr
    _no_temporary_files(out)
    stored = len(list((out / "chunks").glob("part-*.nc")))
    assert stored == (2 if when == "mid-sweep" else 11), stored
    resumed = sweep(KERNEL, SPACE, chunk_size=4, out=out, resume=True, progress=False)
    _same_data(resumed, reference)


# Several processes ---------------------------------------------------------------------------

PROCESS = """
    import os, signal, sys
    import jax
    process_id, port, out, resume, kill_after = sys.argv[1:]
    jax.config.update("jax_enable_x64", True)
    jax.distributed.initialize(
        coordinator_address=f"127.0.0.1:{port}", num_processes=2, process_id=int(process_id)
    )
    from origami_jax.sweep import Samples, sweep
    from tests.test_sweep_engine import KERNEL

    def on_chunk(done, total):
        if int(kill_after) and process_id == "1" and done >= int(kill_after):
            os.kill(os.getpid(), signal.SIGKILL)   # killed midway, as by a scheduler

    space = Samples({"zeta": (-0.1, 1.2), "omega": (0.5, 5.0)}, n=41, seed=3,
                    units={"zeta": "1", "omega": "rad/s"})
    ds = sweep(KERNEL, space, chunk_size=4, out=out, resume=resume == "1", progress=False,
               on_chunk=on_chunk)
    print("DESIGNS", ds.sizes["design"], jax.process_count())
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _two_processes(out: Path, *, resume: bool, kill_after: int = 0) -> list[subprocess.Popen]:
    port = str(_free_port())
    flags = [str(out), "1" if resume else "0", str(kill_after)]
    return [_python(PROCESS, str(i), port, *flags) for i in (0, 1)]


def _finish(processes: list[subprocess.Popen], timeout: float = 300) -> list[tuple[int, str]]:
    return [(p.wait(timeout=timeout), p.communicate()[0]) for p in processes]


def _designs_in_chunks(out: Path) -> np.ndarray:
    return np.concatenate(
        [xr.load_dataset(p)["design"].values for p in (out / "chunks").glob("part-*.nc")]
    )


def test_two_processes_give_the_dataset_of_one(tmp_path, reference):
    results = _finish(_two_processes(tmp_path, resume=False))
    for code, stdout in results:
        assert code == 0 and f"DESIGNS {SPACE.size} 2" in stdout, (code, stdout)
    _same_data(xr.load_dataset(tmp_path / "sweep.nc"), reference)
    assert sorted(_designs_in_chunks(tmp_path).tolist()) == list(range(SPACE.size))


@pytest.mark.slow
def test_a_process_killed_midway_resumes_without_loss_or_duplicates(tmp_path, reference):
    """Process 1 is killed after its first chunk; process 0 finishes its share and then waits for
    its peer at the final barrier, where it is killed too (JAX's coordinator would end it after
    its heartbeat timeout, ~100 s). Two fresh processes resume the sweep."""
    first = _two_processes(tmp_path, resume=False, kill_after=1)
    assert first[1].wait(timeout=300) == -signal.SIGKILL
    # Process 0's share is every other chunk: 6 of the 11 (designs 0, 8, ..., 40).
    deadline = time.monotonic() + 240
    while len(list((tmp_path / "chunks").glob("part-*.nc"))) < 7 and time.monotonic() < deadline:
        time.sleep(0.1)
    first[0].kill()
    _finish(first)
    stored = _designs_in_chunks(tmp_path)
    assert 0 < len(stored) < SPACE.size and len(np.unique(stored)) == len(stored)
    for code, stdout in _finish(_two_processes(tmp_path, resume=True)):
        assert code == 0 and f"DESIGNS {SPACE.size} 2" in stdout, (code, stdout)
    designs = _designs_in_chunks(tmp_path)
    assert sorted(designs.tolist()) == list(range(SPACE.size))  # each design exactly once
    assert not list((tmp_path / "chunks").glob("*.bad"))
    _same_data(xr.load_dataset(tmp_path / "sweep.nc"), reference)
