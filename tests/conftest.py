"""Test configuration: float64, a headless matplotlib, a seeded PRNG key."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax
import pytest

# The physics spans nanometres to hundreds of microns and microseconds to hours: tests run in float64.
# (The library itself never flips this switch; see README "Precision".)
jax.config.update("jax_enable_x64", True)

SEED = 20051105


@pytest.fixture
def getkey():
    """Return a function that yields a fresh, reproducible PRNG key on each call."""
    key = jax.random.key(SEED)

    def _getkey():
        nonlocal key
        key, subkey = jax.random.split(key)
        return subkey

    return _getkey


@pytest.fixture
def key():
    """A seeded PRNG key."""
    return jax.random.key(SEED)
