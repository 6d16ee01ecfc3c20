"""`origami-jax export`: Export geometry or results to other formats (FOLD).

- `origami-jax export corner-cube|waterbomb|degree4|open-chain --format fold --out DIR` writes a catalogue
  single vertex (from `origami_jax.vertex`) as a FOLD file Origami Simulator and Rabbit Ear load.
- `origami-jax export FILE.fold --format fold --out DIR` re-exports a FOLD file normalised: spec 1.2,
  faces and assignments derived where missing, every default fold angle made explicit.
"""

import argparse
from pathlib import Path

from ._common import EXIT_OK, OutputFolder, add_out_argument, fail
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

    if args.name is not None and (not args.name or Path(args.name).name != args.name):
        fail(f"--name must be a plain file name without folders, got {args.name!r}.")
    try:
        if args.source in CATALOGUE:
            return _export_catalogue(args)
        if args.source.lower().endswith(".fold") or Path(args.source).exists():
            return _export_file(args)
    except FoldFormatError as error:
        fail(str(error))
    fail(
        f"unknown SOURCE {args.source!r}: give one of {', '.join(CATALOGUE)} or a .fold file",
    )


# Vertices listed after an export (a large pattern has thousands).
LISTED_VERTICES = 20


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
        fail(f"no such file: {source}")
    fold = normalise_fold(read_fold(source))
    name = f"{args.name or source.stem}.fold"
    if (Path(args.out) / name).resolve() == source.resolve():
        fail(f"refusing to overwrite the input {source}; choose another --out or --name")
    output = OutputFolder(Path(args.out), command="export", owns=(name,), overwrite=args.overwrite)
    with output:
        write_fold(output.dir / name, fold)
    target = output.out / name
    key = fold.key_frame
    print(
        f"wrote {target}: FOLD {fold.file_spec}, {fold.n_frames} frame(s), {key.n_vertices} "
        f"vertices, {key.n_edges} edges, {len(key.faces_vertices or ())} faces"
    )
    if key.edges_assignment is not None:
        candidates = candidate_vertices(list_vertices(fold))
        if candidates:
            print("vertices where creases meet (origami-jax unfold FILE --vertex-index N):")
            for vertex in candidates[:LISTED_VERTICES]:
                print(f"  {vertex}")
            if len(candidates) > LISTED_VERTICES:
                print(f"  ... and {len(candidates) - LISTED_VERTICES} more")
    return EXIT_OK


def _export_catalogue(args: argparse.Namespace) -> int:
    # Imported here so that `origami-jax --help` does not load JAX.
    from ..fold import write_fold
    from ..vertex import single_vertex_to_fold

    name = f"{args.name or args.source}.fold"
    output = OutputFolder(Path(args.out), command="export", owns=(name,), overwrite=args.overwrite)
    with output:
        fold = single_vertex_to_fold(catalogue_vertex(args.source), title=args.source)
        write_fold(output.dir / name, fold)
    target = output.out / name
    print(f"wrote {target}: {args.source}, {fold.n_frames} frame(s) (crease pattern + state)")
    return EXIT_OK
