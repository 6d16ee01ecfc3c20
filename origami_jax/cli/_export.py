"""`origami-jax export`: Export geometry or results to other formats (FOLD)."""

import argparse

from ._common import add_out_argument, not_implemented


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help="Export geometry or results to other formats (FOLD).",
        description="Export geometry or results to other formats (FOLD).",
    )
    add_out_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    return not_implemented("export", issue=8)
