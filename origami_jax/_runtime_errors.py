"""Equinox's runtime checks in the programs compiled for calls made outside any transformation.

A check on a traced value (`equinox.error_if`, which diffrax uses for its sample times and its
failures) compiles into a callback to Python, and JAX's persistent compilation cache does not store
programs that call back: such a solve compiled again in every new process (about 3 s for the
accordion's step). A call from plain Python code (nothing traced) has every value it checks in
hand, so it checks them before compiling and reads the solver's failure from its result code
afterwards; its program needs no callback. `checks_as_nan` traces that program with equinox's checks
turned into NaN (as ``EQX_ON_ERROR=nan`` would), which keeps it storable.

Equinox reads ``EQX_ON_ERROR`` once, at import, into a module constant that its checks consult while
a program is traced; `checks_as_nan` sets that constant around the trace (and the asynchronous
dispatch) of the library's own programs, not around their runs. Code traced in another thread in
that window sees it too: its checks would also give NaN instead of raising. And JAX reuses a
jitted function's trace for the same argument structure: diffrax's `diffeqsolve`, traced once so,
keeps NaN checks of its first step and sample times when the caller's own `jit` later calls
`simulate` with `SolveOptions(throw=False)` and the same structure (such a run then fails with a
result code, which is what `throw=False` reports; with `throw=True` the solve is another program
and raises).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator


def on_error() -> str:
    """How equinox's runtime checks behave in programs traced now (`EQX_ON_ERROR`): ``"raise"``,
    ``"nan"``, ``"off"`` or ``"breakpoint"``."""
    errors = sys.modules.get("equinox._errors")
    return getattr(errors, "EQX_ON_ERROR", os.environ.get("EQX_ON_ERROR", "raise"))


@contextlib.contextmanager
def checks_as_nan(enabled: bool = True) -> Iterator[None]:
    """Programs traced inside this block turn a failed `equinox.error_if` into NaN instead of a
    callback that raises (nothing changes when not `enabled`). For callers that checked every input
    in Python and read failures from result codes. A user's ``EQX_ON_ERROR`` other than ``raise``
    (a breakpoint, say) is left alone, as is an equinox without the constant (then nothing changes:
    the program is only not stored)."""
    import equinox._errors as errors

    saved = getattr(errors, "EQX_ON_ERROR", None)
    if not enabled or saved != "raise":
        yield
        return
    errors.EQX_ON_ERROR = "nan"
    try:
        yield
    finally:
        errors.EQX_ON_ERROR = saved
