"""`origami-jax unfold`: Unfold a single-vertex origami by charge-energy descent and give a verdict (flat-unfoldable or not)."""

import argparse

from ._common import add_out_argument, not_implemented


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "unfold",
        help="Unfold a single-vertex origami by charge-energy descent and give a verdict (flat-unfoldable or not).",
        description="Unfold a single-vertex origami by charge-energy descent and give a verdict (flat-unfoldable or not).",
    )
    add_out_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    return not_implemented("unfold", issue=5)
