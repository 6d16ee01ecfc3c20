"""`origami-jax simulate`: Simulate the folding of a hinged-flap chain (accordion) under a step or etch-rate ramp input."""

import argparse

from ._common import add_out_argument, not_implemented


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "simulate",
        help="Simulate the folding of a hinged-flap chain (accordion) under a step or etch-rate ramp input.",
        description="Simulate the folding of a hinged-flap chain (accordion) under a step or etch-rate ramp input.",
    )
    add_out_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    return not_implemented("simulate", issue=4)
