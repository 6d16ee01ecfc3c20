"""Test configuration: float64, a headless matplotlib, a seeded PRNG key."""

import ctypes
import gc
import os
import shutil
import tempfile
import time

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
# (The library itself never flips this switch; see docs/getting-started.md, "Float64, always".)
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


# A test process keeps every program it has compiled, and XLA's CPU code for each takes memory
# mappings of its own (hundreds per net simulation). Over the slow suite a worker reached the
# kernel's limit on mappings per process (`vm.max_map_count`, 65,530 by default) and XLA crashed
# compiling or serialising the next program (SIGSEGV, SIGABRT). Past half that limit, or a quarter
# of the machine's memory, the programs compiled so far are dropped after the test (later tests
# read them back from the on-disk cache or compile them again); the default suite stays below.
_PAGE = os.sysconf("SC_PAGE_SIZE")
_MEMORY_BYTES = _PAGE * os.sysconf("SC_PHYS_PAGES")


def _max_map_count() -> int:
    try:
        with open("/proc/sys/vm/max_map_count") as limit:
            return int(limit.read())
    except OSError:
        return 65530


_MAPPINGS_LIMIT = _max_map_count()


def _mappings_and_resident_bytes() -> tuple[int, int]:
    with open("/proc/self/maps") as maps:
        mappings = sum(1 for _ in maps)
    with open("/proc/self/statm") as statm:
        return mappings, int(statm.read().split()[1]) * _PAGE


_last_look = [0.0]  # monotonic time of the last look: reading /proc/self/maps takes milliseconds


@pytest.fixture(autouse=True)
def _drop_compiled_programs_when_the_process_fills_up():
    yield
    if time.monotonic() - _last_look[0] < 5.0:
        return
    _last_look[0] = time.monotonic()
    try:
        mappings, resident = _mappings_and_resident_bytes()
    except OSError:  # no /proc: not Linux
        return
    if mappings > _MAPPINGS_LIMIT / 2 or resident > _MEMORY_BYTES / 4:
        jax.clear_caches()
        gc.collect()
        try:
            ctypes.CDLL("libc.so.6").malloc_trim(0)  # hand the freed pages back to the system
        except (OSError, AttributeError):
            pass


def pytest_sessionfinish(session, exitstatus):
    # The run's own compilation cache goes with it (a user-given one is kept).
    if _OWN_CACHE:
        shutil.rmtree(os.environ["JAX_COMPILATION_CACHE_DIR"], ignore_errors=True)
