"""Pieces every subcommand shares: the output folder, float64, the exit codes."""

import argparse
import os
from pathlib import Path

DEFAULT_OUT = Path("origami_out")

# Exit codes of the CLI. 0 success; 1 the computation ran but its answer is negative or failed
# (e.g. a vertex that stalls, a solver that failed); 2 bad usage or bad input.
EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2


def add_out_argument(parser: argparse.ArgumentParser, default: Path = DEFAULT_OUT) -> None:
    parser.add_argument(
        "--out",
        type=Path,
        default=default,
        help=f"output folder, created if missing (default: ./{default})",
    )


def prepare_out(out: Path) -> Path:
    """Create the output folder (and parents); return it."""
    out.mkdir(parents=True, exist_ok=True)
    return out


def setup_runtime() -> None:
    """Configure JAX for command-line runs: float64 on, matplotlib without a screen.

    The library itself never flips global JAX configuration; the CLI does, because its results are
    written to files and must be reproducible to the digits it prints.
    """
    os.environ.setdefault("MPLBACKEND", "Agg")
    import jax

    jax.config.update("jax_enable_x64", True)
