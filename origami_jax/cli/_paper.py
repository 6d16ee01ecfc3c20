"""`origami-jax paper`: the main job. Reproduces the paper's examples on built-in defaults.

Each half of the paper contributes a *part*: a function ``run(out: Path) -> list[str]`` that writes its
figures into ``out`` and returns lines for the text summary.
"""

import argparse
import time
from pathlib import Path

from ._common import EXIT_OK, add_out_argument, prepare_out

HELP = (
    "Reproduce the paper's examples (unfoldings of Fig. 3, step and ramp responses of Figs. 7-11, "
    "and a calibration of the hinges to Fig. 7)."
)


def _parts():
    # Imported lazily so that `origami-jax --help` stays fast.
    from . import _paper_calibration, _paper_dynamics, _paper_unfolding

    return (
        ("single-vertex unfolding", _paper_unfolding.run),
        ("accordion dynamics", _paper_dynamics.run),
        ("hinge calibration to Fig. 7", _paper_calibration.run),
    )


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("paper", help=HELP, description=HELP)
    add_out_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    out = prepare_out(Path(args.out))
    summary: list[str] = ["origami_jax: reproduction of the paper's examples", ""]
    for title, part in _parts():
        start = time.perf_counter()
        print(f"[paper] {title} ...", flush=True)
        lines = part(out)
        elapsed = time.perf_counter() - start
        summary += [f"## {title}", *lines, f"(took {elapsed:.1f} s)", ""]
        print("\n".join(lines), flush=True)
    (out / "summary.txt").write_text("\n".join(summary) + "\n")
    print(f"[paper] summary written to {out / 'summary.txt'}")
    return EXIT_OK
