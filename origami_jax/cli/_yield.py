"""`origami-jax yield`: how often a net folds correctly under fabrication scatter (Monte Carlo)."""

import argparse
import json
import math
import time
from pathlib import Path

from .._exported import note_programs_used
from .._limits import AFTER_RELEASE_US, KERNEL_MAX_STEPS, default_t_end
from ._common import (
    EXIT_OK,
    FIXED_STEP_CHOICES,
    Interrupted,
    OutputFolder,
    add_agitation_argument,
    add_contact_sampling_argument,
    add_dynamics_arguments,
    add_figures_argument,
    add_solver_arguments,
    add_surface_arguments,
    contact_sampling,
    dumps_json,
    dynamics_model,
    fail,
    holds_only_its_lock,
    in_range,
    int_range,
    out_path,
    positive,
    seam_tolerance_value,
    solver_choice,
    surface_model,
    with_solver,
    write_atomic,
)
from ._fold import figure_job, write_folding
from ._painter import paint
from ._panels import (
    check_explicit_steps,
    check_has_creases,
    check_panels_thicker_than_film,
    check_targets,
    warn_if_films_too_thick_to_close,
)
from ._sweep import chunks_kept_on_interrupt, stored_sweep_errors

HELP = "Estimate a net's yield under fabrication scatter (Monte Carlo, resumable)."
DESCRIPTION = (
    HELP
    + """

NET is a FOLD file or the name of a shipped net or crease pattern (origami-jax fold --list), or a
family of nets: cube_nets, octahedron_nets, or a comma-separated list of nets (see the end). Every
sample is the net with its hinges' film stress (misfit strain), film thicknesses, hinge widths, drag coefficient and
release times drawn from the scatter, folded with contact in the KOH bath (--fluid air: in air) and
judged folded, jammed, misfolded, unfinished or invalid: folded when every crease is within
--angle-tolerance of the pattern's angle (3 degrees) and every seam closed. By default each seam's
tolerance is derived from the angle tolerance and the geometry: the gap the seam has in the
intended shape plus what creases each off by the angle tolerance open (root-sum-square), so a seam
is never judged stricter than the creases that place it (10-20 µm on a cube of 200 µm panels at 3
degrees). --seam-tolerance 0.01 judges every seam against a fixed fraction of the largest panel's
size instead (the default before: 2 µm on 200 µm panels, about 0.6 degrees of crease error, so the
seams decided most verdicts); --resume keeps the tolerance the run was stored with. The hinges are fabricated: their lengths
are the nominal design's, so a film that bends more or less than nominal folds its crease past or
short of the pattern's angle. Each hinge is the literature's, at most as wide as its crease.

A crease pattern with closed loops (a waterbomb, a Miura sheet) starts flat, where its branch is
left to the inputs, or pre-folded by --bias rad along its own angles (0.05: a membrane is never
quite flat); a sample that folds onto another branch is misfolded. --improve and --etch-front take
nets (trees of panels) only.

--scatter CONFIG.toml gives one table per parameter (misfit_strain, t_hinge, hinge_width,
t_structural, drag_coefficient, release) with distribution ("normal", "lognormal", "uniform"), width
(1 sigma, or the half-width of a uniform), relative (true: a fraction of the nominal value; false: in
µm or µs) and per ("crease" or "net"); parameters not named keep the defaults (film stress 5 %,
thicknesses 2.5 %, hinge width 0.5 µm; see origami_jax.fab_yield.Scatter), `defaults = false` at the
top switches those off. Without --scatter the defaults are used.

--process NAME=VALUE sets a nominal fabrication value the scatter is drawn about (repeatable;
NAME one of misfit_strain, t_hinge, hinge_width, t_structural, drag_coefficient; VALUE one number,
or one per crease, comma-separated, for the per-crease ones; µm for thicknesses and widths), e.g.
--process misfit_strain=0.00275 for a film 3 % less stressed than the design's 0.00283: where the
estimate, the --widths and the --improve ascent start (default the design's values).

--release T1,T2,... (µs, one per crease) or --etch-front DX,DY,SPEED set the nominal release times,
the folding order (the release scatter is added to them); e.g. for examples/flap_under_flap.fold,
--etch-front 1,0,0.5 frees the left flap 600 µs before the right one.

--step-budget N runs every sample for at most N solver steps first, then the samples that reached
N again, all together, with the full budget (OUT/stragglers/): the same results, and on a GPU (or
with --chunk-size on a CPU) less time, since a vmapped chunk steps until its slowest member is done.
Take a few times the median sample's steps (sweep.nc's num_steps); result.json counts the stragglers.

A sample whose panels still move at --t-end (unfinished, its solve successful) is run again from
the start to --t-settle (8000 µs; OUT/settled/) and judged where it comes to rest, as `fold`
continues a folding until it settles; result.json's "continued" counts them. --t-settle 0 keeps
the verdicts at --t-end.

--solver implicit-step --dt US folds every sample in fixed implicit Euler steps (implicit-bdf2:
second-order BDF2 steps; a fixed count of Newton iterations capped by the plates' collision
detection): every sample of a vmapped chunk does the same work, where the adaptive default
(tsit5) steps until its slowest member is done; it takes no --rtol or --step-budget. On cube nets
the fixed steps judge folded-or-not as the default does, 5-6 times sooner, but differ on jammed
against misfolded in about 2 % of the samples, where the default judges as its own converged solve
does: the reason it stays the default. The solver is recorded in result.json and the store;
--resume continues with the same one only. Each step evaluates a working set of the contact pairs
nearest at its start; result.json's samples_with_contacts_left_out counts the samples where a pair
left out came within reach (0 expected; the summary says so otherwise).

--agitation K shakes every sample with the bath's random force at an effective temperature K
(Langevin noise balanced by the fluid's viscous drag; needs --solver implicit-step): each sample its
own noise, drawn from --seed. Keep the hinges' wobble sqrt(k_B T / k) well below the angle tolerance.

--precision 0.1 samples until the yield's 95 % interval is at most ±0.1: --samples first, then
rounds sized to what the yield so far needs (at least a quarter more each; OUT/samples-FROM-TO/),
at most --max-samples (1000). The samples are one sequence of draws whatever their count (the first
n of a longer estimate are those of an estimate of n), so a family gives each net as many as its
own interval needs: ~35 at a yield near 0.1, ~96 near 0.5, 17 when none folds.

--widths 0.5,1,2 also estimates the yield with every scatter width multiplied by each factor (the
same draws, so the same fabricated nets made more or less carefully; each in OUT/widths/xF/) and
plots it against the factor (OUT/yield_widths.png).

--improve STEPS then climbs the yield: stochastic gradient ascent over the fabrication's nominal
values of --improve-parameters (default: every parameter with a normal or lognormal scatter),
--samples nets per iteration on the same draws, steps of --improve-step spread widths (0.5), at most
STEPS steps, stopping early where no gradient component exceeds 2 standard errors; the best iterate
is re-estimated on --samples fresh draws (see origami_jax.fab_yield.yield_ascent). Iterate 0 is the
estimate itself; the others are stored in OUT/improve/; result.json's "improve" holds every iterate's nominal values, yield,
interval and gradient, and OUT/improve.png plots them (not with --resume).

Every estimate also reports how its yield depends on the tolerances, without simulating again:
each sample stores its margins (its largest crease error over the angle tolerance, its largest
open seam gap over that seam's tolerance), so the yield with the angle tolerance, the seam
tolerances or both multiplied by 0.5, 1 and 2 is a count (result.json's tolerance_sensitivity,
one line of the summary, OUT/yield_tolerances.png). Only folded against not folded moves with the
tolerances; a sample whose simulation failed folds at none.

Writes OUT/result.json (yield, its confidence interval, verdict counts, the scatter, the
tolerances and the yield at their multiples, the yield per --widths factor, and the yield's gradient with respect to each scattered
parameter's nominal value with its standard error: the score-function estimate from the same
samples, see origami_jax.fab_yield.yield_gradient), the figures unless --no-figures (OUT/yield.png: verdict
counts and the yield; OUT/misfolds.png: the final state of one typical sample of each verdict other
than folded, in 3D, next to the intended shape), and the samples as a sweep store: OUT/sweep.nc
(every sample's parameters and verdict) and OUT/chunks/ (one file per finished chunk). An interrupted run continues with
--resume (the same net, settings, scatter, seed and samples; not a finished --improve run, nor
without a --widths factor it was run with); a folder holding an estimate is never overwritten, and
one holding another command's results is refused. A nominal release at or after --t-end is refused
(no sample could fold).

--sample 3,7 then folds samples 3 and 7 (numbered from 0, as in sweep.nc) again on their own, with
their drawn hinges, model, solve and tolerances, and keeps each whole folding in
OUT/samples/sample-I/: result.json (the verdict on it, its reason and numbers, the stored verdict
and the sample's drawn parameters), trajectory.csv, trajectory.fold (origami-jax view shows it) and,
unless --figures none, angles.png and frames.png. With --resume on a finished estimate nothing
else is simulated again. Alone, not beside other samples, a sample's last bits may differ, and
with them its verdict where a crease or seam lies at its tolerance: result.json gives both.

A family (NET cube_nets, octahedron_nets or NET1,NET2,...) estimates each net's yield into
OUT/NET/ (its samples, and its summary OUT/NET/estimate.json once finished), every net from the
same --seed (common random numbers), then writes OUT/family.json and OUT/family.csv (per net: the
yield, its interval, the verdict counts, the flat net's radius of gyration and vertex
connections; Spearman's rank correlation of the yields with each measure and its p-value) and
OUT/family.png (yield against each measure). --resume skips the finished nets and continues an
interrupted one. --improve, --widths, --release, --etch-front and --bias take one net.
Exit codes: 0 done, 1 the run stopped (disk full), 2 bad input or a folder in use, 130 interrupted.
"""
)


class _SeamNotGiven:
    """--seam-tolerance not given: derived for a new run, the stored run's with --resume."""

    def __repr__(self) -> str:
        return "derived"


_SEAM_NOT_GIVEN = _SeamNotGiven()


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "yield",
        help=HELP,
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("net", help="FOLD file or catalogue name")
    parser.add_argument(
        "--samples",
        type=int,
        default=100,
        help="nets to draw (default 100; with --precision, the first round's)",
    )
    parser.add_argument(
        "--precision",
        type=float,
        default=None,
        metavar="HALF_WIDTH",
        help="draw in rounds until the yield's interval is this narrow, its half-width (0.1: "
        "±0.1): --samples first, then as many more as the yield so far needs (each net its own "
        "in a family), at most --max-samples",
    )
    parser.add_argument(
        "--max-samples",
        type=int,
        default=None,
        help=f"--precision: at most this many samples in all (default {_MOST_SAMPLES})",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    parser.add_argument("--scatter", type=Path, default=None, help="scatter config (TOML)")
    parser.add_argument(
        "--process",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a nominal fabrication value (repeatable; e.g. misfit_strain=0.00275 or "
        "hinge_width=2,2,2,2,2 in µm): where the scatter is centred and --improve starts",
    )
    parser.add_argument("--fluid", choices=("air", "koh"), default="koh", help="default koh")
    add_contact_sampling_argument(parser)
    add_surface_arguments(parser)
    add_dynamics_arguments(parser)
    add_agitation_argument(parser)
    parser.add_argument(
        "--t-end",
        type=float,
        default=None,
        help="simulated time, µs (default 1500, or past a release ramp (--release-ramp) the "
        "longer of 1500 and a fifth of the ramp)",
    )
    parser.add_argument(
        "--t-settle",
        type=float,
        default=None,
        help="samples still moving at --t-end run again to this time after the release ramp, µs "
        "(default 8000, the longest folding `fold` continues to; 0: judge them at --t-end, "
        "unfinished)",
    )
    parser.add_argument(
        "--bias",
        type=float,
        default=0.0,
        help="a closed-loop pattern's pre-fold along its own angles, rad (default 0: flat)",
    )
    parser.add_argument(
        "--rtol",
        type=float,
        default=None,
        help="the solver's relative tolerance (default 1e-6, a yield's: against 1e-8 it judged "
        "199 of 200 scattered cube nets alike, as 1e-7 does, in 75 %% of 1e-7's steps; see "
        "origami_jax.fab_yield.YIELD_RTOL); looser is faster and moves contact events in time",
    )
    add_solver_arguments(parser, "tsit5, adaptive (the fold kernel's)")
    parser.add_argument(
        "--confidence", type=float, default=0.95, help="level of the interval (default 0.95)"
    )
    parser.add_argument(
        "--interval",
        choices=("wilson", "clopper-pearson"),
        default="wilson",
        help="interval method (default wilson)",
    )
    parser.add_argument(
        "--release",
        default=None,
        help="nominal release time per crease, µs, comma-separated (default all 0); the release "
        "scatter is added to these",
    )
    parser.add_argument(
        "--etch-front",
        default=None,
        metavar="DX,DY,SPEED",
        help="nominal release times of an etch front moving along (DX, DY) at SPEED µm/µs (the "
        "folding order; instead of --release)",
    )
    parser.add_argument(
        "--angle-tolerance",
        type=float,
        default=3.0,
        help="verdict: crease angle tolerance, degrees (default 3)",
    )
    parser.add_argument(
        "--seam-tolerance",
        type=seam_tolerance_value,
        default=_SEAM_NOT_GIVEN,
        help="verdict: seam gap tolerance, 'derived' (default: each seam's is the gap it would "
        "have with every crease just within the angle tolerance), or a fixed fraction of the "
        "largest panel's size (0.01, the default before); --resume keeps the stored run's",
    )
    parser.add_argument("--chunk-size", type=int, default=None, help="samples per compiled call")
    parser.add_argument(
        "--step-budget",
        type=int,
        default=None,
        help="solver steps per sample in a first pass; the samples that reach it run again "
        "together (pays where chunks are wide: a GPU, or --chunk-size on a CPU)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        help="compiled calls at once (default: one per CPU core on a CPU, else 1)",
    )
    parser.add_argument("--resume", action="store_true", help="continue the estimate in --out")
    parser.add_argument(
        "--sample",
        default=None,
        metavar="I[,J...]",
        help="then fold these samples (numbered from 0) again on their own, their whole folding "
        "kept: OUT/samples/sample-I/ (with --resume, of a stored estimate)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--widths",
        default=None,
        help="comma-separated factors on every scatter width (e.g. 0.5,1,2): also estimate the "
        "yield at each (same draws) and plot it against the width (yield_widths.png)",
    )
    parser.add_argument(
        "--improve",
        type=int,
        default=None,
        metavar="STEPS",
        help="then raise the yield by at most STEPS steps of gradient ascent over the nominal "
        "values (OUT/improve/, result.json's improve, improve.png)",
    )
    parser.add_argument(
        "--improve-parameters",
        default=None,
        help="comma-separated parameters --improve moves (default: every parameter with a normal "
        "or lognormal scatter)",
    )
    parser.add_argument(
        "--improve-step",
        type=float,
        default=None,
        help="--improve's largest move per step, in spread widths (default 0.5)",
    )
    add_figures_argument(
        parser,
        choices=("none", "png"),
        help="none, or png (default): yield.png, misfolds.png, ... (a family: family.png)",
    )
    parser.add_argument(
        "--out",
        type=out_path,
        default=Path("origami_out/yield"),
        help="output folder, created if missing (default: ./origami_out/yield)",
    )
    parser.set_defaults(func=run)


# Every file a yield run writes at the top of --out (its sweep stores aside): a folder holding any
# is refused without --resume; with it, those this run does not write again are removed, so that
# result.json and the figures describe one run.
OWNS = (
    "result.json",
    "yield.png",
    "misfolds.png",
    "yield_widths.png",
    "yield_tolerances.png",
    "improve.png",
)


# What a family run writes at the top of --out (each net's store and summary in OUT/NET/).
FAMILY_OWNS = ("family.json", "family.csv", "family.png")
# Options of one net's estimate that a family does not take.
_SINGLE_NET_ONLY = (
    "improve",
    "improve_parameters",
    "improve_step",
    "widths",
    "release",
    "etch_front",
    "sample",
)


def _scatter(args: argparse.Namespace):
    """The --scatter config (default the documented scatter), checked."""
    from ..fab_yield import Scatter, load_scatter

    if args.scatter is None:
        return Scatter()
    try:
        return load_scatter(args.scatter)
    except (ValueError, OSError) as error:
        fail(f"bad scatter config {args.scatter}: {error}")


def _solve(args: argparse.Namespace, choice: dict, stored=None, pattern=None):
    """Each sample's solve (--t-end; the solver `choice`, `solver_choice`'s record; --rtol with the
    defaults' ratio for the absolute tolerance), the verdict's tolerances (--angle-tolerance,
    --seam-tolerance; with --resume and no --seam-tolerance the stored run's, `stored`:
    `_seam_tolerance`) and the samples' pre-fold (--bias, or `pattern`'s under the fixed steps:
    `start_bias`)."""
    from ..fab_yield import YIELD_SOLVE
    from ..simulation import DEFAULT_ATOL, DEFAULT_RTOL, VerdictTolerances, start_bias

    solve = with_solver(YIELD_SOLVE.replace(t1=args.t_end), choice, default="tsit5")
    if args.rtol is not None:
        solve = solve.replace(rtol=float(args.rtol), atol=DEFAULT_ATOL / DEFAULT_RTOL * args.rtol)
    bias = args.bias if pattern is None else start_bias(pattern, solve.solver, args.bias)
    tolerances = VerdictTolerances.from_degrees(args.angle_tolerance, _seam_tolerance(args, stored))
    return solve, tolerances, bias


# `--max-samples`' default: `SampleUntil`'s.
_MOST_SAMPLES = 1000


def _most_samples(args: argparse.Namespace) -> int:
    """`--precision`'s cap: `--max-samples`, by default `_MOST_SAMPLES` or `--samples` if more."""
    return max(_MOST_SAMPLES, args.samples) if args.max_samples is None else args.max_samples


def _sample_count(args: argparse.Namespace, until: type):
    """`--samples`, or with `--precision` a `SampleUntil` (`until`, the class: the caller has
    `origami_jax.fab_yield` imported) starting from it (checked in `run`)."""
    if args.precision is None:
        return args.samples
    return until(half_width=args.precision, first=args.samples, most=_most_samples(args))


def _samples_said(args: argparse.Namespace) -> str:
    """How many samples, for the first line: a count, or the precision asked for."""
    if args.precision is None:
        return f"{args.samples} samples"
    return (
        f"samples until ±{args.precision:g} (first {args.samples}, at most {_most_samples(args)})"
    )


def _run_settings(args: argparse.Namespace) -> dict:
    """How the estimates run, `RunOptions`' fields but the output folder (--resume, --chunk-size,
    --workers, --no-progress, --step-budget, --t-settle; 0 is no settling run)."""
    return dict(
        resume=args.resume,
        chunk_size=args.chunk_size,
        workers=args.workers,
        progress=not args.no_progress,
        step_budget=args.step_budget,
        # Not given: `RunOptions`' own default (`SETTLE_TIME`); 0: no settling run.
        **({} if args.t_settle is None else {"t_settle": args.t_settle or None}),
    )


def _check_settles_after_the_end(args, pattern) -> None:
    """A one-line exit where --t-settle (after the release ramp) ends at or before the run's end:
    no sample still moving would be run on (`RunOptions.t_settle`)."""
    ramp = pattern.nominal_release_ramp(pattern.default_design(_fluid(args)))
    t_end = default_t_end(ramp) if args.t_end is None else args.t_end
    if args.t_settle + (ramp or 0.0) <= t_end:
        after = f" after the release ramp ({ramp:g} µs)" if ramp else ""
        fail(
            f"--t-settle {args.t_settle:g} µs{after} ends at or before the run's end ({t_end:g} "
            "µs): no sample would be run on; give a later --t-settle, or 0 to judge the samples "
            "at --t-end."
        )


def _check_released_in_time(args, pattern, release, flag: str) -> None:
    """A one-line exit where a crease is released at or after the run's end (--t-end, default
    `default_t_end`, 1500 µs or a fifth of the release ramp past it): every sample would be a 0
    that says nothing."""
    t_end = args.t_end
    if t_end is None:
        ramp = pattern.nominal_release_ramp(pattern.default_design(_fluid(args)))
        t_end = default_t_end(ramp)
    late = [j for j, t in enumerate(release) if t >= t_end]
    if late:
        end = f"--t-end {t_end:g} µs" if args.t_end is not None else f"the run's end, {t_end:g} µs"
        fail(
            f"{flag}: crease {late[0]} is released at {release[late[0]]:g} µs, at or after "
            f"{end}, so no sample could fold (a yield of 0 that says nothing); give a longer "
            "--t-end or earlier release times."
        )


def _dynamics_record(settings: dict) -> dict:
    """What result.json records of the samples' physics beyond the contact, read from the
    estimate's kernel settings (what they were run with): whether they carry the fluid's
    inertia, the release ramp (µs, `None`: at once), and adhesion, friction and agitation where
    on (their numbers in the design's units; the agitation's temperature in kelvin)."""
    surfaces = {k: settings[k] for k in ("adhesion", "friction", "agitation") if k in settings}
    return {
        "fluid_inertia": bool(settings.get("added_mass", False)),
        "release_ramp_us": settings.get("release_ramp_us"),
        **surfaces,
    }


def _fluid(args: argparse.Namespace):
    """The --fluid the nets fold in."""
    from ..system import AIR, KOH_SOLUTION

    return KOH_SOLUTION if args.fluid == "koh" else AIR


def _load(name: str):
    """The pattern `name` names (a FOLD file or a catalogue name), or a one-line failure."""
    from ..fold import FoldFormatError
    from ..loops import load_pattern

    try:
        return load_pattern(name)
    except (FoldFormatError, ValueError, OSError) as error:
        fail(f"cannot load {name}: {error}")


def _run_family(args: argparse.Namespace, members: list[str], sampling, choice: dict) -> int:
    """A family of nets: each net's estimate into OUT/NET/, then the table, the rank
    correlations with compactness and the figure (`origami_jax.fab_yield.family_yield`)."""
    from ..fab_yield import RunOptions, SampleUntil, family_yield

    for name in _SINGLE_NET_ONLY:
        if getattr(args, name) is not None:
            flag = "--" + name.replace("_", "-")
            fail(f"{flag} takes one net, not a family ({args.net}): run it on one net.")
    if args.bias:
        fail(f"--bias pre-folds one closed-loop pattern, not a family ({args.net}).")
    for entry in args.process:
        if "," in entry.partition("=")[2]:
            fail(
                f"--process {entry}: a family takes one value per parameter (its nets' creases "
                "differ), not one per crease."
            )
    if len(members) < 2 or len(set(members)) != len(members):
        fail(f"a family needs at least two different nets, got {args.net!r}.")
    scatter = _scatter(args)
    fluid = _fluid(args)
    patterns = []
    process = None
    for name in members:
        pattern = _load(name)
        if pattern.n_loops > 0:
            fail(f"{name} is a crease pattern with closed loops: a family takes nets (trees).")
        check_has_creases(pattern, name)
        nominal = pattern.default_design(fluid)
        check_panels_thicker_than_film(pattern, nominal, name)
        check_targets(pattern, None, name, nominal)
        warn_if_films_too_thick_to_close(pattern, nominal, name, args.angle_tolerance)
        process = _process(args.process, pattern.n_creases)
        try:
            pattern = pattern.with_model(
                contact=args.contact, contact_sampling=sampling, **dynamics_model(args)
            )
            surface = surface_model(args, pattern, pattern.default_design(fluid))
            patterns.append(pattern.with_model(**surface))
        except ValueError as error:
            fail(f"{name}: {error}")
    out = Path(args.out)
    if (out / "result.json").is_file():
        fail(f"{out} holds one net's yield estimate (result.json): choose another --out.")
    output = OutputFolder(
        out,
        command="yield",
        owns=FAMILY_OWNS,
        overwrite=args.resume,
        lend=True,
        exclusive=True,
        refuse_hint="a yield never replaces results: choose another --out (--resume continues the "
        "family stored there)",
    )
    print(
        f"[yield] family {args.net}: {len(patterns)} nets x {_samples_said(args)}, seed "
        f"{args.seed} -> {output.out}",
        flush=True,
    )

    def on_net(name: str, index: int, total: int) -> None:
        print(f"[yield] net {index + 1}/{total}: {name}", flush=True)

    solve, tolerances, _ = _solve(args, choice)
    start = time.perf_counter()
    with output:
        try:
            with stored_sweep_errors(output.out):
                family = family_yield(
                    patterns,
                    scatter,
                    _sample_count(args, SampleUntil),
                    args.seed,
                    fluid=fluid,
                    process=process,
                    solve=solve,
                    tolerances=tolerances,
                    confidence=args.confidence,
                    interval=args.interval,
                    run=RunOptions(out=output.out, **_run_settings(args)),
                    on_net=on_net,
                )
        except Interrupted:
            raise Interrupted(
                f"interrupted; the finished nets and samples are kept in {output.out}: continue "
                "with --resume."
            ) from None
        elapsed = time.perf_counter() - start
        result = {
            "family": args.net,
            "fluid": args.fluid,
            "t_end_us": args.t_end,
            "rtol": args.rtol,
            "contact": args.contact,
            "contact_sampling": list(sampling),
            "fluid_inertia": any(patterns[0].fluid_inertia(patterns[0].default_design(fluid))),
            "release_ramp_us": {
                p.name: p.nominal_release_ramp(p.default_design(fluid)) for p in patterns
            },
            "agitation_K": args.agitation,
            **choice,
            **family.to_dict(),
            "wall_s": elapsed,
        }
        write_atomic(output.dir / "family.json", dumps_json(result))
        write_atomic(output.dir / "family.csv", family.to_csv())
        if args.figures != "none":
            import matplotlib.pyplot as plt

            from ..plotting.fab_yield import family_figure

            fig = family_figure(family, title=f"{args.net}: yield against compactness")
            fig.savefig(output.dir / "family.png", dpi=120)
            plt.close(fig)
    print(family.summary())
    print(f"wall time {elapsed:.1f} s; results in {output.out}")
    return EXIT_OK


def _check_resumable(out: Path, factors: list[float], solver: dict, seed: int) -> None:
    """`--resume` into `out`: its result.json, if any, is a yield estimate's that this run rewrites
    whole (not another command's; not a finished --improve ascent, which cannot be resumed; no
    --widths factor left out; the same `solver`, `solver_choice`'s record, and the same `seed`:
    the store refuses others too, but only as "the design space's values differ", so a finished
    estimate is refused here, naming the flags it was run with)."""
    import json

    path = out / "result.json"
    if not path.is_file():
        return
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError):
        stored = None
    if not isinstance(stored, dict) or "yield" not in stored or "n_samples" not in stored:
        fail(
            f"{out} holds a result.json that is not a yield estimate's: --resume continues an "
            "estimate in its own folder; choose another --out."
        )
    if "improve" in stored:
        fail(
            f"{out} holds a finished estimate with an --improve ascent, which --resume cannot "
            "continue (it would drop the ascent): its results are complete; choose another --out."
        )
    dropped = sorted({float(w["factor"]) for w in stored.get("widths", [])} - set(factors))
    if dropped:
        fail(
            f"cannot resume {out} without --widths {','.join(f'{w:g}' for w in dropped)}: its "
            "result.json holds the yield at those widths, which this run would drop; give them "
            "in --widths."
        )
    if "seed" in stored and stored["seed"] != seed:
        fail(
            f"cannot resume {out} with --seed {seed}: its estimate was drawn with --seed "
            f"{stored['seed']}; resume with that seed, or choose another --out."
        )
    stored_solver = {k: stored[k] for k in _SOLVER_KEYS if k in stored} or {"solver": "tsit5"}
    if stored_solver != solver:
        fail(
            f"cannot resume {out} with {_solver_flags(solver)}: its estimate was run with "
            f"{_solver_flags(stored_solver)}; resume with the same solver, or choose another --out."
        )


_SOLVER_KEYS = ("solver", "dt_us", "newton_iterations")


def _solver_flags(record: dict) -> str:
    """A solver record (`solver_choice`) as the flags that give it."""
    flags = f"--solver {record['solver']}"
    if "dt_us" in record:
        flags += f" --dt {record['dt_us']:g} --newton-iterations {record['newton_iterations']}"
    return flags


def _seam_tolerance(args: argparse.Namespace, stored) -> float | None:
    """The seam tolerance of this run: --seam-tolerance (a fraction, or None: derived); not given,
    derived, or with --resume the stored run's (`stored`, its `VerdictTolerances` or None; a run
    stored when the fixed 0.01 was the default records none: 0.01), so that its verdicts stay
    the same."""
    if args.seam_tolerance is not _SEAM_NOT_GIVEN:
        return args.seam_tolerance
    if args.resume and stored is not None:
        return stored.seam
    return None


def _numbers(text: str | None, flag: str, parse=float, what: str = "numbers") -> list | None:
    """Comma-separated finite numbers (`parse`d: `float`, or `int` for whole numbers), or None."""
    if text is None:
        return None
    try:
        values = [parse(v) for v in text.split(",") if v.strip()]
    except ValueError:
        fail(f"{flag} expects comma-separated {what}, got {text!r}.")
    if not values or not all(math.isfinite(v) for v in values):
        fail(f"{flag} expects comma-separated finite {what}, got {text!r}.")
    return values


def _sample_numbers(text: str | None, most: int) -> list[int] | None:
    """--sample's comma-separated sample numbers (from 0, below `most`), or `None`."""
    numbers = _numbers(text, "--sample", int, "sample numbers (from 0)")
    if numbers is None:
        return None
    if any(not 0 <= n < most for n in numbers):
        fail(
            f"--sample expects sample numbers from 0 to {most - 1} (at most {most} samples), "
            f"got {text!r}."
        )
    return sorted(set(numbers))


def _folded_again(estimate, pattern, numbers: list[int], folder: Path, figures: bool) -> list:
    """Samples `numbers` of `estimate` folded again on their own (`YieldEstimate.sample_fold`), each
    folding's files in `folder/samples/sample-I/` (`write_folding`, and its figures); their
    verdicts, as folded again and as stored."""
    import numpy as np

    done = []
    for index in numbers:
        if index >= estimate.n_samples:  # --precision stopped before it: nothing to fold
            n = estimate.n_samples
            print(f"[yield] --sample {index}: the estimate has {n} samples (0 to {n - 1}); skipped")
            continue
        print(f"[yield] folding sample {index} again on its own ...", flush=True)
        sample = estimate.sample_fold(index)
        out = folder / "samples" / f"sample-{index}"
        out.mkdir(parents=True, exist_ok=True)
        coords = estimate.dataset.coords
        axis = estimate.dataset["verdict"].dims  # one entry per sample
        drawn = {
            str(name): float(coords[name].values[index])
            for name in coords
            if coords[name].dims == axis and (str(name),) != axis
        }
        record = {
            "sample": index,
            "stored_verdict": sample.verdict,
            **sample.report.to_dict(),
            "drawn": drawn,
            "hinge_targets_deg": [float(x) for x in np.degrees(sample.system.hinges.target)],
            "t_end_us": float(np.asarray(sample.trajectory.times)[-1]),
        }
        write_atomic(out / "result.json", dumps_json(record))
        write_folding(out, pattern, sample.system, sample.trajectory, sample.report)
        if figures and bool(sample.trajectory.succeeded):
            name = f"{pattern.name} sample {index}"
            paint(figure_job(sample.system, sample.trajectory, sample.report, out, name))
        again = str(sample.report.verdict)
        also = "" if again == sample.verdict else f" (stored: {sample.verdict})"
        print(f"[yield] sample {index}: {again}{also}: {sample.report.reason}", flush=True)
        done.append({"sample": index, "verdict": again, "stored_verdict": sample.verdict})
    return done


def _process(entries: list[str], n_creases: int) -> dict | None:
    """The --process nominal values, checked against the pattern's crease count before anything
    compiles (None without --process)."""
    if not entries:
        return None
    from ..fab_yield import PARAMETERS
    from ..fab_yield._estimate import _process as check_process

    known = [n for n in PARAMETERS if n != "release"]
    values: dict = {}
    for entry in entries:
        name, sep, text = entry.partition("=")
        name = name.strip()
        if not sep or name not in known:
            fail(
                f"--process expects NAME=VALUE with NAME one of {', '.join(known)} (release times: "
                f"--release or --etch-front), got {entry!r}."
            )
        if name in values:
            fail(f"--process {name} is given twice.")
        numbers = _numbers(text, f"--process {name}")
        values[name] = numbers[0] if len(numbers) == 1 else numbers
    try:
        check_process(values, n_creases)
    except ValueError as error:
        fail(f"--{error}")
    return values


def _factors(text: str | None) -> list[float]:
    """The --widths factors: positive finite numbers, at most 16, duplicates dropped."""
    if text is None:
        return []
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        fail(f"--widths expects comma-separated numbers (e.g. 0.5,1,2), got {text!r}.")
    if not values or len(values) > 16:
        fail(f"--widths expects 1 to 16 factors, got {text!r}.")
    bad = [v for v in values if not (math.isfinite(v) and v > 0)]
    if bad:
        fail(f"--widths factors must be positive (they multiply every scatter width), got {bad}.")
    return sorted(set(values))


def _gradients(estimate) -> dict:
    """The yield's score-function gradient per scattered parameter (normal or lognormal spreads)
    as JSON-ready rows; empty with fewer than 2 samples."""
    import numpy as np

    from ..fab_yield import yield_gradient

    if estimate.n_samples < 2:
        return {}
    rows = {}
    for name, g in yield_gradient(estimate).items():
        rows[name] = {
            "per": g.per,
            "unit": g.unit,
            "gradient": np.asarray(g.gradient).tolist(),
            "standard_error": np.asarray(g.standard_error).tolist(),
            "summary": g.summary(),
        }
    return rows


def _improve_parameters(args: argparse.Namespace, scatter) -> tuple[str, ...]:
    """The parameters --improve moves, checked before anything compiles (empty without
    --improve)."""
    import numpy as np

    from ..fab_yield import PARAMETERS, AscentSettings, check_ascent

    if args.improve is None:
        for flag, value in (
            ("--improve-parameters", args.improve_parameters),
            ("--improve-step", args.improve_step),
        ):
            if value is not None:
                fail(f"{flag} needs --improve STEPS.")
        return ()
    int_range(args.improve, "--improve", 1, 1000)
    step = AscentSettings.step if args.improve_step is None else args.improve_step
    positive(step, "--improve-step", "spread widths")
    if args.resume:
        fail("--improve cannot resume an ascent; run it without --resume, into a new --out.")
    if args.improve_parameters is None:
        names = [n for n, s in scatter.active().items() if s.distribution != "uniform"]
        if not names:
            fail("--improve: no parameter has a normal or lognormal scatter to move.")
    else:
        names = [n.strip() for n in args.improve_parameters.split(",") if n.strip()]
    ones = {n: np.ones(1) for n in PARAMETERS}
    try:
        return check_ascent(
            scatter, names, ones, steps=args.improve, step=step, significance=2.0,
            bounds=None,
        )[0]  # fmt: skip
    except ValueError as error:
        fail(f"--improve: {error}")


def run(args: argparse.Namespace) -> int:
    int_range(args.samples, "--samples", 1, 10_000_000)
    if args.precision is not None:
        in_range(args.precision, "--precision", 0.0, 0.5, what=" (a half-width: 0.1 for ±0.1)")
        if args.improve:
            fail("--improve takes a fixed --samples per step: drop --precision (or --improve).")
    if args.max_samples is not None:
        if args.precision is None:
            fail("--max-samples caps --precision's rounds: add --precision HALF_WIDTH, or drop it.")
        int_range(
            args.max_samples, "--max-samples", args.samples, 10_000_000, why=" (at least --samples)"
        )
    if args.seed < 0:
        fail(f"--seed must be >= 0, got {args.seed}.")
    if args.t_end is not None:
        positive(args.t_end, "--t-end", "µs")
    if args.t_settle is not None and not (math.isfinite(args.t_settle) and args.t_settle >= 0):
        fail(f"--t-settle must be a time >= 0 µs (0: no settling run), got {args.t_settle:g}.")
    if args.rtol is not None:
        in_range(args.rtol, "--rtol", 0.0, 1.0)
    if args.chunk_size is not None:
        int_range(args.chunk_size, "--chunk-size", 1, 10_000_000)
    if args.step_budget is not None:
        int_range(
            args.step_budget, "--step-budget", 1, 199_999, why=" (the solver's limit is 200,000)"
        )
    if args.workers is not None:
        int_range(args.workers, "--workers", 1, 4096)
    args.sample = _sample_numbers(
        args.sample, args.samples if args.precision is None else _most_samples(args)
    )
    choice = solver_choice(args, args.t_end or AFTER_RELEASE_US, "--t-end") or {"solver": "tsit5"}
    if choice["solver"] in FIXED_STEP_CHOICES:
        for flag, value in (("--rtol", args.rtol), ("--step-budget", args.step_budget)):
            if value is not None:
                fail(
                    f"{flag} is for the adaptive solvers; --solver {choice['solver']} takes fixed steps "
                    "(its accuracy is --dt, every sample the same work): drop it."
                )
    in_range(args.angle_tolerance, "--angle-tolerance", 0.0, 180.0, what=" degrees")
    if args.seam_tolerance is not None and args.seam_tolerance is not _SEAM_NOT_GIVEN:
        in_range(
            args.seam_tolerance, "--seam-tolerance", 0.0, 1.0, what=" (a fraction of the panel)"
        )
    if not 0 < args.confidence < 1:
        fail(f"--confidence must lie strictly between 0 and 1, got {args.confidence}.")
    sampling = contact_sampling(args.contact_sampling, args.contact)
    from ..fab_yield import family_names

    members = family_names(args.net)
    if members is not None:
        return _run_family(args, members, sampling, choice)
    if (Path(args.out) / FAMILY_OWNS[0]).is_file():
        fail(
            f"{args.out} holds a family of yield estimates ({FAMILY_OWNS[0]}): one net's estimate "
            "goes into a folder of its own; choose another --out."
        )
    factors = _factors(args.widths)
    release = _numbers(args.release, "--release")
    front = _numbers(args.etch_front, "--etch-front")
    if release is not None and front is not None:
        fail("give --release or --etch-front, not both.")
    if front is not None and len(front) != 3:
        fail("--etch-front expects DX,DY,SPEED (a direction in the plane and a speed in µm/µs).")
    scatter = _scatter(args)
    # The one place the yield command reads the pattern: the estimates, the kernel and the
    # figures take this object.
    pattern = _load(args.net)
    loops = pattern.n_loops > 0
    check_has_creases(pattern, args.net)
    nominal = pattern.default_design()
    check_panels_thicker_than_film(pattern, nominal, args.net)
    check_targets(pattern, None, args.net, nominal)
    if not loops:  # the yield's nets hinge at point creases
        warn_if_films_too_thick_to_close(pattern, nominal, args.net, args.angle_tolerance)
    if not 0 <= args.bias < 1:
        fail(f"--bias must be a pre-fold angle in [0, 1) rad, got {args.bias}.")
    if args.bias and not loops:
        fail(f"--bias pre-folds closed-loop patterns; {args.net} is a net, which starts flat.")
    if loops and (front is not None or args.improve):
        fail(
            f"{args.net} is a crease pattern with closed loops: --etch-front and --improve take "
            "nets (trees of panels); give --release times per crease instead of a front."
        )
    if front is not None:
        try:
            release = list(pattern.release_times_from_front(front[:2], front[2]))
        except ValueError as error:
            fail(f"--etch-front: {error}")
    if release is not None:
        if len(release) != pattern.n_creases:
            n = pattern.n_creases
            fail(f"--release: {len(release)} values for {n} creases (give one per crease).")
    improve = _improve_parameters(args, scatter)
    process = _process(args.process, pattern.n_creases)
    try:
        pattern = pattern.with_model(
            contact=args.contact, contact_sampling=sampling, **dynamics_model(args)
        )
        pattern = pattern.with_model(
            **surface_model(args, pattern, pattern.default_design(_fluid(args)))
        )
    except ValueError as error:
        fail(f"{args.net}: {error}")
    if release is not None:
        _check_released_in_time(
            args, pattern, release, "--etch-front" if front is not None else "--release"
        )
    if args.t_settle:
        _check_settles_after_the_end(args, pattern)
    if args.t_end is not None and choice["solver"] == "tsit5" and not loops:
        system = pattern.system(pattern.default_design(_fluid(args)))
        check_explicit_steps(system, args.t_end, "--t-end", loops, KERNEL_MAX_STEPS, "yield")
    if args.resume and holds_only_its_lock(Path(args.out)):
        print(f"[yield] --resume: nothing is stored in {args.out} yet; starting the estimate.")
    # Held for the whole run (the estimates' sweep stores borrow its lock): another run into the
    # folder meanwhile is refused, and so is a folder holding results without --resume (a yield
    # never replaces results).
    output = OutputFolder(
        Path(args.out),
        command="yield",
        owns=OWNS,
        overwrite=args.resume,
        lend=True,
        exclusive=True,
        refuse_hint="a yield never replaces results: choose another --out (--resume continues the "
        "estimate stored there)",
    )
    with output, chunks_kept_on_interrupt(output.out):
        return _run(
            args, output, pattern, loops, scatter, sampling, factors, release, process, improve,
            choice,
        )  # fmt: skip


def _run(
    args, output, pattern, loops, scatter, sampling, factors, release, process, improve, choice
):
    """The estimates (and the ascent) into `output.out`, the results staged in `output.dir`;
    `choice`, the solver (`solver_choice`)."""
    import dataclasses

    from ..fab_yield import RunOptions, SampleUntil, stored_run_tolerances, yield_estimate

    out = output.out
    if args.resume:
        _check_resumable(out, factors, choice, args.seed)
    design = pattern.default_design(_fluid(args))
    print(
        f"[yield] {args.net}: {_samples_said(args)}, seed {args.seed}, scatter "
        + (", ".join(f"{n} {s.width:g}" for n, s in scatter.active().items()) or "none")
        + f" -> {out}",
        flush=True,
    )
    ramp = pattern.nominal_release_ramp(design)  # kept: the estimate's kernel reads it again
    if ramp is not None:
        # A quasi-static release sets the samples' times to fold: say so before they are read.
        print(f"[yield] each hinge released over {ramp:g} µs, every sample alike", flush=True)

    # What every estimate of this run shares: the estimate itself, the other widths, the ascent.
    # The solve's tolerances: --rtol with the defaults' ratio for the absolute one.
    solve, tolerances, bias = _solve(args, choice, stored_run_tolerances(out), pattern)
    if bias != args.bias:
        print(
            f"[yield] every sample starts pre-folded by {bias:g} rad along the aimed branch: fixed "
            "steps cannot choose a branch at the flat state (--bias sets the pre-fold).",
            flush=True,
        )
    run = RunOptions(**_run_settings(args))
    common = dict(
        design=design,
        release_times=release,
        process=process,
        solve=solve,
        tolerances=tolerances,
        bias=bias,
    )

    def estimate_at(scatter, folder, count):
        with stored_sweep_errors(out):
            estimate = yield_estimate(
                pattern,
                scatter,
                count,
                args.seed,
                run=dataclasses.replace(run, out=folder),
                **common,
            )
        return estimate.with_interval(args.confidence, args.interval)

    start = time.perf_counter()
    estimate = estimate_at(scatter, out, _sample_count(args, SampleUntil))
    # The yield at other widths: the same draws scaled (Scatter.scaled), each its own store.
    at_width = {}
    for factor in factors:
        if factor == 1.0:
            at_width[factor] = estimate
            continue
        print(f"[yield] scatter widths x {factor:g}", flush=True)
        # The same samples as the estimate's (with --precision, as many as it took).
        at_width[factor] = estimate_at(
            scatter.scaled(factor), out / "widths" / f"x{factor:g}", estimate.n_samples
        )
    # A rerun of this command line reads the estimate's executables while it starts (`prefetch`).
    note_programs_used()
    ascent = None
    if improve:
        from ..fab_yield import AscentSettings, yield_ascent

        print(f"[yield] improving {', '.join(improve)}: at most {args.improve} steps", flush=True)
        with stored_sweep_errors(out):
            ascent = yield_ascent(
                pattern,
                improve,
                scatter,
                args.samples,
                args.seed,
                settings=AscentSettings(
                    steps=args.improve,
                    **({} if args.improve_step is None else {"step": args.improve_step}),
                    confirm_samples=args.samples,
                    confidence=args.confidence,
                    interval=args.interval,
                ),
                first=estimate,  # iterate 0 is the estimate above
                run=dataclasses.replace(run, out=out / "improve"),
                **common,
            )
    elapsed = time.perf_counter() - start
    ds = estimate.dataset
    settings = json.loads(ds.attrs["settings"])  # the kernel's, as the samples were run
    result = {
        "net": args.net,
        "fluid": args.fluid,
        "release_us": None if release is None else [float(t) for t in release],
        "process": process,
        "t_end_us": settings["t_end_us"],
        **({"bias_rad": settings.get("bias", args.bias)} if loops else {}),
        "rtol": args.rtol,
        **choice,
        "contact": args.contact,
        "contact_sampling": list(sampling),
        **_dynamics_record(settings),
        **estimate.to_dict(),
        "compile_s": float(ds.attrs.get("compile_s", 0.0)),
        **(
            {"step_budget": args.step_budget, "stragglers": int(ds.attrs["stragglers"])}
            if args.step_budget is not None
            else {}
        ),
        "wall_s": elapsed,
        "gradient": _gradients(estimate),
    }
    if factors:
        result["widths"] = [
            {"factor": f, **{k: e.to_dict()[k] for k in ("yield", "interval", "counts")}}
            for f, e in sorted(at_width.items())
        ]
    if ascent is not None:
        result["improve"] = ascent.to_dict()
    if args.sample:
        result["samples_folded_again"] = _folded_again(
            estimate, pattern, args.sample, output.dir, args.figures != "none"
        )
    # Staged in output.dir: moved into --out, with the figures, when `run`'s `with output` ends.
    write_atomic(output.dir / "result.json", dumps_json(result))
    if args.figures != "none":
        import matplotlib.pyplot as plt

        from ..plotting.fab_yield import (
            ascent_figure,
            misfold_figure,
            tolerance_figure,
            width_figure,
            yield_figure,
        )

        fig = yield_figure(estimate, title=f"{args.net}: yield under fabrication scatter")
        fig.savefig(output.dir / "yield.png", dpi=120)
        plt.close(fig)
        fig = misfold_figure(pattern, estimate, title=f"{args.net}: misfold modes")
        fig.savefig(output.dir / "misfolds.png", dpi=120)
        plt.close(fig)
        if estimate.tolerance_sensitivity is not None:
            fig = tolerance_figure(estimate.tolerance_sensitivity, title=args.net)
            fig.savefig(output.dir / "yield_tolerances.png", dpi=120)
            plt.close(fig)
        if factors:
            fig = width_figure(
                sorted(at_width), [at_width[f] for f in sorted(at_width)], title=args.net
            )
            fig.savefig(output.dir / "yield_widths.png", dpi=120)
            plt.close(fig)
        if ascent is not None:
            fig = ascent_figure(ascent, title=f"{args.net}: yield ascent")
            fig.savefig(output.dir / "improve.png", dpi=120)
            plt.close(fig)
    print(estimate.summary())
    if estimate.tolerance_sensitivity is not None:
        print(f"  {estimate.tolerance_sensitivity.summary()}")
    if ascent is not None:
        print(ascent.summary())
    for line in result["gradient"].values():
        print(f"  {line['summary']}")
    print(
        f"wall time {elapsed:.1f} s (compiling {result['compile_s']:.1f} s, "
        f"{estimate.seconds_per_sample:.3g} s per sample); results in {out}"
    )
    return EXIT_OK
