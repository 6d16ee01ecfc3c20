"""The comparison helpers must be able to fail, or every test that uses them is hollow."""

import jax.numpy as jnp
import numpy as np

from .helpers import max_relative_error, tree_allclose


def test_tree_allclose_accepts_equal_and_rejects_different():
    a = {"x": jnp.arange(3.0), "y": (1, jnp.ones((2, 2)))}
    assert tree_allclose(a, {"x": jnp.arange(3.0), "y": (1, jnp.ones((2, 2)))})
    assert not tree_allclose(a, {"x": jnp.arange(3.0) + 1e-3, "y": (1, jnp.ones((2, 2)))})
    assert not tree_allclose(a, {"x": jnp.arange(3.0), "y": (2, jnp.ones((2, 2)))})
    assert not tree_allclose(a, {"x": jnp.arange(4.0), "y": (1, jnp.ones((2, 2)))})
    assert not tree_allclose(jnp.array([np.nan]), jnp.array([np.nan]))


def test_max_relative_error():
    assert max_relative_error(jnp.array([1.0, 2.0]), jnp.array([1.0, 2.0])) == 0.0
    assert np.isclose(max_relative_error(jnp.array([1.0, 2.2]), jnp.array([1.0, 2.0])), 0.1)
