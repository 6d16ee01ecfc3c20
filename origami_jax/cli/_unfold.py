"""`origami-jax unfold`: Unfold a single-vertex origami by charge-energy descent and give a verdict (flat-unfoldable or not)."""

import argparse
import io
import math
import re
from pathlib import Path

from ._common import EXIT_FAILED, EXIT_OK, OutputFolder, add_out_argument, fail, write_atomic

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
    parser.add_argument(
        "--p", type=float, default=None, help="energy exponent, > 0 (default 2 / 4)"
    )
    parser.add_argument(
        "--max-steps", type=int, default=2000, help="accepted steps per run, >= 1 (default 2000)"
    )
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


# Vertices a one-line message names (of the table the library's message lists).
_INLINE_VERTICES = 4


def _with_table_inline(message: str) -> str:
    """A message whose vertex table follows on its own lines (`format_vertex_table`) as one line:
    the message, then the first few vertices separated by semicolons."""
    head, _, table = message.partition("\n")
    rows = [" ".join(row.split()) for row in table.splitlines() if row.strip()]
    if not rows:
        return message
    beyond = 0  # the table's own last line when it was cut: "... and N more (...)"
    if rows[-1].startswith("...") and (cut := re.search(r"and (\d+) more", rows[-1])):
        beyond, rows = int(cut.group(1)), rows[:-1]
    more = len(rows) - _INLINE_VERTICES + beyond
    return f"{head} {'; '.join(rows[:_INLINE_VERTICES])}" + (
        f"; ... and {more} more" if more > 0 else ""
    )


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
    buffer = io.BytesIO()
    np.savez(
        buffer,
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
    write_atomic(npz, buffer.getvalue())
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
    buffer = io.BytesIO()
    np.savetxt(buffer, rows, delimiter=",", header=",".join(header), comments="", fmt="%.10g")
    write_atomic(csv, buffer.getvalue())
    return [npz, csv]


# Files `unfold` writes: the path and the pictures of `save_unfolding_pictures`.
OWNS = (
    "path.npz",
    "path.csv",
    "path.html",
    "unfolding_strip.png",
    "unfolding_energy.png",
    "unfolding.gif",
)


def run(args: argparse.Namespace) -> int:
    from .. import vertex

    if args.p is not None and not (math.isfinite(args.p) and args.p > 0):
        fail(f"--p must be a positive finite energy exponent (e.g. 2 or 4), got {args.p}.")
    if args.max_steps < 1:
        fail(f"--max-steps must be at least 1, got {args.max_steps}.")
    if args.vertex_index is not None and args.vertex_index < 0:
        fail(f"--vertex-index must be >= 0, got {args.vertex_index}.")
    if args.target not in EXAMPLES and not Path(args.target).is_file():
        fail(
            f"no such file: {args.target}"
            if args.target.endswith(".fold")
            else f"unknown example {args.target!r}: choose {', '.join(EXAMPLES)} or a .fold file"
        )
    output = OutputFolder(Path(args.out), command="unfold", owns=OWNS, overwrite=args.overwrite)
    with output:
        try:
            target = load_target(args.target, args.vertex_index)
        except (ValueError, OSError) as error:
            fail(_with_table_inline(str(error)))
        result = vertex.unfold(
            target,
            energy=args.energy,
            p=args.p,
            max_steps=args.max_steps,
            escapes=not args.no_escapes,
        )
        print(result.summary())
        if result.verdict == vertex.Verdict.INVALID:
            output.discard()
            return EXIT_FAILED
        written = write_path(result, output.dir)
        if not args.no_pictures:
            from ..plotting.vertex import save_unfolding_pictures

            written += save_unfolding_pictures(result, output.dir)
    print("wrote " + ", ".join(str(output.final(p)) for p in written))
    return EXIT_OK if result.verdict == vertex.Verdict.FLAT_UNFOLDED else EXIT_FAILED
