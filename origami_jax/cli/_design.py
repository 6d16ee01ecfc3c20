"""`origami-jax design`: Fit hinge parameters to target rise times / overshoot or to a measured response."""

import argparse
import math
import time
from pathlib import Path
from typing import overload

from .._limits import MAX_FLAPS
from ._common import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_USAGE,
    OutputFolder,
    add_out_argument,
    add_solver_arguments,
    dumps_json,
    fail,
    int_range,
    positive,
    solver_choice,
    with_solver,
    write_atomic,
)

# Most starts and optimiser steps a command-line fit takes (the starts run as one vmapped batch).
MAX_STARTS = 256
MAX_FIT_STEPS = 10_000

_EPILOG = """\
Times are in SI seconds on the command line; per-joint lists are comma-separated with '-' for a joint
without a target. A single --target-overshoot value targets joint 1 (as the paper reports it).
--solver implicit-step --dt US fits through fixed implicit Euler steps (implicit-bdf2: BDF2 steps;
--dt in µs, as for fold, yield and sweep): the fit's derivatives are then those of the discrete
map; design.json records the solver.

example (the paper's Fig. 7 step response):
  origami-jax design --target-rise 37e-6,101e-6,38e-6 --target-overshoot 0.39 \\
      --free k_scale,b_scale --bounds k_scale=0.1:100,b_scale=0.1:1000 --out design_out
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "design",
        help="Fit hinge parameters to target rise times / overshoot or to a measured response.",
        description="Fit hinge parameters to target rise times / overshoot or to a measured response.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--target-rise", help="10-90 %% rise time per joint, seconds")
    parser.add_argument("--target-overshoot", help="overshoot per joint, fraction (0.39 = 39 %%)")
    parser.add_argument("--target-peak", help="time of the highest peak per joint, seconds")
    parser.add_argument("--target-settling", help="2 %% settling time per joint, seconds")
    parser.add_argument("--target-final", help="final angle per joint, degrees")
    parser.add_argument(
        "--target-t90", help="time to reach 90 %% of the target angle per joint, seconds"
    )
    parser.add_argument(
        "--curve",
        help="measured response: CSV with a header, columns t (s) then theta_1..theta_n (rad)",
    )
    parser.add_argument(
        "--free",
        default="k_scale,b_scale",
        help="free HingeDesign parameters, or the flap size (flap_length, flap_width; default "
        "k_scale,b_scale)",
    )
    parser.add_argument(
        "--bounds",
        default="",
        help="name=lower:upper,... in SI units for dimensional parameters (default ×/÷ 100 of the start)",
    )
    parser.add_argument(
        "--fluid", choices=("air", "koh"), default="air", help="fold fluid (default air)"
    )
    parser.add_argument(
        "--n-flaps", type=int, default=None, help="accordion flaps (default: targets')"
    )
    parser.add_argument(
        "--t1", type=float, default=None, help="run length, s (default from the targets)"
    )
    parser.add_argument("--starts", type=int, default=8, help="multi-start count (default 8)")
    parser.add_argument("--max-steps", type=int, default=48, help="optimiser steps per start")
    parser.add_argument(
        "--tolerance", type=float, default=0.05, help="relative miss counted as met"
    )
    add_solver_arguments(parser, "tsit5 (the fit's derivatives are the resolved motion's)")
    add_out_argument(parser)
    parser.set_defaults(func=run)


def _floats(text: str | None, what: str) -> list[float] | None:
    if text is None:
        return None
    values = []
    for item in text.split(","):
        item = item.strip()
        if item in ("", "-", "nan"):
            values.append(math.nan)
            continue
        try:
            value = float(item)
        except ValueError:
            raise ValueError(f"{what}: {item!r} is not a number.") from None
        if not math.isfinite(value):
            raise ValueError(f"{what}: {item!r} is not finite (use '-' for a joint without one).")
        values.append(value)
    if not values or all(math.isnan(v) for v in values):
        raise ValueError(f"{what}: no values in {text!r}.")
    return values


@overload
def _pad(values: list[float], n: int, what: str) -> list[float]: ...
@overload
def _pad(values: None, n: int, what: str) -> None: ...
def _pad(values: list[float] | None, n: int, what: str) -> list[float] | None:
    if values is None:
        return None
    if len(values) == 1 and n > 1:
        return values + [math.nan] * (n - 1)
    if len(values) != n:
        raise ValueError(f"{what}: {len(values)} values for {n} joints.")
    return values


# SI → design units, per parameter kind (see origami_jax.design._space.parameter_unit).
def _convert(units, kind: str, value: float) -> float:
    return {
        "length": units.length,
        "stress": units.stress,
        "mass/length³": units.density,
    }.get(kind, lambda v: v)(value)


def _check_numbers(args: argparse.Namespace) -> None:
    if args.n_flaps is not None:
        int_range(args.n_flaps, "--n-flaps", 1, MAX_FLAPS)
    if args.t1 is not None:
        positive(args.t1, "--t1", "s")
    int_range(args.starts, "--starts", 1, MAX_STARTS)
    int_range(args.max_steps, "--max-steps", 1, MAX_FIT_STEPS)
    positive(args.tolerance, "--tolerance", "relative miss")


def _read_curve(path: str):
    import numpy as np

    file = Path(path)
    if not file.is_file():
        fail(f"--curve {path}: no such file.")
    try:
        table = np.loadtxt(file, delimiter=",", skiprows=1, ndmin=2)
    except (ValueError, OSError) as error:
        fail(f"--curve {path}: not a CSV of numbers with one header line ({error}).")
    if table.shape[1] < 2 or table.shape[0] < 2:
        fail(
            f"--curve {path}: needs columns t (s), theta_1, ... and at least 2 rows, got shape "
            f"{table.shape}."
        )
    if not np.all(np.isfinite(table[:, 0])):
        fail(f"--curve {path}: the times (first column) must be finite.")
    return table


def run(args: argparse.Namespace) -> int:
    try:
        rise = _floats(args.target_rise, "--target-rise")
        overshoot = _floats(args.target_overshoot, "--target-overshoot")
        peak = _floats(args.target_peak, "--target-peak")
        settling = _floats(args.target_settling, "--target-settling")
        final = _floats(args.target_final, "--target-final")
        t90 = _floats(args.target_t90, "--target-t90")
    except ValueError as error:
        fail(str(error))
    times = {
        "--target-rise": rise,
        "--target-peak": peak,
        "--target-settling": settling,
        "--target-t90": t90,
    }
    for flag, values in times.items():
        bad = [v for v in values or () if v <= 0]  # NaN ('-') is a joint without one
        if bad:
            fail(
                f"{flag}: {bad[0]:g} s is not a positive time (seconds; '-': a joint without one)."
            )
    _check_numbers(args)
    lists = [v for v in (rise, peak, settling, final, t90) if v is not None]
    n = args.n_flaps or (len(lists[0]) if lists else None)
    if n is None and args.curve is None and overshoot is not None:
        n = 3
    if n is None and args.curve is None:
        fail("give at least one target (--target-*, --curve).")
    table = None if args.curve is None else _read_curve(args.curve)
    if n is not None:
        int_range(n, "the joint count of the targets", 1, MAX_FLAPS)
    output = OutputFolder(
        Path(args.out),
        command="design",
        owns=("design.json", "design_response.png"),
        overwrite=args.overwrite,
    )
    with output:
        code = _fit(args, output.dir, n, table, rise, overshoot, peak, settling, final, t90)
    if code == EXIT_OK or code == EXIT_FAILED:
        print(f"wrote {output.out / 'design.json'} and {output.out / 'design_response.png'}")
    return code


def _fit(args, out: Path, n, table, rise, overshoot, peak, settling, final, t90) -> int:
    print(
        "origami-jax design: loading JAX and compiling (the first fit takes a minute) ...",
        flush=True,
    )
    import origami_jax.design as ojd
    import origami_jax.simulation as sim
    from origami_jax.system import AIR, KOH_SOLUTION, MICRO, HingeDesign

    units = MICRO
    try:
        curve = None
        if table is not None:
            curve = ojd.MeasuredCurve(units.time(table[:, 0]), table[:, 1:])
            n = n or curve.theta.shape[1]
        assert n is not None  # from the targets or the curve, checked above
        to_time = lambda v: None if v is None else [units.time(x) for x in _pad(v, n, "time")]
        targets = ojd.Targets(
            rise_time=to_time(rise),
            overshoot=_pad(overshoot, n, "--target-overshoot"),
            peak_time=to_time(peak),
            settling_time=to_time(settling),
            final_angle=None
            if final is None
            else [math.radians(x) for x in _pad(final, n, "--target-final")],
            t90=to_time(t90),
            curve=curve,
        )
        free = [name.strip() for name in args.free.split(",") if name.strip()]
        bounds = {}
        for item in filter(None, (b.strip() for b in args.bounds.split(","))):
            name, _, span = item.partition("=")
            lower, _, upper = span.partition(":")
            kind = ojd.parameter_unit(name.strip())
            low, high = float(lower), float(upper)
            if not (math.isfinite(low) and math.isfinite(high) and low < high):
                raise ValueError(f"--bounds {item!r}: give finite lower < upper.")
            bounds[name.strip()] = (_convert(units, kind, low), _convert(units, kind, high))
        fluid = AIR if args.fluid == "air" else KOH_SOLUTION
        hinge = HingeDesign.literature(units, fluid=fluid)
        t1 = None if args.t1 is None else units.time(args.t1)
    except ValueError as error:
        fail(str(error))
    # --dt in µs, bounded by the run: --t1's, else the one the targets give (`design`'s default).
    horizon = t1 if t1 is not None else ojd.time_horizon(targets)
    choice = solver_choice(
        args,
        math.inf if horizon is None else float(horizon),
        "--t1" if t1 is not None else "the run length the targets give",
    )
    options = with_solver(sim.FIT_OPTIONS.replace(t1=t1), choice)

    print(
        f"  targets: {', '.join(targets.labels) or '-'}{' + measured curve' if curve is not None else ''}"
        f"\n  free: {', '.join(free)}; {args.starts} starts, up to {args.max_steps} steps each",
        flush=True,
    )
    start = time.perf_counter()
    try:
        result = ojd.design(
            hinge,
            targets,
            free,
            bounds=bounds,
            options=options,
            n_starts=args.starts,
            max_steps=args.max_steps,
            tolerance=args.tolerance,
        )
    except (ValueError, RuntimeError) as error:
        fail(str(error), EXIT_FAILED if isinstance(error, RuntimeError) else EXIT_USAGE)
    print(f"  fitted in {time.perf_counter() - start:.1f} s (compilation included)", flush=True)
    print(result.summary())

    payload = result.to_dict()
    payload["solver"] = choice or {"solver": "tsit5"}
    payload["units_note"] = "values in MICRO units: µm, µs, ng, MPa; overshoot as a fraction"
    payload["targets_si"] = {
        row.label: {
            "target": row.target * (1e-6 if row.unit == "time" else 1.0),
            "achieved": row.achieved * (1e-6 if row.unit == "time" else 1.0),
        }
        for row in result.targets
    }
    write_atomic(out / "design.json", dumps_json(payload))
    print("  drawing the before/after response ...", flush=True)
    import matplotlib

    matplotlib.use("Agg")
    ojd.plot_response(result, path=out / "design_response.png")
    return EXIT_OK if result.reached else EXIT_FAILED
