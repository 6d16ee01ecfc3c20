"""`origami-jax sweep`: Run a batch sweep over designs from a TOML config, chunked, resumable."""

import argparse

from ._common import add_out_argument, not_implemented


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="Run a batch sweep over designs from a TOML config, chunked, resumable.",
        description="Run a batch sweep over designs from a TOML config, chunked, resumable.",
    )
    add_out_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    return not_implemented("sweep", issue=7)
