"""Top-level argument parser; each subcommand lives in its own module with ``register(subparsers)``."""

import argparse
import sys
from collections.abc import Sequence

from .._version import __version__
from . import _design, _export, _fold, _paper, _simulate, _sweep, _unfold, _view
from ._common import EXIT_USAGE, setup_runtime

SUBCOMMANDS = (_paper, _unfold, _simulate, _fold, _design, _sweep, _export, _view)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="origami-jax",
        description=(
            "Differentiable simulator for nanostructured origami: unfold single-vertex origami with "
            "charge energies, simulate stressed-hinge folding of flap chains, design hinges, sweep "
            "designs. `origami-jax paper` reproduces the paper's examples."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in SUBCOMMANDS:
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    setup_runtime()
    return int(args.func(args))
