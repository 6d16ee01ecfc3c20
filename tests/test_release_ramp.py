"""A pattern's release ramp (`with_model(release_ramp=...)`) and the fluid's inertia: by default
on in the etch bath with a quasi-static release, off in air with the paper's step; the input its
folds, kernels and yields are driven by, recorded in what they store, refused when it is not a
positive time."""

import math

import diffrax
import equinox as eqx
import jax.numpy as jnp
import pytest

import origami_jax.simulation as sim
from origami_jax.net import fold_kernel, load_net, model_settings


def test_the_release_ramp_is_the_patterns_input_everywhere():
    from origami_jax.system import AIR, KOH_SOLUTION

    net = load_net("cube_net_01")
    assert net.release_ramp == "auto" and net.added_mass is None and net.viscous is None
    koh, air = net.default_design(KOH_SOLUTION), net.default_design(AIR)
    # "auto": quasi-static where the system carries the fluid's inertia (the bath), at once in air.
    assert net.fluid_inertia(koh) == (True, True) and net.fluid_inertia(air) == (False, False)
    step = net.release_input(net.system(air))
    assert isinstance(step, sim.Step) and step.ramp is None
    with pytest.raises(ValueError, match="release ramp is 'auto'.*give the system"):
        net.release_input()
    ramped = net.with_model(release_ramp=250.0)
    assert ramped is net.with_model(release_ramp=250.0)  # one object per options
    assert float(ramped.release_input().ramp) == 250.0
    # Recorded in the kernel's settings (a store is not resumed with another release) only when
    # on: a store written before the options existed still resumes.
    assert model_settings(ramped, air) == {"release_ramp_us": 250.0}
    assert fold_kernel(ramped, fluid="air").settings["release_ramp_us"] == 250.0
    in_air = fold_kernel(net, fluid="air").settings
    assert "release_ramp_us" not in in_air and "added_mass" not in in_air
    assert in_air["t_end_us"] == 1500.0
    # In the bath (the kernel's default fluid): the fluid's inertia and viscosity, the nominal
    # design's quasi-static ramp for every member, and a fifth of it (more than 1500 µs) after it.
    bath = fold_kernel(net).settings
    assert bath["added_mass"] is True and bath["viscous"] is True
    assert bath["release_ramp_us"] == net.nominal_release_ramp(koh) == 40_000.0
    assert bath["t_end_us"] == 48_000.0  # a fifth of the ramp past it
    # The paper's dynamics in the bath, asked for by name.
    paper = net.with_model(added_mass=False, viscous=False, release_ramp=None)
    assert model_settings(paper, koh) == {}
    assert fold_kernel(paper).settings["t_end_us"] == 1500.0


def test_the_nominal_ramp_is_kept_across_processes(tmp_path, monkeypatch):
    """Where the command line keeps its programs, the nominal design's ramp is kept as a value: a
    later process (a warm yield or sweep) neither traces nor runs its program."""
    from origami_jax import _exported
    from origami_jax.net import _pattern
    from origami_jax.system import KOH_SOLUTION

    net = load_net("cube_net_01")
    koh = net.default_design(KOH_SOLUTION)
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_pattern, "_NOMINAL_RAMPS", {})
    assert net.nominal_release_ramp(koh) == 40_000.0
    assert len(list(tmp_path.glob("nominal_release_ramp-*.pkl"))) == 1

    def untraced(*args):
        raise AssertionError("the kept ramp's program was traced again")

    monkeypatch.setattr(_pattern, "_NOMINAL_RAMPS", {})  # a new process
    monkeypatch.setattr(_pattern, "_design_ramp", untraced)
    assert net.nominal_release_ramp(koh) == 40_000.0
    other = eqx.tree_at(lambda d: d.hinge_width, koh, jnp.asarray(150.0))
    with pytest.raises(AssertionError, match="traced again"):  # another design: not read back
        net.nominal_release_ramp(other)


def test_the_automatic_ramp_is_the_quasi_static_one_rounded_up():
    from origami_jax.net._pattern import quasi_static_release, rounded_up
    from origami_jax.system import KOH_SOLUTION

    assert rounded_up(39.6) == 40.0 and rounded_up(13.2) == 14.0 and rounded_up(1000.0) == 1000.0
    assert math.isclose(rounded_up(0.01234), 0.013)
    net = load_net("cube_net_01")
    system = net.system(net.default_design(KOH_SOLUTION))
    exact = float(sim.quasi_static_ramp(system))
    ramp = quasi_static_release(system)
    assert exact <= ramp < 1.1 * exact
    assert net.release_ramp_for(system) == ramp == 40_000.0
    assert net.fold_segment(system) == 48_000.0


def test_a_fluid_knows_whether_it_is_a_liquid():
    import jax
    import jax.numpy as jnp

    from origami_jax.system import AIR, KOH_SOLUTION, MICRO, Fluid, HingeDesign

    assert KOH_SOLUTION.liquid and not AIR.liquid
    assert KOH_SOLUTION.to(MICRO).liquid and not AIR.to(MICRO).liquid
    assert Fluid(1000.0).liquid and not Fluid(1.2).liquid  # kg/m³ (SI)
    assert Fluid(1e-3, MICRO).liquid and not Fluid(1e-6, MICRO).liquid  # ng/µm³: 1000, 1 kg/m³
    with pytest.raises(ValueError, match="liquid must be True, False or None"):
        Fluid(1000.0, liquid="yes")
    net = load_net("cube_net_01")

    def inertia(density, liquid=None):
        design = HingeDesign.literature(fluid=Fluid(density, liquid=liquid))
        return jnp.asarray(net.fluid_inertia(design), dtype=float)

    # Traced, the density cannot say: the fluid must, or the model.
    with pytest.raises(ValueError, match="is a liquid is unknown"):
        jax.jit(inertia)(1000.0)
    assert jax.jit(lambda d: inertia(d, liquid=True))(1000.0).tolist() == [1.0, 1.0]


@pytest.mark.slow  # builds and compiles a whole system; keeps the default suite short
def test_a_crease_pattern_carries_the_fluids_inertia_and_is_released_over_its_branchs_mode():
    """Closed loops of panels in the bath: each panel's added inertia is the strip theory's, as the
    same panels get in the net of their spanning tree (1e-12: the same numbers), and the automatic
    ramp is three periods of the slowest mode along the branch the pattern folds on, computed
    here again with SciPy (the closure's null space and the generalized eigenproblem; 1e-9), no
    longer than the spanning tree's bound (Rayleigh: the loops can only make it faster)."""
    import equinox as eqx
    import jax.numpy as jnp
    import numpy as np
    import scipy.linalg

    from origami_jax.loops import load_pattern
    from origami_jax.net._pattern import rounded_up
    from origami_jax.system import AIR, KOH_SOLUTION

    pattern = load_pattern("vertex_degree4").with_model(contact=False)
    assert pattern.release_ramp == "auto" and pattern.added_mass is None
    koh = pattern.default_design(KOH_SOLUTION)
    assert pattern.fluid_inertia(koh) == (True, True)
    in_air = pattern.default_design(AIR)
    assert pattern.fluid_inertia(in_air) == (False, False)
    assert pattern.with_model(added_mass=True).fluid_inertia(in_air) == (True, False)
    system = pattern.system(koh)
    mechanism = system.mechanism
    assert mechanism.carries_added_inertia
    # The tree's creases are the pattern's first ones, with their own hinge widths.
    tree_design = eqx.tree_at(lambda d: d.hinge_width, koh, koh.hinge_width[: mechanism.n_tree])
    tree_net = pattern.net().with_model(contact=False)
    np.testing.assert_allclose(
        mechanism.tree.added_inertias,
        tree_net.system(tree_design).mechanism.added_inertias,
        rtol=1e-12,
        atol=0.0,
    )
    # The branch's slowest mode, independently.
    theta, _ = pattern.start_state(bias=0.01)
    basis = scipy.linalg.null_space(np.asarray(mechanism.closure_jacobian(jnp.asarray(theta))))
    mass = np.asarray(mechanism.mass_matrix(jnp.asarray(theta)))
    stiffness = np.diag(np.asarray(system.hinges.stiffness))
    slowest = scipy.linalg.eigh(
        basis.T @ stiffness @ basis, basis.T @ mass @ basis, eigvals_only=True
    ).min()
    exact = 3 * 2 * np.pi / np.sqrt(slowest)
    about = pattern.oscillation_state()
    np.testing.assert_allclose(float(sim.quasi_static_ramp(system, about=about)), exact, rtol=1e-9)
    assert pattern.release_ramp_for(system) == rounded_up(exact) == 4000.0
    assert pattern.nominal_release_ramp(koh) == 4000.0
    assert float(sim.quasi_static_ramp(system)) >= exact  # the spanning tree's bound
    # The paper's dynamics, by name: no added inertia, the step.
    paper = pattern.with_model(added_mass=False, viscous=False)
    assert not paper.system(koh).mechanism.carries_added_inertia
    assert paper.nominal_release_ramp(koh) is None


@pytest.mark.parametrize("bad", [0.0, -5.0, math.inf, math.nan, True, "100"])
def test_a_bad_release_ramp_is_refused_in_one_line(bad):
    with pytest.raises(ValueError, match="release_ramp must be 'auto' .* or a positive time"):
        load_net("cube_net_01").with_model(release_ramp=bad)


def test_a_sweep_config_names_the_release_ramp_and_the_fluids_inertia():
    from origami_jax.sweep import get_model

    kernel = get_model("net-fold", net="cube_net_01", release_ramp=100.0, added_mass=True)
    assert kernel.settings["release_ramp_us"] == 100.0
    assert kernel.settings["added_mass"] is True
    assert kernel.settings["t_end_us"] == 1600.0
    # TOML has no null: 0 is the paper's step.
    paper = get_model(
        "net-fold", net="cube_net_01", release_ramp=0, added_mass=False, viscous=False
    )
    assert "release_ramp_us" not in paper.settings and paper.settings["t_end_us"] == 1500.0
    with pytest.raises(ValueError, match="release_ramp must be 'auto'"):
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
        yield_estimate(ramped, n_samples=2, solve=sim.SolveOptions(t1=1500.0))


def test_fold_runs_on_past_the_ramp():
    net = load_net("cube_net_01").with_model(release_ramp=None)
    assert net.fold_segment() == 1000.0
    assert net.with_model(release_ramp=30_000.0).fold_segment() == 36_000.0
    assert net.with_model(release_ramp=2_000.0).fold_segment() == 3_000.0  # FOLD_SEGMENT past it


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


def test_the_yield_command_records_the_samples_physics():
    # result.json's record of the dynamics and the surfaces: the kernel's settings, as run.
    from origami_jax.cli._yield import _dynamics_record
    from origami_jax.contact import Adhesion, Friction

    net = load_net("cube_net_01")
    bath = _dynamics_record(dict(fold_kernel(net).settings))
    assert bath == {"fluid_inertia": True, "release_ramp_us": 40_000.0}
    air = _dynamics_record(dict(fold_kernel(net, fluid="air").settings))
    assert air == {"fluid_inertia": False, "release_ramp_us": None}
    sticky = net.with_model(
        adhesion=Adhesion(work=0.01, range=2.0), friction=Friction(coefficient=0.3, slip=0.01)
    )
    record = _dynamics_record(dict(fold_kernel(sticky, fluid="air").settings))
    assert record["adhesion"]["work"] == 0.01 and record["friction"]["coefficient"] == 0.3


def test_design_releases_a_net_in_the_bath_as_its_fold_does(monkeypatch):
    # The fit's candidates share the nominal design's release, as a sweep's members do; a run that
    # ends within it is refused before anything compiles.
    import origami_jax.design as ojd
    from origami_jax import _exported

    # In this process alone: a command line run earlier in it keeps values on disk, where the
    # nominal ramp would be read back rather than traced (`test_the_nominal_ramp_is_kept_...`).
    monkeypatch.setattr(_exported, "_FOLDER", None)
    from origami_jax.design._design import with_pattern_release
    from origami_jax.system import AIR, KOH_SOLUTION

    net = load_net("corner_cube")
    koh = net.default_design(KOH_SOLUTION)
    settings = ojd.SimulationSettings(8000.0, layout=net)
    released = with_pattern_release(settings, koh)
    assert float(released.inputs.ramp) == net.nominal_release_ramp(koh) == 5900.0
    assert with_pattern_release(settings, net.default_design(AIR)).inputs is None
    # Another design's ramp on the net loaded again, with a weakly typed number: the same
    # compiled program (the pattern static by its contents, the numbers strongly typed; each
    # traced it again, 2-3 s).
    from origami_jax.net._pattern import _design_ramp

    traced = _design_ramp._cached._cache_size()
    other = eqx.tree_at(lambda d: d.b_scale, koh, jnp.asarray(1.5))
    assert load_net("corner_cube").nominal_release_ramp(other) > 0
    assert _design_ramp._cached._cache_size() == traced
    with pytest.raises(ValueError, match="ends within the pattern's release ramp"):
        with_pattern_release(ojd.SimulationSettings(600.0, layout=net), koh)


def test_fold_continues_past_a_ramp_by_its_settling_only():
    # The first run is the ramp and its settling (300 + 1000 µs), each continuation the settling
    # alone (1000 µs), not the ramp again. The second crease, released at 1250 µs, is still moving
    # at the end of the first run.
    net = load_net("corner_cube").with_model(contact=False, release_ramp=300.0)
    system = net.system(release_times=[0.0, 1250.0])
    calls = []
    # Tsit5 named: the continuations' timing is the solver's business alone, and the default's
    # switching solve compiled its implicit half too (10 s of the default suite).
    options = sim.SolveOptions(saveat=sim.SaveAt(n=21), throw=False, solver=diffrax.Tsit5())
    trajectory, _ = net.fold(
        system, options=options, max_segments=2, on_continue=lambda *ends: calls.append(ends)
    )
    assert calls == [(1300.0, 2300.0)]
    assert float(trajectory.times[-1]) == 2300.0
