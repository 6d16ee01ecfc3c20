"""Traced programs kept on disk (`origami_jax._exported`): a later process runs the exported solve
without tracing it, and gets the same numbers; what the key cannot vouch for is traced as usual."""

import equinox._errors
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax import _exported
from origami_jax.chain import accordion_system
from origami_jax.simulation import _simulate
from origami_jax.system import HingeDesign

T1 = 300.0


def _torque(t, theta, theta_dot):  # a user's function: its code is not part of any key
    return jnp.full_like(theta, 1e-3)


@pytest.fixture
def exporting(tmp_path, monkeypatch):
    # As the command line runs: runtime errors as NaN (a program that calls back into Python for
    # its errors cannot be exported).
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    # JAX keeps the traces of inner jitted functions per process: an earlier test's, made with
    # runtime errors raised, would bring its Python callbacks along.
    jax.clear_caches()
    monkeypatch.setattr(_exported, "_REFUSED", set())
    _exported.enable_exported_programs(tmp_path)
    yield tmp_path
    _exported.enable_exported_programs(None)
    jax.clear_caches()  # and the traces made here, with errors as NaN, must not serve later tests


def _run(system, inputs=None):
    return sim.simulate(system, inputs or sim.Step(), t1=T1, n_save=101)


def test_a_later_process_runs_the_exported_solve_without_tracing_it(exporting, monkeypatch):
    system = accordion_system(HingeDesign.literature(), 1)
    plain_folder, _exported._FOLDER = _exported._FOLDER, None
    plain = _run(system)  # the ordinary jitted solve
    _exported._FOLDER = plain_folder
    first = _run(system)  # traced, exported, written
    files = sorted(exporting.glob("solve_until_stiff-*.bin"))
    assert len(files) == 1
    for field in ("theta", "theta_dot", "times"):
        np.testing.assert_array_equal(getattr(first, field), getattr(plain, field))

    # A new process, as far as the solve is concerned: nothing may trace or run it but the file.
    def untraceable(*args, **kwargs):
        raise AssertionError("the solve was traced again")

    monkeypatch.setattr(_simulate, "_solve_until_stiff", untraceable)
    monkeypatch.setattr(_simulate, "_solve_until_stiff_jit", untraceable)
    again = _run(system)
    for field in ("theta", "theta_dot", "times"):
        np.testing.assert_array_equal(getattr(again, field), getattr(plain, field))
    assert again.stats["num_steps"] == plain.stats["num_steps"]
    assert again.result == sim.RESULTS.successful

    # Another value of a parameter is another input, not another program.
    stiffer = accordion_system(HingeDesign.literature(k_scale=2.0), 1)
    assert float(_run(stiffer).stats["num_steps"]) > 0
    assert sorted(exporting.glob("*.bin")) == files

    # A damaged entry is traced again and replaced.
    monkeypatch.undo()
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    files[0].write_bytes(b"not a program")
    repaired = _run(system)
    np.testing.assert_array_equal(repaired.theta, plain.theta)
    assert files[0].read_bytes() != b"not a program"


def test_what_the_key_cannot_vouch_for_is_traced_as_usual(exporting):
    system = accordion_system(HingeDesign.literature(), 1)
    trajectory = _run(system, sim.UserTorque(_torque))
    assert trajectory.succeeded
    assert not list(exporting.glob("*.bin"))  # a function from the tests: refused, not stored


def test_the_key_covers_the_environment(monkeypatch):
    leaves = [jnp.zeros(3)]
    key = _exported._key_and_static("p", leaves, ("static",))
    assert key == _exported._key_and_static("p", leaves, ("static",))
    assert key != _exported._key_and_static("p", [jnp.zeros(4)], ("static",))
    assert key != _exported._key_and_static("p", leaves, ("other",))
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    assert key != _exported._key_and_static("p", leaves, ("static",))
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "raise")
    x64 = jax.config.jax_enable_x64
    try:
        jax.config.update("jax_enable_x64", not x64)
        assert key != _exported._key_and_static("p", leaves, ("static",))
    finally:
        jax.config.update("jax_enable_x64", x64)
    assert _exported._key_and_static("p", leaves, (_torque,)) is None
