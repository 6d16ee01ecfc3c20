"""Inputs: step torque, etch ramp computed torque, fast ramp tracking, user torque, the slow ramp."""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.chain import accordion_system, alternating_targets
from origami_jax.system import MICRO

from .helpers import make_system
from .simulation_cases import literature


def test_alternating_targets():
    np.testing.assert_allclose(alternating_targets(3), [np.pi, -np.pi, np.pi])
    np.testing.assert_allclose(alternating_targets(2, 1.5), [1.5, -1.5])
    with pytest.raises(ValueError):
        alternating_targets(0)


def test_step_torque_is_k_theta_des():
    _, system = literature()
    k = system.hinges.stiffness
    tau = sim.Step().torque(1.0, jnp.zeros(3), jnp.zeros(3), system)
    np.testing.assert_allclose(tau, k * alternating_targets(3))
    explicit = sim.Step(jnp.array([1.0, 2.0, 3.0]))
    np.testing.assert_allclose(
        explicit.torque(1.0, jnp.zeros(3), jnp.zeros(3), system), k * jnp.array([1.0, 2.0, 3.0])
    )
    assert sim.Step().jump_times(system) is None
    # A ValueError without run-time type checking; jaxtyping's TypeError (a TypeCheckError) with it.
    with pytest.raises((ValueError, TypeError)):
        sim.Step(jnp.zeros((3, 2)))


def _staged():
    """The literature accordion and the same with its hinges released at 0, 50 and 100 µs."""
    _, system = literature()
    release = jnp.array([0.0, 50.0, 100.0])
    staged = make_system(
        system.mechanism,
        system.hinges.stiffness,
        system.drag.coefficient,
        system.hinges.target,
        release_time=release,
    )
    return system, staged, release


def test_step_with_release_times():
    # Hinges released one after the other: no torque before a hinge's release, K θ_target after it.
    system, staged, release = _staged()
    step = sim.Step()
    k, target = staged.hinges.stiffness, staged.hinges.target
    np.testing.assert_allclose(
        step.torque(60.0, jnp.zeros(3), jnp.zeros(3), staged), k * target * jnp.array([1, 1, 0])
    )
    np.testing.assert_allclose(step.jump_times(staged), release)


def test_etch_ramp_desired_trajectory_solves_the_dynamics():
    _, system = literature()
    beta = MICRO.length(sim.KOH_ETCH_RATE_SI) / MICRO.time(1.0)
    ramp = sim.EtchRamp(beta)
    # T = l / β ≈ 2.7 h for ρ ≈ 78 µm (paper, "Ramp Input": 2–3 hours).
    duration = ramp.duration(system)
    assert 2.0 < float(duration) * 1e-6 / 3600 < 3.0
    for fraction in (0.1, 0.5, 0.9):
        t = fraction * duration
        theta_des, theta_dot_des = ramp.desired(t, system)
        tau = ramp.torque(t, theta_des, theta_dot_des, system)
        # Computed torque: θ_des is an exact solution between the corners (θ̈_des = 0).
        acc = system.accelerations(theta_des, theta_dot_des, tau)
        np.testing.assert_allclose(acc, 0.0, atol=1e-12)
    theta_end, rate_end = ramp.desired(2 * duration, system)
    np.testing.assert_allclose(theta_end, alternating_targets(3))
    np.testing.assert_allclose(rate_end, 0.0)
    np.testing.assert_allclose(ramp.jump_times(system), ramp.durations(system))


@pytest.mark.slow
def test_fast_ramp_tracks_with_minimal_overshoot():
    # A shortened fast ramp (2 ms instead of the paper's 0.1 s) keeps the test quick; explicit Tsit5
    # suits it in air (not stiff).
    _, system = literature()
    ramp = sim.fast_ramp(alternating_targets(3), duration=2000.0)
    np.testing.assert_allclose(ramp.rate(system), np.pi / 2000.0)
    trajectory = sim.simulate(
        system, ramp, sim.SolveOptions(saveat=sim.SaveAt(n=601), solver=diffrax.Tsit5()), t1=3000.0
    )
    metrics = sim.response_metrics(trajectory)
    desired = jax.vmap(lambda t: ramp.desired(t, system)[0])(trajectory.times)
    # The only departure is the ringing launched by the rate jumps (≈ 0.2 rad for this 2 ms ramp, weakly
    # damped by quadratic drag; 4e-3 rad for the paper's 0.1 s one): well-behaved tracking, far below the
    # step's 80 % overshoot.
    assert float(jnp.max(jnp.abs(trajectory.theta - desired))) < 0.1 * np.pi
    assert float(jnp.max(metrics.overshoot)) < 10.0


def test_user_torque_and_shape_checks():
    _, system = literature()
    k = system.hinges.stiffness
    target = alternating_targets(3)
    user = sim.UserTorque(lambda t, th, thd: k * target, theta_target=target)
    np.testing.assert_allclose(user.torque(0.0, jnp.zeros(3), jnp.zeros(3), system), k * target)
    with pytest.raises(ValueError, match="hinges"):
        sim.simulate(system, sim.Step(jnp.ones(2)), t1=1.0)
    with pytest.raises((ValueError, TypeError)):
        sim.simulate(system, lambda t: t, t1=1.0)  # pyright: ignore[reportArgumentType]
    with pytest.raises((ValueError, TypeError), match="FoldingSystem"):
        sim.simulate(system.mechanism, sim.Step(), t1=1.0)  # pyright: ignore[reportArgumentType]


@pytest.mark.slow
def test_slow_ramp_is_affordable_and_validated():
    _, system = literature("koh")
    beta = MICRO.length(sim.KOH_ETCH_RATE_SI) / MICRO.time(1.0)
    result = sim.simulate_slow_ramp(
        system,
        sim.EtchRamp(beta),
        sim.SLOW_RAMP_OPTIONS.replace(saveat=sim.SaveAt(n=201), max_steps=4096),
    )
    assert bool(result.trajectory.succeeded) and bool(result.window.succeeded)
    assert int(result.trajectory.stats["num_steps"]) < 5000
    assert float(jnp.max(result.quasi_static_error)) < 1e-6
    assert float(jnp.max(result.large_step_error)) < 1e-6


def test_step_ramp_torque_grows_linearly_from_each_release():
    system, staged, _ = _staged()
    k, target = staged.hinges.stiffness, staged.hinges.target
    ramp = sim.Step(ramp=40.0)
    zeros = jnp.zeros(3)
    # At t = 70 µs: 70/40 (capped at 1), 20/40 and not yet released.
    np.testing.assert_allclose(
        ramp.torque(70.0, zeros, zeros, staged), k * target * jnp.array([1.0, 0.5, 0.0])
    )
    np.testing.assert_allclose(ramp.jump_times(staged), [0.0, 50.0, 100.0, 40.0, 90.0, 140.0])
    # Without release times every hinge ramps from t = 0.
    np.testing.assert_allclose(
        ramp.torque(10.0, zeros, zeros, system), 0.25 * system.hinges.stiffness * target
    )
    np.testing.assert_allclose(ramp.jump_times(system), [40.0])
    for bad in (0.0, -1.0, float("nan"), [1.0, 2.0]):
        with pytest.raises(ValueError, match="Step.ramp must be a positive finite time"):
            sim.Step(ramp=bad)


def test_step_ramp_matches_the_driven_oscillator():
    # One flap without drag is a linear oscillator I θ̈ + k θ = k θ_t min(t/R, 1), whose response
    # is θ_t (t/R − sin ωt / (ωR)) during the ramp and a swing of amplitude
    # θ_t |2 sin(ωR/2)| / (ωR) about θ_t after it (a step: θ_t, the flap swings to 2 θ_t).
    design, _ = literature()
    flap = accordion_system(design, 1)
    system = make_system(flap.mechanism, flap.hinges.stiffness, 0.0, [1.0])
    k = float(system.hinges.stiffness[0])
    inertia = float(system.mechanism.mass_matrix(jnp.zeros(1))[0, 0])
    omega = np.sqrt(k / inertia)
    period = 2 * np.pi / omega
    ramp_time = 2.3 * period
    t1 = 4 * period
    trajectory = sim.simulate(
        system,
        sim.Step(ramp=ramp_time),
        sim.SolveOptions(saveat=sim.SaveAt(n=201), rtol=1e-10, atol=1e-12, solver=diffrax.Tsit5()),
        t1=t1,
    )
    t = np.asarray(trajectory.times)
    during = t / ramp_time - np.sin(omega * t) / (omega * ramp_time)
    # After the ramp: the free oscillation from the ramp's end state.
    end = 1.0 - np.sin(omega * ramp_time) / (omega * ramp_time)
    end_rate = (1.0 - np.cos(omega * ramp_time)) / ramp_time
    after = (
        1.0
        + (end - 1.0) * np.cos(omega * (t - ramp_time))
        + end_rate / omega * np.sin(omega * (t - ramp_time))
    )
    expected = np.where(t <= ramp_time, during, after)
    # Tolerance: the solve's 1e-10 relative tolerance over four periods.
    np.testing.assert_allclose(np.asarray(trajectory.theta[:, 0]), expected, atol=1e-7)
    # The swing after the ramp, on a dense grid of the (checked) free oscillation: the step's θ_t
    # reduced by the ramp.
    dense = np.linspace(0.0, t1 - ramp_time, 20001)
    free = (end - 1.0) * np.cos(omega * dense) + end_rate / omega * np.sin(omega * dense)
    swing = np.max(np.abs(free))
    np.testing.assert_allclose(
        swing, abs(2 * np.sin(omega * ramp_time / 2)) / (omega * ramp_time), rtol=1e-3
    )
