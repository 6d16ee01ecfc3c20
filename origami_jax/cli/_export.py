"""`origami-jax export`: Export geometry or results to other formats (FOLD).

- `origami-jax export corner-cube|waterbomb|degree4|open-chain --format fold --out DIR` writes a catalogue
  single vertex (from `origami_jax.vertex`) as a FOLD file Origami Simulator and Rabbit Ear load.
- `origami-jax export FILE.fold --format fold --out DIR` re-exports a FOLD file normalised: spec 1.2,
  faces and assignments derived where missing, every default fold angle made explicit.
"""

import argparse
import sys
from pathlib import Path

from ._common import EXIT_OK, EXIT_USAGE, add_out_argument, prepare_out
from ._unfold import EXAMPLES as CATALOGUE
from ._unfold import catalogue_vertex

HELP = "Export geometry or results to other formats (FOLD)."
FORMATS = ("fold",)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help=HELP,
        description=HELP
        + " SOURCE is a catalogue vertex ("
        + ", ".join(CATALOGUE)
        + ") or a .fold file to re-export normalised.",
    )
    parser.add_argument(
        "source",
        metavar="SOURCE",
        help=f"{' | '.join(CATALOGUE)} | FILE.fold",
    )
    parser.add_argument(
        "--format",
        choices=FORMATS,
        default="fold",
        help="output format (default: fold, FOLD 1.2 JSON)",
    )
    parser.add_argument(
        "--name",
        default=None,
        help="output file name without extension (default: the source's name)",
    )
    add_out_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from origami_jax.fold import FoldFormatError

    try:
        if args.source in CATALOGUE:
            return _export_catalogue(args)
        if args.source.lower().endswith(".fold") or Path(args.source).exists():
            return _export_file(args)
    except FoldFormatError as error:
        print(f"origami-jax export: {error}", file=sys.stderr)
        return EXIT_USAGE
    print(
        f"origami-jax export: unknown SOURCE {args.source!r}: give one of "
        f"{', '.join(CATALOGUE)} or a .fold file",
        file=sys.stderr,
    )
    return EXIT_USAGE


def _export_file(args: argparse.Namespace) -> int:
    from origami_jax.fold import (
        candidate_vertices,
        list_vertices,
        normalise_fold,
        read_fold,
        write_fold,
    )

    source = Path(args.source)
    if not source.is_file():
        print(f"origami-jax export: no such file: {source}", file=sys.stderr)
        return EXIT_USAGE
    fold = normalise_fold(read_fold(source))
    out = prepare_out(Path(args.out))
    target = out / f"{args.name or source.stem}.fold"
    if target.resolve() == source.resolve():
        print(
            f"origami-jax export: refusing to overwrite the input {source}; choose another --out "
            "or --name",
            file=sys.stderr,
        )
        return EXIT_USAGE
    write_fold(target, fold)
    key = fold.key_frame
    print(
        f"wrote {target}: FOLD {fold.file_spec}, {fold.n_frames} frame(s), {key.n_vertices} "
        f"vertices, {key.n_edges} edges, {len(key.faces_vertices or ())} faces"
    )
    if key.edges_assignment is not None:
        candidates = candidate_vertices(list_vertices(fold))
        if candidates:
            print("vertices where creases meet (origami-jax unfold FILE --vertex N):")
            for vertex in candidates:
                print(f"  {vertex}")
    return EXIT_OK


def _export_catalogue(args: argparse.Namespace) -> int:
    # Imported here so that `origami-jax --help` does not load JAX.
    from ..fold import write_fold
    from ..vertex import single_vertex_to_fold

    fold = single_vertex_to_fold(catalogue_vertex(args.source), title=args.source)
    out = prepare_out(Path(args.out))
    target = write_fold(out / f"{args.name or args.source}.fold", fold)
    print(f"wrote {target}: {args.source}, {fold.n_frames} frame(s) (crease pattern + state)")
    return EXIT_OK
