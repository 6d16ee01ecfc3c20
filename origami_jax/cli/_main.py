"""Top-level argument parser; each subcommand lives in its own module with ``register(subparsers)``.

`main` is the one place where errors become exit codes: a command's `CLIError` prints its one line;
Ctrl-C prints one line and exits 130, SIGTERM 143 (`_interrupt`: nothing is written either way);
any other exception prints one line naming the input and the error (exit 2 for a `ValueError`, bad
input found by the library; 1 otherwise), or its traceback with `--debug`.
"""

import argparse
import os
import re
import signal
import sys
import threading
from collections.abc import Sequence

from .._version import __version__
from . import _design, _export, _fold, _paper, _simulate, _sweep, _unfold, _view, _yield
from . import _interrupt as interrupt
from ._common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USAGE,
    CLIError,
    one_line,
    print_error,
    setup_runtime,
)

SUBCOMMANDS = (_paper, _unfold, _simulate, _fold, _design, _sweep, _yield, _export, _view)
DEBUG_HELP = "show the full traceback of an unexpected error"
# Arguments that name a command's input, in the order they are looked for (for error messages).
_INPUT_ARGUMENTS = ("config", "target", "source", "result", "curve")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (its default prints the whole usage block first)."""

    def error(self, message: str):  # pyright: ignore[reportIncompatibleMethodOverride]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="origami-jax",
        description=(
            "Differentiable simulator for nanostructured origami: unfold single-vertex origami with "
            "charge energies, simulate stressed-hinge folding of flap chains, fold nets and crease "
            "patterns from FOLD files until their panels meet, design hinges, sweep designs, "
            "estimate a net's yield under fabrication scatter. `origami-jax paper` reproduces the "
            "paper's examples."
        ),
        epilog=(
            "Results: every command writes into --out as one unit (moved into place when the run "
            "ends) and refuses a folder that holds results of an earlier run unless --overwrite is "
            "given (yield and sweep never replace results: --resume continues the run stored "
            "there). Exit codes: 0 success, 1 the computation failed or its answer is negative, "
            "2 bad input, 130 interrupted."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("--debug", action="store_true", help=DEBUG_HELP)
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in SUBCOMMANDS:
        module.register(subparsers)
    for sub in subparsers.choices.values():
        # Also after the subcommand; SUPPRESS keeps a top-level --debug when not repeated here.
        sub.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=DEBUG_HELP)
    return parser


def _input_of(args: argparse.Namespace, argv: Sequence[str]) -> str:
    for name in _INPUT_ARGUMENTS:
        value = getattr(args, name, None)
        if value is not None:
            return str(value)
    options = " ".join(a for a in argv if a not in ("--debug", args.command))
    options = options if len(options) <= 120 else options[:117] + "..."
    return f"the options '{options}'" if options else "the default options"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line `argv` (default `sys.argv[1:]`, a process of its own: the console
    script, ``python -m origami_jax``); returns the exit code (module docstring)."""
    if argv is None and threading.current_thread() is threading.main_thread():
        interrupt.install()
    code = _run(argv)
    if argv is None and threading.current_thread() is threading.main_thread():
        # The command is done and has said so: a Ctrl-C from here on (the interpreter's shutdown)
        # would turn its exit code into 1 without a word.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        _exit_at_once(code)
    return code


def _exit_at_once(code: int) -> None:
    """End the process now with `code`: every file the command wrote is closed and in place (the
    outputs are moved into place, the compilation cache writes as it compiles), so the
    interpreter's shutdown would only tear down the compiled programs one by one, most of a second
    after a fold, while the user waits for the prompt."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a reader gone (`| head`), a stream closed: nothing to say
            pass
    os._exit(code)


_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d)[\d.eE+-]*(,[\d.eE+-]*)*$")


def negative_lists_attached(argv: list[str]) -> list[str]:
    """`argv` with a negative number, or a comma list that starts with one, joined to the flag
    before it (``--release -5,0,0`` as ``--release=-5,0,0``): argparse reads ``-5`` as a value but
    ``-1e-300`` or such a list as an unknown flag ("expected one argument"), so the value's own
    check never said what is wrong with it."""
    out: list[str] = []
    for token in argv:
        previous = out[-1] if out else ""
        if _NEGATIVE_VALUE.match(token) and previous.startswith("--") and "=" not in previous:
            out[-1] = f"{previous}={token}"
        else:
            out.append(token)
    return out


def _run(argv: Sequence[str] | None) -> int:
    argv = negative_lists_attached(list(sys.argv[1:] if argv is None else argv))
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        setup_runtime(args.command, argv)  # imports JAX: seconds in which a Ctrl-C may come too
        return int(args.func(args))
    except CLIError as error:
        print_error(args.command, str(error))
        return error.code
    except KeyboardInterrupt:
        if interrupt.received() == signal.SIGTERM:
            print_error(args.command, "terminated (SIGTERM); nothing was written to --out.")
            return EXIT_TERMINATED
        print_error(args.command, "interrupted (Ctrl-C); nothing was written to --out.")
        return EXIT_INTERRUPTED
    except Exception as error:
        if args.debug:
            raise
        kind = type(error).__name__
        message = one_line(str(error)) or kind
        print_error(
            args.command,
            f"failed on {_input_of(args, argv)}: {kind}: {message} (--debug shows the traceback)",
        )
        return EXIT_USAGE if isinstance(error, ValueError) else EXIT_FAILED
