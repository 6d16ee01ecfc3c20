"""A pattern's release ramp (`with_model(release_ramp=...)`): the input its folds, kernels and
yields are driven by, recorded in what they store, refused when it is not a positive time."""

import math

import pytest

import origami_jax.simulation as sim
from origami_jax.net import fold_kernel, load_net, model_settings


def test_the_release_ramp_is_the_patterns_input_everywhere():
    net = load_net("cube_net_01")
    assert net.release_ramp is None
    step = net.release_input()
    assert isinstance(step, sim.Step) and step.ramp is None
    ramped = net.with_model(release_ramp=250.0)
    assert ramped is net.with_model(release_ramp=250.0)  # one object per options
    assert float(ramped.release_input().ramp) == 250.0
    # Recorded in the kernel's settings (a store is not resumed with another release) only when
    # on: a store written before the option existed still resumes.
    assert "release_ramp_us" not in fold_kernel(net).settings
    assert fold_kernel(ramped).settings["release_ramp_us"] == 250.0
    assert model_settings(ramped) == {"release_ramp_us": 250.0}
    # The fluid's inertia and viscosity are recorded as well (they were not, before).
    inertia = net.with_model(added_mass=True, viscous=True)
    assert model_settings(inertia) == {"added_mass": True, "viscous": True}
    assert fold_kernel(inertia).settings["added_mass"] is True


@pytest.mark.parametrize("bad", [0.0, -5.0, math.inf, math.nan, True, "100"])
def test_a_bad_release_ramp_is_refused_in_one_line(bad):
    with pytest.raises(ValueError, match="release_ramp must be None .* or a positive time in µs"):
        load_net("cube_net_01").with_model(release_ramp=bad)


def test_a_sweep_config_names_the_release_ramp_and_the_fluids_inertia():
    from origami_jax.sweep import get_model

    kernel = get_model("net-fold", net="cube_net_01", release_ramp=100.0, added_mass=True)
    assert kernel.settings["release_ramp_us"] == 100.0
    assert kernel.settings["added_mass"] is True
    with pytest.raises(ValueError, match="release_ramp must be None"):
        get_model("net-fold", net="cube_net_01", release_ramp=-1.0)


@pytest.mark.slow  # two cube-net foldings in the bath with the fluid's inertia (~40 s)
def test_with_the_baths_inertia_a_step_flings_the_panels_and_a_slow_release_folds():
    # In KOH the fluid's inertia is ~250 times a panel's: released at once, the walls swing far
    # past 90°; released over 30 ms (against hinge periods of 2–11 ms flat) the net follows its
    # equilibrium and folds, no crease more than a few degrees past its target.
    import numpy as np

    from origami_jax.system import KOH_SOLUTION

    net = load_net("cube_net_01").with_model(added_mass=True, viscous=True)
    system = net.system(net.default_design(KOH_SOLUTION))
    options = sim.SolveOptions(saveat=sim.SaveAt(n=721), throw=False, max_steps=400_000)
    step_run, step_report = net.fold(system, sim.Step(), options, t1=8000.0)
    assert np.degrees(float(np.max(step_run.theta))) > 120.0
    assert step_report.verdict != "folded"
    slow = net.with_model(release_ramp=30_000.0)
    slow_run, slow_report = slow.fold(system, None, options, t1=36_000.0)
    assert slow_report.verdict == "folded", slow_report.summary()
    assert np.degrees(float(np.max(slow_run.theta))) < 95.0


def test_a_yield_whose_ramp_outlasts_the_run_is_refused_before_compiling():
    from origami_jax.fab_yield import yield_estimate

    ramped = load_net("cube_net_01").with_model(release_ramp=30_000.0)
    with pytest.raises(ValueError, match=r"release ramp \(30000 µs\) lasts to or past t_end"):
        yield_estimate(ramped, n_samples=2)


def test_fold_runs_on_past_the_ramp():
    net = load_net("cube_net_01")
    assert net.fold_segment() == 1000.0
    assert net.with_model(release_ramp=30_000.0).fold_segment() == 31_000.0


def test_the_quasi_static_ramp_is_periods_of_the_slowest_hinge_mode():
    # One flap: the mode is the flap's own, T = 2π √(I/k) (exact). A cube net: the slowest mode
    # of M q̈ + K q = 0 is at least as slow as each hinge alone (Rayleigh's quotient).
    import jax.numpy as jnp
    import numpy as np

    from origami_jax.chain import accordion_system
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    flap = accordion_system(HingeDesign.literature(), 1)
    inertia = float(flap.mechanism.mass_matrix(jnp.zeros(1))[0, 0])
    period = 2 * np.pi * np.sqrt(inertia / float(flap.hinges.stiffness[0]))
    np.testing.assert_allclose(float(sim.quasi_static_ramp(flap)), 3 * period, rtol=1e-12)
    np.testing.assert_allclose(
        float(sim.quasi_static_ramp(flap, periods=1.5)), 1.5 * period, rtol=1e-12
    )
    net = load_net("cube_net_01").with_model(added_mass=True, viscous=True)
    system = net.system(net.default_design(KOH_SOLUTION))
    diagonal = np.diagonal(np.asarray(system.mechanism.mass_matrix(jnp.zeros(5))))
    alone = 2 * np.pi * np.sqrt(diagonal / np.asarray(system.hinges.stiffness))
    slowest = float(sim.quasi_static_ramp(system, periods=1.0))
    assert np.max(alone) <= slowest < 2 * np.max(alone)
    assert 5_000.0 < slowest < 30_000.0  # ms in the bath with the fluid's inertia
    with pytest.raises(ValueError, match="periods must be a positive number"):
        sim.quasi_static_ramp(system, periods=0.0)
