"""StiffnessSwitching: the stiffness estimate, the switch, agreement with closed forms, vmap and gradients.

The test problem is the scalar relaxation ``y' = −a (y − cos t)``, ``y(0) = 0``, whose solution is
``y = (a² cos t + a sin t − a² e^{−a t}) / (a² + 1)``: stiff for large ``a`` (ρ = a), mild for small.
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.chain import accordion_system
from origami_jax.simulation._switching import _tsit5_stiffness
from origami_jax.system import HingeDesign

from .helpers import solve_programs

T1 = 10.0
RTOL, ATOL = 1e-8, 1e-10
# |y − exact| at T1: the global error of a tolerance-1e-8 solve of a unit-size solution.
EXACT_AGREEMENT = 1e-6


def _exact(a, t):
    return (a**2 * jnp.cos(t) + a * jnp.sin(t) - a**2 * jnp.exp(-a * t)) / (a**2 + 1)


def _solve(a, solver, max_steps=100_000, adjoint=None):
    solution = diffrax.diffeqsolve(
        diffrax.ODETerm(lambda t, y, a: -a * (y - jnp.cos(t))),
        solver,
        0.0,
        T1,
        1e-6,
        jnp.zeros(()),
        a,
        saveat=diffrax.SaveAt(t1=True, solver_state=isinstance(solver, sim.StiffnessSwitching)),
        stepsize_controller=diffrax.PIDController(rtol=RTOL, atol=ATOL),
        max_steps=max_steps,
        throw=False,
        adjoint=diffrax.RecursiveCheckpointAdjoint() if adjoint is None else adjoint,
    )
    switch_time = (
        solution.solver_state[1].switch_time
        if isinstance(solver, sim.StiffnessSwitching)
        else jnp.inf
    )
    return solution.ys[-1], solution.stats["num_steps"], switch_time, solution.result


_switching = jax.jit(lambda a: _solve(a, sim.StiffnessSwitching()))


def test_stiffness_estimate_is_exact_for_a_linear_scalar_problem():
    # For f = λ y the estimate ‖k₇ − k₆‖ / ‖y₁ − Y₆‖ is exactly |λ| h.
    lam, h = -37.0, 0.05
    term = diffrax.ODETerm(lambda t, y, args: lam * y)
    tsit5 = diffrax.Tsit5()
    y0 = jnp.ones(())
    state = tsit5.init(term, 0.0, h, y0, None)
    _, _, dense, _, _ = tsit5.step(term, jnp.array(0.0), jnp.array(h), y0, None, state, False)
    np.testing.assert_allclose(_tsit5_stiffness(dense, tsit5), abs(lam) * h, rtol=1e-12)


def test_switches_on_a_stiff_problem_and_matches_the_closed_form():
    a = 1e5
    y, steps, switch_time, result = _switching(a)
    assert result == diffrax.RESULTS.successful
    np.testing.assert_allclose(y, _exact(a, T1), atol=EXACT_AGREEMENT)
    assert 0.0 < switch_time < 1e-2, (
        switch_time
    )  # the first stiff stretch: 15 steps after the layer
    # Tsit5 alone is held to |h a| < 3.51 over the whole interval: ~3e5 steps. The switch solves it in
    # a few hundred.
    assert steps < 2_000, steps


def test_stays_explicit_on_a_mild_problem_and_matches_the_closed_form():
    a = 2.0
    y, steps, switch_time, result = _switching(a)
    assert result == diffrax.RESULTS.successful
    assert np.isinf(switch_time)
    np.testing.assert_allclose(y, _exact(a, T1), atol=EXACT_AGREEMENT)
    # Same steps as Tsit5 alone, which it is until a switch.
    _, tsit5_steps, _, _ = jax.jit(lambda a: _solve(a, diffrax.Tsit5()))(a)
    assert int(steps) == int(tsit5_steps)


@pytest.mark.slow
def test_vmap_over_stiff_and_mild_members_matches_single_solves():
    # Under vmap the switch flag is batched and both branches run; each member must still follow its own.
    a = jnp.array([2.0, 1e5])
    y, _, switch_time, _ = jax.jit(jax.vmap(lambda a: _solve(a, sim.StiffnessSwitching())))(a)
    for i in range(2):
        single_y, _, single_switch, _ = _switching(a[i])
        np.testing.assert_allclose(y[i], single_y, rtol=1e-12)
        np.testing.assert_array_equal(switch_time[i], single_switch)


@pytest.mark.parametrize("mode", ["forward", pytest.param("reverse", marks=pytest.mark.slow)])
def test_gradient_through_the_switch_matches_the_closed_form(mode):
    # d y(T1) / d a: the derivative of the closed form, through a solve that switches (a = 1e3).
    a = 1e3
    if mode == "forward":
        solver = sim.StiffnessSwitching().with_scan_kind("lax")
        solve = lambda a: _solve(a, solver, adjoint=diffrax.ForwardMode())[0]  # noqa: E731
        gradient = jax.jit(jax.jacfwd(solve))(a)
    else:
        gradient = jax.jit(jax.grad(lambda a: _solve(a, sim.StiffnessSwitching())[0]))(a)
    exact = jax.grad(lambda a: _exact(a, T1))(a)
    # |dy/da| ~ 1e-6 here; the solve's error in y (≤ 1e-6 relative to y ~ 1) differentiates to ~1e-9.
    np.testing.assert_allclose(gradient, exact, rtol=1e-3, atol=1e-9)


def test_start_implicit_and_bad_arguments():
    y, _, switch_time, _ = jax.jit(
        lambda a: _solve(a, sim.StiffnessSwitching(start_implicit=True))
    )(2.0)
    assert switch_time == 0.0
    np.testing.assert_allclose(y, _exact(2.0, T1), atol=EXACT_AGREEMENT)
    with pytest.raises(ValueError, match="threshold must be positive"):
        sim.StiffnessSwitching(threshold=0.0)
    with pytest.raises(ValueError, match="patience must be at least 1"):
        sim.StiffnessSwitching(patience=0)


class _Viscous(eqx.Module):
    """A hinge pulled to its target against a linear damper: ``τ = k θ* − c θ̇`` (torque units)."""

    pull: jax.Array
    damping: jax.Array

    def __call__(self, t, theta, theta_dot):
        return self.pull - self.damping * theta_dot


@pytest.mark.slow  # a whole program of its own to compile; the default run stays under 10 min
def test_top_level_simulate_compiles_the_implicit_phase_only_when_a_run_turns_stiff(monkeypatch):
    # One flap in air with a linear damper c = r √(k I): eigenvalues ≈ −ω/r and −r ω. At r = 0.3
    # the run is mildly damped and never stiff; at r = 30 the fast mode makes the explicit steps
    # stability-bound and the default solver turns implicit.
    from origami_jax.simulation import _simulate

    system = accordion_system(HingeDesign.literature(), 1)
    k = system.hinges.stiffness[0]
    inertia = system.mechanism.mass_matrix(jnp.zeros(1))[0, 0]
    omega = float(jnp.sqrt(k / inertia))

    def viscous(r):
        c = jnp.atleast_1d(r * jnp.sqrt(k * inertia))
        return sim.UserTorque(_Viscous(k * system.hinges.target, c))

    kvaerno5_traces = []
    step = diffrax.Kvaerno5.step
    monkeypatch.setattr(
        diffrax.Kvaerno5, "step", lambda *a, **kw: kvaerno5_traces.append(1) or step(*a, **kw)
    )
    single = _simulate._solve_jit._cached._cache_size()

    def implicit_programs():  # compiled in memory with `SOLVE_COMPILE`, or by `jit` where unvouched
        return solve_programs("solve_from_switch", _simulate._solve_from_switch_jit)

    implicit = implicit_programs()
    run = lambda r: sim.simulate(
        system, viscous(r), sim.SolveOptions(saveat=sim.SaveAt(n=201)), t1=100 / omega
    )  # noqa: E731

    mild = run(0.3)
    assert np.isinf(mild.stats["switch_time"]) and mild.succeeded
    assert kvaerno5_traces == []  # no implicit step was even traced
    assert implicit_programs() == implicit
    assert _simulate._solve_jit._cached._cache_size() == single

    stiff = run(30.0)
    assert 0.0 < float(stiff.stats["switch_time"]) < 100 / omega and stiff.succeeded
    assert kvaerno5_traces and implicit_programs() == implicit + 1
    # The same run as one program (under jit nothing is split): the second program restarts from
    # the first one's solver state, controller state and next step, so the steps are the same and
    # the samples agree to rounding (1e-12 rad; they were bitwise equal when measured).
    whole = jax.jit(
        lambda s, u: sim.simulate(s, u, sim.SolveOptions(saveat=sim.SaveAt(n=201)), t1=100 / omega)
    )(system, viscous(30.0))
    for key in ("num_steps", "num_accepted_steps", "num_rejected_steps", "switch_time"):
        assert stiff.stats[key] == whole.stats[key], key
    for field in ("times", "theta", "theta_dot", "theta_ddot", "tau"):
        np.testing.assert_allclose(getattr(stiff, field), getattr(whole, field), rtol=0, atol=1e-12)
    # Independent of the solver: overdamped, the slow mode relaxes as θ* (1 − e^{−k t / c}) (the
    # air drag, quadratic in θ̇, is negligible at these rates); at the end, 100/ω = 3.3 c/k,
    # θ is within 5 % of θ* and on that curve to a few % of θ*.
    target = float(system.hinges.target[0])
    slow = target * (1 - np.exp(-float(stiff.times[-1]) * omega / 30.0))
    assert abs(float(stiff.theta[-1, 0]) - slow) < 0.03 * abs(target)


# Compiles the reverse-mode gradient of two whole simulations (30-60 s on 2 cores); the default run
# keeps the top-level test above, which checks the same split without the gradient.
@pytest.mark.slow
def test_differentiated_simulate_compiles_the_explicit_phase_only(monkeypatch):
    # The system of the test above. Differentiated with the default solver, simulate takes the
    # explicit phase only: for the mild run (r = 0.3) the value and derivative are those of Tsit5
    # under the default solver's controller (the same steps: the switching solver's explicit step
    # is Tsit5's), to rounding; the stiff run (r = 30) ends with a result code that says how to
    # differentiate both phases, and raises it with `throw`.
    system = accordion_system(HingeDesign.literature(), 1)
    k = system.hinges.stiffness[0]
    inertia = system.mechanism.mass_matrix(jnp.zeros(1))[0, 0]
    omega = float(jnp.sqrt(k / inertia))
    t1 = 100 / omega

    def metric(r, solver=None, controller=None, throw=False):
        c = jnp.atleast_1d(r * jnp.sqrt(k * inertia))
        torque = sim.UserTorque(_Viscous(k * system.hinges.target, c))
        trajectory = sim.simulate(
            system,
            torque,
            sim.SolveOptions(
                saveat=sim.SaveAt(n=65), solver=solver, stepsize_controller=controller, throw=throw
            ),
            t1=t1,
        )
        return jnp.mean(trajectory.theta**2), trajectory.result

    kvaerno5_traces = []
    step = diffrax.Kvaerno5.step
    monkeypatch.setattr(
        diffrax.Kvaerno5, "step", lambda *a, **kw: kvaerno5_traces.append(1) or step(*a, **kw)
    )
    ours = jax.jit(jax.value_and_grad(metric, has_aux=True))
    (value, result), derivative = ours(0.3)
    assert kvaerno5_traces == []  # the implicit phase was not even traced
    assert result == sim.RESULTS.successful
    controller = sim.default_controller(sim.DEFAULT_RTOL, sim.DEFAULT_ATOL, sim.default_solver())
    tsit5 = jax.jit(
        jax.value_and_grad(
            lambda r: metric(r, diffrax.Tsit5(), controller)[0],
        )
    )
    reference_value, reference_derivative = tsit5(0.3)
    np.testing.assert_allclose(value, reference_value, rtol=1e-12)
    np.testing.assert_allclose(derivative, reference_derivative, rtol=1e-9)
    assert abs(float(derivative)) > 0

    (_, result), derivative = ours(30.0)  # a value: the same program
    assert result == sim.RESULTS.stiff_while_differentiated
    with pytest.raises(Exception, match="StiffnessSwitching"):
        jax.grad(lambda r: metric(r, throw=True)[0])(30.0)
