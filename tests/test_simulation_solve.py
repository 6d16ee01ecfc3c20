"""simulate(): agreement with scipy, unit independence, result codes, jit/vmap, dense output."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import origami_jax.simulation as sim
from origami_jax.chain import accordion
from origami_jax.system import SI

from .helpers import make_system
from .simulation_cases import air_step_metrics, literature, step_simulation

# Max |θ_diffrax − θ_scipy| over the samples, rad: both solvers at rtol 1e-9…1e-11 on the same ODE.
SCIPY_AGREEMENT_RAD = 1e-6
# Relative agreement of metrics computed in SI and in MICRO (µm, µs, ng), float64.
UNITS_AGREEMENT = 1e-6


@pytest.mark.parametrize("solver", ["default", pytest.param("implicit", marks=pytest.mark.slow)])
def test_step_matches_scipy_radau(solver):
    # "default" is StiffnessSwitching (explicit steps throughout in air); "implicit" is Kvaerno5 alone.
    t1 = 200.0
    trajectory = step_simulation(
        "air", t1_us=t1, solver=sim.implicit_solver() if solver == "implicit" else None
    )
    if solver == "default":
        assert np.isinf(trajectory.stats["switch_time"])
    _, system = literature("air")
    chain, k, b = system.mechanism, system.hinges.stiffness, system.drag.coefficient
    tau = k * system.hinges.target

    @jax.jit
    def rhs(y):
        # The paper's Eq. 11 written out here, independently of the system's force assembly.
        theta, theta_dot = y[:3], y[3:]
        acc = jnp.linalg.solve(
            chain.mass_matrix(theta),
            tau
            - k * theta
            - b * theta_dot * jnp.abs(theta_dot)
            - chain.bias_force(theta, theta_dot),
        )
        return jnp.concatenate([theta_dot, acc])

    jac = jax.jit(jax.jacfwd(rhs))
    reference = solve_ivp(
        lambda t, y: np.asarray(rhs(jnp.asarray(y))),
        (0.0, t1),
        np.zeros(6),
        method="Radau",
        t_eval=np.asarray(trajectory.times),
        rtol=1e-10,
        atol=1e-12,
        jac=lambda t, y: np.asarray(jac(jnp.asarray(y))),
    )
    assert reference.success
    error = np.max(np.abs(reference.y[:3].T - np.asarray(trajectory.theta)))
    assert error < SCIPY_AGREEMENT_RAD, error


def test_literature_air_step_metrics():
    # Literature values in air give ≈ 94 / 22 / 23 µs and 80 % overshoot.
    metrics = air_step_metrics()
    np.testing.assert_allclose(metrics.rise_time, [94.0, 22.0, 23.0], rtol=0.05)
    assert 75.0 < float(metrics.overshoot[0]) < 85.0
    assert not np.any(metrics.rise_ill_conditioned)
    # Quadratic-only drag: 2 % settling is not reached within 1.2 ms, and says so.
    assert np.all(metrics.settling_ill_posed)


@pytest.mark.slow  # units are checked on the dynamics by default (test_chain_dynamics.py)
def test_si_and_micro_give_the_same_metrics():
    micro = air_step_metrics()
    si = sim.response_metrics(step_simulation("air", units=SI))
    for name in ("rise_time", "t10", "t90", "peak_time"):
        np.testing.assert_allclose(
            np.asarray(getattr(si, name)) * 1e6, getattr(micro, name), rtol=UNITS_AGREEMENT
        )
    np.testing.assert_allclose(si.overshoot, micro.overshoot, rtol=UNITS_AGREEMENT)
    # Not the final error at 1.2 ms: the 3-flap ringing is sensitive enough to amplify 1e-9 local errors
    # to ~1e-5 rad by then (both unit systems agree with each other to that level, as they should).
    np.testing.assert_allclose(si.final_error, micro.final_error, atol=1e-4)


# --- cheap single-flap cases (Tsit5) for result codes, vmap and dense output -------------------------


def _flap():
    return make_system(accordion(1), 800.0, 2.8e4, jnp.array([np.pi]))


def test_failed_solve_raises_by_default():
    with pytest.raises(eqx.EquinoxRuntimeError, match="maximum number of solver steps"):
        sim.simulate(
            _flap(),
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(n=11), solver=diffrax.Tsit5(), max_steps=8),
            t1=5000.0,
        )


def test_throw_false_under_vmap_reports_failed_members():
    system = _flap()

    def run(t1):
        return sim.simulate(
            system,
            sim.Step(),
            sim.SolveOptions(
                saveat=sim.SaveAt(n=11), solver=diffrax.Tsit5(), max_steps=64, throw=False
            ),
            t1=t1,
        )

    batch = jax.vmap(run)(jnp.array([50.0, 100.0, 1e6]))
    ok = np.asarray(batch.succeeded)
    np.testing.assert_array_equal(ok, [True, True, False])
    # The failed member says why, with a result code; nothing is a silent NaN.
    codes = np.asarray(batch.result._value)
    assert codes[2] == sim.RESULTS.max_steps_reached._value
    assert codes[0] == sim.RESULTS.successful._value
    assert batch.theta.shape == (3, 11, 1)
    assert not np.any(np.isnan(np.asarray(batch.theta)))
    assert np.all(np.isfinite(np.asarray(batch.theta[:2])))


def test_dense_output():
    trajectory = sim.simulate(
        _flap(),
        sim.Step(),
        sim.SolveOptions(
            saveat=sim.SaveAt(n=21, dense=True), solver=diffrax.Tsit5(), rtol=1e-10, atol=1e-12
        ),
        t1=200.0,
    )
    theta_at_sample, theta_dot_at_sample = trajectory.evaluate(trajectory.times[7])
    np.testing.assert_allclose(theta_at_sample, trajectory.theta[7], atol=1e-8)
    np.testing.assert_allclose(theta_dot_at_sample, trajectory.theta_dot[7], atol=1e-8)
    with pytest.raises(ValueError, match="dense"):
        step_simulation("air", t1_us=10.0).evaluate(1.0)


def test_default_controller_per_solver():
    """Explicit Runge–Kutta solvers get diffrax's integral controller (fewer steps for Tsit5 on the
    accordion), everything else the PID controller measured best for Kvaerno5."""
    from origami_jax.simulation import StiffnessSwitching, default_controller

    explicit = default_controller(1e-8, 1e-10, diffrax.Tsit5())
    assert (explicit.pcoeff, explicit.icoeff) == (0, 1)
    for solver in (None, StiffnessSwitching(), diffrax.Kvaerno5()):
        controller = default_controller(1e-8, 1e-10, solver)
        assert (controller.pcoeff, controller.icoeff) == (0.3, 0.3)
        assert (controller.rtol, controller.atol) == (1e-8, 1e-10)
