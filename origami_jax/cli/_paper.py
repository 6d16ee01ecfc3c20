"""`origami-jax paper`: the main job. Reproduces the paper's examples on built-in defaults.

Each half of the paper contributes a *part*: a function ``run(out: Path) -> list[str]`` that writes its
figures into ``out`` and returns lines for the text summary.
"""

import argparse
import time
from pathlib import Path

from . import _paper_calibration, _paper_dynamics, _paper_extended, _paper_unfolding
from ._common import EXIT_OK, OutputFolder, add_out_argument, write_atomic

HELP = (
    "Reproduce the paper's examples (unfoldings of Fig. 3, step and ramp responses of Figs. 7-11, "
    "a calibration of the hinges to Fig. 7; with --extended, the extended model next to the "
    "paper's)."
)
EXTENDED_HELP = (
    "also run the paper's model next to the extended one (arc hinges, fluid inertia and viscosity, "
    "contact) on Fig. 7's step in air, the KOH step and the etch ramp, and fit every model variant "
    "to Fig. 7 within plausible bounds: tens of minutes more on two cores (each variant compiles "
    "its own fit)"
)


def _parts(extended: bool = False):
    # Imported lazily so that `origami-jax --help` stays fast.

    parts = (
        ("single-vertex unfolding", _paper_unfolding.run),
        ("accordion dynamics", _paper_dynamics.run),
        ("hinge calibration to Fig. 7", _paper_calibration.run),
    )
    if extended:
        parts += (("the paper's model and the extended one", _paper_extended.run),)
    return parts


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("paper", help=HELP, description=HELP)
    add_out_argument(parser)
    parser.add_argument("--extended", action="store_true", help=EXTENDED_HELP)
    parser.set_defaults(func=run)


# Everything the parts write (see each part), relative to --out.
OWNS = (
    "summary.txt",
    "dynamics_metrics.json",
    "fig*",
    "slow_ramp_koh_trajectory.*",
    "paper_vs_extended.*",
    "unfolding/*",
    "calibration/*",
)


def run(args: argparse.Namespace) -> int:
    output = OutputFolder(Path(args.out), command="paper", owns=OWNS, overwrite=args.overwrite)
    summary: list[str] = ["origami_jax: reproduction of the paper's examples", ""]
    with output:
        for title, part in _parts(extended=args.extended):
            start = time.perf_counter()
            print(f"[paper] {title} ...", flush=True)
            lines = [line.replace(str(output.dir), str(output.out)) for line in part(output.dir)]
            elapsed = time.perf_counter() - start
            summary += [f"## {title}", *lines, f"(took {elapsed:.1f} s)", ""]
            print("\n".join(lines), flush=True)
        write_atomic(output.dir / "summary.txt", "\n".join(summary) + "\n")
    print(f"[paper] results and summary written to {output.out / 'summary.txt'}")
    return EXIT_OK
