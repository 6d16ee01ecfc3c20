"""Agitation (Langevin forcing): fluctuation–dissipation checked by equipartition, reproducible
seeds, refusals.

The check is independent of the implementation: a harmonic hinge ``k`` with inertia ``I`` in a bath
at temperature ``T`` settles into the Boltzmann distribution, so ``⟨k θ²⟩ = ⟨I θ̇²⟩ = k_B T``
(equipartition; both follow from the noise's covariance ``2 k_B T c`` only if it balances the
damping ``c``, and they test the noise amplitude and the mass matrix's part separately).
"""

import dataclasses

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.linalg import solve_discrete_lyapunov

from origami_jax.chain import accordion_system
from origami_jax.fluid import ViscousDrag
from origami_jax.simulation import (
    ImplicitStep,
    SaveAt,
    SolveOptions,
    Step,
    StiffnessSwitching,
    simulate,
)
from origami_jax.system import BOLTZMANN, MICRO, Agitation, HingeDesign

N_SEEDS = 32
N_SAVE = 201
BURN_IN = 20  # samples (20 natural periods / 2π): the start at θ = 0 is forgotten by then


@pytest.fixture(scope="module")
def hinge():
    """One flap on a harmonic hinge with viscous damping at damping ratio 0.5, and the ``(k, I,
    ω₀)`` of its closed form."""
    system = accordion_system(HingeDesign.literature(), n_flaps=1)
    k = float(system.hinges.stiffness[0])
    q0, _ = system.mechanism.rest_state()
    inertia = float(system.mechanism.mass_matrix(q0)[0, 0])
    omega = np.sqrt(k / inertia)
    damping = np.zeros((1, 6, 6))
    damping[0, 3:, 3:] = 2 * 0.5 * np.sqrt(k * inertia) * np.eye(3)
    return dataclasses.replace(system, drag=ViscousDrag(damping)), k, inertia, omega


@pytest.fixture(scope="module")
def thermal_runs(hinge):
    """`N_SEEDS` realisations at an effective temperature with ``k_B T = 0.0025 k`` (θ_rms 0.05 rad),
    each 200/ω₀ long, sampled every 1/ω₀; fixed steps of 0.05/ω₀ (Heun)."""
    system, k, _, omega = hinge
    kt = 0.0025 * k
    temperature = kt / MICRO.from_si(BOLTZMANN, length=2, time=-2, mass=1)

    def run(key):
        agitated = dataclasses.replace(system, agitation=Agitation(temperature, key))
        trajectory = simulate(
            agitated,
            Step(jnp.zeros(1)),
            SolveOptions(
                saveat=SaveAt(n=N_SAVE),
                stepsize_controller=diffrax.ConstantStepSize(),
                dt0=0.05 / omega,
                max_steps=5000,
                throw=False,
            ),
            t1=200 / omega,
        )
        return trajectory.theta[:, 0], trajectory.theta_dot[:, 0], trajectory.result._value

    keys = jax.random.split(jax.random.PRNGKey(0), N_SEEDS)
    theta, rate, result = jax.jit(jax.vmap(run))(keys)
    return np.asarray(theta), np.asarray(rate), np.asarray(result), kt, keys, run


def test_equipartition(hinge, thermal_runs):
    """``⟨k θ²⟩`` and ``⟨I θ̇²⟩`` equal ``k_B T`` within four standard errors of the mean over the
    realisations (each realisation's time average is one independent sample; 32 of them put the
    standard error at ~3 %, and the fixed step's bias, O((ω₀ dt)²) = 0.25 %, is far below it)."""
    _, k, inertia, _ = hinge
    theta, rate, result, kt, _, _ = thermal_runs
    assert np.all(result == 0)
    for values, stiffness in ((theta, k), (rate, inertia)):
        per_run = stiffness * np.mean(values[:, BURN_IN:] ** 2, axis=1) / kt
        mean = per_run.mean()
        error = per_run.std(ddof=1) / np.sqrt(len(per_run))
        assert abs(mean - 1) < max(4 * error, 0.02), (mean, error)
        assert error < 0.08


def _implicit_euler_variances(k, inertia, damping, kt, h):
    """The stationary ``(⟨k θ²⟩, ⟨I θ̇²⟩) / k_B T`` of the fixed-step engine's scheme on a harmonic
    hinge, in closed form: ``(I + h c + h² k) v' = I v − h k θ + √(2 k_B T c h) ξ``, ``θ' = θ + h
    v'`` is the linear map ``x' = A x + B ξ`` of ``x = (θ, v)``, whose stationary covariance solves
    the discrete Lyapunov equation ``P = A P Aᵀ + B Bᵀ``."""
    d = inertia + h * damping + h * h * k
    a = np.array([[1 - h * h * k / d, h * inertia / d], [-h * k / d, inertia / d]])
    sigma = np.sqrt(2 * kt * damping * h)
    b = np.array([[h * sigma / d], [sigma / d]])
    p = solve_discrete_lyapunov(a, b @ b.T)
    return k * p[0, 0] / kt, inertia * p[1, 1] / kt


def test_the_fixed_step_engine_samples_its_own_stationary_distribution(hinge):
    """`ImplicitStep` on the agitated hinge: ``⟨k θ²⟩`` and ``⟨I θ̇²⟩`` over 32 realisations equal
    the closed form of its discrete scheme (`_implicit_euler_variances`) within four standard
    errors; that closed form tends to ``k_B T`` as the step shrinks (implicit Euler's numerical
    damping takes a first-order share: 0.91 and 0.86 of it at ``ω₀ h = 0.1``, 0.99 at 0.01)."""
    system, k, inertia, omega = hinge
    damping = 2 * 0.5 * np.sqrt(k * inertia)
    kt = 0.0025 * k
    temperature = kt / MICRO.from_si(BOLTZMANN, length=2, time=-2, mass=1)
    h = 0.1 / omega

    def run(key):
        agitated = dataclasses.replace(system, agitation=Agitation(temperature, key))
        trajectory = simulate(
            agitated,
            Step(jnp.zeros(1)),
            SolveOptions(saveat=SaveAt(n=N_SAVE), solver=ImplicitStep(dt=float(h)), throw=False),
            t1=200 / omega,
        )
        return trajectory.theta[:, 0], trajectory.theta_dot[:, 0], trajectory.result._value

    keys = jax.random.split(jax.random.PRNGKey(1), N_SEEDS)
    theta, rate, result = (np.asarray(x) for x in jax.jit(jax.vmap(run))(keys))
    assert np.all(result == 0)
    expected = _implicit_euler_variances(k, inertia, damping, kt, h)
    for values, stiffness, closed in ((theta, k, expected[0]), (rate, inertia, expected[1])):
        per_run = stiffness * np.mean(values[:, BURN_IN:] ** 2, axis=1) / kt
        error = per_run.std(ddof=1) / np.sqrt(len(per_run))
        assert abs(per_run.mean() - closed) < 4 * error, (per_run.mean(), closed, error)
        assert error < 0.05
    assert expected[0] == pytest.approx(0.911, abs=0.005)
    fine = _implicit_euler_variances(k, inertia, damping, kt, 0.01 / omega)
    assert fine == pytest.approx((1.0, 1.0), abs=0.015)
    # The same key gives the same path alone as in the batch.
    alone = np.asarray(jax.jit(run)(keys[5])[0])
    np.testing.assert_allclose(alone, theta[5], rtol=1e-9, atol=1e-12)


@pytest.mark.slow  # a reverse-mode program of the engine of its own
def test_the_fixed_step_engines_gradient_in_the_temperature(hinge):
    """The derivative of the agitated hinge's end angle in the temperature through `ImplicitStep`
    (the same noise path: its key fixed) against central differences (relative steps 1e-4: the
    angle is ``√T`` times a fixed path, smooth; 1e-6 relative), and finite at 0 K."""
    system, k, _, omega = hinge
    kelvin_per_k = 1 / MICRO.from_si(BOLTZMANN, length=2, time=-2, mass=1)

    def end_angle(temperature):
        agitated = dataclasses.replace(system, agitation=Agitation(temperature, 7))
        trajectory = simulate(
            agitated,
            Step(jnp.zeros(1)),
            SolveOptions(
                saveat=SaveAt(n=3), solver=ImplicitStep(dt=float(0.1 / omega)), throw=False
            ),
            t1=20 / omega,
        )
        return trajectory.theta[-1, 0]

    value_and_grad = jax.jit(jax.value_and_grad(end_angle))
    temperature = 0.0025 * k * kelvin_per_k
    value, grad = value_and_grad(temperature)
    step = 1e-4 * temperature
    central = (end_angle(temperature + step) - end_angle(temperature - step)) / (2 * step)
    assert abs(float(value)) > 0
    assert float(grad) == pytest.approx(float(central), rel=1e-6)
    assert float(grad) == pytest.approx(float(value) / (2 * temperature), rel=1e-6)  # ∝ √T
    cold_value, cold_grad = value_and_grad(0.0)
    assert float(cold_value) == 0 and np.isfinite(float(cold_grad))


def test_seeds_reproducible_and_independent(thermal_runs):
    """The same seed gives the same path (run alone instead of in the batch); different seeds give
    different paths, uncorrelated at the end."""
    theta, _, _, _, keys, run = thermal_runs
    alone, _, _ = jax.jit(run)(keys[3])
    np.testing.assert_allclose(np.asarray(alone), theta[3], rtol=1e-9, atol=1e-12)
    assert not np.allclose(theta[0], theta[1])
    end = theta[:, -1]
    assert abs(np.corrcoef(end[:-1], end[1:])[0, 1]) < 0.6


def test_zero_temperature_is_deterministic(hinge):
    """At 0 K the random force vanishes: the hinge held at θ = 0 stays there exactly."""
    system, _, _, omega = hinge
    cold = dataclasses.replace(system, agitation=Agitation(0.0, 5))
    trajectory = simulate(
        cold,
        Step(jnp.zeros(1)),
        SolveOptions(
            saveat=SaveAt(n=3), stepsize_controller=diffrax.ConstantStepSize(), dt0=0.5 / omega
        ),
        t1=5 / omega,
    )
    assert np.all(np.asarray(trajectory.theta) == 0)


def test_thermal_energy_closed_form():
    """``k_B T`` at 300 K is 4.14 zJ = 4.14e-9 pJ (MICRO's energy unit, µN·µm)."""
    value = float(Agitation(300.0).thermal_energy(MICRO))
    assert value == pytest.approx(300 * 1.380649e-23 / 1e-12, rel=1e-12)


def test_refusals(hinge):
    """One-line errors before compiling: the paper's drag has no viscous part to balance noise; the
    stiffness-switching solver and the fixed steps' BDF2 scheme take no random force; bad
    temperatures and seeds."""
    system, _, _, _ = hinge
    paper = accordion_system(HingeDesign.literature(), n_flaps=1)
    with pytest.raises(ValueError, match="linear \\(viscous\\) part"):
        simulate(dataclasses.replace(paper, agitation=Agitation(300.0)), Step(), t1=1.0)
    agitated = dataclasses.replace(system, agitation=Agitation(300.0))
    with pytest.raises(ValueError, match="stochastic equations"):
        simulate(agitated, Step(), SolveOptions(solver=StiffnessSwitching()), t1=1.0)
    bdf2 = ImplicitStep(dt=0.1, scheme="bdf2")
    with pytest.raises(ValueError, match="takes ImplicitStep's Euler scheme"):
        simulate(agitated, Step(), SolveOptions(solver=bdf2), t1=1.0)
    for bad in (-1.0, float("nan"), [1.0, 2.0]):
        with pytest.raises(ValueError, match="temperature"):
            Agitation(bad)
    with pytest.raises(ValueError, match="seed"):
        Agitation(300.0, seed=True)
    with pytest.raises(ValueError, match="agitation must be"):
        dataclasses.replace(system, agitation=300.0)


@pytest.mark.slow  # 32 agitated folds of 4200 fixed steps each
def test_a_closed_loop_in_the_bath_shares_k_t_with_its_one_degree_of_freedom():
    """A degree-4 vertex (one degree of freedom under its loop's closure) agitated in the etch
    bath at its folded equilibrium: the hinges' potential energy ``⟨Σ k_j δθ_j²⟩`` is ``k_B T``
    (equipartition of the single mode, whatever its direction), as the discrete scheme's closed
    form gives it for the mode's stiffness, inertia and damping (`_implicit_euler_variances`:
    0.83 ``k_B T`` at ``ω₀ h = 0.05``, the mode being lightly damped, ζ = 0.12, so the scheme's
    numerical damping takes a large share), within four standard errors over 32 realisations; the
    loop stays closed. Measured at ``ω₀ h = 0.005``: 0.996 ± 0.037 against the scheme's 0.979,
    closure 4e-9 rad."""
    from origami_jax.loops import load_pattern
    from origami_jax.system import KOH_SOLUTION
    from origami_jax.system._agitation import viscous_damping

    pattern = load_pattern("vertex_degree4").with_model(contact=False)
    system = pattern.system(HingeDesign.literature(fluid=KOH_SOLUTION))
    mechanism = system.mechanism
    rest = jnp.asarray(pattern.intended_angles)
    mode = np.linalg.svd(np.asarray(mechanism.closure_jacobian(rest)))[2][-1]
    k = np.asarray(system.hinges.stiffness)
    stiffness = mode @ (k * mode)
    inertia = mode @ np.asarray(mechanism.mass_matrix(rest)) @ mode
    damping = mode @ np.asarray(viscous_damping(mechanism, system.drag, rest)) @ mode
    omega = float(np.sqrt(stiffness / inertia))
    kt = 0.0025 * stiffness
    temperature = kt / MICRO.from_si(BOLTZMANN, length=2, time=-2, mass=1)
    h = 0.05 / omega
    fixed = SolveOptions(saveat=SaveAt(n=N_SAVE), solver=ImplicitStep(dt=h), throw=False)

    def run(key):
        agitated = dataclasses.replace(system, agitation=Agitation(temperature, key))
        trajectory = simulate(agitated, Step(), fixed, t1=210 / omega, theta0=rest)
        return trajectory.theta, trajectory.result._value

    keys = jax.random.split(jax.random.PRNGKey(2), N_SEEDS)
    theta, result = jax.jit(jax.vmap(run))(keys)
    assert np.all(np.asarray(result) == 0)
    closure = jax.vmap(jax.vmap(mechanism.closure))(theta)
    assert float(jnp.max(jnp.abs(closure))) < 1e-6
    departure = np.asarray(theta)[:, BURN_IN:] - np.asarray(rest)
    per_run = np.mean(np.sum(k * departure**2, axis=-1), axis=1) / kt
    error = per_run.std(ddof=1) / np.sqrt(len(per_run))
    expected = _implicit_euler_variances(stiffness, inertia, damping, kt, h)[0]
    assert abs(per_run.mean() - expected) < 4 * error, (per_run.mean(), expected, error)
    assert error < 0.08
