"""`origami-jax unfold`: Unfold a single-vertex origami by charge-energy descent and give a verdict (flat-unfoldable or not)."""

import argparse
import sys
from pathlib import Path

from ._common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, add_out_argument, prepare_out

EXAMPLES = ("corner-cube", "waterbomb", "degree4", "open-chain")
HELP = "Unfold a single-vertex origami by charge-energy descent and give a verdict (flat-unfoldable or not)."


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "unfold",
        help=HELP,
        description=HELP
        + " Writes the path (NPZ and CSV) and pictures (PNG strip, energy/fold-angle plot, GIF)."
        " Exit status 0 for flat-unfolded, 1 otherwise.",
    )
    parser.add_argument(
        "target", help=f"a catalogue example ({', '.join(EXAMPLES)}) or a FILE.fold"
    )
    parser.add_argument(
        "--energy",
        choices=("separable", "nonseparable"),
        default="separable",
        help="Eq. 1 or Eq. 2",
    )
    parser.add_argument("--p", type=float, default=None, help="energy exponent (default 2 / 4)")
    parser.add_argument("--max-steps", type=int, default=2000, help="accepted steps per run")
    parser.add_argument("--no-escapes", action="store_true", help="do not try escapes on a stall")
    parser.add_argument("--vertex-index", type=int, default=None, help="FOLD vertex to unfold")
    parser.add_argument("--no-pictures", action="store_true", help="skip PNG/GIF output")
    add_out_argument(parser)
    parser.set_defaults(func=run)


def catalogue_vertex(name: str):
    """The `SingleVertex` of a catalogue example (one of `EXAMPLES`)."""
    from .. import vertex

    makers = {
        "corner-cube": vertex.corner_cube,
        "waterbomb": vertex.waterbomb_base,
        "degree4": vertex.degree4_vertex,
        "open-chain": vertex.open_chain_vertex,
    }
    return makers[name]()


def load_target(target: str, vertex_index: int | None = None):
    """The `SingleVertex` named by `target` (catalogue name or FOLD file)."""
    if target in EXAMPLES:
        return catalogue_vertex(target)
    if not target.endswith(".fold"):
        raise ValueError(
            f"unknown example {target!r}: choose {', '.join(EXAMPLES)} or a .fold file"
        )
    from ..vertex import load_single_vertex

    return load_single_vertex(Path(target), vertex_index=vertex_index)


def write_path(result, out: Path, stem: str = "path") -> list[Path]:
    """Write the path as `<stem>.npz` (radians, unit vectors) and `<stem>.csv` (degrees)."""
    import numpy as np

    npz = out / f"{stem}.npz"
    np.savez(
        npz,
        directions=result.path,
        fold_angles_rad=result.fold_angles,
        energy=result.energy,
        path_length_rad=result.path_length,
        sector_angles_rad=np.asarray(result.vertex.sector_angles),
        creases=result.crease_report.creases,
        closed=result.vertex.closed,
        verdict=result.verdict.value,
        units="directions: unit vectors (dimensionless); angles: radians; energy: dimensionless",
    )
    csv = out / f"{stem}.csv"
    creases = result.crease_report.creases
    header = ["step", "path_length_rad", "energy"] + [f"fold_{int(c)}_deg" for c in creases]
    rows = np.column_stack(
        [
            np.arange(len(result.path)),
            result.path_length,
            result.energy,
            np.rad2deg(result.fold_angles),
        ]
    )
    np.savetxt(csv, rows, delimiter=",", header=",".join(header), comments="", fmt="%.10g")
    return [npz, csv]


def run(args: argparse.Namespace) -> int:
    from .. import vertex

    try:
        target = load_target(args.target, args.vertex_index)
    except (ValueError, OSError) as error:
        print(f"origami-jax unfold: {error}", file=sys.stderr)
        return EXIT_USAGE
    out = prepare_out(Path(args.out))
    result = vertex.unfold(
        target, energy=args.energy, p=args.p, max_steps=args.max_steps, escapes=not args.no_escapes
    )
    print(result.summary())
    if result.verdict == vertex.Verdict.INVALID:
        return EXIT_FAILED
    written = write_path(result, out)
    if not args.no_pictures:
        from ..plotting.vertex import save_unfolding_pictures

        written += save_unfolding_pictures(result, out)
    print("wrote " + ", ".join(str(p) for p in written))
    return EXIT_OK if result.verdict == vertex.Verdict.FLAT_UNFOLDED else EXIT_FAILED
