"""The persistent compilation cache: compiled programs kept on disk between Python processes.

JAX compiles every jitted program the first time it meets it in a process: for a folding simulation
that is seconds to tens of seconds, against milliseconds to run it. JAX's own persistent cache
(``jax_compilation_cache_dir``) stores each compiled program under a key of the program and the
compiler, so a later process that builds the same program loads it instead of compiling it again.
`enable_compilation_cache` turns it on in a per-user folder; the command line does so by default.

This module imports nothing heavy: `jax` is imported inside the function.
"""

from __future__ import annotations

import os
from pathlib import Path

CACHE_ENV = "ORIGAMI_JAX_CACHE"
"""Environment variable: `0` (or `off`, `false`, `no`) turns the cache off, a folder moves it, `1`
(or unset) keeps the default folder (`default_cache_dir`)."""

# Every program is written, however fast it compiled (JAX's default threshold is 1 s): the command
# line's small programs (array set-up, metrics, plotting helpers) compile in 0.01-0.5 s each, about
# 90 of them for a step response, and together they are 1.5-2.5 s of a warm run on 2 cores; loading
# one is about a millisecond and a few kB on disk.
MIN_COMPILE_TIME_S = 0.0
_JAX_DEFAULT_MIN_COMPILE_TIME_S = 1.0  # a threshold someone else chose is kept

_OFF = frozenset({"0", "off", "false", "no", "none"})
_ON = frozenset({"", "1", "on", "true", "yes"})


def default_cache_dir() -> Path:
    """The per-user folder of the cache: ``$XDG_CACHE_HOME/origami_jax/jax``, by default
    ``~/.cache/origami_jax/jax``."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "origami_jax" / "jax"


def _requested(path: str | os.PathLike | None) -> Path | None:
    """The folder asked for: `path`, else the environment variable, else the default; `None` off."""
    if path is not None:
        return Path(path).expanduser()
    value = os.environ.get(CACHE_ENV)
    if value is None:
        return default_cache_dir()
    word = value.strip().lower()
    if word in _OFF:
        return None
    if word in _ON:
        return default_cache_dir()
    return Path(value).expanduser()


def enable_compilation_cache(path: str | os.PathLike | None = None) -> Path | None:
    """Keep compiled programs on disk, so that a new Python process reuses them instead of
    compiling again (JAX's persistent compilation cache).

    The command line calls this for you. In a script or a notebook call it once, before the first
    simulation; it changes JAX's global configuration (``jax_compilation_cache_dir`` and the
    thresholds of what is written), which is why the library never does it on import.

    **Arguments:**
    - `path`: the cache folder (created if missing). Default: the environment variable
      `ORIGAMI_JAX_CACHE` if set (a folder, or `0` to turn the cache off), else a cache folder
      JAX was already given (`JAX_COMPILATION_CACHE_DIR`), else the per-user folder
      ``$XDG_CACHE_HOME/origami_jax/jax`` (``~/.cache/origami_jax/jax``).

    **Returns:** the folder in use, or `None` when `ORIGAMI_JAX_CACHE=0` turned the cache off (then
    nothing is changed).

    Programs are keyed by their content, the JAX and XLA versions and the machine, so a stale entry
    is never used; delete the folder to reclaim its space. Several processes may share the folder:
    an entry is written once, by whichever process compiles it first, and a process that reads an
    entry still being written gets a read error, which JAX turns into a warning and a fresh compile.
    Programs that call back into Python (`equinox.error_if` on traced values, progress meters)
    cannot be stored and compile in every process. Called from plain Python, `simulate`, sweeps of
    the built-in models, `yield_estimate` and `design`/`calibrate` keep their programs free of them
    (inputs checked before compiling, failures read from result codes).
    """
    folder = _requested(path)
    if folder is None:
        return None
    import jax

    configured = jax.config.jax_compilation_cache_dir
    if path is None and CACHE_ENV not in os.environ and configured:
        folder = Path(configured)  # JAX_COMPILATION_CACHE_DIR, or an earlier call: keep it
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ValueError(
            f"cannot create the compilation cache folder {folder}: {error.strerror or error}; "
            f"give another folder (or set {CACHE_ENV}=0 to turn the cache off)."
        ) from error
    if configured != str(folder):
        from jax.experimental.compilation_cache import compilation_cache

        # The cache binds its folder at the first compilation of the process; a new one needs a
        # reset to take effect.
        compilation_cache.reset_cache()
        jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_enable_compilation_cache", True)
    if jax.config.jax_persistent_cache_min_compile_time_secs == _JAX_DEFAULT_MIN_COMPILE_TIME_S:
        jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_TIME_S)
    return folder
