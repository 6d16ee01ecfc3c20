"""Gradient-safe helpers: values against closed forms, derivatives finite at the singular points."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from origami_jax._math import (
    SIN_COS_REDUCTION_LIMIT,
    geodesic_angle,
    normalise,
    safe_divide,
    safe_norm,
    sin_cos_reduced,
)


def test_safe_norm_value_and_gradient_at_zero():
    assert float(safe_norm(jnp.array([3.0, 4.0]))) == 5.0
    gradient = jax.grad(safe_norm)(jnp.zeros(3))
    assert jnp.all(jnp.isfinite(gradient))
    check_grads(safe_norm, (jnp.array([0.3, -1.2, 2.0]),), order=2, modes=["fwd", "rev"])


def test_normalise_zero_vector_is_finite():
    assert jnp.all(normalise(jnp.zeros(3)) == 0)
    jacobian = jax.jacfwd(normalise)(jnp.zeros(3))
    assert jnp.all(jnp.isfinite(jacobian))
    np.testing.assert_allclose(normalise(jnp.array([0.0, 0.0, 2.0])), [0.0, 0.0, 1.0])


@pytest.mark.parametrize("angle", [1e-9, 1e-4, 0.7, np.pi / 2, np.pi - 1e-4, np.pi - 1e-9])
def test_geodesic_angle_precise_where_arccos_is_not(angle):
    a = jnp.array([1.0, 0.0, 0.0])
    b = jnp.array([np.cos(angle), np.sin(angle), 0.0])
    # atan2 keeps ~1e-16 absolute accuracy at both ends, where arccos(a.b) loses half the digits.
    assert abs(float(geodesic_angle(a, b)) - angle) < 1e-15 + 1e-15 * angle


def test_geodesic_angle_gradient_finite_at_coincident_and_antipodal_points():
    a = jnp.array([0.0, 0.0, 1.0])
    for b in (a, -a):
        gradient = jax.grad(geodesic_angle, argnums=(0, 1))(a, b)
        assert all(jnp.all(jnp.isfinite(g)) for g in gradient)
    check_grads(
        geodesic_angle,
        (jnp.array([0.2, 0.3, 0.9]), jnp.array([-0.5, 0.1, 0.4])),
        order=2,
        modes=["fwd", "rev"],
    )


def test_safe_divide():
    assert float(safe_divide(1.0, 0.0, fill=7.0)) == 7.0
    assert float(safe_divide(1.0, 4.0)) == 0.25
    assert jnp.isfinite(jax.grad(lambda d: safe_divide(1.0, d))(0.0))


def test_sin_cos_reduced_within_two_ulp_of_numpy():
    """The polynomial sin/cos the scalar dynamics use on the CPU: within 2 ulp of NumPy's (libm's,
    correctly rounded to ~0.5 ulp) over small and large angles up to the reduction limit, at the
    quadrant boundaries (multiples of π/4 and π/2, where the reduction cancels most digits), at 0,
    −0 and subnormals. Beyond the limit callers fall back to jnp.sin/cos (dynamics test)."""
    rng = np.random.default_rng(3)
    x = np.concatenate(
        [
            rng.uniform(-10.0, 10.0, 20_000),
            rng.uniform(-SIN_COS_REDUCTION_LIMIT, SIN_COS_REDUCTION_LIMIT, 20_000),
            np.arange(-400, 401) * (np.pi / 4),
            [0.0, -0.0, 5e-324, 1e-300, 1e-8, -1e-8],
        ]
    )
    sine, cosine = (np.asarray(v) for v in jax.jit(sin_cos_reduced)(jnp.asarray(x)))
    for ours, exact in ((sine, np.sin(x)), (cosine, np.cos(x))):
        ulp = np.spacing(np.maximum(np.abs(exact), np.finfo(float).tiny))
        assert np.max(np.abs(ours - exact) / ulp) <= 2.0
    assert np.signbit(sine[x == 0.0]).tolist() == np.signbit(np.sin(x[x == 0.0])).tolist()


def test_sin_cos_once_per_element_and_independent_of_the_batch():
    """The hinge angles' sin/cos on the CPU: the polynomials within their range, `jnp.sin`/`cos`
    beyond it, NaN where the angle is not finite, element by element. Under `vmap` a member's
    values must not depend on the other members: a blown-up trial state of one member (an angle
    beyond the range) used to switch the whole batch to `jnp.sin`, 1 ulp away, which contact
    dynamics amplified into different trajectories for the other members."""
    from origami_jax._math import sin_cos_once

    rng = np.random.default_rng(8)
    calm = rng.uniform(-10.0, 10.0, 64)
    wild = calm.copy()
    wild[5], wild[9], wild[11] = 3.0 * SIN_COS_REDUCTION_LIMIT, np.nan, -np.inf
    once = jax.jit(jax.vmap(sin_cos_once))
    polynomial = [np.asarray(v) for v in jax.jit(sin_cos_reduced)(jnp.asarray(calm))]
    # The test can fail: the polynomials and jnp.sin/cos differ in the last bit somewhere here.
    assert np.any(polynomial[0] != np.asarray(jnp.sin(calm)))
    alone = [np.asarray(v) for v in once(jnp.asarray(np.stack([calm, calm])))]
    beside_wild = [np.asarray(v) for v in once(jnp.asarray(np.stack([calm, wild])))]
    for k in range(2):
        np.testing.assert_array_equal(alone[k][0], polynomial[k])
        np.testing.assert_array_equal(beside_wild[k][0], polynomial[k])  # bit for bit
    sine, cosine = beside_wild[0][1], beside_wild[1][1]
    assert sine[5] == np.asarray(jnp.sin(wild[5])) and cosine[5] == np.asarray(jnp.cos(wild[5]))
    assert np.isnan(sine[[9, 11]]).all() and np.isnan(cosine[[9, 11]]).all()
    keep = np.setdiff1d(np.arange(64), [5, 9, 11])
    np.testing.assert_array_equal(sine[keep], polynomial[0][keep])
