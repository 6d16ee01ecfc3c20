"""The sweep engine: batching, failure codes, sharding, storage and resume.

The kernel here is a *test fixture*, not physics: the closed-form step response of a unit damped
oscillator `x'' + 2ζω x' + ω² x = ω²`, whose 10 % and 90 % crossing times are found by a bisection
`while_loop` (a data-dependent loop, like the real solvers'). Invalid inputs (`ζ <= 0` or `ω <= 0`)
return result code 1, overdamped ones (`ζ >= 1`, outside the closed form used) code 2.
"""

import dataclasses
import json
import logging
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr

from origami_jax.sweep import Grid, Kernel, Samples, Table, TraceCache, sweep

ROOT = Path(__file__).resolve().parents[1]
# Sharded and unsharded runs compile different programs (different per-device batch sizes); XLA may
# vectorise the elementwise math differently, so equality is checked to this relative tolerance and
# the test reports whether it also held bit for bit.
SHARDING_RTOL = 1e-13


def oscillator(params):
    """Test fixture (see module docstring): step-response metrics of a damped oscillator."""
    zeta, omega = params["zeta"], params["omega"]
    invalid = (zeta <= 0) | (omega <= 0)
    overdamped = zeta >= 1
    bad = invalid | overdamped
    z = jnp.where(bad, 0.5, zeta)
    w = jnp.where(invalid, 1.0, omega)
    root = jnp.sqrt(1 - z**2)
    damped = w * root
    peak_time = jnp.pi / damped

    def x(t):
        return 1 - jnp.exp(-z * w * t) * (jnp.cos(damped * t) + z / root * jnp.sin(damped * t))

    def crossing(level):
        def cond(bracket):
            return bracket[1] - bracket[0] > 1e-12 * peak_time

        def body(bracket):
            lo, hi = bracket
            mid = 0.5 * (lo + hi)
            above = x(mid) >= level
            return jnp.where(above, lo, mid), jnp.where(above, mid, hi)

        lo, hi = jax.lax.while_loop(cond, body, (jnp.zeros_like(peak_time), peak_time))
        return 0.5 * (lo + hi)

    t10, t90 = crossing(0.1), crossing(0.9)
    result = jnp.where(invalid, 1, jnp.where(overdamped, 2, 0))
    return {
        "overshoot": jnp.where(bad, jnp.nan, jnp.exp(-jnp.pi * z / root)),
        "rise_time": jnp.where(bad, jnp.nan, t90 - t10),
        "crossings": jnp.where(bad, jnp.nan, jnp.stack([t10, t90])),
        "result": result,
    }


KERNEL = Kernel(
    oscillator,
    name="test-oscillator",
    settings={"bisection_rtol": 1e-12},
    parameters={"zeta": "1", "omega": "rad/s"},
    output_units={"rise_time": "s", "overshoot": "1", "crossings": "s"},
    output_dims={"crossings": ("level",)},
    result_messages={0: "successful", 1: "invalid input", 2: "overdamped"},
)
SPACE = Grid(
    {"zeta": [-0.2, 0.05, 0.2, 0.4, 0.7, 1.5], "omega": [0.5, 2.0, 7.0]}, units={"omega": "rad/s"}
)


def test_sweep_matches_direct_vmap_and_marks_failures():
    traces = []

    def counted(params):
        traces.append(1)
        return oscillator(params)

    kernel = Kernel(counted, name="counted", output_dims={"crossings": ("level",)})
    ds = sweep(kernel, SPACE, chunk_size=4, progress=False)  # 18 designs: 5 chunks, last padded
    # One trace: the shape probe's, reused by the compiled chunks (vmapped) and by chunks of one
    # design (the kernel itself, no batch axis), however many chunks.
    one_at_a_time = sweep(kernel, SPACE, chunk_size=1, progress=False)
    assert len(traces) == 1
    for name in ("overshoot", "rise_time", "crossings", "result"):
        np.testing.assert_allclose(one_at_a_time[name].values, ds[name].values, rtol=1e-14)
    columns = SPACE.columns()
    direct = jax.jit(jax.vmap(oscillator))({k: jnp.asarray(v) for k, v in columns.items()})
    for name in ("overshoot", "rise_time", "crossings"):
        np.testing.assert_array_equal(ds[name].values, np.asarray(direct[name]))
    np.testing.assert_array_equal(ds["zeta"].values, columns["zeta"])
    expected = np.where(columns["zeta"] <= 0, 1, np.where(columns["zeta"] >= 1, 2, 0))
    np.testing.assert_array_equal(ds["result"].values, expected)
    assert ds.attrs["n_failed"] == int((expected != 0).sum()) == 6
    assert ds["crossings"].dims == ("design", "level")
    # Timings: compiling and the steady state (chunks computed and stored) are reported apart.
    assert ds.attrs["compile_s"] > 0 and ds.attrs["run_s"] > 0
    # Closed form: overshoot exp(-πζ/√(1-ζ²)).
    ok = expected == 0
    zeta = columns["zeta"][ok]
    np.testing.assert_allclose(
        ds["overshoot"].values[ok], np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2)), rtol=1e-14
    )


def test_kernels_of_one_program_with_other_inputs_compile_nothing_again():
    """`Kernel.inputs` reach its `program` as data: a second kernel of the same program with other
    input values (a setting a user changes between sweeps) traces and compiles nothing, and its
    results follow its own values (the damping ratio scaled by an input, against the oscillator
    swept at the scaled ratio); another shape or dtype is another trace; a swept parameter may not take
    an input's name, and inputs that are not numbers are refused before anything is traced."""
    traces = []

    def scaled(params):
        traces.append(1)
        return oscillator({**params, "zeta": params["zeta"] * params["scale"]})

    space = Grid({"zeta": [0.1, 0.2, 0.3], "omega": [2.0]})

    def bound(scale):
        return lambda params: scaled({**params, "scale": scale})

    kernels = [
        Kernel(
            bound(s),
            name="scaled",
            output_dims={"crossings": ("level",)},
            program=scaled,
            inputs={"scale": s},
        )
        for s in (1.0, 2.0)
    ]
    traces_kept = TraceCache()
    first, second = (
        sweep(k, space, chunk_size=2, progress=False, traces=traces_kept) for k in kernels
    )
    assert len(traces) == 1 and second.attrs["compile_s"] == 0.0
    # Other compiler options: the same trace, compiled again (the numbers the same here).
    loops = dataclasses.replace(kernels[1], compiler_options={"xla_cpu_use_fusion_emitters": False})
    looped = sweep(loops, space, chunk_size=2, progress=False, traces=traces_kept)
    assert len(traces) == 1 and looped.attrs["compile_s"] > 0.0
    for name in ("overshoot", "rise_time"):
        np.testing.assert_allclose(looped[name].values, second[name].values, rtol=1e-14)
    doubled = sweep(
        KERNEL, Grid({"zeta": [0.2, 0.4, 0.6], "omega": [2.0]}), chunk_size=2, progress=False
    )
    for name in ("overshoot", "rise_time"):
        np.testing.assert_allclose(second[name].values, doubled[name].values, rtol=1e-14)
        assert not np.allclose(first[name].values, second[name].values)
    direct = kernels[1]({"zeta": 0.1, "omega": 2.0})["overshoot"]  # a call takes them too
    np.testing.assert_allclose(direct, doubled["overshoot"].values[0], rtol=1e-14)
    whole = dataclasses.replace(kernels[0], inputs={"scale": 2})  # an integer: another dtype
    before = len(traces)
    sweep(whole, space, chunk_size=2, progress=False, traces=traces_kept)
    assert len(traces) == before + 1
    with pytest.raises(ValueError, match="fixed inputs"):
        sweep(kernels[0], Grid({"zeta": [0.1], "omega": [2.0], "scale": [1.0]}), progress=False)
    for bad, message in (({"scale": "two"}, "numbers or arrays"), ([2.0], "a mapping")):
        with pytest.raises(ValueError, match=message):
            sweep(dataclasses.replace(kernels[0], inputs=bad), space, progress=False)
    with pytest.raises(ValueError, match="inputs go to a program"):
        Kernel(oscillator, name="no program", inputs={"scale": 2.0})


def test_a_kernel_with_a_program_key_is_kept_compiled_for_a_later_process(tmp_path, monkeypatch):
    """Where the command line keeps its programs, a kernel with a `program_key` has its chunks'
    executable and its output shapes kept: a later process (nothing in memory) neither traces nor
    compiles it, and gets the same numbers; without the key nothing is kept."""
    from origami_jax import _exported

    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_LOADED", {})
    traces = []

    def scaled(params):
        traces.append(1)
        return oscillator({**params, "zeta": params["zeta"] * params["scale"]})

    def kernel(key):
        return Kernel(
            lambda params: scaled({**params, "scale": 2.0}),
            name="scaled",
            output_dims={"crossings": ("level",)},
            program=scaled,
            inputs={"scale": 2.0},
            program_key=key,
        )

    space = Grid({"zeta": [0.1, 0.2, 0.3], "omega": [2.0]})
    first = sweep(kernel(("scaled", 1)), space, chunk_size=2, progress=False, traces=TraceCache())
    assert len(traces) == 1
    assert len(list(tmp_path.glob("sweep_chunk-*.xla"))) == 1
    assert len(list(tmp_path.glob("sweep_shapes-*.pkl"))) == 1
    monkeypatch.setattr(_exported, "_LOADED", {})  # a later process
    later = sweep(kernel(("scaled", 1)), space, chunk_size=2, progress=False, traces=TraceCache())
    assert len(traces) == 1  # read back: not traced
    for name in ("overshoot", "rise_time", "crossings"):
        np.testing.assert_array_equal(later[name].values, first[name].values)
    sweep(kernel(None), space, chunk_size=2, progress=False, traces=TraceCache())
    assert len(traces) == 2 and len(list(tmp_path.glob("sweep_chunk-*.xla"))) == 1


def test_some_invalid_members_complete_and_are_marked_exactly():
    zeta = [0.3, -1.0, 0.5, 0.1, 2.0, 0.3, 0.0]
    omega = [1.0, 1.0, -3.0, 2.0, 1.0, 0.0, 1.0]
    ds = sweep(KERNEL, Table({"zeta": zeta, "omega": omega}), chunk_size=3, progress=False)
    assert ds["result"].values.tolist() == [0, 1, 1, 0, 2, 1, 1]
    good = ds["result"].values == 0
    assert np.isfinite(ds["rise_time"].values[good]).all()
    assert np.isnan(ds["rise_time"].values[~good]).all()
    assert ds["result"].attrs["flag_meanings"] == "successful invalid_input overdamped"
    assert ds["rise_time"].attrs["units"] == "s" and ds["omega"].attrs["units"] == ""


def test_static_parameters_compile_once_per_value_and_pad_outputs():
    traces = []

    def kernel_fn(params):
        traces.append(params["n"])
        n = params["n"]  # a Python int: it fixes the output's shape
        return {"powers": params["a"] ** jnp.arange(1, n + 1), "result": jnp.int32(0)}

    kernel = Kernel(kernel_fn, name="powers", static=("n",), output_dims={"powers": ("k",)})
    space = Grid({"n": [2, 3], "a": [1.5, 2.0, 3.0]})
    ds = sweep(kernel, space, chunk_size=2, progress=False)
    assert sorted(traces) == [2, 3]  # one trace per static value
    assert ds.sizes["k"] == 3
    np.testing.assert_array_equal(ds["powers"].values[0], [1.5, 2.25, np.nan])
    np.testing.assert_array_equal(ds["powers"].values[5], [3.0, 9.0, 27.0])


def test_kernel_that_throws_is_reported():
    def throwing(params):
        return {"y": eqx.error_if(params["a"], params["a"] < 0, "negative")}

    with pytest.raises(RuntimeError, match="throw=False"):
        sweep(throwing, Table({"a": [1.0, -1.0]}), progress=False)


def test_unknown_parameter_is_refused():
    with pytest.raises(ValueError, match="accepts"):
        sweep(KERNEL, Grid({"zeta": [0.5], "mass": [1.0]}), progress=False)


def same_sweep(a: xr.Dataset, b: xr.Dataset) -> None:
    """Identical datasets apart from `compile_s`, `run_s` and `workers`: how each run went."""
    a, b = a.copy(), b.copy()
    for ds in (a, b):
        for name in ("compile_s", "run_s", "workers"):
            ds.attrs.pop(name, None)
    xr.testing.assert_identical(a, b)


class _Interrupted(Exception):
    pass


def test_interrupted_sweep_resumes_to_the_same_dataset(tmp_path, caplog):
    space = Samples({"zeta": (-0.1, 1.2), "omega": (0.5, 5.0)}, n=21, seed=1)
    reference = sweep(KERNEL, space, chunk_size=4, out=tmp_path / "whole", progress=False)

    def stop_after_two(done, total):
        if done >= 8:
            raise _Interrupted

    with pytest.raises(_Interrupted):
        sweep(KERNEL, space, chunk_size=4, out=tmp_path / "cut", on_chunk=stop_after_two)
    assert len(list((tmp_path / "cut" / "chunks").glob("part-*.nc"))) == 2
    with pytest.raises(FileExistsError, match="resume"):
        sweep(KERNEL, space, chunk_size=4, out=tmp_path / "cut", progress=False)
    # Resumed in chunks of another size: said, since the two compile different vector code.
    shutil.copytree(tmp_path / "cut", tmp_path / "other")
    with caplog.at_level(logging.WARNING, logger="origami_jax.sweep"):
        sweep(KERNEL, space, chunk_size=8, out=tmp_path / "other", resume=True, progress=False)
    assert "computed in chunks of 4; results may differ" in caplog.text
    assert "Pass chunk_size=4" in caplog.text
    caplog.clear()
    computed = []
    resumed = sweep(
        KERNEL,
        space,
        chunk_size=4,
        out=tmp_path / "cut",
        resume=True,
        workers=1,  # chunks finish in order (side by side, the short last one may finish first)
        progress=False,
        on_chunk=lambda done, total: computed.append(done),
    )
    assert computed == [12, 16, 20, 21]  # only the 13 designs not stored yet
    assert "results may differ" not in caplog.text  # the same size: nothing to say
    same_sweep(resumed, reference)
    same_sweep(xr.load_dataset(tmp_path / "cut" / "sweep.nc"), reference)
    assert reference.attrs["n_failed"] == int((reference["result"] != 0).sum()) > 0


def _slow_first(params):
    """The oscillator, with a busy loop for design `slow` (about 10^7 iterations) so that, computed
    side by side, it finishes after the designs behind it."""
    spins = jnp.where(params["slow"] > 0, 10_000_000, 1)

    def body(state):
        i, x = state
        return i + 1, jnp.sin(x) + 0.5

    _, x = jax.lax.while_loop(lambda s: s[0] < spins, body, (0, params["zeta"]))
    return {**oscillator(params), "spun": x}


SLOW_FIRST = Kernel(_slow_first, name="slow-first", output_dims={"crossings": ("level",)})


def test_chunks_side_by_side_finish_out_of_order_and_change_no_result(tmp_path):
    n = 9
    rng = np.random.default_rng(4)
    table = Table(
        {
            "zeta": rng.uniform(0.05, 0.9, n),
            "omega": rng.uniform(0.5, 5.0, n),
            "slow": np.r_[1.0, np.zeros(n - 1)],
        }
    )
    order = []
    alone = sweep(SLOW_FIRST, table, chunk_size=1, workers=1, out=tmp_path / "one", progress=False)
    together = sweep(
        SLOW_FIRST,
        table,
        chunk_size=1,
        workers=3,
        out=tmp_path / "three",
        progress=False,
        on_chunk=lambda done, total: order.append(done),
    )
    assert (alone.attrs["workers"], together.attrs["workers"]) == (1, 3)
    assert order == list(range(1, n + 1))  # every chunk reported once, as it is stored
    # The slow first design finished after others: they were stored before it.
    parts = sorted((tmp_path / "three" / "chunks").glob("part-*.nc"), key=os.path.getmtime)
    assert len(parts) == n and not parts[0].name.startswith("part-0-")
    same_sweep(together, alone)
    same_sweep(xr.load_dataset(tmp_path / "three" / "sweep.nc"), alone)


def test_small_chunks_are_stored_together_and_kept_on_an_interruption(tmp_path):
    space = Samples({"zeta": (0.05, 0.9), "omega": (0.5, 5.0)}, n=23, seed=2)
    reference = sweep(KERNEL, space, chunk_size=1, out=tmp_path / "apart", progress=False)
    assert len(list((tmp_path / "apart" / "chunks").glob("part-*.nc"))) == 23  # as given
    # The sweep's own chunk size for a kernel that asks for one design per call: one file.
    single = dataclasses.replace(KERNEL, cpu_chunk_size=1)
    together = sweep(single, space, out=tmp_path / "together", progress=False)
    assert together.attrs["chunk_size"] == 1
    assert len(list((tmp_path / "together" / "chunks").glob("part-*.nc"))) == 1
    same_sweep(together, reference)

    # Held designs are stored when the sweep is interrupted, and a resume computes the rest.
    def stop(done, total):
        if done == 7:
            raise _Interrupted

    with pytest.raises(_Interrupted):
        sweep(KERNEL, space, chunk_size=1, store_every=5, out=tmp_path / "cut", on_chunk=stop,
              workers=1, progress=False)  # fmt: skip
    stored = [xr.load_dataset(p) for p in sorted((tmp_path / "cut" / "chunks").glob("part-*.nc"))]
    assert [ds.sizes["design"] for ds in stored] == [5, 2]
    computed = []
    resumed = sweep(KERNEL, space, chunk_size=1, store_every=5, out=tmp_path / "cut", resume=True,
                    progress=False, on_chunk=lambda done, total: computed.append(done))  # fmt: skip
    assert len(computed) == 23 - 7
    same_sweep(resumed, reference)
    with pytest.raises(ValueError, match="store_every must be a whole number >= 1"):
        sweep(KERNEL, space, store_every=0, progress=False)


@pytest.mark.parametrize("workers", [0, -2, 1.5, True, "2"])
def test_bad_workers_are_refused(workers):
    with pytest.raises(ValueError, match="workers must be a whole number >= 1"):
        sweep(KERNEL, SPACE, workers=workers, progress=False)


def test_default_chunks_and_workers_on_a_cpu():
    from origami_jax.sweep import get_model
    from origami_jax.sweep._engine import _default_chunk_size, _default_workers

    # A kernel's CPU chunk size, per device, on a CPU only; otherwise at least 8 chunks.
    assert _default_chunk_size(10_000, 1, "cpu", 1) == 1
    assert _default_chunk_size(10_000, 2, "cpu", 3) == 6
    assert _default_chunk_size(5, 1, "cpu", 8) == 5
    assert _default_chunk_size(10_000, 1, "gpu", 1) == 1250
    assert _default_chunk_size(10_000, 1, "cpu") == 256
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert _default_workers(jax.local_devices()[:1]) == cores
    assert _default_workers(jax.local_devices()[:1] * 2) == 1  # devices already split a chunk
    # The nets' kernel: contact makes its members' costs spread, so one net per call on a CPU.
    assert get_model("net-fold").cpu_chunk_size == 1


def test_resume_refuses_a_different_sweep(tmp_path):
    sweep(KERNEL, SPACE, chunk_size=9, out=tmp_path, progress=False)
    other = Grid({"zeta": [0.3], "omega": [0.5, 2.0, 7.0]}, units={"omega": "rad/s"})
    with pytest.raises(ValueError, match="different sweep"):
        sweep(KERNEL, other, out=tmp_path, resume=True, progress=False)
    retuned = Kernel(oscillator, name="test-oscillator", settings={"bisection_rtol": 1e-9})
    with pytest.raises(ValueError, match="settings.bisection_rtol"):
        sweep(retuned, SPACE, out=tmp_path, resume=True, progress=False)
    again = sweep(KERNEL, SPACE, out=tmp_path, resume=True, progress=False)  # nothing left to do
    assert again.sizes["design"] == SPACE.size


def _run_python(code: str, *, env_extra: dict[str, str], timeout: int = 120):
    env = {**os.environ, **env_extra, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def test_sharded_over_four_cpu_devices_equals_one_device():
    # The device count must be fixed before JAX starts, hence a subprocess.
    code = """
        import json
        import jax, jax.numpy as jnp, numpy as np
        jax.config.update("jax_enable_x64", True)
        from origami_jax.sweep import Samples, sweep
        from tests.test_sweep_engine import KERNEL, SHARDING_RTOL, oscillator
        assert len(jax.devices()) == 4, jax.devices()
        space = Samples({"zeta": (-0.1, 1.2), "omega": (0.5, 5.0)}, n=37, seed=5)
        four = sweep(KERNEL, space, chunk_size=10, progress=False)   # 12 per chunk: 3 per device
        one = sweep(KERNEL, space, chunk_size=10, devices=jax.devices()[:1], progress=False)
        columns = {k: jnp.asarray(v) for k, v in space.columns().items()}
        plain = jax.jit(jax.vmap(oscillator))(columns)
        report = {"devices": four.attrs["devices"], "chunk_size": four.attrs["chunk_size"]}
        for name in ("overshoot", "rise_time", "crossings", "result"):
            a, b, c = four[name].values, one[name].values, np.asarray(plain[name])
            report[name] = {
                "bitwise_one": bool(np.array_equal(a, b, equal_nan=True)),
                "bitwise_plain": bool(np.array_equal(a, c, equal_nan=True)),
                "close": bool(np.allclose(a, b, rtol=SHARDING_RTOL, atol=0, equal_nan=True)
                              and np.allclose(a, c, rtol=SHARDING_RTOL, atol=0, equal_nan=True)),
            }
        print("REPORT" + json.dumps(report))
    """
    result = _run_python(code, env_extra={"XLA_FLAGS": "--xla_force_host_platform_device_count=4"})
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads(result.stdout.split("REPORT", 1)[1])
    assert report["devices"].count("cpu") == 4 and report["chunk_size"] == 12
    for name in ("overshoot", "rise_time", "crossings", "result"):
        assert report[name]["close"], report
    # Observed on jax 0.10.2 CPU: bit for bit. Kept as a check so a change is noticed.
    assert all(
        report[n]["bitwise_one"] and report[n]["bitwise_plain"]
        for n in report
        if n not in ("devices", "chunk_size")
    ), report


def test_killed_process_resumes_to_the_same_dataset(tmp_path):
    code = f"""
        import os, signal
        import jax
        jax.config.update("jax_enable_x64", True)
        from origami_jax.sweep import Samples, sweep
        from tests.test_sweep_engine import KERNEL
        space = Samples({{"zeta": (-0.1, 1.2), "omega": (0.5, 5.0)}}, n=21, seed=1)

        def kill(done, total):
            if done >= 12:
                os.kill(os.getpid(), signal.SIGKILL)

        sweep(KERNEL, space, chunk_size=4, out={str(tmp_path / "killed")!r}, on_chunk=kill,
              progress=False)
    """
    result = _run_python(code, env_extra={})
    assert result.returncode == -9, result.stderr[-3000:]
    assert len(list((tmp_path / "killed" / "chunks").glob("part-*.nc"))) == 3
    space = Samples({"zeta": (-0.1, 1.2), "omega": (0.5, 5.0)}, n=21, seed=1)
    resumed = sweep(
        KERNEL, space, chunk_size=4, out=tmp_path / "killed", resume=True, progress=False
    )
    reference = sweep(KERNEL, space, chunk_size=4, progress=False)
    same_sweep(resumed, reference)


def test_cost_ordering_groups_similar_designs_and_changes_no_result(tmp_path):
    # With a cost estimate, chunks are filled cheapest first: here the cost is ω, so each chunk of 6
    # holds one ω of the grid (the grid runs ζ fastest) and chunk files are named by their first design.
    import dataclasses

    by_omega = dataclasses.replace(KERNEL, cost=lambda p: -p["omega"])  # largest ω first
    space = Grid({"omega": [0.5, 2.0, 7.0], "zeta": [0.05, 0.2, 0.4, 0.7, 1.5, -0.2]})
    plain = sweep(KERNEL, space, chunk_size=6, out=tmp_path / "plain", progress=False)
    ordered = sweep(by_omega, space, chunk_size=6, out=tmp_path / "ordered", progress=False)
    same_sweep(ordered, plain)  # bit for bit: every design's computation is unchanged
    plain_parts = sorted(p.name for p in (tmp_path / "plain" / "chunks").glob("part-*.nc"))
    assert plain_parts == [f"part-{i:09d}-000006.nc" for i in (0, 6, 12)]
    for part in (tmp_path / "ordered" / "chunks").glob("part-*.nc"):
        omegas = np.unique(xr.load_dataset(part)["omega"].values)
        assert len(omegas) == 1, (part.name, omegas)
    # A cost that cannot be evaluated for some designs (NaN) puts them last instead of failing.
    nan_cost = dataclasses.replace(KERNEL, cost=lambda p: jnp.where(p["zeta"] < 0, jnp.nan, 1.0))
    same_sweep(sweep(nan_cost, space, chunk_size=6, progress=False), plain)


@pytest.mark.slow
def test_accordion_sweep_sharded_over_two_cpu_devices_agrees_to_solver_accuracy():
    """The physics kernel is not bit for bit across device counts: XLA compiles the per-device batch
    (a different size) with different vector code, the rounding differs, and adaptive step sequences
    part ways (observed: 55 of 64 designs took different step counts). The metrics must still agree to
    the solver's accuracy: rise times to 1e-6 relative (rtol 1e-8; the simulation's metrics move by
    ~1e-6 between rtol 1e-8 and 1e-9), overshoot to 1e-4 percentage points."""
    code = """
        import json
        import jax, numpy as np
        jax.config.update("jax_enable_x64", True)
        import origami_jax.sweep as ojs
        assert len(jax.devices()) == 2, jax.devices()
        space = ojs.Grid({"hinge_width": np.geomspace(20.0, 200.0, 4),
                          "misfit_strain": np.linspace(1.5e-3, 4.0e-3, 4)})
        kernel = ojs.get_model("accordion-step", rtol=1e-8, atol=1e-10, solver="tsit5", t_end=600.0,
                               n_save=601)
        two = ojs.sweep(kernel, space, chunk_size=8, progress=False)
        one = ojs.sweep(kernel, space, chunk_size=8, devices=jax.devices()[:1], progress=False)
        rise = np.abs(two.rise_time.values - one.rise_time.values) / np.abs(one.rise_time.values)
        report = {"rise": float(np.max(rise)),
                  "overshoot": float(np.max(np.abs(two.overshoot.values - one.overshoot.values))),
                  "results": two.result.values.tolist() + one.result.values.tolist(),
                  "devices": two.attrs["devices"]}
        print("REPORT" + json.dumps(report))
    """
    result = _run_python(
        code, env_extra={"XLA_FLAGS": "--xla_force_host_platform_device_count=2"}, timeout=600
    )
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads(result.stdout.split("REPORT", 1)[1])
    assert report["devices"].count("cpu") == 2
    assert set(report["results"]) == {0}
    assert report["rise"] < 1e-6 and report["overshoot"] < 1e-4, report
