"""Ctrl-C and termination: a run stopped by SIGINT or SIGTERM writes nothing to `--out` and says so.

Python raises `KeyboardInterrupt` wherever the main thread is when SIGINT arrives, and one raised
inside a garbage-collector callback (JAX frees device buffers from one) is only printed, "Exception
ignored in ...", and lost: the run carried on and wrote its results. SIGTERM (`timeout`, a batch
system's kill) ends the process at once by default, leaving its staging folder behind. `install`
makes both signals raise `Signalled` (a `KeyboardInterrupt`, so every clean-up path runs) and
remembers them; `check`, called before a run's results are moved into place, raises again when the
first one was lost; the lost one's "Exception ignored" report is not printed. A second signal while
the first one's exception unwinds the run (its staging folder being removed: `kill` and `timeout`
together send two) is only remembered; a third ends the process at once, as the signal would have.
"""

from __future__ import annotations

import os
import signal
import sys

_received: list[int] = []
# Whether a `Signalled` is on its way up (not lost in a callback): later signals wait for it.
_raised = [False]


class Signalled(KeyboardInterrupt):
    """A run stopped by a signal (`signum`: SIGINT or SIGTERM)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def install() -> None:
    """Handle SIGINT and SIGTERM as above (the console script's main thread only)."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _handler)
    previous = sys.unraisablehook

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt) and _received:
            _raised[0] = False  # lost: the next signal, or `check`, raises it again
            return
        previous(unraisable)

    sys.unraisablehook = hook


def _handler(signum, frame) -> None:
    _received.append(signum)
    if not _raised[0]:
        _raised[0] = True
        raise Signalled(signum)
    if len(_received) >= 3:  # the clean-up hangs: stop as the signal itself would
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)


def received() -> int | None:
    """The last signal received (`signal.SIGINT`, `signal.SIGTERM`), or `None`."""
    return _received[-1] if _received else None


def check() -> None:
    """Raise `Signalled` if a signal came, even one whose exception was lost."""
    if _received:
        raise Signalled(_received[-1])
