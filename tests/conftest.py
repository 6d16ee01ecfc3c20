"""Test configuration: float64, a headless matplotlib, a seeded PRNG key."""

import os
import shutil
import tempfile

os.environ.setdefault("MPLBACKEND", "Agg")
# One XLA compilation cache for the whole run, shared with the notebook kernels (they inherit the
# environment): tests, notebooks and the CLI compile many identical programs (the accordion's step
# response, the unfolding kernels) from different jit wrappers and processes. A fresh folder per run,
# so CI never reads a stale cache; set JAX_COMPILATION_CACHE_DIR yourself to keep one between runs.
_OWN_CACHE = "JAX_COMPILATION_CACHE_DIR" not in os.environ
if _OWN_CACHE:
    os.environ["JAX_COMPILATION_CACHE_DIR"] = tempfile.mkdtemp(prefix="origami_jax_test_xla_cache_")

import jax  # noqa: E402  (after the environment is set)
import pytest  # noqa: E402

# The physics spans nanometres to hundreds of microns and microseconds to hours: tests run in float64.
# (The library itself never flips this switch; see README "Precision".)
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", os.environ["JAX_COMPILATION_CACHE_DIR"])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)

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


def pytest_sessionfinish(session, exitstatus):
    # The run's own compilation cache goes with it (a user-given one is kept).
    if _OWN_CACHE:
        shutil.rmtree(os.environ["JAX_COMPILATION_CACHE_DIR"], ignore_errors=True)
