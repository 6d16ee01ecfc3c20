"""Traced programs kept on disk (`origami_jax._exported`): a later process runs the exported solve
without tracing it, and gets the same numbers; what the key cannot vouch for is traced as usual.

The solves run in fresh processes with ``EQX_ON_ERROR=nan`` (as the command line sets it): in this
process equinox raises its runtime errors through Python callbacks, which no exported program can
hold, and JAX keeps the traces it made here for the rest of the test session.
"""

import dataclasses
import os
import threading

import diffrax
import equinox._errors
import jax
import jax.numpy as jnp
import pytest

from origami_jax import _exported

from .helpers import run_python

_RUN = """
    import hashlib, json, sys
    import diffrax
    import jax
    jax.config.update("jax_enable_x64", True)
    import numpy as np
    import origami_jax
    from origami_jax import _exported
    from origami_jax.simulation import _simulate
    import origami_jax.simulation as sim
    from origami_jax.chain import accordion_system
    from origami_jax.system import HingeDesign

    folder = sys.argv[1]
    origami_jax.enable_compilation_cache(folder)
    traced = {"solve_until_stiff": [], "solve": []}
    for name in traced:  # the functions the exports trace (their jitted fallbacks are the originals)
        function = getattr(_simulate, "_" + name)
        setattr(_simulate, "_" + name, lambda *a, f=function, n=name: traced[n].append(1) or f(*a))
    from origami_jax.net import _pattern, load_net
    from origami_jax.system import KOH_SOLUTION
    loads = _pattern.fluid_loads  # called when its program is traced, not when it is loaded
    _pattern.fluid_loads = lambda *a, **k: traced["fluid_loads"].append(1) or loads(*a, **k)
    traced["fluid_loads"] = []
    net = load_net("corner_cube").with_model(contact=False)
    inertia = lambda: np.asarray(net.system(net.default_design(KOH_SOLUTION)).mechanism.added_inertias)  # noqa
    system = accordion_system(HingeDesign.literature(), 1)
    solvers = {"solve_until_stiff": None, "solve": diffrax.Tsit5()}  # the default and a named one
    def run(solver):
        options = sim.SolveOptions(saveat=sim.SaveAt(n=101), throw=False, solver=solver)
        return sim.simulate(system, sim.Step(), options, t1=300.0)
    plain = {name: run(solver) for name, solver in solvers.items()}  # ordinary jitted solves
    plain_inertia = inertia()
    for calls in traced.values():
        calls.clear()
    _exported.enable_exported_programs(folder + "/exported")
    ours = {name: run(solver) for name, solver in solvers.items()}
    ours_inertia = inertia()
    digest = lambda t: hashlib.sha256(np.asarray(t.theta).tobytes()).hexdigest()  # noqa
    print(json.dumps({
        name: {
            "traced": len(traced[name]),
            "plain": digest(plain[name]),
            "ours": digest(ours[name]),
            "steps": [int(plain[name].stats["num_steps"]), int(ours[name].stats["num_steps"])],
            "succeeded": bool(ours[name].succeeded),
        }
        for name in solvers
    } | {"fluid_loads": {
        "traced": len(traced["fluid_loads"]),
        "same": bool(np.array_equal(plain_inertia, ours_inertia)),
    }}))
"""


def _process(folder) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "JAX_COMPILATION_CACHE_DIR"}
    env["EQX_ON_ERROR"] = "nan"
    return run_python(_RUN, env, str(folder))


@pytest.mark.slow  # four Python processes, each exporting or loading two solves: ~50 s
def test_a_later_process_runs_the_exported_solve_without_tracing_it(tmp_path):
    """The default solver's explicit phase (`solve_until_stiff`), a named solver's whole solve
    (`solve`: the command line's Tsit5) and a net's fluid loads alike."""
    first = _process(tmp_path)  # traces, exports, writes
    fluid = first.pop("fluid_loads")  # a net's fluid loads in the bath: one more program
    assert fluid["traced"] == 1 and fluid["same"]
    for name, run in first.items():
        files = sorted((tmp_path / "exported").glob(f"{name}-*.bin"))
        assert len(files) == 1 and run["traced"] == 1, name
        assert run["ours"] == run["plain"] and run["succeeded"], name
    files = sorted((tmp_path / "exported").glob("*.bin"))
    assert len(files) == 3
    executables = sorted((tmp_path / "exported").glob("*.xla"))  # each compiled, kept beside
    assert len(executables) == 3

    later = _process(tmp_path)  # loads the programs: no trace of the solves, the same samples
    fluid = later.pop("fluid_loads")
    assert fluid["traced"] == 0 and fluid["same"]
    for name, run in later.items():
        assert run["traced"] == 0, name
        assert run["ours"] == run["plain"] == first[name]["plain"], name
        assert run["steps"][0] == run["steps"][1], name
    assert sorted((tmp_path / "exported").glob("*.bin")) == files
    assert sorted((tmp_path / "exported").glob("*.xla")) == executables

    # A damaged program without its executable is traced again and replaced; a damaged
    # executable is compiled again from its program (no trace) and replaced.
    executable = next((tmp_path / "exported").glob("solve_until_stiff-*.xla"))
    executable.unlink()
    damaged = next((tmp_path / "exported").glob("solve_until_stiff-*.bin"))
    damaged.write_bytes(b"not a program")
    repaired = _process(tmp_path)["solve_until_stiff"]
    assert repaired["traced"] == 1 and repaired["ours"] == first["solve_until_stiff"]["plain"]
    assert damaged.read_bytes() != b"not a program" and executable.exists()
    executable.write_bytes(b"not an executable")
    recompiled = _process(tmp_path)["solve_until_stiff"]
    assert recompiled["traced"] == 0 and recompiled["ours"] == first["solve_until_stiff"]["plain"]
    assert executable.read_bytes() != b"not an executable"


def _torque(t, theta, theta_dot):  # a user's function: its code is not part of any key
    return jnp.full_like(theta, 1e-3)


def test_the_key_covers_the_environment_and_refuses_what_it_cannot_vouch_for(monkeypatch):
    leaves = [jnp.zeros(3)]
    key = _exported._key("p", leaves, ("static",))
    assert key == _exported._key("p", leaves, ("static",))
    assert key != _exported._key("p", [jnp.zeros(4)], ("static",))
    assert key != _exported._key("p", [jnp.zeros(3, jnp.float32)], ("static",))
    # A weakly typed leaf (a scalar a fresh trace returns; the same from an exported program is
    # strongly typed) has the same program: the export traces shapes and dtypes only.
    weak, strong = jnp.asarray(3), jnp.asarray(3, dtype=jnp.asarray(3).dtype)
    assert weak.weak_type and not strong.weak_type
    assert _exported._key("p", [weak], ("static",)) == _exported._key("p", [strong], ("static",))
    assert key != _exported._key("p", leaves, ("other",))
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    assert key != _exported._key("p", leaves, ("static",))
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "raise")
    x64 = jax.config.jax_enable_x64
    try:
        jax.config.update("jax_enable_x64", not x64)
        assert key != _exported._key("p", leaves, ("static",))
    finally:
        jax.config.update("jax_enable_x64", x64)
    # A function or class from outside the vouched libraries: no key (traced as usual).
    assert _exported._key("p", leaves, (_torque,)) is None
    assert _exported._key("p", leaves, (type("Local", (), {})(),)) is None
    assert _exported._key("p", leaves, (diffrax.Tsit5(),)) is not None  # vouched


def test_the_key_ignores_what_a_cached_property_filled_in_since():
    # A net's contact tables pack their pairs on first use (`functools.cached_property`): the solve
    # of a second folding segment must find the first segment's program, not export another.
    from origami_jax.net import load_net

    net = load_net("corner_cube")
    tables = net.contact_tables()
    fresh = dataclasses.replace(tables)  # equal contents, nothing cached yet
    assert "blocks" not in vars(fresh)
    leaves = [jnp.zeros(3)]
    before = _exported._key("p", leaves, (fresh,))
    assert fresh.blocks and "blocks" in vars(fresh)
    assert _exported._key("p", leaves, (fresh,)) == before
    other = load_net("cube_net_01").contact_tables()
    assert _exported._key("p", leaves, (other,)) != before


def test_the_key_does_not_depend_on_which_parts_are_one_object():
    # A system read back from disk (`remembered`) holds its field names as strings of its own
    # where a built one shares them with its classes: a pickle that memoises objects told the two
    # apart, and every program the read-back system reached compiled again under another key.
    import pickle

    import equinox as eqx

    from origami_jax.net import load_net

    static = eqx.partition(load_net("corner_cube").system(), eqx.is_array)[1]
    again = pickle.loads(pickle.dumps(static))
    leaves = [jnp.zeros(3)]
    assert _exported._key("p", leaves, (static,)) == _exported._key("p", leaves, (again,))


def _twice(x):
    return 2.0 * x


def test_an_exported_program_gives_uncommitted_arrays(tmp_path, monkeypatch):
    # Committed outputs would be compiled into every program they reach as sharded arguments, a
    # program of its own beside the one the same values get when built by `jit` or read back.
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    x = jnp.arange(3.0)
    for _ in range(2):  # exported, then read back
        out = _exported.exported_call("twice", _twice, jax.jit(_twice), x)
        assert not out.committed
        assert jnp.array_equal(out, 2.0 * x)
    assert len(list(tmp_path.glob("twice-*.bin"))) == 1


def _mixed(x):  # transcendental functions, a reduction, a root: code the emitters may differ on
    return jnp.sum(jnp.exp(-x) * jnp.arctan2(x, 1.0 + x**2)) + jnp.sqrt(1.0 + jnp.cos(x) ** 2)


def _kept(tmp_path, suffix):
    return sorted(tmp_path.glob(f"*.{suffix}"))


def test_a_kept_executable_runs_without_the_program_and_is_replaced_when_it_cannot(
    tmp_path, monkeypatch
):
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_LOADED", {})
    monkeypatch.setattr(_exported, "_REFUSED", set())
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    x = jnp.linspace(-2.0, 3.0, 7)
    plain = jax.jit(_mixed)(x)
    call = _exported.exported_call
    # A program a command runs once, compiled for its compile time: the same bits as `jit`'s.
    assert jnp.array_equal(
        call("mixed", _mixed, jax.jit(_mixed), x, options=_exported.QUICK_COMPILE), plain
    )
    assert len(_kept(tmp_path, "bin")) == 1 and len(_kept(tmp_path, "xla")) == 1
    assert jnp.array_equal(call("mixed", _mixed, jax.jit(_mixed), x), plain)  # default options
    assert len(_kept(tmp_path, "bin")) == 1 and len(_kept(tmp_path, "xla")) == 2

    exported = []  # a later process (nothing loaded yet) runs the kept executable alone
    read_or_export = _exported._read_or_export
    monkeypatch.setattr(
        _exported, "_read_or_export", lambda *a: exported.append(1) or read_or_export(*a)
    )
    monkeypatch.setattr(_exported, "_LOADED", {})
    out = call("mixed", _mixed, jax.jit(_mixed), x, options=_exported.QUICK_COMPILE)
    assert jnp.array_equal(out, plain) and not out.committed and not exported

    for path in _kept(tmp_path, "xla"):  # damaged: compiled again from the program, replaced
        path.write_bytes(b"not an executable")
    monkeypatch.setattr(_exported, "_LOADED", {})
    assert jnp.array_equal(call("mixed", _mixed, jax.jit(_mixed), x), plain) and exported
    assert sum(p.read_bytes() != b"not an executable" for p in _kept(tmp_path, "xla")) == 1

    class Failing:  # an executable that loads but cannot run: removed, the call traced as usual
        def __call__(self, *args):
            raise RuntimeError("NOT_FOUND: Function fusion.3 not found")

    monkeypatch.setattr(_exported, "_LOADED", {})
    monkeypatch.setattr(_exported, "_read_compiled", lambda path: (Failing(), (None, {})))
    assert jnp.array_equal(call("mixed", _mixed, jax.jit(_mixed), x), plain)
    assert len(_kept(tmp_path, "xla")) == 1 and "mixed" in _exported._REFUSED


def test_a_remembered_system_brings_the_executables_its_last_run_used(tmp_path, monkeypatch):
    # `remembered(..., prefetch_after=True)` (a command's system): the executables a process ran
    # after it are noted beside it; a later process reading it back reads them on a background
    # thread while it goes on, and runs them without reading them again.
    for name, value in (("_FOLDER", tmp_path), ("_LOADED", {}), ("_READING", {})):
        monkeypatch.setattr(_exported, name, value)
    monkeypatch.setattr(_exported, "_USED", {})
    monkeypatch.setattr(_exported, "_ANCHOR", None)
    monkeypatch.setattr(_exported, "_HINT", None)
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    x = jnp.linspace(-2.0, 3.0, 7)
    plain = jax.jit(_mixed)(x)
    _exported.prefetch_for_command(["fold", "net"])  # nothing noted yet: nothing read
    assert not _exported._READING

    def run():
        system = _exported.remembered("system", lambda: {"n": 7}, 7, prefetch_after=True)
        out = _exported.exported_call("mixed", _mixed, jax.jit(_mixed), x)
        return system, out

    before = jnp.arange(3.0)  # run before the system: not what its next reader needs
    _exported.exported_call("twice", _twice, jax.jit(_twice), before)
    assert run()[0] == {"n": 7}
    _exported.note_programs_used()
    [uses] = tmp_path.glob("system-*.uses")
    assert uses.read_text().split() == [p.name for p in tmp_path.glob("mixed-*.xla")]
    [command] = tmp_path.glob("command-*.uses")  # the command line's own note, the same
    assert command.read_text() == uses.read_text()

    threads = []  # a later process: the kept executable read on the prefetch thread, once
    read_compiled = _exported._read_compiled
    monkeypatch.setattr(
        _exported,
        "_read_compiled",
        lambda path: threads.append(threading.current_thread().name) or read_compiled(path),
    )
    for name, value in (("_LOADED", {}), ("_READING", {}), ("_USED", {}), ("_ANCHOR", None)):
        monkeypatch.setattr(_exported, name, value)
    system, out = run()
    assert system == {"n": 7} and jnp.array_equal(out, plain) and not out.committed
    assert len(threads) == 1 and threads[0].startswith("origami-prefetch")
    assert not _exported._READING  # taken by the call that ran it
    # The same command line again: read ahead as soon as it starts, before any system is read.
    for name, value in (("_LOADED", {}), ("_READING", {}), ("_USED", {}), ("_ANCHOR", None)):
        monkeypatch.setattr(_exported, name, value)
    _exported.prefetch_for_command(["fold", "net"])
    [reading] = _exported._READING.values()
    reading.result()
    assert len(threads) == 2 and threads[1].startswith("origami-prefetch")
    assert jnp.array_equal(run()[1], plain) and len(threads) == 2
    # Off where nothing is kept, and where no value started the work.
    monkeypatch.setattr(_exported, "_ANCHOR", None)
    uses.unlink()
    _exported.note_programs_used()
    assert not list(tmp_path.glob("system-*.uses"))
    # A command that remembers no such value (a yield, a sweep): its own note lists every kept
    # executable it ran, under its words less the output folder, so that a rerun into another
    # folder (a yield never replaces one) reads them ahead.
    for name, value in (("_LOADED", {}), ("_READING", {}), ("_USED", {}), ("_HINT", None)):
        monkeypatch.setattr(_exported, name, value)
    _exported.prefetch_for_command(["yield", "net", "--out", "first"])
    assert not _exported._READING  # nothing noted under these words yet
    _exported.exported_call("mixed", _mixed, jax.jit(_mixed), x)
    _exported.note_programs_used()
    hint = _exported._HINT
    assert hint.read_text().split() == [p.name for p in tmp_path.glob("mixed-*.xla")]
    for name, value in (("_LOADED", {}), ("_READING", {}), ("_USED", {}), ("_HINT", None)):
        monkeypatch.setattr(_exported, name, value)
    _exported.prefetch_for_command(["yield", "net", "--out=second"])
    assert _exported._HINT == hint
    [reading] = _exported._READING.values()
    reading.result()
    assert threads[-1].startswith("origami-prefetch")


def test_a_program_given_options_compiles_with_them_kept_or_not(tmp_path, monkeypatch):
    # The command line keeps the executable; the library (no folder), or raised runtime errors
    # (which no exported program can hold), compile it in memory with the same options: the
    # same bits either way, whatever the options do to them.
    options_seen = []
    compile_ = jax.stages.Lowered.compile

    def spy(self, compiler_options=None):
        options_seen.append(compiler_options)
        return compile_(self, compiler_options=compiler_options)

    monkeypatch.setattr(jax.stages.Lowered, "compile", spy)
    monkeypatch.setattr(_exported, "_IN_MEMORY", {})
    monkeypatch.setattr(_exported, "_LOADED", {})
    monkeypatch.setattr(_exported, "_REFUSED", set())
    traced = []

    def mixed(x):
        traced.append(1)
        return _mixed(x)

    x = jnp.linspace(-2.0, 3.0, 7)
    quick = _exported.QUICK_COMPILE
    call = _exported.exported_call
    monkeypatch.setattr(_exported, "_FOLDER", None)
    library = [call("mixed", mixed, jax.jit(mixed), x, options=quick) for _ in range(2)]
    assert len(traced) == 1 and options_seen == [quick]  # compiled once, with the options
    assert len(_exported._IN_MEMORY) == 1
    assert not library[0].committed and jnp.array_equal(library[0], library[1])

    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    kept = call("mixed", mixed, jax.jit(mixed), x, options=quick)
    assert options_seen[-1] == {**_exported._OWN_KEY, **quick} and _kept(tmp_path, "xla")
    assert jnp.array_equal(kept, library[0])

    # Runtime errors raised (as in the library's calls above): its program compiled in memory.
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "raise")
    raised = call("mixed", mixed, jax.jit(mixed), x, options=quick)
    assert len(options_seen) == 2 and len(_exported._IN_MEMORY) == 1
    assert jnp.array_equal(raised, library[0]) and len(_kept(tmp_path, "xla")) == 1

    # Without options the call is `jitted`'s, kept or not (the solve: its own defaults).
    monkeypatch.setattr(_exported, "_FOLDER", None)
    before = len(options_seen)
    assert jnp.array_equal(call("twice", _twice, jax.jit(_twice), x), 2.0 * x)
    assert len(_exported._IN_MEMORY) == 1 and all(o is None for o in options_seen[before:])


def test_the_programs_kept_in_memory_are_bounded(monkeypatch):
    monkeypatch.setattr(_exported, "_IN_MEMORY", {})
    monkeypatch.setattr(_exported, "_FOLDER", None)
    monkeypatch.setattr(_exported, "_IN_MEMORY_LIMIT", 2)
    traced = []

    def twice(x):
        traced.append(x.shape)
        return _twice(x)

    for n in (1, 2, 1, 3, 2):  # the third reuses the first; the fourth drops the second
        x = jnp.ones(n)
        out = _exported.exported_call("twice", twice, jax.jit(twice), x, options={"a": 1})
        assert jnp.array_equal(out, 2.0 * x)
    assert traced == [(1,), (2,), (3,), (2,)] and len(_exported._IN_MEMORY) == 2


def test_a_kept_compilation_is_read_back_and_replaced_when_it_cannot_run(tmp_path, monkeypatch):
    # `kept_compiled`: a lowering's executable kept under an identity; a later process reads it
    # back without lowering; what the key cannot vouch for is compiled as usual and not kept.
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_LOADED", {})
    x = jnp.linspace(-2.0, 3.0, 7)
    lowered = []

    def lower():
        lowered.append(1)
        return jax.jit(_mixed).lower(x)

    plain = jax.jit(_mixed)(x)
    kept = _exported.kept_compiled("mixed", ("mixed", 7), lower)
    assert jnp.array_equal(kept(x), plain) and len(_kept(tmp_path, "xla")) == 1
    monkeypatch.setattr(_exported, "_LOADED", {})  # a later process
    again = _exported.kept_compiled("mixed", ("mixed", 7), lower)
    assert jnp.array_equal(again(x), plain) and len(lowered) == 1
    assert again.memory_analysis() is not None

    class Failing:  # an executable that loads but cannot run: removed, compiled again, once
        def __call__(self, *args):
            raise RuntimeError("NOT_FOUND: Function fusion.3 not found")

    monkeypatch.setattr(_exported, "_LOADED", {})
    monkeypatch.setattr(_exported, "_read_compiled", lambda path: (Failing(), None))
    failing = _exported.kept_compiled("mixed", ("mixed", 7), lower)
    assert jnp.array_equal(failing(x), plain) and jnp.array_equal(failing(x), plain)
    assert len(lowered) == 2 and not _kept(tmp_path, "xla")

    unvouched = _exported.kept_compiled("mixed", ("mixed", _torque), lower)  # a user's function
    assert jnp.array_equal(unvouched(x), plain) and len(lowered) == 3 and not _kept(tmp_path, "xla")

    # Compiler options are part of the key: the loop emitters' executable is kept apart, compiled
    # with its options (the same values to round-off).
    monkeypatch.undo()  # the failing reader above
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_LOADED", {})
    seen = []
    real = _exported.compiled_with

    def compiled_with(lowered, options, base=None):
        seen.append(dict(options or {}))
        return real(lowered, options, base)

    monkeypatch.setattr(_exported, "compiled_with", compiled_with)
    files = set(_kept(tmp_path, "xla"))
    quick = _exported.kept_compiled("mixed", ("mixed", 7), lower, _exported.SOLVE_COMPILE)
    assert jnp.allclose(quick(x), plain, rtol=1e-14, atol=0)
    assert seen == [_exported.SOLVE_COMPILE] and len(set(_kept(tmp_path, "xla")) - files) == 1


def _smallest_eigenvalue(x):  # LAPACK on the CPU (`syevd`)
    return jnp.linalg.eigvalsh(jnp.outer(x, x) + jnp.eye(x.shape[0]))[0]


def test_lapack_is_set_up_only_for_a_kept_executable_that_calls_it(tmp_path, monkeypatch):
    # Setting it up imports SciPy's BLAS: a warm command whose programs call no LAPACK skips it.
    # (This test's own name holds the word: the programs' locations must not count.)
    from jax._src.lax import linalg

    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_REFUSED", set())
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    x = jnp.arange(3.0)
    expected = {"twice": 2.0 * x, "eigen": jax.jit(_smallest_eigenvalue)(x)}
    functions = {"twice": _twice, "eigen": _smallest_eigenvalue}
    for name, fn in functions.items():  # compiled and kept
        _exported.exported_call(name, fn, jax.jit(fn), x)
    set_up = []
    initialize = linalg.initialize_lapack
    monkeypatch.setattr(linalg, "initialize_lapack", lambda: set_up.append(1) or initialize())
    for name, fn in functions.items():  # a later process: read back
        monkeypatch.setattr(_exported, "_LOADED", {})
        out = _exported.exported_call(name, fn, jax.jit(fn), x)
        assert jnp.allclose(out, expected[name]) and len(set_up) == (name == "eigen"), name


def test_a_release_ramp_is_kept_as_a_value(tmp_path, monkeypatch):
    # A warm fold neither loads nor runs the ramp's program (nor sets up the LAPACK it calls).
    from origami_jax.net import _pattern, load_net
    from origami_jax.system import KOH_SOLUTION

    monkeypatch.setattr(_exported, "_FOLDER", None)  # off: the program each time
    net = load_net("corner_cube")
    system = net.system(net.default_design(KOH_SOLUTION))
    plain = _pattern.quasi_static_release(system)
    runs = []
    ramp = _pattern._quasi_static_ramp
    monkeypatch.setattr(_pattern, "_quasi_static_ramp", lambda *a: runs.append(1) or ramp(*a))
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    assert [_pattern.quasi_static_release(system) for _ in range(3)] == [plain] * 3
    assert len(runs) == 1 and len(list(tmp_path.glob("release_ramp_value-*.pkl"))) == 1


def test_a_program_kept_by_value_is_neither_loaded_nor_run_for_the_same_arguments(
    tmp_path, monkeypatch
):
    # `exported_jit(by_value=True)` (a net's masses at rest, its seams' tolerances): where the
    # command keeps its programs, a later process with the same arguments reads the value (the
    # program's own bits); other values run the program; under a trace it is inlined.
    import numpy as np

    def halves(x):
        return {"half": x / 2.0, "sum": jnp.sum(x)}

    kept = _exported.exported_jit("halves_by_value", by_value=True)(halves)
    x = jnp.linspace(0.1, 1.7, 5)
    monkeypatch.setattr(_exported, "_FOLDER", None)  # off: the program each time
    plain = kept(x)
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_LOADED", {})
    first = kept(x)
    assert len(list(tmp_path.glob("halves_by_value-*.pkl"))) == 1
    monkeypatch.setattr(_exported, "_LOADED", {})  # a later process: nothing loaded yet
    monkeypatch.setattr(_exported, "_IN_MEMORY", {})
    called = []
    call = _exported.exported_call
    monkeypatch.setattr(
        _exported, "exported_call", lambda *a, **k: called.append(a[0]) or call(*a, **k)
    )
    again = kept(x)
    assert called == []  # the program neither loaded, compiled nor run
    for value in (first, again):
        assert isinstance(value["half"], jax.Array) and not value["half"].committed
        assert np.array_equal(value["half"], plain["half"]) and value["sum"] == plain["sum"]
    other = kept(x + 1.0)  # another value: the program again
    assert called == ["halves_by_value"] and jnp.allclose(other["half"], (x + 1.0) / 2.0)
    assert len(list(tmp_path.glob("halves_by_value-*.pkl"))) == 2
    inlined = jax.jit(lambda y: kept(y)["sum"])(x)  # under a trace: inlined, nothing kept
    assert inlined == plain["sum"] and len(list(tmp_path.glob("halves_by_value-*.pkl"))) == 2


def test_a_compilation_the_persistent_cache_served_is_not_kept(tmp_path, monkeypatch):
    # Such an executable serialises without its machine code: kept, it would fail when run.
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_LOADED", {})
    monkeypatch.setattr(_exported, "_REFUSED", set())
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    hits = iter(range(100))
    monkeypatch.setattr(_exported, "_persistent_cache_hits", lambda: next(hits))
    x = jnp.arange(3.0)
    assert jnp.array_equal(_exported.exported_call("twice", _twice, jax.jit(_twice), x), 2.0 * x)
    assert len(_kept(tmp_path, "bin")) == 1 and not _kept(tmp_path, "xla")


_CACHE_HITS = """
    import sys
    import jax
    import jax.numpy as jnp
    from origami_jax import _exported
    jax.config.update("jax_compilation_cache_dir", sys.argv[1])
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    f = jax.jit(lambda x: jnp.sin(x) * 3.0)
    before = _exported._persistent_cache_hits()
    f.lower(jnp.ones(5)).compile()
    compiled = _exported._persistent_cache_hits()
    jax.clear_caches()  # the same programs again: read from the persistent cache
    f.lower(jnp.ones(5)).compile()
    print([before, compiled, _exported._persistent_cache_hits()])
"""


def test_jax_reports_the_persistent_cache_hits_the_guard_counts(tmp_path):
    # The guard above listens for JAX's monitoring event by name: this JAX must still send it.
    env = {k: v for k, v in os.environ.items() if k != "JAX_COMPILATION_CACHE_DIR"}
    before, compiled, read = run_python(_CACHE_HITS, env, str(tmp_path))
    assert before == compiled and read > compiled  # (the eager `ones` are read back too)


def test_a_remembered_value_is_built_once_per_key(tmp_path, monkeypatch):
    import numpy as np

    built = []

    def build():
        built.append(1)
        return {"x": np.arange(3.0) * len(built)}

    monkeypatch.setattr(_exported, "_FOLDER", None)  # off: built every time
    _exported.remembered("v", build, np.arange(2.0))
    _exported.remembered("v", build, np.arange(2.0))
    assert len(built) == 2
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    first = _exported.remembered("v", build, np.arange(2.0), "s")
    again = _exported.remembered("v", build, np.arange(2.0), "s")
    assert len(built) == 3 and np.array_equal(first["x"], again["x"])
    _exported.remembered("v", build, np.arange(2.0) + 1.0, "s")  # other values, another key
    assert len(built) == 4
    for _ in range(2):  # code the key cannot vouch for: built each time, nothing kept
        _exported.remembered("v", build, _torque)
    assert len(built) == 6
    for path in tmp_path.glob("v-*.pkl"):  # a damaged entry is built again and replaced
        path.write_bytes(b"not a pickle")
    assert np.array_equal(
        _exported.remembered("v", build, np.arange(2.0), "s")["x"], 7 * np.arange(3.0)
    )
    assert len(list(tmp_path.glob("v-*.pkl"))) == 2
    locks = []  # a value that does not pickle: built each time, nothing kept, no error

    def lock():
        locks.append(threading.Lock())
        return locks[-1]

    assert _exported.remembered("w", lock, 1.0) is not _exported.remembered("w", lock, 1.0)
    assert len(locks) == 2 and not list(tmp_path.glob("w-*"))


def test_a_kept_system_is_the_one_built_and_brings_its_tables(tmp_path, monkeypatch):
    import equinox as eqx
    import numpy as np

    from origami_jax.net import load_net
    from origami_jax.system import KOH_SOLUTION

    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    net = load_net("corner_cube")
    design = net.default_design(KOH_SOLUTION)
    built = net.kept_system(design, release_times=[0.0, 5.0])
    assert len(list(tmp_path.glob("system-*.pkl"))) == 1
    fresh = load_net("corner_cube")  # another object, its host cache empty
    assert not any(key[0] == "tables" for key, _ in fresh.host_cache.items())
    read = fresh.kept_system(design, release_times=[0.0, 5.0])
    leaves = [jnp.zeros(1)]
    parts = [eqx.partition(s, eqx.is_array) for s in (built, read)]
    assert _exported._key("s", leaves, (parts[0][1],)) == _exported._key(
        "s", leaves, (parts[1][1],)
    )
    for a, b in zip(jax.tree.leaves(parts[0][0]), jax.tree.leaves(parts[1][0]), strict=True):
        assert np.array_equal(np.asarray(a), np.asarray(b))
    assert any(key[0] == "tables" for key, _ in fresh.host_cache.items())
    # Another release, another system; arc hinges (layouts kept by identity) are never kept.
    fresh.kept_system(design, release_times=[0.0, 0.0])
    net.with_model(hinges="arc").kept_system(design)
    assert len(list(tmp_path.glob("system-*.pkl"))) == 2
