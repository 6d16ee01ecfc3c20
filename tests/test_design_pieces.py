"""Design building blocks without the simulation: bounded reparametrisation, targets, the multi-start
least-squares driver on a closed-form residual, the identifiability verdict."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

import origami_jax.design as ojd
from origami_jax.chain import Accordion
from origami_jax.system import HingeDesign

NAN = math.nan


@pytest.fixture(scope="module")
def hinge():
    return HingeDesign.literature()


def test_space_round_trip_and_bounds(hinge):
    space = ojd.parameter_space(
        hinge,
        ["k_scale", "hinge_width", "hinge.poisson_ratio"],
        {"k_scale": (0.1, 100.0), "hinge.poisson_ratio": (0.0, 0.4)},
    )
    assert space.log == (True, True, False)
    start = space.read(hinge)
    np.testing.assert_allclose(space.to_physical(space.to_unconstrained(start)), start, rtol=1e-12)
    # Any z, however large, maps strictly inside the bounds: no clipping, no escape.
    for z in (jnp.full(3, -30.0), jnp.full(3, 30.0), jnp.array([3.0, -2.0, 0.5])):
        x = space.to_physical(z)
        assert bool(jnp.all(x >= space.lower)) and bool(jnp.all(x <= space.upper))
    # Gradient of the map is finite and positive (monotone) everywhere.
    z = jnp.array([0.3, -1.0, 2.0])
    grad = jax.jacfwd(space.to_physical)(z)
    assert bool(jnp.all(jnp.diag(grad) > 0))
    # The closed-form Jacobian (what the report uses, on the host) is autodiff's diagonal, to rounding.
    np.testing.assert_allclose(grad, np.diag(np.diag(grad)), atol=0.0)
    for xp in (jnp, np):
        closed_form = space.to_physical_jacobian(np.asarray(z), xp=xp)
        np.testing.assert_allclose(closed_form, np.diag(grad), rtol=1e-13)
    applied = space.apply(hinge, jnp.array([2.0, 150.0, 0.3]))
    assert float(applied.k_scale) == 2.0 and float(applied.hinge.poisson_ratio) == 0.3
    assert float(applied.b_scale) == float(hinge.b_scale)


def test_pattern_geometry_is_a_free_parameter(hinge):
    """The accordion's flap size is the pattern's, not the design's: the space reads its start from
    the pattern, `apply` leaves the design alone and `apply_pattern` sets it in the pattern,
    differentiably: the paper's drag b = C_D ν (L w) L³ / 16 grows as L⁴, so d log b / d log L = 4
    (1e-12: one product's rounding)."""
    pattern = Accordion(3, flap_length=150.0)
    space = ojd.parameter_space(hinge, ["k_scale", "flap_length"], pattern=pattern)
    assert ojd.parameter_unit("flap_length") == "length"
    np.testing.assert_allclose(space.read(hinge, pattern), [1.0, 150.0])
    np.testing.assert_allclose([space.lower[1], space.upper[1]], [1.5, 15000.0])
    assert float(space.apply(hinge, jnp.array([2.0, 120.0])).k_scale) == 2.0
    assert space.apply_pattern(pattern, [2.0, 120.0]) == Accordion(3, flap_length=120.0)

    def log_drag(length):
        fitted = space.apply_pattern(pattern, jnp.stack([jnp.asarray(1.0), length]))
        return jnp.log(fitted(hinge).drag.coefficient[0])

    assert float(jax.grad(log_drag)(jnp.asarray(150.0))) * 150.0 == pytest.approx(4.0, rel=1e-12)
    with pytest.raises(ValueError, match="flap_length is the accordion's flap geometry"):
        ojd.parameter_space(hinge, ["flap_length"])  # no pattern to read it from
    with pytest.raises(ValueError, match="one value for the whole pattern"):
        ojd.parameter_space(hinge, ["flap_length[0]"], pattern=pattern)


def test_space_rejects_bad_input(hinge):
    with pytest.raises(ValueError, match="not a free parameter"):
        ojd.parameter_space(hinge, ["stiffness"])
    with pytest.raises(ValueError, match="outside its bounds"):
        ojd.parameter_space(hinge, ["k_scale"], {"k_scale": (2.0, 3.0)})
    with pytest.raises(ValueError, match="lower < upper"):
        ojd.parameter_space(hinge, ["k_scale"], {"k_scale": (3.0, 0.1)})
    with pytest.raises(ValueError, match="unique"):
        ojd.parameter_space(hinge, ["k_scale", "k_scale"])
    space = ojd.parameter_space(hinge, ["fluid_density"])
    assert space.names == ("fluid.density",)
    # Bounds reaching outside a parameter's physical range: refused before anything is traced (the
    # fit would otherwise try a value HingeDesign refuses).
    with pytest.raises(ValueError, match=r"physical range \(0, inf\)"):
        ojd.parameter_space(hinge, ["hinge_width"], {"hinge_width": (-10.0, 300.0)})
    with pytest.raises(ValueError, match=r"physical range \(-1, 0.5\)"):
        ojd.parameter_space(hinge, ["hinge.poisson_ratio"], {"hinge.poisson_ratio": (0.1, 0.6)})
    # Default bounds stay inside it: a factor 100 around ν = 0.3 would reach 30.
    nu = ojd.parameter_space(hinge, ["hinge.poisson_ratio"])
    assert float(nu.upper[0]) == 0.5 and 0 < float(nu.lower[0]) < float(hinge.hinge.poisson_ratio)


def test_targets_rows_and_validation():
    targets = ojd.Targets(rise_time=[37.0, 101.0, 38.0], overshoot=[0.39, NAN, NAN])
    assert targets.labels == [
        "rise_time[joint 1]",
        "rise_time[joint 2]",
        "rise_time[joint 3]",
        "overshoot[joint 1]",
    ]
    np.testing.assert_allclose(targets.scales(), [37.0, 101.0, 38.0, 0.39])
    assert ojd.time_horizon(targets) == pytest.approx(606.0)
    with pytest.raises(ValueError, match="one value per joint"):
        ojd.Targets(rise_time=[37.0, 101.0], overshoot=[0.39, NAN, NAN])
    with pytest.raises(ValueError, match="positive times"):
        ojd.Targets(rise_time=[-1.0])
    with pytest.raises(ValueError, match="nothing to aim at"):
        ojd.Targets()


def _exponential_fit(z, data):
    t, y = data
    amplitude, rate = z[0], z[1]
    model = amplitude * jnp.exp(-rate * t)
    return model - y, jnp.array([amplitude * rate]), {"model": model}


@pytest.mark.parametrize(
    "solver", [None, optx.GaussNewton(rtol=1e-8, atol=1e-10), optx.BFGS(rtol=1e-8, atol=1e-10)]
)
def test_fit_batch_closed_form(solver):
    t = jnp.linspace(0.0, 3.0, 25)
    data = (t, 2.0 * jnp.exp(-0.7 * t))
    z0s = jnp.array([[1.0, 0.1], [5.0, 2.0], [0.5, 0.5]])
    batch = ojd.fit_batch(_exponential_fit, z0s, data, solver=solver, max_steps=200)
    np.testing.assert_allclose(batch.z, np.tile([2.0, 0.7], (3, 1)), rtol=1e-6)
    assert bool(jnp.all(batch.result._value == ojd.RESULTS.successful._value))
    # The Jacobian handed to the optimiser is the exact one.
    exact = jax.jacfwd(lambda z: _exponential_fit(z, data)[0])(batch.z[0])
    np.testing.assert_allclose(batch.jacobian[0], exact, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(batch.extra[:, 0], 1.4, rtol=1e-6)
    np.testing.assert_allclose(batch.extra_jacobian[0, 0], [0.7, 2.0], rtol=1e-6)


def test_default_solver_stops_on_the_next_step():
    """`GaussNewtonStepStop` (the default): the same answer as optimistix's Levenberg–Marquardt at the
    same tolerances, within them, in one step fewer (optimistix's last step only confirms
    convergence), with a zero residual at the optimum and with a non-zero one (the least-squares
    optimum scipy finds)."""
    from scipy.optimize import least_squares

    t = jnp.linspace(0.0, 3.0, 25)
    noise = 0.05 * jnp.sin(7.0 * t)  # inconsistent data: the optimum keeps a residual
    z0s = jnp.array([[1.0, 0.1], [5.0, 2.0]])
    for y in (2.0 * jnp.exp(-0.7 * t), 2.0 * jnp.exp(-0.7 * t) + noise):
        data = (t, y)
        ours = ojd.fit_batch(_exponential_fit, z0s, data, max_steps=200)
        theirs = ojd.fit_batch(
            _exponential_fit, z0s, data, solver=optx.LevenbergMarquardt(1e-6, 1e-6), max_steps=200
        )
        reference = least_squares(
            lambda z, y=y: np.asarray(_exponential_fit(jnp.asarray(z), (t, y))[0]),
            [1.0, 0.1],
            xtol=1e-14,
            ftol=1e-14,
            gtol=1e-14,
        ).x
        # Tolerances 1e-6 (the default's atol and rtol) on steps of z ~ 1: answers within ~1e-6.
        np.testing.assert_allclose(ours.z, np.tile(reference, (2, 1)), rtol=2e-6)
        np.testing.assert_allclose(theirs.z, np.tile(reference, (2, 1)), rtol=2e-6)
        assert bool(jnp.all(ours.result._value == ojd.RESULTS.successful._value))
        assert bool(jnp.all(ours.num_steps < theirs.num_steps))


def test_fit_batch_reports_nonfinite_start_without_raising():
    def fn(z, _):
        r = jnp.where(z[0] > 10.0, jnp.nan, z - jnp.array([1.0, 2.0]))
        return r, jnp.zeros(0), None

    batch = ojd.fit_batch(fn, jnp.array([[0.0, 0.0], [20.0, 0.0]]), None)
    np.testing.assert_allclose(batch.z[0], [1.0, 2.0], atol=1e-8)
    assert bool(batch.nonfinite[1]) and not bool(batch.nonfinite[0])
    assert batch.best() == 0
    assert int(batch.result._value[1]) == int(ojd.RESULTS.nonfinite_residual._value)


def test_identifiability_finds_width_times_stiffness():
    # Columns for log(hinge_width) and log(k_scale) identical (k ∝ w·k_scale), b_scale independent.
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=6), rng.normal(size=6)
    verdict = ojd.identifiability(
        np.stack([a, a, b], axis=1), ["hinge_width", "k_scale", "b_scale"]
    )
    assert verdict.rank == 2 and not verdict.identifiable
    assert len(verdict.undetermined) == 1
    text = verdict.undetermined[0]
    assert "hinge_width × c^+1" in text and "k_scale × c^-1" in text
    full = ojd.identifiability(np.stack([a, b], axis=1), ["k_scale", "b_scale"])
    assert full.identifiable and "determined" in full.verdict
    weak = ojd.identifiability(np.stack([a, a + 1e-5 * b], axis=1), ["x", "y"])
    assert weak.rank == 2 and weak.weak


@pytest.mark.parametrize("code", ["successful", "max_steps_reached", "nonlinear_divergence"])
def test_result_codes_promote_as_equinox_does_without_device_work(code):
    # `promote` replaces equinox's `RESULTS.promote`, which runs its lookup eagerly even inside a
    # trace; both enumerations that use it: the fits' (optimistix's codes) and the simulations'
    # (diffrax's codes, themselves optimistix's).
    import diffrax

    import origami_jax.simulation as sim
    from origami_jax.simulation._results import promote

    for source, target in ((optx.RESULTS, ojd.RESULTS), (diffrax.RESULTS, sim.RESULTS)):
        item = getattr(source, code)
        expected = target.promote(item)
        constant = promote(item, target)
        assert isinstance(constant._value, np.ndarray)  # a constant stays on the host
        assert constant == expected
        traced = jax.jit(lambda i, t=target: promote(i, t)._value)(item)
        assert int(traced) == int(expected._value)


def test_result_codes_read_the_same_after_a_fetch_to_the_host():
    # A fit's result codes are fetched to the host before the report words them; equinox words a
    # NumPy scalar code as "unknown" (a design that ran out of steps said "Optimiser: unknown").
    from origami_jax._result_codes import message
    from origami_jax.design._report import _message, _take
    from origami_jax.simulation import RESULTS as SIM_RESULTS

    def codes(enumeration):
        def pick(ok):
            return enumeration.where(ok, enumeration.successful, enumeration.max_steps_reached)

        return jax.vmap(pick)(jnp.array([True, False]))

    for batch in (codes(ojd.RESULTS), jax.device_get(codes(ojd.RESULTS))):
        assert _message(_take(batch, 0)) == ""
        assert _message(_take(batch, 1)).startswith("The maximum number of solver steps")
    host = _take(jax.device_get(codes(SIM_RESULTS)), 1)
    assert message(host, SIM_RESULTS) == str(SIM_RESULTS[SIM_RESULTS.max_steps_reached])
    assert "unknown" not in message(host, SIM_RESULTS)


def test_an_optimiser_out_of_steps_with_targets_met_is_not_worded_as_a_failure():
    from origami_jax.design._report import optimiser_warning

    spent = optimiser_warning(
        ojd.RESULTS.max_steps_reached, 32, targets_met=True, tolerance=ojd.DEFAULT_TOLERANCE
    )
    assert "every target met" in spent and "32 steps" in spent and "Try increasing" not in spent
    missed = optimiser_warning(ojd.RESULTS.max_steps_reached, 32, targets_met=False, tolerance=0.01)
    assert "Try increasing `max_steps`" in missed
    other = optimiser_warning(ojd.RESULTS.nonfinite_residual, 3, targets_met=True, tolerance=0.01)
    assert "NaN or infinite" in other
