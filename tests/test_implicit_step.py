"""The fixed-step engine `ImplicitStep`: first-order (Euler) and second-order (BDF2) convergence to
the adaptive solve, no energy gain and no plate through another in contact, gradients against
central differences, a vmapped batch.

Tolerances: the convergence order from errors at three steps (ratio of successive errors within
[1.6, 2.5]: 2 for a first-order method, off by the next order's share; [3.2, 5] for BDF2's 4); energy may rise between
samples by no more than 1e-6 of the energy in play (the Newton iterations' remaining error);
gradients against central differences to 1e-4 relative (the difference step's truncation and the
Newton iterations' convergence).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.chain import accordion_system
from origami_jax.net import load_net
from origami_jax.simulation._implicit import integrate
from origami_jax.system import AIR, KOH_SOLUTION, HingeDesign, HingeDrag

SCALE = 0.5  # the catalogue's nets at half scale: 100 µm panels


def _two_flaps(fluid=KOH_SOLUTION):
    """The paper's accordion with two flaps (hinge drag, no contact), in KOH by default."""
    return accordion_system(HingeDesign.literature(fluid=fluid), 2)


def test_arguments_are_checked():
    with pytest.raises(ValueError, match="dt"):
        sim.ImplicitStep(dt=0.0)
    with pytest.raises(ValueError, match="newton_iterations"):
        sim.ImplicitStep(dt=1.0, newton_iterations=0)
    with pytest.raises(ValueError, match="scheme must be one of 'euler', 'bdf2'"):
        sim.ImplicitStep(dt=1.0, scheme="bdf3")
    assert sim.named_solver("implicit-bdf2", dt=2.0) == sim.ImplicitStep(dt=2.0, scheme="bdf2")
    assert sim.named_solver("implicit-step", dt=2.0).scheme == "euler"
    with pytest.raises(ValueError, match="dense"):
        sim.simulate(
            _two_flaps(),
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(dense=True), solver=sim.ImplicitStep(dt=0.1)),
            t1=1.0,
        )


def test_other_end_times_and_sample_counts_compile_nothing_again():
    """Outside any transformation the fixed steps solve on samples padded to a power of two:
    another end time or sample count within it that takes the same steps per interval reuses the
    compiled solve (each compiled again, 20-30 s on a net), with the numbers of a solve compiled
    for its own count (under `jit`: nothing padded)."""
    from origami_jax.simulation import _simulate

    system = _two_flaps()

    def options(n):
        return sim.SolveOptions(saveat=sim.SaveAt(n=n), solver=sim.ImplicitStep(dt=0.5))

    first = sim.simulate(system, sim.Step(), options(11), t1=20.0)  # 4 steps of 0.5 µs per sample
    compiled = _simulate._implicit_solve_jit._cached._cache_size()
    for t1, n in ((16.0, 11), (20.0, 13), (14.0, 9)):  # 3.2, 3.3 and 3.5 steps: 4 each
        run = sim.simulate(system, sim.Step(), options(n), t1=t1)
        assert run.theta.shape[0] == n and float(run.times[-1]) == t1
        assert int(run.stats["num_steps"]) == 4 * (n - 1)
    assert _simulate._implicit_solve_jit._cached._cache_size() == compiled
    inside = jax.jit(lambda s: sim.simulate(s, sim.Step(), options(11), t1=20.0).theta)(system)
    np.testing.assert_allclose(first.theta, inside, rtol=1e-12, atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("scheme, low, high", [("euler", 1.6, 2.5), ("bdf2", 3.2, 5.0)])
def test_converges_at_its_order_to_the_adaptive_solve(scheme, low, high):
    """Halving the step halves the error at a fixed time (Euler) or quarters it (BDF2), against the
    adaptive solve at rtol 1e-10: the two-flap accordion in air, 20 µs into its first swing (steps
    of 1/40 to 1/160 of it; in KOH the first microseconds' transient, as fast as a step, keeps the
    ratio near 1.7 until steps far below it). Measured (2026-12-06): Euler's errors 3.3e-2,
    1.7e-2, 8.4e-3 rad, BDF2's 3.0e-3, 6.6e-4, 1.5e-4."""
    system = _two_flaps(AIR)
    t1 = 20.0
    reference = sim.simulate(
        system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=2), rtol=1e-10, atol=1e-12), t1=t1
    )
    errors = []
    for dt in (0.5, 0.25, 0.125):
        solver = sim.ImplicitStep(dt=dt, scheme=scheme)
        run = sim.simulate(
            system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=2), solver=solver), t1=t1
        )
        assert bool(run.succeeded)
        assert int(run.stats["num_steps"]) == round(t1 / dt)
        errors.append(float(jnp.max(jnp.abs(run.theta[-1] - reference.theta[-1]))))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > low) & (ratios < high)), (errors, ratios)


@pytest.mark.slow
def test_bdf2_across_uneven_sample_intervals():
    """BDF2 where the sample intervals, and so the steps, change length: by 0.5× and 2× (the
    variable-step formula) and by 8× (a restart with one Euler step: variable-step BDF2 is
    zero-stable only for ratios below 1 + √2). Against the adaptive solve at the same times
    (the accordion in air, as above): below the error of even steps of 1 µs, half its longest
    (measured 2026-12-06: 1.7e-2 against 2.7e-2 rad; even steps of 2 µs, 9.3e-2)."""
    system = _two_flaps(AIR)
    ts = jnp.asarray([2.0, 3.0, 5.0, 6.0, 14.0, 20.0])  # steps of 0.5, 0.25, 0.5, 0.25, 2, 1.5 µs
    exact = sim.SolveOptions(saveat=sim.SaveAt(ts=ts), rtol=1e-10, atol=1e-12)
    reference = sim.simulate(system, sim.Step(), exact, t1=20.0)
    uneven = sim.SolveOptions(
        saveat=sim.SaveAt(ts=ts), solver=sim.ImplicitStep(dt=2.0, scheme="bdf2")
    )
    run = sim.simulate(system, sim.Step(), uneven, t1=20.0)
    even = sim.SolveOptions(saveat=sim.SaveAt(n=21), solver=sim.ImplicitStep(dt=1.0, scheme="bdf2"))
    bound = sim.simulate(system, sim.Step(), even, t1=20.0)
    error = float(jnp.max(jnp.abs(run.theta - reference.theta)))
    even_error = float(jnp.max(jnp.abs(bound.theta[ts.astype(int)] - reference.theta)))
    assert bool(run.succeeded) and error < even_error, (error, even_error)


@eqx.filter_jit
def _step_energy(system, trajectory):
    """Mechanical energy with the step's potential ``−Σ k θ_target θ``: conserved without drag and
    contact damping, so it may only fall (implicit Euler dissipates besides)."""
    k, target = system.hinges.stiffness, system.hinges.target
    q, v = trajectory.theta, trajectory.theta_dot
    return jax.vmap(system.energy)(q, v) - q @ (k * target)


def _launched_flaps(solver, n_save: int):
    """The corner cube at half scale without drag, its two flaps launched at each other from 0.98
    of their closed angles (0.02 rad/µs each), folded by `solver` to 60 µs with `n_save` samples:
    ``(net, system, trajectory)``."""
    net = load_net("corner_cube", length_scale=SCALE)
    system = net.system(drag="hinge")
    system = eqx.tree_at(lambda s: s.drag, system, HingeDrag(jnp.zeros(system.n_hinges)))
    closed = jnp.asarray(net.intended_angles)
    options = sim.SolveOptions(saveat=sim.SaveAt(n=n_save), solver=solver)
    trajectory = sim.simulate(system, sim.Step(), options, t1=60.0, theta0=closed * 0.98, theta_dot0=jnp.asarray([0.02, 0.02]))  # fmt: skip
    return net, system, trajectory


@pytest.mark.slow  # the plate contact's Jacobian: ~40 s to compile
@pytest.mark.parametrize("dt, n_save, iterations", [(0.5, 61, 6), (4.0, 16, 20)])
def test_launched_flaps_stop_on_each_other_without_gaining_energy(dt, n_save, iterations):
    """The corner cube's two flaps, no drag, launched at each other from near their closed state:
    their corners and rims meet under the exact plate contact. The energy never rises, the
    contact stopped them, and the plates overlap by less than the film's thickness at every
    sample; with steps of 0.5 µs and of 4 µs (the flaps close their last 0.03 rad in ~1.5 µs).
    The 4 µs steps need more Newton iterations than the default: with 6, the step after the
    impact ends unconverged against the barrier and the energy rose by 0.2 % of that in play."""
    solver = sim.ImplicitStep(dt=dt, newton_iterations=iterations)
    net, system, trajectory = _launched_flaps(solver, n_save)
    assert bool(trajectory.succeeded)
    energy = np.asarray(_step_energy(system, trajectory))
    assert np.max(np.diff(energy)) <= 1e-6 * np.max(np.abs(energy))
    assert energy[-1] < energy[0]
    report = jax.vmap(lambda q: system.contact.report(system.mechanism, q))(trajectory.theta)
    assert int(jnp.max(report["engaged"])) > 0  # they did meet
    thickness = 2 * float(np.min(np.asarray(system.contact.half_thickness)))
    assert float(jnp.max(report["penetration"])) < thickness
    assert float(net.outcome(system, trajectory).penetration) < thickness


@pytest.mark.slow  # the plate contact's Jacobian: ~40 s to compile
def test_bdf2_flaps_meet_without_passing_and_give_back_less_than_the_impact_took():
    """The same launched flaps with BDF2 (steps of 0.5 µs, Newton converged): no plate through
    the other, and no net gain, but BDF2 is not energy-monotone at an impact (it is G-stable: a
    norm of two consecutive states decreases, not the energy of one): after the flaps meet, the
    energy rises again by part of what the impact took (measured 2026-12-06: by 2.3 between two
    samples, 2.6 in all, of the 8.3 it took, in the units of `system.energy`; Euler's rises by
    nothing and keeps the flaps at rest; the resolved adaptive solve loses only 0.52 at the
    impact and the flaps rebound). The bound, half of what
    the impact took, guards against a scheme that would hand the impact's loss back."""
    solver = sim.ImplicitStep(dt=0.5, newton_iterations=20, scheme="bdf2")
    _, system, trajectory = _launched_flaps(solver, 61)
    assert bool(trajectory.succeeded) and float(trajectory.stats["newton_error"]) < 1e-9
    energy = np.asarray(_step_energy(system, trajectory))
    taken = energy[0] - np.min(energy)
    assert taken > 0 and energy[-1] < energy[0]
    assert np.max(np.diff(energy)) < 0.5 * taken
    report = jax.vmap(lambda q: system.contact.report(system.mechanism, q))(trajectory.theta)
    thickness = 2 * float(np.min(np.asarray(system.contact.half_thickness)))
    assert int(jnp.max(report["engaged"])) > 0
    assert float(jnp.max(report["penetration"])) < thickness


@pytest.mark.parametrize("scheme", ["euler", pytest.param("bdf2", marks=pytest.mark.slow)])
def test_gradient_matches_central_differences_away_from_contact(scheme):
    """d θ(t1) / d(stiffness scale) of the two-flap accordion (no contact) through the implicit
    function theorem at every step (with BDF2, through the previous state it carries too),
    against central differences of the same discrete map."""
    system = _two_flaps()
    solver = sim.ImplicitStep(dt=1.0, scheme=scheme)

    def final_angle(scale):
        scaled = eqx.tree_at(lambda s: s.hinges.stiffness, system, system.hinges.stiffness * scale)
        run = sim.simulate(
            scaled, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=2), solver=solver), t1=20.0
        )
        return run.theta[-1, 1]

    value_and_grad = jax.jit(jax.value_and_grad(final_angle))
    _, gradient = value_and_grad(1.0)
    step = 1e-5
    f = jax.jit(final_angle)
    difference = (f(1.0 + step) - f(1.0 - step)) / (2 * step)
    assert abs(float(gradient) - float(difference)) <= 1e-4 * abs(float(difference))


def test_vmapped_batch_of_designs():
    """Four stiffness scales of the two-flap accordion in one vmapped call: the same fixed work per
    member, each member's samples those of its own run."""
    system = _two_flaps()
    solver = sim.ImplicitStep(dt=1.0)

    def run(scale):
        scaled = eqx.tree_at(lambda s: s.hinges.stiffness, system, system.hinges.stiffness * scale)
        trajectory = sim.simulate(
            scaled, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=3), solver=solver), t1=10.0
        )
        return trajectory.theta, trajectory.stats["num_steps"]

    scales = jnp.asarray([0.5, 1.0, 1.5, 2.0])
    theta, steps = jax.jit(jax.vmap(run))(scales)
    assert theta.shape == (4, 3, 2)
    assert np.all(np.asarray(steps) == 10)
    single, _ = jax.jit(run)(scales[2])
    np.testing.assert_allclose(theta[2], single, rtol=1e-10, atol=1e-12)
    assert len({float(x) for x in theta[:, -1, 0]}) == 4  # the designs differ


def test_early_exit_gives_the_fixed_count_result():
    """`early_exit` (Newton stops when converged, line searches at their first acceptable trial)
    lands on the same roots as the fixed counts, to the convergence threshold."""
    system = _two_flaps()
    runs = [
        sim.simulate(
            system,
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(n=3), solver=sim.ImplicitStep(dt=1.0, early_exit=e)),
            t1=20.0,
        )
        for e in (False, True)
    ]
    np.testing.assert_allclose(runs[1].theta, runs[0].theta, rtol=0, atol=1e-9)
    assert float(runs[1].stats["newton_error"]) < 1e-9


def _one_step(system, solver, t0, q0, v0):
    """One step of `solver` from ``(q0, v0)`` at `t0`: the state and its Newton error."""
    q, _, stats, _ = integrate(system, sim.Step(), solver, t0, jnp.reshape(t0 + solver.dt, (1,)), q0, v0, 1)  # fmt: skip
    return q[-1], stats["newton_error"]


def _converged_within_its_test(system, t0, states, dt=0.5):
    """Each of `states` `(q, v)` stepped with the default early exit and with 30 fixed Newton
    iterations (the root to rounding): the early exit's state is that root to its convergence test
    (1e-10 rad), whether it stopped on a small update or took its last update on the error the
    rate of convergence left it (reported as the step's Newton error, itself below the test)."""
    early = eqx.filter_jit(_one_step)
    exact = sim.ImplicitStep(dt=dt, newton_iterations=30, early_exit=False)
    for q0, v0 in states:
        q, error = early(system, sim.ImplicitStep(dt=dt), t0, q0, v0)
        root, _ = early(system, exact, t0, q0, v0)
        assert float(error) <= 1e-10
        assert float(jnp.max(jnp.abs(q - root))) <= 1e-10, (q - root, error)


@pytest.mark.parametrize("dt", [0.5, 8.0])
def test_early_exit_ends_within_its_test_of_the_root(dt):
    """Without contact (the exact Jacobian: quadratic convergence, the last update taken once the
    next would be ``θ²`` as long) at three states of the accordion's fold in air, with short steps
    and with long ones (more updates to converge)."""
    system = _two_flaps(AIR)
    run = sim.simulate(
        system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=4), solver=sim.ImplicitStep(dt=0.5)), t1=30.0
    )  # fmt: skip
    states = zip(run.theta[1:], run.theta_dot[1:], strict=True)
    _converged_within_its_test(system, 0.0, states, dt)


@pytest.mark.slow  # the plate contact's Jacobian: ~40 s to compile
def test_early_exit_ends_within_its_test_of_the_root_at_a_contact():
    """At the corner cube's flaps pressed together (the Gauss–Newton matrix: linear convergence,
    the last update taken once the next would be ``θ/(1 − θ)`` of it; its contact-free part held
    where the first update is short), from every third sample of the launched flaps where a pair
    is engaged."""
    _, system, trajectory = _launched_flaps(sim.ImplicitStep(dt=0.5), 31)
    report = jax.vmap(lambda q: system.contact.report(system.mechanism, q))(trajectory.theta)
    engaged = np.nonzero(np.asarray(report["engaged"]) > 0)[0]
    assert len(engaged) > 5
    states = [(trajectory.theta[k], trajectory.theta_dot[k]) for k in engaged[::3]]
    _converged_within_its_test(system, 0.0, states)


@pytest.mark.slow  # two plate-contact folds to compile: ~30 s
def test_early_exit_meets_contact_as_the_fixed_counts_do():
    """The launched flaps of the corner cube (they meet under the plate contact): `early_exit`'s
    collision check (as many chords as an update needs, one after another) and the fixed counts'
    (every `ccd_pieces` chords side by side) cap the updates alike, and the two runs land on the
    same states to the Newton iterations' convergence (1e-10 rad per step, 120 steps)."""
    _, system, fixed = _launched_flaps(sim.ImplicitStep(dt=0.5, early_exit=False), 31)
    _, _, early = _launched_flaps(sim.ImplicitStep(dt=0.5), 31)
    report = jax.vmap(lambda q: system.contact.report(system.mechanism, q))(early.theta)
    assert int(jnp.max(report["engaged"])) > 0  # they did meet
    np.testing.assert_allclose(early.theta, fixed.theta, rtol=0, atol=1e-8)
