"""Pieces every subcommand shares: the output folder, one-line errors, JSON and number checks.

Every command writes its results through an `OutputFolder`: files go to a staging folder inside
`--out` and are moved into place only when the command has finished, so the results in `--out` are
always those of one complete run. A kill mid-run leaves the earlier results untouched (and a
`.partial-*` folder that the next run removes). A folder that already holds results of the same
command is refused unless `--overwrite` is given; with it the earlier run's files are replaced, and
those the new run does not write are removed. Each run records which command wrote which files
(`RESULTS_MARKER`): another command's results count as earlier results too (replaced together
with `--overwrite`, never mixed), and a sweep's or yield's folder is never another command's.
While a run writes, it holds the folder's lock (the one a sweep takes, `origami_jax._folder_lock`):
a second run into the same folder is refused.

Errors a command reports are `CLIError`s (one line, exit code 2 or 1); `_main.main` turns anything
else into one line too, and `--debug` shows the traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import sys
import tempfile
import uuid
import warnings
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from .._cache import enable_compilation_cache
from .._exported import enable_exported_programs, prefetch_for_command
from .._folder_lock import LOCK, FolderBusyError, FolderLock, lock_folder
from .._limits import CONTACT_SAMPLING, MAX_CONTACT_SAMPLING, MAX_FIXED_STEPS
from .._names import did_you_mean
from . import _interrupt as interrupt

DEFAULT_OUT = Path("origami_out")

# Exit codes of the CLI. 0 success; 1 the computation ran but its answer is negative or failed
# (e.g. a vertex that stalls, a solver that failed); 2 bad usage or bad input; 130 interrupted
# (Ctrl-C), 143 terminated (SIGTERM): the shell's 128 + the signal's number.
EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

STAGING_PREFIX = ".partial-"
# Written by every run's commit: the command and the files it wrote (JSON), so that a later run of
# another command neither mixes its results with them nor, without --overwrite, replaces them.
RESULTS_MARKER = ".origami-jax-results.json"
_OVERWRITE_HINT = "pass --overwrite to replace them, or choose another --out"
# Longest list a message prints in full; longer ones are cut with "... and N more".
MESSAGE_LIST_LIMIT = 8


class CLIError(Exception):
    """A problem a command reports as one line on stderr, with exit code `code` (default 2)."""

    def __init__(self, message: str, code: int = EXIT_USAGE):
        super().__init__(message)
        self.code = code


class Interrupted(CLIError):
    """Ctrl-C, with a message saying what was kept (exit code 130; 143 when SIGTERM stopped it)."""

    def __init__(self, message: str = "interrupted"):
        terminated = interrupt.received() == signal.SIGTERM
        super().__init__(message, EXIT_TERMINATED if terminated else EXIT_INTERRUPTED)


def fail(message: str, code: int = EXIT_USAGE) -> NoReturn:
    """Stop the command with a one-line message (exit code `code`, default 2: bad input)."""
    raise CLIError(message, code)


def one_line(text: str, limit: int = 400) -> str:
    """The first non-empty line of `text`, cut to `limit` characters."""
    for line in str(text).splitlines():
        if line.strip():
            line = line.strip()
            return line if len(line) <= limit else line[: limit - 3] + "..."
    return ""


def capped(items: Sequence[Any], limit: int = MESSAGE_LIST_LIMIT) -> str:
    """`items` joined by ", ", at most `limit` of them, then "... and N more"."""
    shown = ", ".join(str(x) for x in items[:limit])
    return shown + (f", ... and {len(items) - limit} more" if len(items) > limit else "")


# HingeDesign arguments that are not numbers (so not --param).
_NOT_PARAMS = frozenset({"structural", "hinge", "fluid", "stiffness_model", "drag_model", "units"})
FLAP_PARAMS = ("flap_length", "flap_width")
"""`--param` names of the accordion's flap size (`origami_jax.chain.Accordion`), not the hinge's."""


def param_names() -> tuple[str, ...]:
    """The HingeDesign arguments `--param` sets (the numeric ones)."""
    import inspect

    from origami_jax.system import HingeDesign

    signature = inspect.signature(HingeDesign.__init__)
    return tuple(
        n
        for n, p in signature.parameters.items()
        if n != "self" and n not in _NOT_PARAMS and p.kind is not p.VAR_KEYWORD
    )


def hinge_params(items: Sequence[str], *, flaps: bool = False) -> dict[str, list[float]]:
    """`--param` items, ``NAME=VALUE`` or ``NAME=V0,V1,...`` (one value per hinge), checked: a
    known numeric HingeDesign field, or with `flaps` the accordion's flap size (`FLAP_PARAMS`),
    finite numbers (MICRO units). `ValueError` (one line) for a bad item; the caller checks how
    many values each name may have."""
    names = param_names() + (FLAP_PARAMS if flaps else ())
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep:
            raise ValueError(f"--param expects NAME=VALUE, got {item!r}.")
        if name in FLAP_PARAMS and not flaps:
            raise ValueError(
                f"--param {name}: the flap size belongs to the accordion (origami-jax simulate "
                f"--param {name}=...); this command's panels are its pattern's own."
            )
        if name not in names:
            raise ValueError(
                f"--param {name!r} is not a hinge parameter{did_you_mean(name, names)}; give one "
                f"of {capped(names, 20)}."
            )
        try:
            values = [float(v) for v in value.split(",")]
        except ValueError:
            raise ValueError(
                f"--param {name}={value!r}: the value must be a number (MICRO units), or one "
                "number per hinge separated by commas where the command takes them."
            ) from None
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"--param {name}={value}: the value must be finite.")
        if name in out:
            raise ValueError(
                f"--param {name} is given twice; give it once (NAME=V0,V1,... for one value per "
                "hinge)."
            )
        out[name] = values
    return out


def out_path(text: str) -> Path:
    """An `--out` value as a path (argparse `type`): an empty one is refused (it wrote into the
    current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError('empty: give a folder ("." for the current one)')
    return Path(text)


def add_out_argument(parser: argparse.ArgumentParser, default: Path = DEFAULT_OUT) -> None:
    """`--out FOLDER` and `--overwrite` (see the module docstring)."""
    parser.add_argument(
        "--out",
        type=out_path,
        default=default,
        help=f"output folder, created if missing (default: ./{default})",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the results of an earlier run of this command in --out (default: refuse "
        "and keep them)",
    )


FIGURE_CHOICES = ("none", "png", "all")


def add_figures_argument(
    parser: argparse.ArgumentParser,
    *,
    choices: tuple[str, ...] = FIGURE_CHOICES,
    help: str = "none; png: the angle plot and a strip of 3D frames; all (default): also the "
    "animated GIF",
) -> None:
    """`--figures` (one of `choices`, default the last: `none|png|all` for a folding) and
    `--no-figures` (same as `--figures none`)."""
    parser.add_argument("--figures", choices=choices, default=choices[-1], help=help)
    parser.add_argument(
        "--no-figures",
        dest="figures",
        action="store_const",
        const="none",
        help="same as --figures none",
    )


# Numbers from the command line: each check names the flag and says what it takes.
def finite(value: float, flag: str) -> float:
    if not math.isfinite(value):
        fail(f"{flag} must be a finite number, got {value}.")
    return value


def positive(value: float, flag: str, unit: str = "") -> float:
    if not (math.isfinite(value) and value > 0):
        fail(f"{flag} must be a positive finite number{f' ({unit})' if unit else ''}, got {value}.")
    return value


def seam_tolerance_value(text: str) -> float | None:
    """`--seam-tolerance`'s value: a fraction of the panel size, or `derived` (`None`: each seam's
    tolerance from the angle tolerance and the geometry)."""
    if text.strip().lower() == "derived":
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a fraction of the panel size or 'derived', got {text!r}"
        ) from None


def in_range(value: float, flag: str, low: float, high: float, *, what: str = "") -> float:
    """`low < value < high` (open interval)."""
    if not (math.isfinite(value) and low < value < high):
        fail(f"{flag} must lie strictly between {low:g} and {high:g}{what}, got {value}.")
    return value


def int_range(value: int, flag: str, low: int, high: int, *, why: str = "") -> int:
    """`low <= value <= high`."""
    if not low <= value <= high:
        fail(f"{flag} must be between {low} and {high}{why}, got {value}.")
    return value


SOLVER_CHOICES = ("tsit5", "kvaerno5", "implicit-step", "implicit-bdf2")
"""`--solver`'s choices (`origami_jax.simulation.SOLVER_NAMES`; named here so that parsing the command
line imports no JAX)."""
FIXED_STEP_CHOICES = ("implicit-step", "implicit-bdf2")
"""The fixed-step engines of `SOLVER_CHOICES` (`origami_jax.simulation.FIXED_STEP_SOLVERS`)."""
DEFAULT_NEWTON_ITERATIONS = 10
"""`--newton-iterations`' default: `ImplicitStep`'s."""


def add_solver_arguments(parser: argparse.ArgumentParser, default: str) -> None:
    """`--solver`, `--dt` and `--newton-iterations` (`fold`, `yield`, `sweep`); `default` says what
    the command runs without `--solver`. Check them with `solver_choice`."""
    parser.add_argument(
        "--solver",
        choices=SOLVER_CHOICES,
        default=None,
        help="the time stepper: tsit5 (adaptive explicit Runge-Kutta: accurate trajectories), "
        "kvaerno5 (adaptive implicit: stiff runs), implicit-step (fixed implicit Euler steps "
        "of --dt, a fixed count of Newton iterations capped by collision detection: the same work "
        "for every sample of a batch, first-order accurate and damped; needs --dt), or "
        "implicit-bdf2 (the same engine with second-order BDF2 steps: far less damped); "
        f"default {default}",
    )
    parser.add_argument(
        "--dt",
        type=float,
        default=None,
        metavar="US",
        help="--solver implicit-step or implicit-bdf2: its largest step, µs, each interval between "
        "samples cut into equal steps no longer (required: no step suits every net and question; 2.5 judged "
        "cube_net_01 as the adaptive solver does, in KOH and in air; shorter resolves ringing "
        "better)",
    )
    parser.add_argument(
        "--newton-iterations",
        type=int,
        default=None,
        metavar="N",
        help=f"--solver implicit-step or implicit-bdf2: Newton iterations per step (default "
        f"{DEFAULT_NEWTON_ITERATIONS}; more for steps long against an impact)",
    )


def solver_choice(args: argparse.Namespace, t1: float, t1_flag: str) -> dict[str, Any] | None:
    """`--solver`, `--dt` and `--newton-iterations` checked before anything compiles (a one-line
    exit otherwise; `t1`, the run or segment length in µs that `t1_flag` sets, bounds `--dt`): what
    `result.json` records of them (`solver`, and with implicit-step `dt_us` and
    `newton_iterations`), or `None` without `--solver`. `with_solver` makes it a solve."""
    fixed = {"--dt": args.dt, "--newton-iterations": args.newton_iterations}
    given = [flag for flag, value in fixed.items() if value is not None]
    if args.solver not in FIXED_STEP_CHOICES:
        if given:
            fail(
                f"{' and '.join(given)} set{'s' if len(given) == 1 else ''} the implicit-step "
                "engine's fixed steps: add --solver implicit-step, or drop "
                f"{'it' if len(given) == 1 else 'them'} (the adaptive solvers choose their own steps)."
            )
        return None if args.solver is None else {"solver": args.solver}
    if args.dt is None:
        fail(
            f"--solver {args.solver} needs --dt US, its fixed step in µs (e.g. --dt 2.5, which "
            "judged cube_net_01 as the adaptive solver does; see the guide Simulating: Two engines)."
        )
    positive(args.dt, "--dt", "µs")
    if args.dt > t1:
        fail(
            f"--dt {args.dt:g} µs is longer than the run ({t1_flag}: {t1:g} µs): give a step a "
            "small fraction of it."
        )
    if t1 / args.dt > MAX_FIXED_STEPS:
        fail(
            f"--dt {args.dt:g} µs over the run ({t1_flag}: {t1:g} µs) is {t1 / args.dt:.3g} fixed "
            f"steps, more than the {MAX_FIXED_STEPS:,} one run may take: give a longer --dt or a "
            "shorter run."
        )
    iterations = (
        DEFAULT_NEWTON_ITERATIONS if args.newton_iterations is None else args.newton_iterations
    )
    int_range(iterations, "--newton-iterations", 1, 1000)
    return {"solver": args.solver, "dt_us": float(args.dt), "newton_iterations": iterations}


def with_solver(options: Any, choice: dict[str, Any] | None, default: str | None = None) -> Any:
    """The `SolveOptions` `options` with the solver of `choice` (`solver_choice`): unchanged without
    one, or when it names the command's `default` solver (the solve it runs anyway, so that a sweep
    store of it resumes whether or not `--solver` named it)."""
    if choice is None or choice["solver"] == default:
        return options
    from ..simulation import named_solver

    fixed = {}
    if "dt_us" in choice:
        fixed = {"dt": choice["dt_us"], "newton_iterations": choice["newton_iterations"]}
    return options.replace(solver=named_solver(choice["solver"], **fixed))


def add_contact_sampling_argument(parser: argparse.ArgumentParser) -> None:
    """`--contact {plate,sampled}` and `--contact-sampling RING,RIM` (`contact` and
    `contact_sampling` of `Net.system`; parse the sampling with `contact_sampling`)."""
    default = ",".join(map(str, CONTACT_SAMPLING))
    parser.add_argument(
        "--contact",
        choices=("plate", "sampled"),
        default="plate",
        help="the contact model: plate (default: the plates' exact geometry, with continuous "
        "collision detection, so no panel passes through another) or sampled (points sampled on "
        "each panel's rings and rim: cheaper, but corners and edges between its points go "
        "unchecked)",
    )
    parser.add_argument(
        "--contact-sampling",
        default=default,
        metavar="RING,RIM",
        help=f"--contact sampled: contact points per panel edge on the inner ring and on the rim "
        f"(default {default}, at most {MAX_CONTACT_SAMPLING}; denser resolves the same contact more "
        "finely, to check a verdict where edges meet)",
    )


def contact_sampling(text: str, model: str = "sampled") -> tuple[int, int]:
    """The two counts of `--contact-sampling`, or a one-line exit (before anything compiles); a
    sampling other than the default is refused unless `model` (`--contact`) is `"sampled"`."""
    parts = [x.strip() for x in text.split(",")]
    if len(parts) != 2 or not all(p.isdigit() for p in parts) or int(parts[0]) < 1:
        fail(
            f"--contact-sampling expects RING,RIM: two whole numbers, RING >= 1 (e.g. 8,6), got "
            f"{text!r}."
        )
    ring, rim = int(parts[0]), int(parts[1])
    if max(ring, rim) > MAX_CONTACT_SAMPLING:
        fail(
            f"--contact-sampling takes at most {MAX_CONTACT_SAMPLING} points per edge on the ring "
            f"and on the rim (the contact's work grows with their square), got {text!r}."
        )
    if model != "sampled" and (ring, rim) != tuple(CONTACT_SAMPLING):
        fail(
            f"--contact-sampling sets the sampled contact model's points; add --contact sampled "
            f"(the {model} contact is exact and takes no sampling)."
        )
    return ring, rim


# Friction's slip speed ε_v when --friction gives none (m/s = µm/µs): below it friction is a
# viscous creep; a few per cent of a folding 200 µm panel's edge speed (~0.2 m/s in KOH).
DEFAULT_FRICTION_SLIP = 0.01


def add_surface_arguments(parser: argparse.ArgumentParser) -> None:
    """`--adhesion W[,RANGE[,LINE]]` and `--friction MU[,SLIP]` (a pattern's `adhesion` and
    `friction`, `Net.with_model`; parse them with `surface_model`)."""
    parser.add_argument(
        "--adhesion",
        default=None,
        metavar="W[,RANGE[,LINE]]",
        help="surfaces that touch stick (off by default): work of adhesion W in J/m² (1e-3 to 0.1 "
        "in air, below 1e-2 in water or KOH; origami_jax.contact.Adhesion), its range in µm "
        "(default twice the contact's activation gap: numerical, see the docs) and the seams' "
        "edge-on-edge adhesion LINE in J/m (default 0; ~ W × the film thickness)",
    )
    parser.add_argument(
        "--friction",
        default=None,
        metavar="MU[,SLIP]",
        help="smoothed Coulomb friction where plates touch (off by default): coefficient MU (0.2 "
        "to 0.7 dry, 0.05 to 0.3 wet; origami_jax.contact.Friction) and the slip speed in m/s "
        f"below which it is a viscous creep (default {DEFAULT_FRICTION_SLIP:g})",
    )


def add_dynamics_arguments(parser: argparse.ArgumentParser) -> None:
    """`--fluid-inertia`/`--no-fluid-inertia` and `--release-ramp US` (a pattern's `added_mass`
    and `viscous`, and its `release_ramp`: `Net.with_model`; parse them with
    `dynamics_model`)."""
    parser.add_argument(
        "--fluid-inertia",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the fluid's inertia (added mass) and viscous drag on every panel, on top of its "
        "pressure drag. Default: on in the etch bath (koh), where the fluid's inertia is "
        "~250 times a panel's, off in air; --no-fluid-inertia is the paper's model in the bath",
    )
    parser.add_argument(
        "--release-ramp",
        type=float,
        default=None,
        metavar="US",
        help="release each hinge over US µs (its torque growing linearly from its release); 0: "
        "at once (the paper's step). Default: quasi-static where the panels carry the fluid's "
        "inertia (three periods of their slowest motion: 40000 µs for a 200 µm cube net in KOH; "
        "a real etch frees a hinge over minutes), at once otherwise",
    )


def add_agitation_argument(parser: argparse.ArgumentParser, *, seed: bool = False) -> None:
    """`--agitation K` (a pattern's `agitation`, `Net.with_model`; parsed by `dynamics_model`),
    and with `seed` `--noise-seed N`, the seed of its one realisation (a yield draws each
    sample's from its `--seed`)."""
    parser.add_argument(
        "--agitation",
        type=float,
        default=None,
        metavar="K",
        help="random forcing by the bath at an effective temperature K (kelvin; off by default): "
        "Langevin noise in balance with the fluid's viscous drag, each sample its own noise from "
        "--seed; needs --solver implicit-step and the fluid's inertia (the etch bath). k_B T is "
        "1.38e-11 pJ per kelvin and a crease's rms wobble sqrt(k_B T / k): a 200 µm cube net's "
        "hinges (k ~ 1600 pJ/rad²) wobble 0.17° at 1e9 K. The verdict allows for the wobble when "
        "it judges whether a run is at rest; keep it well below the angle tolerance",
    )
    if seed:
        parser.add_argument(
            "--noise-seed",
            type=int,
            default=None,
            metavar="N",
            help="seed of --agitation's random force (default 0; the same seed, the same path)",
        )


def dynamics_model(args: argparse.Namespace) -> dict:
    """The `with_model` options `--fluid-inertia`/`--no-fluid-inertia`, `--release-ramp` and
    `--agitation` (where the command has it) ask of a pattern (`{}` with none: the defaults), or a
    one-line exit for a ramp that is not a time >= 0 or an agitation that is not a temperature > 0
    with the fixed-step engine."""
    options: dict[str, Any] = {}
    inertia = getattr(args, "fluid_inertia", None)
    if inertia is not None:
        options.update(added_mass=inertia, viscous=inertia)
    ramp = getattr(args, "release_ramp", None)
    if ramp is not None:
        if not (math.isfinite(ramp) and ramp >= 0):
            fail(f"--release-ramp must be a time >= 0 µs (0: at once), got {ramp:g}.")
        options["release_ramp"] = float(ramp) if ramp > 0 else None
    temperature = getattr(args, "agitation", None)
    if temperature is None and getattr(args, "noise_seed", None) is not None:
        fail("--noise-seed seeds --agitation's random force: give --agitation K too, or drop it.")
    if temperature is not None:
        if not (math.isfinite(temperature) and temperature > 0):
            fail(f"--agitation must be an effective temperature > 0 K, got {temperature:g}.")
        if getattr(args, "solver", None) != "implicit-step":
            fail(
                "--agitation folds with the fixed-step engine's Euler steps, which add the random "
                "force to each step under contact (balanced against that scheme's damping): "
                "use --solver implicit-step --dt US."
            )
        # The bath's viscous drag balances the noise: a one-line refusal naming the flag that
        # removes it, before any net is loaded.
        if getattr(args, "fluid", None) == "air":
            fail("--agitation is the etch bath's random force: it needs --fluid koh (the default).")
        if inertia is False:
            fail(
                "--agitation needs the bath's viscous drag to balance its noise, which "
                "--no-fluid-inertia switches off with the fluid's inertia: drop --no-fluid-inertia."
            )
        from ..system import Agitation

        seed = getattr(args, "noise_seed", None) or 0
        if seed < 0:
            fail(f"--noise-seed must be a whole number >= 0, got {seed}.")
        options["agitation"] = Agitation(float(temperature), seed)
    return options


def _surface_numbers(text: str, flag: str, form: str, most: int) -> list[float | None]:
    """The comma-separated numbers of `flag` (an empty one, after the first: None, its default)."""
    parts = [x.strip() for x in text.split(",")]
    try:
        values = [float(x) if (x or k == 0) else None for k, x in enumerate(parts)]
    except ValueError:
        values = []
    if not 1 <= len(values) <= most or not all(v is None or math.isfinite(v) for v in values):
        fail(f"{flag} expects {form}: up to {most} comma-separated numbers, got {text!r}.")
    return values + [None] * (most - len(values))


def surface_model(args: argparse.Namespace, pattern: Any, design: Any) -> dict:
    """The `with_model` options `--adhesion` and `--friction` ask of `pattern` (folded with
    `design`): `{}` when neither is given, else `adhesion`/`friction` objects in the design's
    units, or a one-line exit. Adhesion's default range is twice the pattern's contact activation
    gap (its system is built once on the host to read it)."""
    from ..contact import Adhesion, Friction

    options: dict[str, Any] = {}
    if args.adhesion is not None:
        values = _surface_numbers(args.adhesion, "--adhesion", "W[,RANGE[,LINE]]", 3)
        work, line = values[0], (0.0 if values[2] is None else values[2])
        try:  # W and LINE checked before the default range builds the pattern's system
            Adhesion.from_si(design.units, work=work, range=1.0, line=line)
        except ValueError as error:
            fail(f"--adhesion {args.adhesion}: {one_line(str(error))}")
        if values[1] is not None:
            span = values[1] * 1e-6
        else:
            contact = pattern.system(design).contact
            if contact is None:
                fail("--adhesion acts where plates meet: it needs contact (drop --no-contact).")
            span = 2 * float(contact.activation) * design.units.metre_per_length
        try:
            options["adhesion"] = Adhesion.from_si(design.units, work=work, range=span, line=line)
        except ValueError as error:
            fail(f"--adhesion {args.adhesion}: {one_line(str(error))}")
    if args.friction is not None:
        values = _surface_numbers(args.friction, "--friction", "MU[,SLIP]", 2)
        slip = DEFAULT_FRICTION_SLIP if values[1] is None else values[1]
        try:
            options["friction"] = Friction(
                coefficient=values[0], slip=design.units.from_si(slip, length=1, time=-1)
            )
        except ValueError as error:
            fail(f"--friction {args.friction}: {one_line(str(error))}")
    return options


def jsonable(value: Any) -> Any:
    """`value` as plain JSON: NumPy and JAX numbers and arrays as Python numbers and lists, NaN and
    infinities as `None` (JSON `null`: strict JSON has no NaN), mappings and sequences recursed."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, str | bool) or value is None:
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if hasattr(value, "tolist"):  # NumPy or JAX scalar or array
        return jsonable(value.tolist())
    return str(value)


def dumps_json(value: Any) -> str:
    """Strict JSON text of `value` (see `jsonable`), indented."""
    return json.dumps(jsonable(value), indent=2, allow_nan=False) + "\n"


def write_atomic(path: Path, data: str | bytes) -> Path:
    """Write `data` to `path` through a temporary file in the same folder and `os.replace`, so that
    `path` holds either its old content or all of the new one; the temporary file is removed if the
    write fails (a full disk, Ctrl-C)."""
    path = Path(path)
    tmp = path.with_name(f".tmp-{os.getpid()}-{uuid.uuid4().hex[:12]}-{path.name}")
    try:
        with open(tmp, "wb") as handle:
            handle.write(data.encode("utf-8") if isinstance(data, str) else data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _stale_staging(out: Path) -> Iterable[Path]:
    """Staging folders left by killed runs (their process is gone)."""
    for path in out.glob(f"{STAGING_PREFIX}*"):
        parts = path.name[len(STAGING_PREFIX) :].split("-")
        pid = next((int(p) for p in parts if p.isdigit()), None)
        if path.is_dir() and (pid is None or not _pid_alive(pid)):
            yield path


def check_out_folder(out: Path, flag: str = "--out") -> Path:
    """Create `out` (and parents) and check it can be written; one-line errors otherwise."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        fail(f"{flag} {out} is a file, not a folder: give a folder to write the results into.")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        fail(f"cannot create the output folder {out}: {error.strerror or error}.")
    # A file created and removed: permissions alone pass a folder that takes no files (/proc,
    # read-only mounts for root), which failed only after the work.
    try:
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as error:
        fail(f"cannot write into the output folder {out}: {error.strerror or error}.")
    return out


class OutputFolder:
    """The results of one command run, written as a unit into `out` (module docstring).

    **Arguments:**
    - `out`: the folder (created if missing).
    - `command`: the subcommand's name, for messages and the staging folder's name.
    - `owns`: glob patterns (relative to `out`) of every file this command writes there. A match
      means the folder holds an earlier run's results: refused unless `overwrite`; with `overwrite`
      the matches this run does not write again are removed when it commits.
    - `overwrite`: replace earlier results (the `--overwrite` flag).
    - `refuse_hint`: what the message refusing earlier results tells the user to do.
    - `exclusive`: the folder is this command's alone (`sweep`, `yield`: their stores live
      there): another command's results in it are refused even with `overwrite`, and other
      commands refuse it once this one has written there.
    - `lend`: lend the folder's lock to library calls of this process that write into `out` (a
      sweep store: `origami_jax._folder_lock`).

    The folder is locked from here until `commit()` or `discard()`: a second run into `out` (of any
    command, or a sweep) is refused meanwhile.

    Write into `dir` (a staging folder inside `out`, same layout); `commit()` moves every file into
    `out` and returns their final paths. As a context manager it commits on success and discards
    the staging folder on an exception (Ctrl-C included).

    **Raises:** `CLIError` when `out` is a file, cannot be written, is in use by another run, or
    holds results (see `owns`).
    """

    def __init__(
        self,
        out: Path,
        *,
        command: str,
        owns: Sequence[str],
        overwrite: bool = False,
        lend: bool = False,
        refuse_hint: str = _OVERWRITE_HINT,
        exclusive: bool = False,
    ):
        # A folder this run creates is removed again when the run ends without results in it.
        self._created = not Path(out).exists()
        self.out = check_out_folder(Path(out))
        self.committed: list[Path] = []
        self.command = command
        self.owns = tuple(owns)
        self.overwrite = overwrite
        self.exclusive = exclusive
        # Held until commit or discard: a second run into `out` meanwhile is refused (the folder
        # was checked at the start only, and two runs each wrote half of the results).
        try:
            self._lock: FolderLock | None = lock_folder(self.out, command=command, lend=lend)
        except FolderBusyError as error:
            fail(_busy_line(error))
        try:
            for stale in _stale_staging(self.out):
                shutil.rmtree(stale, ignore_errors=True)
            self._marker = _read_marker(self.out)
            other = self._other()
            theirs = self._listed(other)
            if theirs and (not overwrite or exclusive or other.get("exclusive")):
                names = [str(p.relative_to(self.out)) for p in theirs]
                hint = (
                    "choose another --out"
                    if exclusive or other.get("exclusive") or refuse_hint != _OVERWRITE_HINT
                    else refuse_hint
                )
                fail(
                    f"{self.out} holds the results of an earlier `{other['command']}` run "
                    f"({capped(names, 4)}); {hint}."
                )
            earlier = self.existing()
            if earlier and not overwrite:
                names = [str(p.relative_to(self.out)) for p in earlier]
                fail(
                    f"{self.out} already holds results of an earlier run ({capped(names, 4)}); "
                    f"{refuse_hint}."
                )
            self.dir = self.out / f"{STAGING_PREFIX}{command}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
            try:
                self.dir.mkdir()
            except OSError as error:
                fail(f"cannot write into the output folder {self.out}: {error.strerror or error}.")
        except BaseException:
            self._release()
            raise
        self.discarded = False

    def _release(self) -> None:
        # Before the lock is let go: a run that opened the lock file meanwhile is refused as busy,
        # rather than taking a lock on a file no longer in the folder.
        if self._created and not self.committed:
            _remove_if_only_lock(self.out)
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def _other(self) -> dict | None:
        """The folder's marker when another command wrote the results there."""
        marker = self._marker
        return marker if marker is not None and marker["command"] != self.command else None

    def _listed(self, marker: dict | None) -> list[Path]:
        """The files `marker` lists that are still in `out`."""
        if marker is None:
            return []
        return sorted(p for p in (self.out / f for f in marker["files"]) if p.is_file())

    def existing(self) -> list[Path]:
        """Files in `out` that match `owns`, or that another command's run wrote there (its
        marker lists them): results of an earlier run."""
        found: set[Path] = set(self._listed(self._other()))
        for pattern in self.owns:
            found.update(p for p in self.out.glob(pattern) if p.is_file())
        return sorted(found)

    def final(self, path: str | os.PathLike) -> Path:
        """Where a file written under `dir` ends up after `commit()`."""
        path = Path(path)
        try:
            return self.out / path.relative_to(self.dir)
        except ValueError:
            return path

    def commit(self) -> list[Path]:
        """Move every staged file into `out` (replacing earlier ones), remove the earlier run's
        files this run did not write (with `overwrite`), and return the final paths."""
        if self.discarded:
            return []
        try:
            finals = self._commit()
        except BaseException:
            self.discard()
            raise
        self._release()
        return finals

    def _commit(self) -> list[Path]:
        # A Ctrl-C whose exception was lost (raised in a garbage collector's callback): stop here.
        interrupt.check()
        staged = sorted(p for p in self.dir.rglob("*") if p.is_file())
        finals = [self.final(p) for p in staged]
        if self.overwrite:
            keep = set(finals)
            for old in self.existing():
                if old not in keep:
                    old.unlink(missing_ok=True)
        for source, target in zip(staged, finals, strict=True):
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(source, target)
        shutil.rmtree(self.dir, ignore_errors=True)
        # Which command's results the folder holds, and which files they are (an earlier run of
        # this command that still has files there keeps them listed: `export`s of other names).
        mine = self._marker if self._other() is None else None
        listed = {str(p.relative_to(self.out)) for p in finals}
        listed.update(str(p.relative_to(self.out)) for p in self._listed(mine))
        marker = {"command": self.command, "files": sorted(listed), "exclusive": self.exclusive}
        write_atomic(self.out / RESULTS_MARKER, json.dumps(marker, indent=1) + "\n")
        self.committed = finals
        return finals

    def discard(self) -> None:
        """Drop everything staged: `out` keeps what it held."""
        shutil.rmtree(self.dir, ignore_errors=True)
        self.discarded = True
        self._release()

    def __enter__(self) -> OutputFolder:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is None:
            self.commit()
        else:
            self.discard()


def _busy_line(error: FolderBusyError) -> str:
    return f"{error}".replace("another output folder", "another --out")


def refuse_busy_folder(out: Path, command: str) -> None:
    """A one-line refusal when another run holds the folder `out`, for a command that works for
    seconds before it opens its `OutputFolder` (a net's fold builds and compiles its system
    first): said at once rather than after that work. Only a folder with a lock file is tried
    (every holder has one), so nothing is written into `out` here."""
    if not (Path(out) / LOCK).exists():
        return
    try:
        lock_folder(Path(out), command=command).close()
    except FolderBusyError as error:
        fail(_busy_line(error))
    except OSError:
        return  # an unreadable folder: `OutputFolder` says what is wrong with it


def holds_only_its_lock(out: Path) -> bool:
    """Whether the folder `out` is missing or holds nothing but its lock file (no earlier run's
    results or store)."""
    return not out.is_dir() or {p.name for p in out.iterdir()} <= {LOCK}


def _remove_if_only_lock(out: Path) -> None:
    """Remove the folder `out` if it holds nothing but its lock file (a run that created it and
    stopped before writing: bad input found late, an interrupt). Anything else there keeps it."""
    try:
        if out.is_dir() and holds_only_its_lock(out):
            (out / LOCK).unlink(missing_ok=True)
            out.rmdir()
    except OSError:
        pass


def _read_marker(out: Path) -> dict | None:
    """The folder's `RESULTS_MARKER` (`command`, `files`, `exclusive`), or `None` when there is
    none or it cannot be read (a folder written before it existed: `owns` alone decides)."""
    try:
        marker = json.loads((out / RESULTS_MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not (
        isinstance(marker, dict)
        and isinstance(marker.get("command"), str)
        and isinstance(marker.get("files"), list)
        and all(isinstance(f, str) and f and not Path(f).is_absolute() for f in marker["files"])
    ):
        return None
    # Only files inside the folder (a hand-edited "../x" is not ours to remove).
    files = [f for f in marker["files"] if ".." not in Path(f).parts]
    return {
        "command": marker["command"],
        "files": files,
        "exclusive": bool(marker.get("exclusive")),
    }


def prepare_out(out: Path) -> Path:
    """Create the output folder (and parents) with one-line errors; return it. Commands that write
    results use `OutputFolder` instead."""
    return check_out_folder(Path(out))


# Commands whose inputs are all checked before anything compiles and whose solver failures are
# result codes (never exceptions): inside their compiled programs a failed runtime check gives NaN
# instead of calling back into Python to raise (`EQX_ON_ERROR=nan`), which lets JAX store those
# programs in the persistent cache (it cannot store a program that calls back into Python; diffrax
# checks its sample times that way). The simulation's solve is most of a run's compile time.
NAN_ON_ERROR_COMMANDS = frozenset({"simulate", "fold"})


def setup_runtime(command: str | None = None, argv: Sequence[str] | None = None) -> None:
    """Configure JAX for command-line runs: float64 on, the persistent compilation cache on (see
    `origami_jax.enable_compilation_cache`; `ORIGAMI_JAX_CACHE=0` turns it off), matplotlib
    without a screen; for `NAN_ON_ERROR_COMMANDS`, `EQX_ON_ERROR=nan` unless set (it is read when
    equinox is first imported, so an in-process caller that imported it keeps its own).

    The library itself never flips global JAX configuration; the CLI does, because its results are
    written to files and must be reproducible to the digits it prints, and because each command is
    a new process that would otherwise compile everything again. With the command line's words
    `argv`, the executables its last run ran start loading in the background at once
    (`prefetch_for_command`).
    """
    os.environ.setdefault("MPLBACKEND", "Agg")
    if command in NAN_ON_ERROR_COMMANDS and "equinox" not in sys.modules:
        os.environ.setdefault("EQX_ON_ERROR", "nan")
    import jax

    jax.config.update("jax_enable_x64", True)
    # A cache entry that cannot be read or written (a full disk, another process writing it) only
    # costs a compilation; JAX warns with a multi-line message that would bury the command's own.
    warnings.filterwarnings(
        "ignore", message=r"Error (reading|writing) persistent compilation cache"
    )
    # The package's warnings are for the user (a hinge wider than its crease): one line each, as
    # the command's own messages, without the file and line they were raised at.
    warnings.formatwarning = _one_line_warning
    try:
        folder = enable_compilation_cache()
        if folder is not None:
            # The traced solve as well, so that a warm run neither traces nor compiles it.
            enable_exported_programs(folder / "exported")
            if argv is not None:
                prefetch_for_command(argv)
    except (ValueError, OSError) as error:  # an unwritable cache folder costs time, not the run
        print(f"origami-jax: warning: {error}", file=sys.stderr)


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"origami-jax: warning: {message}\n"


# The library's messages name its Python API (keywords, classes, functions) where the command line
# has flags: each phrase, as the library words it, and as the command line says it.
COMMAND_LINE_WORDING = (
    (", or pass require_targets=False", ""),
    (
        "give length_scale= (origami-jax fold --length-scale), the design's length units per FOLD "
        "unit, e.g. 1.0 for µm.",
        "give --length-scale, µm per FOLD unit (1 for a file drawn in µm).",
    ),
    (
        ": origami_jax.fold.catalogue_names() lists them (on the command line: origami-jax fold "
        "--list).",
        "; origami-jax fold --list lists them.",
    ),
    ("(contact='plate' or True), not no contact", "(--contact plate), not --no-contact"),
    ("Give radians (numpy.radians converts degrees).", "Give radians (degrees × π/180)."),
    ("Adhesion.work", "the work of adhesion W"),
    ("Adhesion.range", "the adhesion's RANGE"),
    ("Adhesion.line", "the adhesion's LINE"),
    ("Friction.coefficient", "the friction coefficient MU"),
    ("Friction.slip", "the friction's SLIP"),
)


def command_line_wording(message: str) -> str:
    """`message` with the library's Python names (`COMMAND_LINE_WORDING`) put as the command line's
    flags."""
    for library, command_line in COMMAND_LINE_WORDING:
        message = message.replace(library, command_line)
    return message


def print_error(command: str | None, message: str) -> None:
    """Print `message` as the command's one-line error (in the command line's wording)."""
    prefix = "origami-jax" + (f" {command}" if command else "")
    print(f"{prefix}: {command_line_wording(message)}", file=sys.stderr)
