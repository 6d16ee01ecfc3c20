"""Command-line interface: ``origami-jax <subcommand> ...`` (also ``python -m origami_jax``)."""

from ._main import build_parser as build_parser
from ._main import main as main
