"""Clear errors for bad chain input (issue #3 item 6): Python-level before tracing, error_if inside jit."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.chain as oc

from .chain_cases import forward_dynamics

# eqx.error_if surfaces as EquinoxRuntimeError, or wrapped by the CPU callback as a ValueError/
# JaxRuntimeError depending on the JAX version; the message is what the user reads.
_RUNTIME_ERRORS = (eqx.EquinoxRuntimeError, ValueError, jax.errors.JaxRuntimeError)


def _parts(n=2):
    chain = oc.accordion(n)
    return dict(
        axes=np.asarray(chain.axes),
        points=np.asarray(chain.points),
        cg_poses=np.asarray(chain.cg_poses),
        masses=np.asarray(chain.masses),
        inertias=np.asarray(chain.inertias),
    )


def _with(**changes):
    parts = _parts()
    parts.update(changes)
    return parts


def test_valid_parts_build():
    assert oc.Chain(**_parts()).n_joints == 2


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (dict(axes=np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])), "zero vector"),
        (dict(axes=np.array([[2.0, 0.0, 0.0], [1.0, 0.0, 0.0]])), "not 1; pass unit vectors"),
        (dict(masses=np.array([1.0, -1.0])), "masses must be positive"),
        (dict(masses=np.array([1.0, 1.0, 1.0])), r"masses must have shape \(2,\)"),
        (dict(points=np.zeros((3, 3))), r"points must have shape \(2, 3\)"),
        (dict(axes=np.array([1.0, 0.0, 0.0])), r"axes must have shape \(\?, 3\)"),
        (dict(inertias=np.stack([np.eye(3), -np.eye(3)])), "not positive definite"),
        (dict(inertias=np.stack([np.eye(3), np.triu(np.ones((3, 3)))])), "not symmetric"),
        (dict(points=np.array([[0.0, np.nan, 0.0], [0.0, 0.0, 0.0]])), "NaN or inf"),
        (dict(cg_poses=np.tile(2 * np.eye(4), (2, 1, 1))), "rigid transforms"),
    ],
)
def test_chain_rejects(changes, message):
    with pytest.raises(ValueError, match=message):
        oc.Chain(**_with(**changes))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(thickness=0.0), "thickness must be positive"),
        (dict(flap_length=-200.0), "flap_length must be positive"),
        (dict(flap_width=-1.0), "flap_width must be positive"),
        (dict(density=0.0), "density must be positive"),
        (dict(thickness=np.ones(4)), r"thickness must be a scalar or have shape \(3,\)"),
    ],
)
def test_accordion_rejects(kwargs, message):
    with pytest.raises(ValueError, match=message):
        oc.accordion(3, **kwargs)


def test_accordion_rejects_bad_count():
    with pytest.raises(ValueError, match="n_flaps must be an integer >= 1"):
        oc.accordion(0)


def test_traced_values_are_checked_inside_jit():
    @jax.jit
    def mass(length):
        return oc.accordion(2, flap_length=length).masses

    np.testing.assert_allclose(mass(200.0), 24.8)
    with pytest.raises(_RUNTIME_ERRORS, match="flap_length must be positive"):
        jax.block_until_ready(mass(-200.0))

    @jax.jit
    def build(axes):
        return oc.Chain(
            axes, jnp.zeros((1, 3)), jnp.eye(4)[None], jnp.ones(1), jnp.eye(3)[None]
        ).axes

    with pytest.raises(_RUNTIME_ERRORS, match="unit vectors"):
        jax.block_until_ready(build(jnp.array([[0.0, 2.0, 0.0]])))


def test_planar_flag_detected_asserted_and_checked():
    """`Chain.planar` (every axis parallel: the dynamics run in two dimensions): detected from known
    axes, also for an accordion built under `jit`; asserting it on bent axes fails clearly, in Python
    and inside `jit`; a chain whose axes were replaced after it was built is caught instead of
    silently using the planar algebra (Python error, NaN when traced)."""
    assert oc.accordion(3).planar
    assert not oc.Chain(**_with(axes=np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]]))).planar
    flipped = oc.Chain(**_with(axes=np.array([[0.0, 0.6, 0.8], [0.0, -0.6, -0.8]])))
    assert flipped.planar  # antiparallel axes are parallel lines: the hinge turns the other way
    assert not oc.Chain(**_parts(), planar=False).planar
    planar_under_jit = jax.eval_shape(lambda length: oc.accordion(3, flap_length=length), 200.0)
    assert planar_under_jit.planar

    bent = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match=r"planar=True but axes\[1\] is not parallel"):
        oc.Chain(**_with(axes=bent), planar=True)
    # ValueError from the function; TypeError when the suite's runtime type checker sees it first.
    with pytest.raises((ValueError, TypeError), match="planar"):
        oc.Chain(**_parts(), planar="yes")  # pyright: ignore[reportArgumentType]

    parts = _parts()

    @jax.jit
    def build(axes):
        chain = oc.Chain(**{**parts, "axes": axes}, planar=True)
        assert chain.planar
        return chain.axes

    np.testing.assert_array_equal(build(jnp.asarray(_parts()["axes"])), _parts()["axes"])
    with pytest.raises(_RUNTIME_ERRORS, match="planar=True but the hinge axes are not parallel"):
        jax.block_until_ready(build(jnp.asarray(bent)))

    chain = oc.accordion(2)
    tilted = eqx.tree_at(lambda c: c.axes, chain, jnp.asarray(bent))
    state = (jnp.array([0.3, -0.2]), jnp.array([0.01, 0.02]), jnp.array([5.0, -3.0]))
    with pytest.raises(ValueError, match="marked planar but its hinge axes are not parallel"):
        forward_dynamics(tilted, *state, stiffness=1.0, drag=0.1)
    traced = jax.jit(lambda c, q, v, t: forward_dynamics(c, q, v, t, stiffness=1.0, drag=0.1))
    assert bool(jnp.all(jnp.isnan(traced(tilted, *state))))
    assert bool(jnp.all(jnp.isfinite(traced(chain, *state))))
