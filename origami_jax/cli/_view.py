"""`origami-jax view`: an interactive 3D view of a result, as one self-contained HTML page."""

import argparse
import os
import sys
from pathlib import Path

from .._limits import MAX_SAMPLES
from ._common import EXIT_OK, check_out_folder, fail, one_line, out_path

HELP = "Write an interactive 3D view of a result (one offline HTML page) and open it if asked."
DESCRIPTION = """\
Write an interactive 3D view of a result as one self-contained HTML page: panels with thickness and
hinges in 3D, a time slider with play/pause, the fold angles plotted against time with a cursor
linked to the slider, contacts and the verdict highlighted, camera presets. The page bundles its 3D
library and works offline.

RESULT is one of:
  FILE.fold                     a FOLD file; its frames are the animation (Origami Simulator, Rabbit
                                Ear, `origami-jax export`); flat crease-pattern frames are folded by
                                their fold angles
  OUT/path.npz                  the unfolding path written by `origami-jax unfold`
  OUT/trajectory.csv|.npz       the trajectory written by `origami-jax simulate` (its metrics.json
                                beside it gives the design)
  OUT/sweep.nc --member K       design K of an accordion `origami-jax sweep`, simulated again
  NAME                          a shipped pattern (origami-jax fold --list) previewed: flat, then every
                                crease turned linearly to its intended angle (kinematics, not a
                                simulation: fold it with `origami-jax fold` and view the trajectory)
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "view",
        help=HELP,
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "result", type=Path, metavar="RESULT", help="the result or shipped pattern to view (above)"
    )
    parser.add_argument(
        "--out",
        type=out_path,
        default=None,
        help="the page to write (FILE.html), or a folder for it (default: beside RESULT, "
        "RESULT's name with .html; a sweep member: sweep_member_K.html)",
    )
    parser.add_argument(
        "--frames",
        type=int,
        default=None,
        help="at most this many frames, evenly spaced in time (default 300; 0 keeps every sample)",
    )
    parser.add_argument("--member", type=int, default=None, help="design index in a sweep.nc")
    parser.add_argument(
        "--overwrite", action="store_true", help="replace an existing page (default: refuse)"
    )
    parser.add_argument("--title", default=None, help="the page's title")
    parser.add_argument("--open", action="store_true", help="open the page in the web browser")
    parser.set_defaults(func=run)


def _target(args: argparse.Namespace) -> Path:
    result: Path = args.result
    name = f"{result.stem}.html"
    if _shipped_pattern(args):
        # A name, not a file: the page goes to the working folder (or --out), never beside it.
        result = Path(name)
    if result.suffix.lower() == ".nc" and args.member is not None:
        name = f"{result.stem}_member_{args.member}.html"
    if args.out is None:
        return result.with_name(name)
    if args.out.suffix.lower() in (".html", ".htm"):
        return args.out
    return args.out / name


def _shipped_pattern(args: argparse.Namespace) -> bool:
    """Whether RESULT names a shipped pattern (and no file of that name exists)."""
    from ..fold import catalogue_names

    name = str(args.result)
    return not args.result.exists() and name.removesuffix(".fold") in catalogue_names()


def _pattern_scene(name: str, title: str | None):
    """The preview of shipped pattern `name`: flat, then folded to its intended angles."""
    from ..loops import load_pattern
    from ..view import scene_from_pattern

    return scene_from_pattern(load_pattern(name.removesuffix(".fold")), title=title)


def run(args: argparse.Namespace) -> int:
    from ..view import DEFAULT_MAX_FRAMES, load_scene, open_in_browser, resample, write_html

    frames = args.frames
    if frames is not None and (frames < 0 or frames == 1 or frames > MAX_SAMPLES):
        fail(f"--frames must be 0 (all samples) or between 2 and {MAX_SAMPLES}, got {args.frames}.")
    max_frames = DEFAULT_MAX_FRAMES if args.frames is None else (args.frames or None)
    if args.member is not None and args.result.suffix.lower() != ".nc":
        fail("--member only applies to a sweep.nc")
    if args.member is not None and args.member < 0:
        fail(f"--member must be a design index >= 0, got {args.member}")
    if args.result.is_symlink() and not args.result.exists():
        fail(f"{args.result} is a link to {os.readlink(args.result)}, which does not exist")
    shipped = _shipped_pattern(args)
    if not shipped and not args.result.exists():
        fail(f"no such file or shipped pattern: {args.result} (origami-jax fold --list names them)")
    target = _target(args)
    if target.is_dir():
        fail(f"{target} is a folder: give --out FILE.html or a folder to put the page in")
    if target.exists() and not args.overwrite:
        fail(f"{target} exists; pass --overwrite to replace it, or choose another --out")
    check_out_folder(target.parent, "the folder of the page")
    try:
        if shipped:
            scene = _pattern_scene(str(args.result), args.title)
        else:
            scene = load_scene(args.result, member=args.member, title=args.title)
        samples = scene.n_frames
        scene = resample(scene, max_frames)
        target = write_html(scene, target)
    except (ValueError, OSError, KeyError) as error:
        fail(one_line(str(error)) or type(error).__name__)
    shown = f"{scene.n_frames} frames" + (
        f" of {samples} samples" if samples > scene.n_frames else ""
    )
    print(
        f"wrote {target}: {scene.n_panels} panels, {scene.n_hinges} hinges, {shown}"
        + (f"; {scene.verdict}" if scene.verdict else "")
    )
    if args.open and not open_in_browser(target):
        print(f"no web browser could be started: open {target} yourself", file=sys.stderr)
    return EXIT_OK
