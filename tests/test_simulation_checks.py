"""`simulate` refuses values that cannot give an answer before anything compiles, and its samples
carry the solver's accuracy.

Argument checks: each bad value used to run the solver to its step budget and end with "max steps"
(or, for a negative end time, integrate backwards and report success). Sample accuracy: a free chain
(no drag, no input, soft springs) conserves `system.energy`, so the energy's drift at the samples
measures the interpolation between steps against the drift at the step ends.
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.chain import accordion_system
from origami_jax.simulation._switching import SwitchingInterpolation
from origami_jax.system import FoldingSystem, HingeDesign, HingeDrag, Hinges


@pytest.fixture(scope="module")
def two_flaps():
    return accordion_system(HingeDesign.literature(), 2)


@pytest.mark.parametrize(
    "kwargs, options, message",
    [
        (dict(t1=-5.0), {}, "t1 must be greater than t0"),
        (dict(t1=0.0), {}, "t1 must be greater than t0"),
        (dict(t1=float("inf")), {}, "t1 must be a finite time"),
        (dict(t1=float("nan")), {}, "t1 must be a finite time"),
        (dict(t1=10.0, t0=float("nan")), {}, "t0 must be a finite time"),
        ({}, dict(rtol=-1.0), r"SolveOptions\(rtol=...\) must be a positive finite tolerance"),
        ({}, dict(rtol=float("nan")), r"SolveOptions\(rtol=...\) must be a positive finite"),
        ({}, dict(atol=0.0), r"SolveOptions\(atol=...\) must be a positive finite tolerance"),
        ({}, dict(dt0=-0.1), r"SolveOptions\(dt0=...\) must be a positive finite first step"),
        ({}, dict(dt0=float("nan")), r"SolveOptions\(dt0=...\) must be a positive finite"),
        ({}, dict(saveat=sim.SaveAt(ts=jnp.array([0.0, 20.0]))), r"SaveAt\(ts=...\) must lie"),
        (
            {},
            dict(saveat=sim.SaveAt(ts=jnp.array([5.0, 1.0]))),
            r"SaveAt\(ts=...\) must be non-dec",
        ),
        (dict(t1=10.0, theta0=jnp.array([jnp.nan, 0.0])), {}, "theta0 contains NaN"),
    ],
)
def test_bad_arguments_are_refused_before_compiling(two_flaps, kwargs, options, message):
    options = (
        sim.SolveOptions(**options) if "t1" in kwargs else sim.SolveOptions(t1=10.0, **options)
    )
    with pytest.raises(ValueError, match=message):
        sim.simulate(two_flaps, sim.Step(), options, **kwargs)


@pytest.mark.parametrize(
    "build, message",
    [
        (lambda: sim.SaveAt(n=1), r"SaveAt\(n=...\) must be an integer of at least 2"),
        (lambda: sim.SaveAt(n=0), r"SaveAt\(n=...\) must be an integer of at least 2"),
        (
            lambda: sim.SolveOptions(max_steps=0),
            r"SolveOptions\(max_steps=...\) must be a positive",
        ),
    ],
)
def test_bad_options_are_refused_when_built(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def test_negative_or_non_finite_system_values_are_refused(two_flaps):
    negative_k = eqx.tree_at(lambda s: s.hinges.stiffness, two_flaps, -two_flaps.hinges.stiffness)
    with pytest.raises(ValueError, match="stiffness must be positive"):
        sim.simulate(negative_k, sim.Step(), t1=10.0)
    negative_b = eqx.tree_at(lambda s: s.drag, two_flaps, HingeDrag(-two_flaps.drag.coefficient))
    with pytest.raises(ValueError, match="drag coefficient must be >= 0"):
        sim.simulate(negative_b, sim.Step(), t1=10.0)
    nan_target = eqx.tree_at(lambda s: s.hinges.target, two_flaps, jnp.array([jnp.nan, 1.0]))
    with pytest.raises(ValueError, match="hinges.target contains NaN"):
        sim.simulate(nan_target, sim.Step(), t1=10.0)


def test_forward_mode_without_its_adjoint_says_which_adjoint_to_pass(two_flaps):
    # The default adjoint is a custom VJP: JAX's own error names neither cause nor fix. Raised
    # while tracing, before anything compiles.
    def metric(scale):
        system = eqx.tree_at(
            lambda s: s.hinges.stiffness, two_flaps, scale * two_flaps.hinges.stiffness
        )
        return sim.simulate(system, sim.Step(), t1=10.0).theta[-1, 0]

    with pytest.raises(TypeError, match=r"SolveOptions\(adjoint=diffrax\.ForwardMode\(\)\)"):
        jax.jacfwd(metric)(1.0)


@pytest.mark.slow
def test_traced_end_time_is_checked_when_the_solve_runs():
    # Under jit the value is unknown while tracing: the same check runs in the compiled solve.
    system = accordion_system(HingeDesign.literature(), 1)

    @eqx.filter_jit
    def final_angle(t1):
        return sim.simulate(
            system,
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(n=2), solver=diffrax.Tsit5()),
            t1=t1,
        ).theta[-1]

    assert np.isfinite(final_angle(jnp.asarray(1.0))).all()
    with pytest.raises(Exception, match="t1 > t0"):
        jax.block_until_ready(final_angle(jnp.asarray(-1.0)))


def test_switching_interpolation_is_tsit5s_on_explicit_steps_and_hermite_on_implicit(getkey):
    y0 = (jax.random.normal(getkey(), (3,)), jax.random.normal(getkey(), (3,)))
    y1 = (jax.random.normal(getkey(), (3,)), jax.random.normal(getkey(), (3,)))
    k = (jax.random.normal(getkey(), (7, 3)), jax.random.normal(getkey(), (7, 3)))
    t0, t1, t = jnp.asarray(0.5), jnp.asarray(0.8), jnp.asarray(0.71)
    span = dict(t0=t0, t1=t1, y0=y0, y1=y1, k=k)
    tsit5 = diffrax.Tsit5.interpolation_cls(**span).evaluate(t)
    hermite = diffrax.ThirdOrderHermitePolynomialInterpolation.from_k(**span).evaluate(t)
    for flag, expected in ((False, tsit5), (True, hermite)):
        got = SwitchingInterpolation(**span, implicit=jnp.asarray(flag)).evaluate(t)
        for a, b in zip(got, expected, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-13)
    # A batch with one explicit and one implicit step (the flag batched under vmap).
    flags = jnp.array([False, True])
    batch = jax.vmap(lambda f: SwitchingInterpolation(**span, implicit=f).evaluate(t))(flags)
    np.testing.assert_allclose(batch[0][0], tsit5[0], rtol=1e-13)
    np.testing.assert_allclose(batch[0][1], hermite[0], rtol=1e-13)


@eqx.filter_jit
def _drifts(system, trajectory, e0):
    """Largest relative energy error at the step ends, at the samples, and at the samples as the
    cubic Hermite interpolant of the same steps would give them."""

    def drift(q, v, mask):
        energy = jax.vmap(system.energy)(q, v)
        return jnp.max(jnp.where(mask, jnp.abs(energy - e0), 0.0)) / e0

    interpolation = trajectory.solution.interpolation
    n_ends = interpolation.ts_size  # step ends, t0 included; the rest of `ts` is padding
    ends = interpolation.ts
    q1, v1 = interpolation.infos["y1"]  # one row per step, then padding
    steps = jnp.arange(q1.shape[0]) < n_ends - 1
    safe = jax.tree.map(lambda x: jnp.where(steps[:, None], x, 0.0), (q1, v1))
    at_steps = drift(*safe, steps)
    samples = jnp.ones(trajectory.times.shape, bool)
    at_samples = drift(trajectory.theta, trajectory.theta_dot, samples)

    index = jnp.clip(jnp.searchsorted(ends, trajectory.times, side="right") - 1, 0, n_ends - 2)
    infos = jax.tree.map(lambda x: x[index], interpolation.infos)

    def hermite(t, t0, t1, info):
        return diffrax.ThirdOrderHermitePolynomialInterpolation.from_k(
            t0=t0, t1=t1, y0=info["y0"], y1=info["y1"], k=info["k"]
        ).evaluate(t)

    q_h, v_h = jax.vmap(hermite)(trajectory.times, ends[index], ends[index + 1], infos)
    return at_steps, at_samples, drift(q_h, v_h, samples)


@pytest.mark.slow
def test_samples_carry_the_solvers_accuracy_on_a_free_chain():
    """Energy of a free flap (no drag, no input, a soft spring): the default solver (explicit here,
    it never turns stiff) drifts by ~1e-10 at its step ends. Its samples used to be cubic Hermite
    interpolants between the steps, far worse; Tsit5's own interpolant keeps them within a small
    factor of the step ends (diffrax's Tsit5 alone shows a factor ~7 on a free chain: its
    interpolant is one order below its steps)."""
    base = accordion_system(HingeDesign.literature(), 1)
    hinges = Hinges(1e-3 * base.hinges.stiffness, base.hinges.target, base.hinges.radius)
    free = FoldingSystem(mechanism=base.mechanism, hinges=hinges, drag=HingeDrag(jnp.zeros(1)))
    no_input = sim.UserTorque(lambda t, theta, theta_dot: jnp.zeros_like(theta))
    v0 = jnp.array([0.02])
    trajectory = sim.simulate(
        free,
        no_input,
        sim.SolveOptions(saveat=sim.SaveAt(n=801, dense=True)),
        t1=400.0,
        theta_dot0=v0,
    )
    assert trajectory.succeeded and trajectory.stats["switch_time"] == jnp.inf
    at_steps, at_samples, with_hermite = (
        float(x) for x in _drifts(free, trajectory, free.energy(jnp.zeros(1), v0))
    )
    assert at_steps < 1e-8
    assert at_samples < 30 * at_steps, (at_samples, at_steps)
    assert with_hermite > 10 * at_samples, (with_hermite, at_samples)
