"""`origami-jax fold`: fold a net of panels, or a crease pattern with closed loops, from FOLD under its
stressed hinges.

Writes `result.json` (the verdict and the numbers behind it), `trajectory.csv` (hinge angles against
time), `trajectory.fold` (the folding as FOLD frames: `origami-jax view` plays it), and unless
`--figures none` the angle plot and a strip of 3D frames (`png`) and an animation (`all`, the
default).
"""

import argparse
import math
from pathlib import Path

from .._exported import note_programs_used
from .._limits import FOLD_MAX_STEPS, FOLD_SEGMENT, MAX_FOLD_SEGMENTS, MAX_SAMPLES
from ._common import (
    EXIT_FAILED,
    EXIT_OK,
    OutputFolder,
    add_agitation_argument,
    add_contact_sampling_argument,
    add_dynamics_arguments,
    add_figures_argument,
    add_out_argument,
    add_solver_arguments,
    add_surface_arguments,
    contact_sampling,
    dumps_json,
    dynamics_model,
    fail,
    hinge_params,
    in_range,
    int_range,
    positive,
    refuse_busy_folder,
    seam_tolerance_value,
    solver_choice,
    surface_model,
    with_solver,
)
from ._painter import FoldFigures, Painter
from ._panels import (
    check_explicit_steps,
    check_has_creases,
    check_panels_thicker_than_film,
    check_targets,
    warn_if_films_too_thick_to_close,
)

# Every file `run` writes into --out (an earlier run's are refused without --overwrite).
OWNS = (
    "result.json",
    "trajectory.csv",
    "trajectory.fold",
    "angles.png",
    "frames.png",
    "animation.gif",
)

HELP = (
    "Fold a net or a crease pattern (FOLD file or catalogue name) under its hinges; say whether it "
    "folds."
)
DESCRIPTION = (
    HELP
    + """

NET is a FOLD file, or the name of a shipped pattern (origami-jax fold --list): a net (faces joined
by creases into a tree; cut seams allowed) or a crease pattern whose creases close loops around
interior vertices (single vertices, Miura-ori, waterbombs; the loops are held closed as constraints;
an Origami Simulator export is read as it is, with --length-scale for its unitless coordinates).
A file that holds only a folded form (3D) is unfolded to its crease pattern, each crease aiming at
its dihedral angle in the form (a closed polyhedron is cut where a warning says).
The largest face stays on the substrate (--root picks another); every crease is a bilayer hinge of
the literature design (200 nm SiNx, 100 nm Cr at 1 GPa, 200 µm wide or as wide as a shorter crease;
override any HingeDesign field with --param NAME=VALUE or NAME=V0,V1,... per crease, in MICRO units:
µm, µs, ng, MPa) folding to the crease's edges_foldAngle, in the KOH etch bath where released
devices fold (--fluid air: the paper's setting, where panels ring far longer). Panels have the
membrane's thickness and meet (contact) unless --no-contact; drag acts on every panel from its own
motion (--drag hinge: the paper's per-hinge drag). In the bath the panels also carry the fluid's
inertia (hundreds of times their own) and its viscous drag, and each hinge is released
quasi-statically, its torque growing over a few periods of the panels' slowest motion (40 ms for a
200 µm cube net; a real etch frees a hinge over minutes): --no-fluid-inertia and --release-ramp 0
are the paper's dynamics, released at once.

A closed-loop pattern starts flat, where its folding branches meet, and the hinges pick the branch;
--bias RAD starts it pre-folded by RAD along the branch the hinges aim at. A pattern that rigid panels
cannot fold to its angles (a square twist) is refused with the closure residual (--no-rigid-check
simulates it anyway).

Creases and seams are numbered from 0, in the order of --targets and --release, of
result.json's arrays and of the verdict; result.json's crease_edges gives each crease's FOLD edges,
seam_faces and seam_edges the two FOLD faces and edges each seam joins.

Verdicts: folded (every crease within --tolerance, every seam closed: within the seam tolerance or
its panels touching; by default each seam's tolerance is the gap it would have with every crease
just within --tolerance, derived from the geometry; --seam-tolerance 0.01 judges every seam against
1 % of the largest panel's size instead, the default before), jammed (contact stops a crease short), misfolded (another final state, another branch),
unfinished (time ran out; without --t1 a net still moving is folded on, 1000 µs at a time after
the release ramp, up to 8 such segments), invalid (the simulation failed).

--solver implicit-step --dt US folds in fixed implicit Euler steps (Newton iterations capped by
the plates' collision detection: no panel steps through another however long the step), first-order
accurate and damped; --solver implicit-bdf2 takes the same steps with the second-order BDF2 formula
(far less damped); the adaptive default resolves every impact and the ringing. result.json
records the solver (with the step and Newton iterations) and its stats the largest Newton update
left at the end of a step (newton_error, rad: small against the motion when the steps converged)
and the steps whose working set of contact pairs missed one (contacts_left_out: 0 expected).
Exit codes: 0 folded, 1 any other verdict, 2 bad input.
"""
)


# Without --t1: fold for FOLD_SEGMENT (µs), and while the panels still move ("unfinished", not
# because the solver ran out of steps, or "folded" but not at rest), continue from where the run ended, up to
# MAX_FOLD_SEGMENTS segments (`Net.fold`'s defaults). The continuations reuse the compiled solve
# (times and the initial state are traced values).


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fold",
        help=HELP,
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("net", nargs="?", help="FOLD file or catalogue name")
    parser.add_argument(
        "--list", action="store_true", help="list the shipped nets and their families, and exit"
    )
    parser.add_argument(
        "--fluid",
        choices=("air", "koh"),
        default="koh",
        help="the fluid the panels fold in (default koh: released devices fold in the etch bath; "
        "air is the paper's setting)",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override a HingeDesign field (MICRO units) on every crease, or give one value per "
        "crease: NAME=V0,V1,... (e.g. hinge_width=100,200,100); repeatable",
    )
    parser.add_argument(
        "--t1",
        type=float,
        default=None,
        help=f"end time, µs (default {FOLD_SEGMENT:g} after the release ramp, continued by as "
        f"much while the panels still move, up to {MAX_FOLD_SEGMENTS} times)",
    )
    parser.add_argument(
        "--n-save", type=int, default=501, help="samples per segment (default 501, at least 21)"
    )
    parser.add_argument(
        "--targets",
        default=None,
        help="fold target per crease, degrees, comma-separated: where the hinges aim (the verdict "
        "still judges the pattern's own angles; result.json's hinge_targets records them)",
    )
    parser.add_argument(
        "--release", default=None, help="release time per crease, µs, comma-separated (default 0)"
    )
    parser.add_argument(
        "--etch-front",
        default=None,
        metavar="DX,DY,SPEED",
        help="release each crease when an etch front moving along (DX, DY) at SPEED µm/µs passes it",
    )
    parser.add_argument("--no-contact", action="store_true", help="panels pass through each other")
    add_contact_sampling_argument(parser)
    add_surface_arguments(parser)
    add_dynamics_arguments(parser)
    add_agitation_argument(parser, seed=True)
    parser.add_argument("--drag", choices=("panel", "hinge"), default="panel", help="default panel")
    parser.add_argument(
        "--hinges", choices=("point", "arc"), default="point", help="point creases or bending arcs"
    )
    parser.add_argument(
        "--arc-layout",
        choices=("fillet", "drawn"),
        default=None,
        help="with --hinges arc (nets): panels trimmed for their strips so seams close "
        "(default), or strips at the drawn creases; a file drawn with its hinge strips "
        "(faces_origami_jax:hinge) takes them as drawn unless told",
    )
    parser.add_argument("--root", type=int, default=None, help="the fixed face (default: largest)")
    parser.add_argument(
        "--length-scale",
        type=float,
        default=None,
        metavar="UM",
        help="µm per FOLD length unit, for unitless files (Origami Simulator's export)",
    )
    parser.add_argument(
        "--bias",
        type=float,
        default=0.0,
        metavar="RAD",
        help="closed loops: start pre-folded by RAD along the hinges' branch (default 0: flat)",
    )
    parser.add_argument(
        "--flat-creases",
        choices=("panel", "hinge"),
        default=None,
        help="F edges (facet diagonals) join their faces into one rigid panel (default) or, "
        "closed loops only, hinge",
    )
    parser.add_argument(
        "--no-rigid-check",
        action="store_true",
        help="closed loops: simulate a pattern rigid panels cannot fold to its angles anyway",
    )
    parser.add_argument(
        "--tolerance", type=float, default=3.0, help="crease angle tolerance, degrees (default 3)"
    )
    parser.add_argument(
        "--seam-tolerance",
        type=seam_tolerance_value,
        default=None,
        help="seam gap tolerance: 'derived' (default: each seam's tolerance is the gap it would "
        "have with every crease just within --tolerance), or a fixed fraction of the largest "
        "panel's size (0.01, the default before: 2 µm on 200 µm panels)",
    )
    parser.add_argument(
        "--progress",
        choices=("auto", "on", "off"),
        default="auto",
        help="progress bar of the solve: auto (default) shows it for patterns of more than "
        f"{PROGRESS_CREASES} creases; with a bar the solve compiles in every run (it calls back "
        "into Python, which the compilation cache cannot store)",
    )
    add_solver_arguments(parser, "tsit5, as the yield and sweep kernels")
    add_figures_argument(parser)
    add_out_argument(parser)
    parser.set_defaults(func=run)


MIN_SAMPLES = 21
"""Fewest samples of a `fold` run (`--n-save`): the time to fold is the first sample from which the
net stays folded, so it is known to a twentieth of the run at worst (2 samples reported the run's
end)."""

PROGRESS_CREASES = 24
"""`--progress auto`: a bar for patterns with more creases than this (sheets that fold for minutes);
smaller nets fold in seconds, where a solve kept in the cache (no bar) saves more than a bar shows."""


def _progress_meter(choice: str, n_creases: int):
    import diffrax

    if choice == "on" or (choice == "auto" and n_creases > PROGRESS_CREASES):
        return diffrax.TqdmProgressMeter(refresh_steps=200)
    return diffrax.NoProgressMeter()


def _floats(text: str | None, what: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError as error:
        raise ValueError(f"{what}: {error}") from None


def _params(items: list[str]) -> dict[str, float | list[float]]:
    """`--param NAME=VALUE` (every crease) or `NAME=V0,V1,...` (one value per crease, in crease
    order; the count is checked once the net is read), MICRO units."""
    return {name: v[0] if len(v) == 1 else v for name, v in hinge_params(items).items()}


def _per_crease(params: dict, m: int) -> dict:
    """`params` with each list checked to hold one value per crease (`m`) and made an array."""
    import numpy as np

    out = {}
    for name, value in params.items():
        if isinstance(value, list):
            if len(value) != m:
                raise ValueError(
                    f"--param {name}: {len(value)} values for {m} creases (give one, or one per "
                    "crease)"
                )
            value = np.asarray(value)
        out[name] = value
    return out


def _design(net, fluid: str, params: dict):
    """The literature `HingeDesign` in `fluid` (`"air"` or `"koh"`) with the `--param` values
    (one per crease where a list was given); each hinge at most as wide as its crease unless
    `hinge_width` was given."""
    from origami_jax.net import hinges_within_creases
    from origami_jax.system import AIR, KOH_SOLUTION, HingeDesign

    fluid_ = {"air": AIR, "koh": KOH_SOLUTION}[fluid]
    design = HingeDesign.literature(fluid=fluid_, **_per_crease(params, net.n_creases))
    if "hinge_width" in params:
        return design
    return hinges_within_creases(design, net.crease_lengths)


def run(args: argparse.Namespace) -> int:
    from origami_jax.fold import (
        FoldFormatError,
        catalogue_families,
        catalogue_family,
        catalogue_names,
    )

    if args.list:
        if args.net is not None:
            fail(f"--list lists the shipped nets and takes no NET; drop {args.net} or --list.")
        for name in catalogue_names():
            print(name)
        print("# families (origami-jax yield FAMILY estimates each member's yield):")
        for family in catalogue_families():
            print(f"{family}: {','.join(catalogue_family(family))}")
        return EXIT_OK
    if args.net is None:
        fail("give a NET: a FOLD file or a catalogue name (origami-jax fold --list names them).")
    try:
        params = _params(args.param)
        targets_deg = _floats(args.targets, "--targets")
        release = _floats(args.release, "--release")
        front = _floats(args.etch_front, "--etch-front")
    except ValueError as error:
        fail(str(error))
    sampling = contact_sampling(args.contact_sampling, args.contact)
    if release is not None and front is not None:
        fail("give --release or --etch-front, not both (the front sets every release time).")
    if front is not None and len(front) != 3:
        fail("--etch-front expects DX,DY,SPEED (a direction in the plane and a speed in µm/µs).")
    if args.t1 is not None:
        positive(args.t1, "--t1", "µs")
    if args.t1 is None:
        choice = solver_choice(args, FOLD_SEGMENT, "each segment, without --t1")
    else:
        choice = solver_choice(args, args.t1, "--t1")
    int_range(
        args.n_save,
        "--n-save",
        MIN_SAMPLES,
        MAX_SAMPLES,
        why=" (the time to fold is read off the samples: fewer resolve it no better than the run)",
    )
    if not 0 <= args.bias < 1:
        fail(f"--bias must be a pre-fold angle in [0, 1) rad, got {args.bias}.")
    if args.length_scale is not None:
        positive(args.length_scale, "--length-scale", "µm per FOLD length unit")
    in_range(args.tolerance, "--tolerance", 0.0, 180.0, what=" degrees")
    if args.seam_tolerance is not None:
        in_range(
            args.seam_tolerance, "--seam-tolerance", 0.0, 1.0, what=" (a fraction of the panel)"
        )
    for flag, values in (
        ("--targets", targets_deg),
        ("--release", release),
        ("--etch-front", front),
    ):
        if values is not None and not all(math.isfinite(v) for v in values):
            fail(f"{flag} must be finite numbers, got {values}.")
    if targets_deg is not None and not all(-180 <= v <= 180 for v in targets_deg):
        fail(f"--targets are fold angles in degrees, each within [-180, 180]; got {targets_deg}.")
    refuse_busy_folder(Path(args.out), "fold")  # before the system's seconds of building

    import numpy as np

    from origami_jax.fold import FRAME_UNITS_M, is_folded_form, read_fold, source_and_label
    from origami_jax.loops import NotRigidlyFoldableError, load_pattern

    try:
        # Read once: the loader takes the file, and whether it held a folded form is told here.
        path, label = source_and_label(args.net)
        fold = read_fold(path)
        unit = fold.key_frame.frame_unit
        if args.length_scale is not None and FRAME_UNITS_M.get(unit or "unit") is not None:
            fail(
                f"{args.net} gives its lengths in {unit!r}: --length-scale is for unitless files "
                "(Origami Simulator's export); drop it."
            )
        unfolded = is_folded_form(fold.key_frame)
        net = load_pattern(
            fold,
            name=label,
            root=args.root,
            length_scale=args.length_scale,
            flat_creases=args.flat_creases or "panel",
        )
        loops = net.n_loops > 0
        check_has_creases(net, args.net)
        if args.bias and not loops:
            fail(f"--bias pre-folds closed-loop patterns; {args.net} is a net, which starts flat.")
        if args.no_rigid_check and not loops:
            fail(f"--no-rigid-check is for closed-loop patterns; {args.net} is a net: drop it.")
        if args.flat_creases == "hinge" and not loops:
            fail(
                f"--flat-creases hinge is for closed-loop patterns; {args.net} is a net, whose "
                "flat (F) edges would be hinges aimed at 0°, which a stressed hinge is not: drop "
                "it (F edges join their faces into one panel)."
            )
        if args.arc_layout is not None and (args.hinges != "arc" or loops):
            looped = f" ({args.net} has closed loops)" if loops else ""
            fail(
                "--arc-layout lays out a net's bending-arc hinges: it needs --hinges arc and a net"
                f"{looped}."
            )
        m = net.n_creases
        design = _design(net, args.fluid, params)
        check_panels_thicker_than_film(net, design, args.net)
        targets = None
        if targets_deg is not None:
            if len(targets_deg) != m:
                raise ValueError(f"--targets: {len(targets_deg)} values for {m} creases")
            targets = np.radians(targets_deg)
        check_targets(net, targets, args.net, design)
        if args.hinges != "arc" and not loops:
            warn_if_films_too_thick_to_close(net, design, args.net, args.tolerance)
        if release is not None and len(release) != m:
            raise ValueError(f"--release: {len(release)} values for {m} creases")
        if front is not None:
            release = net.release_times_from_front(front[:2], front[2])
        model = dict(
            contact=False if args.no_contact else args.contact,
            drag=args.drag,
            hinges=args.hinges,
            contact_sampling=sampling,
        )
        if loops:
            model["check_rigid"] = not args.no_rigid_check
        layout = {"arc_layout": args.arc_layout} if args.hinges == "arc" and not loops else {}
        net = net.with_model(**model)
        net = net.with_model(**surface_model(args, net, design), **dynamics_model(args))
        system = net.kept_system(design, targets=targets, release_times=release, **layout)
        ramp = net.release_ramp_for(system)
        if args.t1 is not None and ramp is not None and args.t1 <= ramp:
            raise ValueError(
                f"--t1 {args.t1:g} µs ends within the release ramp ({ramp:g} µs): no hinge is "
                "whole before the end; give a longer --t1, or --release-ramp 0 (released at once)"
            )
        if args.bias:
            net.start_state(system, bias=args.bias)  # refused here, before the output folder
        if choice is None or choice["solver"] == "tsit5":
            span = args.t1 or net.fold_segment(system)
            check_explicit_steps(system, span, "--t1" if args.t1 else "each segment", loops)
    except FileNotFoundError as error:
        fail(str(error))  # it names the file
    except NotRigidlyFoldableError as error:
        fail(str(error))  # it names the pattern
    except (FoldFormatError, ValueError, TypeError, OSError) as error:
        text = str(error)  # a file's own errors start with its path already
        fail(text if text.startswith(f"{args.net}:") else f"{args.net}: {text}")

    drawn = len(fold.key_frame.faces_vertices or ())
    strips = getattr(net, "drawn_layout", None) is not None  # a file's hinge strips are no panels
    if drawn > net.geometry.n_faces and not strips:
        print(
            f"[fold] {net.name}: the file's {drawn} faces joined across flat (F) edges into "
            f"{net.geometry.n_faces} panels (the outputs describe the panels)",
            flush=True,
        )
    output = OutputFolder(Path(args.out), command="fold", owns=OWNS, overwrite=args.overwrite)
    # The figures' worker starts now, importing matplotlib while the net folds (`_painter`).
    with output, Painter(enabled=args.figures != "none") as painter:
        code = _run(
            args, net, system, params, release, sampling, output, unfolded,
            choice=choice, design=design, painter=painter,
        )  # fmt: skip
    return code


def _run(
    args, net, system, params, release, sampling, output, unfolded, *, choice, design, painter
) -> int:
    """Fold, assess and write into the staging folder of `output`; returns the exit code.
    `unfolded`: the file held a folded form, read as the crease pattern it unfolds to; `choice`:
    `--solver` and its settings (`solver_choice`); `design`, the one `system` was built with;
    `painter`, the `Painter` that draws the figures while the other files are written."""
    import diffrax
    import numpy as np

    import origami_jax.simulation as sim
    from origami_jax.net import model_settings

    out = output.dir
    m = net.n_creases
    loops = net.n_loops > 0
    kind = f"{net.n_loops} closed loop(s), " if loops else ""
    if unfolded:
        print(
            f"[fold] {net.name}: the file holds a folded form: unfolded to its crease pattern, each "
            "crease aiming at its dihedral angle in the form",
            flush=True,
        )
    segment = net.fold_segment(system) if args.t1 is None else args.t1
    ramp = net.release_ramp_for(system)
    # A quasi-static release sets the time to fold: say so before it is read as the hinges' own.
    released = "" if ramp is None else f", each hinge released over {ramp:g} µs"
    print(
        f"[fold] {net.name}: {m} creases, {kind}{system.mechanism.n_bodies} moving panels, contact "
        f"{'on' if system.contact is not None else 'off'}{released}; compiling and folding for "
        f"{segment:g} µs ...",
        flush=True,
    )
    # Explicit Tsit5, as the kernels that judge yields. The library's default (switching to
    # Kvaerno5 once stiff) fires on a quasi-static release in the bath, where the explicit steps
    # were fewer and each far cheaper, and its implicit half is one more program to compile (on
    # closed loops it differentiates through the constraint solve and compiles for minutes).
    solver = diffrax.Tsit5()
    tolerances = sim.VerdictTolerances.from_degrees(args.tolerance, args.seam_tolerance)
    segments = 1

    def still_moving(end, next_end):
        nonlocal segments
        segments += 1
        print(f"[fold] still moving at {end:g} µs; folding on to {next_end:g} µs ...", flush=True)

    # The pattern's fold: continued while still moving unless --t1 (a closed-loop pattern's state
    # is not its hinge angles: one segment).
    options = with_solver(
        sim.SolveOptions(
            # The verdict, files and figures read angles and rates: no accelerations to compile.
            saveat=sim.SaveAt(n=args.n_save, accelerations=False),
            solver=solver,
            max_steps=FOLD_MAX_STEPS,
            throw=False,
            progress_meter=_progress_meter(args.progress, m),
        ),
        choice,
    )
    bias = sim.start_bias(net, options.solver, args.bias)
    if bias != args.bias:
        print(
            f"[fold] starting pre-folded by {bias:g} rad along the aimed branch: fixed steps cannot "
            "choose a branch at the flat state (--bias sets the pre-fold).",
            flush=True,
        )
    trajectory, report = net.fold(
        system,
        None,  # the pattern's own release (`release_input`), its ramp computed once there
        t1=args.t1,
        bias=bias,
        tolerances=tolerances,
        on_continue=still_moving,
        options=options,
    )
    t_end = float(np.asarray(trajectory.times)[-1])
    if args.figures != "none" and bool(trajectory.succeeded):
        job = figure_job(system, trajectory, report, out, net.name, animation=args.figures == "all")
        painter.send(job)  # drawn while the files below are written
    if segments == MAX_FOLD_SEGMENTS and report.verdict == "unfinished":
        print(
            f"[fold] still moving at {t_end:g} µs, the end of the automatic extension: give a "
            "longer --t1, or more damping (in air a net rings far longer than in the etch bath).",
            flush=True,
        )
    result = report.to_dict()
    result.update(
        net=net.name,
        creases=m,
        units={"time": "us", "length": "um", "angle": "rad"},
        params=params,
        fluid=args.fluid,
        contact=False if args.no_contact else args.contact,
        contact_sampling=list(sampling),
        drag=args.drag,
        hinges=args.hinges,
        **(
            {"arc_layout": _arc_layout_name(args, net)}
            if args.hinges == "arc" and not loops
            else {}
        ),
        **model_settings(net, design, system),
        closed_loops=net.n_loops if loops else 0,
        unfolded_from_folded_form=unfolded,
        bias=bias,
        **(choice or {"solver": "tsit5"}),
        length_scale=float(net.length_scale),  # µm per FOLD length unit, as used
        t1=t_end,
        segments=segments,
        release_times=None if release is None else [float(x) for x in release],
        hinge_targets=[float(x) for x in np.asarray(system.hinges.target)],
        stats={
            k: (int(v) if np.asarray(v).dtype.kind in "iu" else float(v))
            for k, v in trajectory.stats.items()
        },
        final_angles_deg=[float(x) for x in np.degrees(report.final_angles)],
        **numbering(net),
    )
    result["stats"] = {
        k: (v if not isinstance(v, float) or np.isfinite(v) else None)
        for k, v in result["stats"].items()
    }
    (out / "result.json").write_text(dumps_json(result))
    write_folding(out, net, system, trajectory, report)
    # The next fold of this system reads these executables while it starts (`prefetch`).
    note_programs_used()
    print(report.summary())
    written = ["result.json", "trajectory.csv", "trajectory.fold", *painter.finish()]
    print(f"wrote {output.out}: {', '.join(written)}")
    return EXIT_OK if report.verdict == "folded" else EXIT_FAILED


def write_folding(out: Path, net, system, trajectory, report) -> list[str]:
    """A folding's files in `out`: `trajectory.csv` (time in µs, each crease's angle in rad, every
    saved sample) and `trajectory.fold` (the net's FOLD animation, about 200 frames, annotated for
    `origami-jax view`: the verdict, the creases off target, where panels touch). Returns their
    names."""
    import numpy as np

    from origami_jax.fold import write_fold

    times = np.asarray(trajectory.times)
    theta = np.asarray(trajectory.theta)
    header = "time [us]," + ",".join(f"theta_{j} [rad]" for j in range(theta.shape[-1]))
    np.savetxt(
        out / "trajectory.csv",
        np.column_stack([times, theta]),
        delimiter=",",
        header=header,
        comments="",
        fmt="%.12g",
    )
    every = max(1, len(times) // 200)
    extras, key_extra = _view_annotations(net, system, trajectory, report, every)
    animation = net.to_fold(trajectory, every=every, extras=extras, key_extra=key_extra)
    write_fold(out / "trajectory.fold", animation)
    return ["trajectory.csv", "trajectory.fold"]


def figure_job(system, trajectory, report, out: Path, name: str, *, animation: bool = False):
    """The figures of a folding (`_figure_job`), showing the fold itself rather than the long rest
    after it: to twice its time to fold where it folded."""
    import numpy as np

    t_end = float(np.asarray(trajectory.times)[-1])  # on the host: indexing a device array compiles
    t_max = None if report.time_to_fold is None else min(2.0 * report.time_to_fold, t_end)
    return _figure_job(system, trajectory, report, out, name, t_max, animation=animation)


def _arc_layout_name(args, net) -> str:
    """The arc layout a net's arc hinges took: the one asked for, else the file's hinge strips
    (`"strips"`) or `"fillet"`."""
    if args.arc_layout is not None:
        return args.arc_layout
    return "fillet" if getattr(net, "drawn_layout", None) is None else "strips"


def numbering(net) -> dict[str, list]:
    """Where the creases and seams that the verdict numbers (from 0) are in the FOLD file:
    `crease_edges` (each crease's FOLD edges), `seam_faces` and `seam_edges` (the two FOLD faces, and
    their two edges, that each seam joins)."""
    import numpy as np

    return dict(
        crease_edges=[[int(e) for e in edges] for edges in net.crease_edge_ids],
        seam_faces=np.asarray(net.seams.faces, dtype=int).reshape(-1, 2).tolist(),
        seam_edges=np.asarray(net.seams.edges, dtype=int).reshape(-1, 2).tolist(),
    )


def _figure_job(system, trajectory, report, out: Path, name: str, t_max, *, animation: bool):
    """The fold's figures as a `FoldFigures` job (`_painter`): the angle plot titled with the
    verdict (the time to fold marked), a strip of 3D frames and (with `animation`) a GIF, as plain
    arrays; the frames' panel outlines are computed here (JAX), the drawing needs matplotlib only."""
    import numpy as np

    from origami_jax.plotting.frames import frame_set

    frames = frame_set(system, trajectory, 6, t_max, by_motion=True)
    gif = frame_set(system, trajectory, 24, t_max, by_motion=True) if animation else None
    return FoldFigures(
        out=out,
        title=f"{name}: {report.verdict}",
        times=np.asarray(trajectory.times),
        theta=np.asarray(trajectory.theta),
        target=np.asarray(trajectory.target),
        time_to_fold=report.time_to_fold,
        frames=frames,
        animation=gif,
    )


def _view_annotations(net, system, trajectory, report, every: int) -> tuple[list[dict], dict]:
    """What `origami-jax view trajectory.fold` shows beside the panels: the verdict, its reason and
    the FOLD edges of the creases outside tolerance (crease-pattern frame), and where panels touch
    in every frame the animation keeps (`every`; in the FOLD file's unit)."""
    import numpy as np

    from origami_jax.contact import contact_points
    from origami_jax.net import kept_samples

    key_extra = {
        "origami_jax:verdict": str(report.verdict),
        "origami_jax:verdict_reason": report.reason,
        "origami_jax:off_target_edges": sorted(
            int(e) for j in np.nonzero(report.off_target)[0] for e in net.crease_edge_ids[int(j)]
        ),
    }
    states = np.asarray(trajectory.theta if trajectory.state is None else trajectory.state[0])
    extras: list[dict] = [{} for _ in range(len(states))]
    kept = kept_samples(np.asarray(trajectory.theta), every)
    frames, points, _ = contact_points(system, states[kept])
    points = points / net.length_scale
    for s in np.unique(frames):
        extras[int(kept[s])]["origami_jax:contact_points"] = points[frames == s].round(9).tolist()
    return extras, key_extra
