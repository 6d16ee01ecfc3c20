"""Traced programs kept on disk (`origami_jax._exported`): a later process runs the exported solve
without tracing it, and gets the same numbers; what the key cannot vouch for is traced as usual.

The solves run in fresh processes with ``EQX_ON_ERROR=nan`` (as the command line sets it): in this
process equinox raises its runtime errors through Python callbacks, which no exported program can
hold, and JAX keeps the traces it made here for the rest of the test session.
"""

import dataclasses
import os

import diffrax
import equinox._errors
import jax
import jax.numpy as jnp
import pytest

from origami_jax import _exported

from .helpers import run_python

_RUN = """
    import hashlib, json, sys
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
    traced = []
    solve = _simulate._solve_until_stiff
    _simulate._solve_until_stiff = lambda *a: traced.append(1) or solve(*a)
    system = accordion_system(HingeDesign.literature(), 1)
    run = lambda: sim.simulate(system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=101), throw=False), t1=300.0)  # noqa
    plain = run()  # the ordinary jitted solve
    traced.clear()
    _exported.enable_exported_programs(folder + "/exported")
    ours = run()
    digest = lambda t: hashlib.sha256(np.asarray(t.theta).tobytes()).hexdigest()  # noqa
    print(json.dumps({
        "traced": len(traced),
        "plain": digest(plain),
        "ours": digest(ours),
        "steps": [int(plain.stats["num_steps"]), int(ours.stats["num_steps"])],
        "succeeded": bool(ours.succeeded),
    }))
"""


def _process(folder) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "JAX_COMPILATION_CACHE_DIR"}
    env["EQX_ON_ERROR"] = "nan"
    return run_python(_RUN, env, str(folder))


@pytest.mark.slow  # two Python processes, one exporting and one loading a solve: ~20 s
def test_a_later_process_runs_the_exported_solve_without_tracing_it(tmp_path):
    first = _process(tmp_path)  # traces, exports, writes
    files = sorted((tmp_path / "exported").glob("solve_until_stiff-*.bin"))
    assert len(files) == 1 and first["traced"] == 1
    assert first["ours"] == first["plain"] and first["succeeded"]

    later = _process(tmp_path)  # loads the program: no trace of the solve, the same samples
    assert later["traced"] == 0
    assert later["ours"] == later["plain"] == first["plain"]
    assert later["steps"][0] == later["steps"][1]
    assert sorted((tmp_path / "exported").glob("*.bin")) == files

    files[0].write_bytes(b"not a program")  # a damaged entry is traced again and replaced
    repaired = _process(tmp_path)
    assert repaired["traced"] == 1 and repaired["ours"] == first["plain"]
    assert files[0].read_bytes() != b"not a program"


def _torque(t, theta, theta_dot):  # a user's function: its code is not part of any key
    return jnp.full_like(theta, 1e-3)


def test_the_key_covers_the_environment_and_refuses_what_it_cannot_vouch_for(monkeypatch):
    leaves = [jnp.zeros(3)]
    key = _exported._key("p", leaves, ("static",))
    assert key == _exported._key("p", leaves, ("static",))
    assert key != _exported._key("p", [jnp.zeros(4)], ("static",))
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
