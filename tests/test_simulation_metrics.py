"""Response metrics: closed-form second-order values, flags, gradients against finite differences."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import brentq

import origami_jax.simulation as sim
from origami_jax.chain import accordion, mass_matrix

from .helpers import make_system
from .simulation_cases import ATOL, N_SAVE, RTOL, literature

# Closed-form second-order values against simulated + root-found metrics (relative).
CLOSED_FORM_RTOL = 1e-6
# Gradients of metrics against central finite differences (relative), stiff regime (KOH bath).
GRADIENT_RTOL = 1e-5


def _second_order(zeta, omega):
    omega_d = omega * np.sqrt(1 - zeta**2)

    def y(t):
        return 1 - np.exp(-zeta * omega * t) * (
            np.cos(omega_d * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(omega_d * t)
        )

    return y, omega_d


def test_linear_single_flap_matches_closed_form():
    # One flap, linear damping c θ̇ instead of quadratic drag: M θ̈ + c θ̇ + k θ = k θ_des.
    chain = accordion(1)
    inertia = float(mass_matrix(chain, jnp.zeros(1))[0, 0])
    k, zeta = 800.0, 0.2
    omega = np.sqrt(k / inertia)
    c = 2 * zeta * np.sqrt(k * inertia)
    target = jnp.array([np.pi])
    inputs = sim.UserTorque(lambda t, th, thd: k * target - c * thd, theta_target=target)
    t1 = 12 * 2 * np.pi / omega
    trajectory = sim.simulate(
        make_system(chain, k, 0.0, target),
        inputs,
        sim.SolveOptions(saveat=sim.SaveAt(n=2001), solver=diffrax.Tsit5(), rtol=1e-11, atol=1e-13),
        t1=t1,
    )
    metrics = sim.response_metrics(trajectory)
    y, omega_d = _second_order(zeta, omega)
    t_peak = np.pi / omega_d
    t10 = brentq(lambda t: y(t) - 0.1, 0, t_peak)
    t90 = brentq(lambda t: y(t) - 0.9, 0, t_peak)
    overshoot = 100 * np.exp(-zeta * np.pi / np.sqrt(1 - zeta**2))
    # Settling: the last exit from the 2 % band, between two extrema of the closed form.
    grid = np.linspace(0, t1, 200_001)
    outside = np.abs(y(grid) - 1) > 0.02
    last = np.nonzero(outside)[0][-1]
    level = 1 + 0.02 * np.sign(y(grid[last]) - 1)
    t_settle = brentq(lambda t: y(t) - level, grid[last], grid[last + 1])
    np.testing.assert_allclose(metrics.rise_time, [t90 - t10], rtol=CLOSED_FORM_RTOL)
    np.testing.assert_allclose(metrics.overshoot, [overshoot], rtol=CLOSED_FORM_RTOL)
    np.testing.assert_allclose(metrics.peak_time, [t_peak], rtol=CLOSED_FORM_RTOL)
    np.testing.assert_allclose(metrics.settling_time, [t_settle], rtol=CLOSED_FORM_RTOL)
    assert bool(metrics.settled[0]) and not bool(metrics.settling_ill_posed[0])
    assert not bool(metrics.rise_ill_conditioned[0])


def _synthetic(y_fn, t1=10.0, n=4001, target=2.0):
    """A Trajectory from an analytic normalised response (tests of the metric definitions alone)."""
    times = jnp.linspace(0.0, t1, n)
    y = jax.vmap(y_fn)(times)
    v = jax.vmap(jax.grad(y_fn))(times)
    a = jax.vmap(jax.grad(jax.grad(y_fn)))(times)
    zeros = jnp.zeros((n, 1))
    return sim.Trajectory(
        times=times,
        theta=target * y[:, None],
        theta_dot=target * v[:, None],
        theta_ddot=target * a[:, None],
        tau=zeros,
        target=jnp.array([target]),
        stats={},
        result=sim.RESULTS.successful,
    )


def test_a_zero_target_is_refused_before_compiling_and_checked_when_traced():
    """Known targets are checked in Python, a `ValueError` (so the compiled metrics hold no
    callback and can be cached between processes); traced ones (under `jit`) by the compiled
    program, equinox's runtime error."""
    trajectory = _synthetic(lambda t: 1 - jnp.exp(-t), n=11, target=0.0)
    with pytest.raises(ValueError, match="a joint's target is 0"):
        sim.response_metrics(trajectory)
    with pytest.raises(eqx.EquinoxRuntimeError, match="a joint's target is 0"):
        eqx.filter_jit(sim.response_metrics)(trajectory)


def test_grazing_peak_flags_the_rise_time():
    # An early bump peaking at 0.895 (just below 90 %), then the real rise: the first-crossing rise time
    # would jump by ~3 time units if the bump grew by 0.5 %.
    def y(t, height):
        bump = height * jnp.exp(-((t - 2.0) ** 2) / 0.3)
        rise = 1 - jnp.exp(-(jnp.maximum(t - 4.0, 0.0) ** 2))
        return jnp.where(t < 3.0, bump, jnp.maximum(bump, rise))

    grazing = sim.response_metrics(_synthetic(lambda t: y(t, 0.895)))
    clear = sim.response_metrics(_synthetic(lambda t: y(t, 0.6)))
    assert bool(grazing.rise_ill_conditioned[0]) and bool(grazing.t90_ill_conditioned[0])
    assert not bool(clear.rise_ill_conditioned[0]) and not bool(clear.t90_ill_conditioned[0])
    # A bump grazing the 10 % level moves t10 (so the rise time) but not t90: only the rise time
    # is flagged, and a design aiming at t90 is not warned about it.
    low_graze = sim.response_metrics(_synthetic(lambda t: y(t, 0.095)))
    assert bool(low_graze.rise_ill_conditioned[0]) and not bool(low_graze.t90_ill_conditioned[0])


def test_settling_flagged_when_not_settled():
    slow = sim.response_metrics(_synthetic(lambda t: 1 - jnp.exp(-0.2 * t)))
    fast = sim.response_metrics(_synthetic(lambda t: 1 - jnp.exp(-3.0 * t)))
    assert not bool(slow.settled[0]) and bool(slow.settling_ill_posed[0])
    assert bool(fast.settled[0]) and not bool(fast.settling_ill_posed[0])
    np.testing.assert_allclose(fast.settling_time, [np.log(50) / 3.0], rtol=1e-7)


def test_metric_gradients_on_closed_forms():
    # The metric definitions alone (no ODE solve, so cheap): crossing, peak and settling times of
    # analytic responses differentiated through the Hermite root finding against closed-form derivatives.
    def first_order(a):
        return sim.response_metrics(_synthetic(lambda t: 1 - jnp.exp(-a * t), n=2001)).rise_time[0]

    a = 1.3
    np.testing.assert_allclose(jax.grad(first_order)(a), -np.log(9.0) / a**2, rtol=1e-7)

    def second_order(zeta):
        omega_d = jnp.sqrt(1 - zeta**2)

        def y(t):
            return 1 - jnp.exp(-zeta * t) * (
                jnp.cos(omega_d * t) + zeta / omega_d * jnp.sin(omega_d * t)
            )

        m = sim.response_metrics(_synthetic(y, t1=40.0, n=2001))
        return jnp.stack([m.overshoot[0], m.peak_time[0], m.settling_time[0]])

    zeta = 0.3
    jac = jax.jacrev(second_order)(zeta)
    exact_overshoot = jax.grad(lambda z: 100 * jnp.exp(-z * jnp.pi / jnp.sqrt(1 - z**2)))(zeta)
    exact_peak = jax.grad(lambda z: jnp.pi / jnp.sqrt(1 - z**2))(zeta)
    np.testing.assert_allclose(jac[:2], [exact_overshoot, exact_peak], rtol=1e-6)
    assert np.isfinite(jac[2]) and jac[2] < 0  # more damping settles sooner (ζ = 0.3)


@pytest.mark.slow
def test_metric_gradients_match_finite_differences_in_koh():
    # KOH bath: drag ~1000× air, overdamped and stiff. Default solver (differentiated, its explicit
    # phase: the KOH step does not turn stiff at these tolerances), forward mode. Marked
    # slow: compiling the forward-mode Kvaerno5 solve takes ~1-5 min on a shared 2-core machine.
    design, system = literature("koh")

    def metrics(log_scales, adjoint=None):
        scaled = eqx.tree_at(
            lambda s: (s.hinges.stiffness, s.drag.coefficient),
            system,
            (
                system.hinges.stiffness * jnp.exp(log_scales[0]),
                system.drag.coefficient * jnp.exp(log_scales[1]),
            ),
        )
        trajectory = sim.simulate(
            scaled,
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(n=N_SAVE), rtol=RTOL, atol=ATOL, adjoint=adjoint),
            t1=1500.0,
        )
        m = sim.response_metrics(trajectory)
        return jnp.stack([m.rise_time[0], m.t90[1], m.settling_time[2], m.peak_value[0]])

    x = jnp.zeros(2)
    jac = jax.jacfwd(lambda x: metrics(x, diffrax.ForwardMode()))(x)
    # The finite differences reuse the compiled solve of the other accordion tests.
    eps = 1e-5
    fd = jnp.stack(
        [(metrics(x + eps * e) - metrics(x - eps * e)) / (2 * eps) for e in jnp.eye(2)], axis=1
    )
    # Times are O(100 µs); the peak value's derivative is O(1e-2) and its finite difference carries the
    # solver's ~1e-9 noise divided by 2·eps, hence the absolute floor.
    np.testing.assert_allclose(jac, fd, rtol=GRADIENT_RTOL, atol=2e-5)
    # Physics sanity: stiffer hinges rise faster, more drag rises slower.
    assert jac[0, 0] < 0 < jac[0, 1]


@pytest.mark.slow
def test_metric_gradients_reverse_mode_in_koh():
    design, system = literature("koh")

    def rise(log_scales):
        scaled = eqx.tree_at(
            lambda s: (s.hinges.stiffness, s.drag.coefficient),
            system,
            (
                system.hinges.stiffness * jnp.exp(log_scales[0]),
                system.drag.coefficient * jnp.exp(log_scales[1]),
            ),
        )
        trajectory = sim.simulate(
            scaled,
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(n=N_SAVE), rtol=RTOL, atol=ATOL),
            t1=1500.0,
        )
        return jnp.sum(sim.response_metrics(trajectory).rise_time)

    x = jnp.zeros(2)
    grad = jax.jit(jax.grad(rise))(x)
    eps = 1e-5
    f = jax.jit(rise)
    fd = jnp.array([(f(x + eps * e) - f(x - eps * e)) / (2 * eps) for e in jnp.eye(2)])
    np.testing.assert_allclose(grad, fd, rtol=GRADIENT_RTOL)


def test_t90_target_is_the_time_to_ninety_percent_in_closed_form():
    # y = 1 − e^{−at} reaches 90 % at ln(10)/a: the design's `t90` target reads that metric, and
    # its residual vanishes there.
    import origami_jax.design as ojd
    from origami_jax.design._targets import achieved_values, residual

    rate = 1.7
    trajectory = _synthetic(lambda t: 1 - jnp.exp(-rate * t))
    metrics = sim.response_metrics(trajectory)
    exact = np.log(10.0) / rate
    targets = ojd.Targets(t90=[exact])
    assert targets.labels == ["t90[joint 1]"] and ojd.time_horizon(targets) == 3 * exact
    np.testing.assert_allclose(achieved_values(targets, metrics), [exact], rtol=1e-9)
    np.testing.assert_allclose(residual(targets, metrics, trajectory), [0.0], atol=1e-9)
    with pytest.raises(ValueError, match="positive times"):
        ojd.Targets(t90=[0.0])
