"""`origami-jax design`: Fit hinge parameters to target rise times / overshoot or to a measured response."""

import argparse

from ._common import add_out_argument, not_implemented


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "design",
        help="Fit hinge parameters to target rise times / overshoot or to a measured response.",
        description="Fit hinge parameters to target rise times / overshoot or to a measured response.",
    )
    add_out_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    return not_implemented("design", issue=6)
