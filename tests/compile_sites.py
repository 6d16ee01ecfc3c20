"""A pytest plugin that finds where the test suite's small compilations come from (a tool, not a test).

Much of the suite's time is XLA compiling programs of a few operations: JAX operations run eagerly
(outside `jit`) compile one program per operation and shape, ~0.03-0.07 s each, the first time a
process meets them. This plugin records every compilation under `MAX_SECONDS` with the test that
caused it and the innermost package frame, and writes the totals per (test, package site) to
``compile_sites_<pid>.txt`` (one file per worker) in `COMPILE_SITES_DIR` (default: the system's
temporary folder):

    python -m pytest -n 2 --dist loadfile -p tests.compile_sites -p no:logging

(`-p no:logging` keeps pytest from capturing JAX's log records first; the few tests that use the
`caplog` fixture then error.) A site with many compilations is usually fixed by one `jax.jit`
around the eager code, in the test or in the package.
"""

import collections
import logging
import os
import tempfile
import traceback

import jax

MAX_SECONDS = 1.0
_seconds: collections.Counter = collections.Counter()
_counts: collections.Counter = collections.Counter()


def _frame(stack, part: str, *, innermost: bool = False) -> str:
    """The outermost (or innermost) frame of the stack in a file under a folder named `part`."""
    frames = [f for f in stack if f"/{part}/" in f.filename]
    if not frames:
        return "-"
    f = frames[-1] if innermost else frames[0]
    return f"{os.path.basename(f.filename)}:{f.lineno}:{f.name}"


class _Record(logging.Handler):
    def emit(self, record):
        message = record.getMessage()
        if not message.startswith("Finished XLA compilation"):
            return
        seconds = float(message.rsplit(" in ", 1)[-1].split()[0])
        if seconds > MAX_SECONDS:
            return
        stack = traceback.extract_stack()
        key = (_frame(stack, "tests"), _frame(stack, "origami_jax", innermost=True))
        _seconds[key] += seconds
        _counts[key] += 1


def pytest_configure(config):
    jax.config.update("jax_log_compiles", True)
    handler = _Record(level=logging.DEBUG)
    logger = logging.getLogger("jax")
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG)


def pytest_sessionfinish(session, exitstatus):
    if not _counts:
        return  # the controller of a distributed run
    folder = os.environ.get("COMPILE_SITES_DIR", tempfile.gettempdir())
    path = os.path.join(folder, f"compile_sites_{os.getpid()}.txt")
    with open(path, "w") as out:
        out.write(f"{sum(_seconds.values()):.1f} s in {sum(_counts.values())} compilations\n")
        out.write("seconds count test package-site\n")
        for key, seconds in _seconds.most_common():
            out.write(f"{seconds:7.2f} {_counts[key]:5d} {key[0]} {key[1]}\n")
    print(f"\ncompile_sites: {path}")
