"""Time to a first result: the persistent compilation cache, no recompilation for values, light
imports.

Compilations are counted, never timed: JAX's monitoring events for the persistent cache (a hit is
a program loaded from disk instead of compiled) and the jit caches of the public entry points (a
new entry is a new trace and compile).
"""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import pytest

import origami_jax
import origami_jax.simulation as sim
from origami_jax._cache import CACHE_ENV, _requested, default_cache_dir
from origami_jax.chain import accordion_system
from origami_jax.system import HingeDesign

from .helpers import run_python, solve_programs

ROOT = Path(__file__).resolve().parents[1]


def _environment(tmp_path: Path, **extra: str) -> dict[str, str]:
    """The test process's environment without its own cache settings (conftest sets
    JAX_COMPILATION_CACHE_DIR for the whole run), with a private XDG cache home."""
    env = {k: v for k, v in os.environ.items() if k not in ("JAX_COMPILATION_CACHE_DIR", CACHE_ENV)}
    env.update(PYTHONPATH=str(ROOT), XDG_CACHE_HOME=str(tmp_path / "xdg"), **extra)
    return env


# ---- the persistent cache -----------------------------------------------------------------------

_COUNT_CACHE_EVENTS = """
    import json, jax
    from collections import Counter
    events = Counter()
    jax.monitoring.register_event_listener(lambda name, **kw: events.update([name]))
    import origami_jax
    folder = origami_jax.enable_compilation_cache()
    jax.config.update("jax_enable_x64", True)

    @jax.jit
    def f(x):
        return jax.numpy.sin(x) @ jax.numpy.cos(x).T + jax.numpy.linalg.det(x)

    f(jax.numpy.eye(3) * 0.5).block_until_ready()
    print(json.dumps({
        "folder": None if folder is None else str(folder),
        "config": jax.config.jax_compilation_cache_dir,
        "hits": events["/jax/compilation_cache/cache_hits"],
        "misses": events["/jax/compilation_cache/cache_misses"],
    }))
"""


def test_a_second_process_loads_what_the_first_compiled(tmp_path):
    cache = tmp_path / "cache"
    env = _environment(tmp_path, **{CACHE_ENV: str(cache)})
    first = run_python(_COUNT_CACHE_EVENTS, env)
    assert first["folder"] == first["config"] == str(cache)
    assert first["hits"] == 0 and first["misses"] >= 1
    written = sorted(p.name for p in cache.iterdir() if p.name.endswith("-cache"))
    assert any(name.startswith("jit_f-") for name in written), written
    second = run_python(_COUNT_CACHE_EVENTS, env)
    # Every program of the first run is loaded, none compiled again.
    assert second["hits"] == first["misses"] and second["misses"] == 0, (first, second)
    assert sorted(p.name for p in cache.iterdir() if p.name.endswith("-cache")) == written


def test_the_cache_can_be_turned_off(tmp_path):
    env = _environment(tmp_path, **{CACHE_ENV: "0"})
    off = run_python(_COUNT_CACHE_EVENTS, env)
    assert off["folder"] is None and off["config"] is None
    assert off["hits"] == off["misses"] == 0
    assert not (tmp_path / "xdg").exists()


def test_the_command_line_turns_it_on_in_the_user_cache_folder(tmp_path):
    code = """
        import json, sys, jax
        from origami_jax.cli._common import setup_runtime
        setup_runtime("unfold")
        print(json.dumps({"dir": jax.config.jax_compilation_cache_dir,
                          "x64": jax.config.jax_enable_x64,
                          "min_time": jax.config.jax_persistent_cache_min_compile_time_secs,
                          "equinox": "equinox" in sys.modules}))
    """
    out = run_python(code, _environment(tmp_path))
    assert out["dir"] == str(tmp_path / "xdg" / "origami_jax" / "jax")
    assert out["x64"] and out["min_time"] == 0.0 and not out["equinox"]
    # A folder JAX was given is kept.
    mine = tmp_path / "mine"
    out = run_python(code, _environment(tmp_path, JAX_COMPILATION_CACHE_DIR=str(mine)))
    assert out["dir"] == str(mine)


@pytest.mark.slow  # a CLI run in a subprocess; the cache itself is checked by default
def test_the_simulate_command_stores_its_solve(tmp_path):
    # A compiled program that calls back into Python cannot be stored: the command's solve must not
    # (no progress bar for a step, runtime checks as NaN). Cheap options: one flap, Tsit5.
    out = tmp_path / "run"
    argv = [sys.executable, "-m", "origami_jax", "simulate", "--flaps", "1", "--n-save", "11"]
    argv += ["--solver", "tsit5", "--t1", "100", "--figures", "png", "--out", str(out)]
    env = _environment(tmp_path)
    process = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=300)
    assert process.returncode == 0, process.stderr[-2000:]
    folder = tmp_path / "xdg" / "origami_jax" / "jax"
    # The solve is stored as an exported program (its trace: `exported/solve-*.bin`) and its
    # executable beside it (`exported/solve-*.xla`, compiled outside JAX's cache), so a warm
    # command neither traces, lowers nor compiles it.
    names = sorted(p.name for p in (folder / "exported").iterdir())
    assert any(name.startswith("solve-") and name.endswith(".bin") for name in names), names
    assert any(name.startswith("solve-") and name.endswith(".xla") for name in names), names
    # --figures png: the angle plot and the frames, no animation.
    assert sorted(p.name for p in out.glob("step_*")) == ["step_angles.png", "step_frames.png"]
    code = "import equinox._config as c, json; print(json.dumps(c.EQX_ON_ERROR))"
    probe = "from origami_jax.cli._common import setup_runtime; setup_runtime('simulate'); " + code
    assert run_python(probe, env) == "nan"
    assert run_python(code, env) == "raise"  # the library's own default is left alone


@pytest.mark.slow  # a whole program of its own to compile; the default run stays under 10 min
def test_a_script_stores_its_solve_and_sweep_and_still_raises(tmp_path):
    # Called from plain Python with EQX_ON_ERROR unset, `simulate` (throw=True) and a sweep of a
    # built-in model (its kernel turns bad values into result codes) compile without callbacks into
    # Python, so the cache stores them; a failed solve still raises (from the result code), a user's
    # raising kernel is still reported, and equinox's own setting is the same afterwards (a user's
    # jitted check still raises). One process for all: each costs a Python start and an import.
    code = """
        import json, diffrax, equinox as eqx, jax
        import equinox._errors as errors
        import origami_jax
        from origami_jax import chain, simulation, system
        from origami_jax.sweep import Table, get_model, sweep
        folder = origami_jax.enable_compilation_cache()
        jax.config.update("jax_enable_x64", True)
        def stored(prefix):
            return sorted(p.name for p in folder.iterdir() if p.name.startswith(prefix))
        flap = chain.accordion_system(system.HingeDesign.literature(), 1)
        run = simulation.SolveOptions(saveat=simulation.SaveAt(n=11), solver=diffrax.Tsit5())
        theta = simulation.simulate(flap, simulation.Step(), run, t1=100.0).theta
        out = {"solve": stored("jit__solve-"), "final": float(theta[-1, 0])}
        try:  # the same compiled solve, asked for an error it cannot reach in its step budget
            tiny = run.replace(rtol=1e-300, atol=1e-300)
            simulation.simulate(flap, simulation.Step(), tiny, t1=100.0)
        except eqx.EquinoxRuntimeError as error:
            out["message"] = str(error)
        model = get_model("accordion-step", n_flaps=1, t_end=100.0, n_save=11, solver="tsit5")
        data = sweep(model, Table({"hinge_width": [100.0, -1.0]}), progress=False)
        out.update(sweep=stored("jit_sweep_chunk-"), result=data["result"].values.tolist())
        def raising(params):
            return {"y": eqx.error_if(params["a"], params["a"] < 0, "negative")}
        try:
            sweep(raising, Table({"a": [1.0, -1.0]}), progress=False)
        except RuntimeError as error:
            out["reported"] = str(error)
        try:
            jax.jit(lambda x: eqx.error_if(x, x > 0, "user check"))(1.0)
        except Exception as error:
            out["user"] = type(error).__name__
        out["setting"] = errors.EQX_ON_ERROR
        print(json.dumps(out))
    """
    out = run_python(code, _environment(tmp_path, **{CACHE_ENV: str(tmp_path / "cache")}))
    assert len(out["solve"]) == 1 and 0.0 < out["final"] < 6.3, out  # stored; a real fold, no NaN
    assert out.get("message", "").startswith("simulate: The maximum number of solver steps"), out
    assert len(out["sweep"]) == 1, out
    assert out["result"] == [0, -1], out  # the bad width is reported as invalid input, not NaN
    assert "throw=False" in out.get("reported", ""), out
    assert out["setting"] == "raise" and "user" in out, out


@pytest.mark.slow  # a whole program of its own to compile; the default run stays under 10 min
def test_a_sweep_in_the_bath_stores_its_kernel(tmp_path):  # a subprocess, ~15 s
    # In the etch bath the kernel releases every member over the nominal design's quasi-static
    # ramp, computed first by a program of its own; traced with callbacks, that program's inner
    # traces were reused by the kernel's, which then could not be stored (a warm yield compiled
    # its kernel again: 15 s of a 20 s run).
    code = """
        import json, jax
        import origami_jax
        from origami_jax.sweep import Table, get_model, sweep
        folder = origami_jax.enable_compilation_cache()
        jax.config.update("jax_enable_x64", True)
        model = get_model("net-fold", net="corner_cube", contact=False, n_save=11)
        data = sweep(model, Table({"misfit_strain": [0.004]}), progress=False)
        stored = sorted(p.name for p in folder.iterdir() if p.name.startswith("jit_sweep_chunk-"))
        print(json.dumps({"stored": stored, "ramp": model.settings.get("release_ramp_us"),
                          "result": data["result"].values.tolist()}))
    """
    out = run_python(code, _environment(tmp_path, **{CACHE_ENV: str(tmp_path / "cache")}))
    assert out["ramp"] is not None and out["result"] == [0], out  # the bath's ramp, a clean run
    assert len(out["stored"]) == 1, out


@pytest.mark.slow  # a design compiled in a subprocess (~15 s)
def test_a_script_stores_its_design_fit(tmp_path):
    # `calibrate` from a script: the fit runs this package's code only, so its program is traced
    # with equinox's checks as NaN and stored.
    code = """
        import json, jax, numpy as np
        import origami_jax
        import origami_jax.design as ojd
        import origami_jax.simulation as sim
        from origami_jax.system import HingeDesign
        folder = origami_jax.enable_compilation_cache()
        jax.config.update("jax_enable_x64", True)
        options = sim.FIT_OPTIONS.replace(saveat=sim.SaveAt(n=16))
        settings = ojd.SimulationSettings(100.0, n_flaps=1, options=options)
        fit = ojd.calibrate(HingeDesign.literature(), ojd.Targets(rise_time=[30.0]), ["k_scale"],
                            settings=settings, max_steps=3)
        stored = sorted(p.name for p in folder.iterdir() if p.name.startswith("jit__fit_and_start-"))
        print(json.dumps({"stored": stored, "value": float(fit.values[0])}))
    """
    out = run_python(code, _environment(tmp_path, **{CACHE_ENV: str(tmp_path / "cache")}))
    assert len(out["stored"]) == 1 and out["value"] > 0, out


@pytest.mark.slow  # two CLI runs in subprocesses
def test_a_warm_simulate_command_runs_its_exported_solve(tmp_path):
    # The default solver's explicit phase is exported into the cache folder by the first run and
    # run from there by the second, with the same numbers.
    env = _environment(tmp_path)
    outputs = []
    for run in ("cold", "warm"):
        out = tmp_path / run
        argv = [sys.executable, "-m", "origami_jax", "simulate", "--flaps", "1", "--n-save", "11"]
        argv += ["--t1", "100", "--figures", "none", "--out", str(out)]
        process = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=300)
        assert process.returncode == 0, process.stderr[-2000:]
        outputs.append((out / "trajectory.csv").read_text())
    exported = tmp_path / "xdg" / "origami_jax" / "jax" / "exported"
    assert len(list(exported.glob("solve_until_stiff-*.bin"))) == 1
    assert outputs[0] == outputs[1]


def test_cache_folder_choice(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv(CACHE_ENV, raising=False)
    assert default_cache_dir() == tmp_path / "origami_jax" / "jax"
    assert _requested(None) == default_cache_dir()
    assert _requested(tmp_path / "given") == tmp_path / "given"
    for word, expected in (("0", None), ("off", None), ("1", default_cache_dir())):
        monkeypatch.setenv(CACHE_ENV, word)
        assert _requested(None) == expected
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "env"))
    assert _requested(None) == tmp_path / "env"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert default_cache_dir() == Path.home() / ".cache" / "origami_jax" / "jax"


def test_an_unwritable_cache_folder_is_one_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(ValueError, match="cannot create the compilation cache folder"):
        origami_jax.enable_compilation_cache(blocker / "cache")


# ---- no recompilation for values ----------------------------------------------------------------


class _Compilations:
    """Counts traces of Python functions to jaxprs and XLA compilations (JAX's monitoring events),
    and the entries of `simulate`'s compiled solve (kept in memory by `origami_jax._exported`, or
    `_solve_jit`'s), while active."""

    TRACE = "/jax/core/compile/jaxpr_trace_duration"
    COMPILE = "/jax/core/compile/backend_compile_duration"

    def __init__(self):
        self.counts = {self.TRACE: 0, self.COMPILE: 0}
        self.active = False

    def __call__(self, event, duration, **kwargs):
        if self.active and event in self.counts:
            self.counts[event] += 1

    @staticmethod
    def _solves():
        # A top-level solve compiles in memory with `SOLVE_COMPILE` (`_compiled_in_memory`), or
        # through `_solve_jit` where its static parts hold code the key cannot vouch for.
        from origami_jax.simulation._simulate import _solve_jit

        return solve_programs("solve", _solve_jit)

    def during(self, call):
        before = self._solves()
        self.counts = dict.fromkeys(self.counts, 0)
        self.active = True
        try:
            self.out = out = call()
            jax.block_until_ready(out)
        finally:
            self.active = False
        return {
            "solve": self._solves() - before,
            "traces": self.counts[self.TRACE],
            "compiles": self.counts[self.COMPILE],
        }


@pytest.fixture(scope="module")
def compilations():
    from origami_jax import _exported

    # Library semantics: a command run in this process earlier (`main`) turned exported programs
    # on, and a named solver's solve would then be the exported one, not `_solve_jit`'s.
    folder = _exported._FOLDER
    _exported.enable_exported_programs(None)
    counter = _Compilations()
    jax.monitoring.register_event_duration_secs_listener(counter)
    yield counter
    jax.monitoring.unregister_event_duration_listener(counter)
    _exported._FOLDER = folder


class Push(eqx.Module):
    """A user torque law with its numbers as leaves: ``τ = gain (θ* − θ) − damping θ̇`` from
    `start` on."""

    gain: jax.Array
    target: jax.Array
    damping: jax.Array
    start: jax.Array

    def __call__(self, t, theta, theta_dot):
        on = jnp.where(t >= self.start, 1.0, 0.0)
        return on * (self.gain * (self.target - theta) - self.damping * theta_dot)


def _push(gain, start):
    return sim.UserTorque(
        Push(jnp.asarray(gain), jnp.asarray([1.0, -1.0]), jnp.asarray(0.5), jnp.asarray(start)),
        jumps=jnp.asarray([start]),
    )


def test_values_do_not_recompile(compilations):
    # One small system (2 flaps, Tsit5, 101 samples): every case below shares its compiled solve.
    def system(release=(0.0, 5.0), targets=(2.5, -2.5), flap_length=None, **params):
        design = HingeDesign.literature(**params)
        return accordion_system(
            design,
            2,
            flap_length=flap_length,
            release_times=jnp.asarray(release),
            targets=jnp.asarray(targets),
        )

    def run(sys_=None, inputs=None, n_save=101, **changes):
        options = sim.SolveOptions(
            t1=100.0, saveat=sim.SaveAt(n=n_save), solver=diffrax.Tsit5(), rtol=1e-6, atol=1e-8
        )
        at = {k: changes.pop(k) for k in ("theta0", "theta_dot0") if k in changes}
        options = options.replace(**changes)
        return lambda: (
            sim.simulate(
                system() if sys_ is None else sys_,
                sim.Step() if inputs is None else inputs,
                options,
                **at,
            ).theta
        )

    first = compilations.during(run())
    assert first["solve"] == 1 and first["compiles"] >= 1  # the counter sees a compilation
    changes = {
        "tolerances": run(rtol=3e-7, atol=2e-9),
        "end time": run(t1=80.0),
        "stiffness scale": run(system(k_scale=2.0)),
        "hinge width, flap length, fold angle": run(
            system(hinge_width=120.0, flap_length=150.0, theta_final=2.0)
        ),
        "fold targets": run(system(targets=(1.0, -2.0))),
        "release times": run(system(release=(3.0, 0.0))),
        "initial state": run(theta0=jnp.asarray([0.1, 0.0])),
    }
    # A start state placed on a device (committed, as the command line's exported solve returns
    # its results; the rest state is not): the same program.
    device = jax.devices()[0]
    changes["a committed start state"] = run(
        theta0=jax.device_put(jnp.asarray([0.2, 0.0]), device),
        theta_dot0=jax.device_put(jnp.zeros(2), device),
    )
    for what, call in changes.items():
        counts = compilations.during(call)
        assert counts == {"solve": 0, "traces": 0, "compiles": 0}, (what, counts)
    # A new sample count within the padded size (101 and 77 samples both solve on 128): no new
    # solve; only the sample grid and the cut to 77 samples, two programs of a few operations.
    assert sim.padded_sample_count(101) == sim.padded_sample_count(77) == 128
    fewer = compilations.during(run(n_save=77, t1=80.0))
    assert fewer["solve"] == 0 and fewer["compiles"] <= 2, fewer
    assert compilations.out.shape == (77, 2)
    # Same samples as a solve compiled for 77 (under jit: not padded), to rounding.
    unpadded = jax.jit(run(n_save=77, t1=80.0))()
    assert jnp.allclose(compilations.out, unpadded, rtol=1e-12, atol=1e-12)
    # A user torque given as a module with array leaves: once per structure, not per value.
    first = compilations.during(run(inputs=_push(2.0, 1.0)))
    assert first["solve"] == 1
    counts = compilations.during(run(inputs=_push(5.0, 7.0)))
    assert counts == {"solve": 0, "traces": 0, "compiles": 0}, counts
    # A new function object is new structure: it compiles again (documented in `UserTorque`; so
    # does a sample count past the padded size, 129 samples or more here).
    law = lambda t, theta, theta_dot: -theta  # noqa: E731
    assert compilations.during(run(inputs=sim.UserTorque(law)))["solve"] == 1


# ---- start-up -----------------------------------------------------------------------------------

_HEAVY = ("jax", "jaxlib", "equinox", "diffrax", "matplotlib", "xarray", "scipy", "optax", "h5py")


@pytest.mark.parametrize(
    "statement",
    [
        "import origami_jax",
        "from origami_jax.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass",
        "from origami_jax.cli import main\ntry:\n    main(['simulate', '--help'])\nexcept SystemExit:\n"
        "    pass",
    ],
    ids=["import", "help", "simulate-help"],
)
def test_start_up_imports_nothing_heavy(statement, tmp_path):
    code = (
        "import io, contextlib, json, sys\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        + textwrap.indent(statement, "    ")
        + f"\nprint(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & {set(_HEAVY)!r})))"
    )
    assert run_python(code, _environment(tmp_path)) == []


def test_every_subpackage_is_an_attribute_of_the_package(tmp_path):
    """`origami_jax.<name>` after a plain `import origami_jax`, for every folder of the package: the
    subpackages load on first use (a fresh process, where no test has imported them already), and
    none of them on `import origami_jax`."""
    folders = sorted(p.parent.name for p in (ROOT / "origami_jax").glob("*/__init__.py"))
    assert {"loops", "fab_yield", "cli"} <= set(folders)
    code = """
        import json, sys
        import origami_jax
        names = sys.argv[1:]
        loaded = sorted(n for n in names if f"origami_jax.{n}" in sys.modules)
        found = {n: getattr(origami_jax, n).__name__ for n in names}
        print(json.dumps({"loaded": loaded, "found": found, "dir": dir(origami_jax),
                          "all": origami_jax.__all__}))
    """
    out = run_python(code, _environment(tmp_path), *folders)
    assert out["loaded"] == []
    assert out["found"] == {name: f"origami_jax.{name}" for name in folders}
    assert set(folders) <= set(out["dir"]) and set(folders) <= set(out["all"])
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        _ = origami_jax.nonexistent  # pyright: ignore[reportAttributeAccessIssue]


# ---- figures ------------------------------------------------------------------------------------


def test_figures_choice_and_its_alias():
    from origami_jax.cli import build_parser

    parser = build_parser()
    for command in ("simulate", "fold"):
        base = [command] if command == "simulate" else [command, "net.fold"]
        assert parser.parse_args(base).figures == "all"
        assert parser.parse_args([*base, "--no-figures"]).figures == "none"
        assert parser.parse_args([*base, "--figures", "png"]).figures == "png"


def test_the_fold_command_keeps_small_nets_solve_storable():
    # A progress bar calls back into Python, so a solve with one cannot be stored in the cache: the
    # fold command shows it only for large patterns (or when asked), and like simulate it turns
    # failed runtime checks into NaN (its inputs are checked before compiling; failures are verdicts).
    import diffrax

    from origami_jax.cli import build_parser
    from origami_jax.cli._common import NAN_ON_ERROR_COMMANDS
    from origami_jax.cli._fold import PROGRESS_CREASES, _progress_meter

    assert build_parser().parse_args(["fold", "net.fold"]).progress == "auto"
    quiet, bar = diffrax.NoProgressMeter, diffrax.TqdmProgressMeter
    assert isinstance(_progress_meter("auto", PROGRESS_CREASES), quiet)
    assert isinstance(_progress_meter("auto", PROGRESS_CREASES + 1), bar)
    assert isinstance(_progress_meter("on", 2), bar)
    assert isinstance(_progress_meter("off", 500), quiet)
    assert {"simulate", "fold"} <= NAN_ON_ERROR_COMMANDS


def test_animation_of_a_folding(tmp_path):
    import numpy as np
    from PIL import Image

    from origami_jax.plotting.chain import animate_folding

    class Samples:
        times = np.linspace(0.0, 100.0, 201)
        theta = np.column_stack([np.minimum(times / 50.0, 1.0) * 2.5, -np.sin(times / 30.0)])
        state = None

    system = accordion_system(HingeDesign.literature(), 2)
    path = animate_folding(system, Samples, tmp_path / "fold.gif", n_frames=12, fps=10)
    with Image.open(path) as image:
        assert image.n_frames == 12 and image.size == (360, 360)  # 4 in at 90 dpi
        durations = []
        for k in range(image.n_frames):
            image.seek(k)
            durations.append(image.info["duration"])
    assert durations[:-1] == [100] * 11 and durations[-1] == 1000  # the last frame held 1 s


def test_animation_frames_follow_the_motion():
    import numpy as np

    from origami_jax.plotting.frames import _frame_indices

    class Samples:
        # Moves in the first tenth of the time, then rests.
        times = np.linspace(0.0, 100.0, 1001)
        theta = np.where(times < 10.0, times / 10.0, 1.0)[:, None] * np.array([[1.0, -1.0]])
        state = None

    even = _frame_indices(Samples, 20, None)
    moving = _frame_indices(Samples, 20, None, by_motion=True)
    assert even[0] == moving[0] == 0 and even[-1] == moving[-1] == 1000
    assert np.all(np.diff(moving) > 0)
    # Evenly in time, 2 of 20 frames fall in the motion; by motion and time alike, about half.
    assert np.sum(Samples.times[even] < 10.0) <= 2
    assert 8 <= np.sum(Samples.times[moving] < 10.0) <= 12


def test_batched_frame_geometry_is_the_mechanisms_own():
    import numpy as np

    from origami_jax.plotting.frames import _polygon_frames

    mechanism = accordion_system(HingeDesign.literature(), 2).mechanism
    states = np.array([[0.0, 0.0], [1.0, -2.0], [3.0, -3.0]])
    frames = _polygon_frames(mechanism, states)
    skip = 0 if mechanism.base_outline() is None else 1
    for state, polygons in zip(states, frames, strict=True):
        # The per-state computation, one state at a time (the path the figures used before).
        expected = mechanism.panel_polygons(state)
        assert len(polygons) == len(expected) + skip
        for got, want in zip(polygons[skip:], expected, strict=True):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)  # µm, same arithmetic
