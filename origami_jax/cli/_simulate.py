"""`origami-jax simulate`: simulate the folding of a hinged-flap chain (accordion) under a step or an
etch-rate ramp input; write the trajectory, the metrics and the figures."""

import argparse
import json
from pathlib import Path

from .._limits import MAX_FLAPS, MAX_SAMPLES
from ._common import (
    EXIT_FAILED,
    EXIT_OK,
    FLAP_PARAMS,
    OutputFolder,
    add_figures_argument,
    add_out_argument,
    dumps_json,
    fail,
    hinge_params,
    in_range,
    int_range,
    positive,
    print_error,
    write_atomic,
)

HELP = (
    "Simulate the folding of a hinged-flap chain (accordion) under a step or etch-rate ramp input."
)
DESCRIPTION = HELP + (
    " Hinges use the literature defaults (200 nm SiNx, 100 nm Cr at 1 GPa, 200 µm square flaps, C_D 1.17);"
    " override any HingeDesign field, or the flaps' size (flap_length, flap_width), with"
    " --param NAME=VALUE in MICRO units (µm, µs, ng, MPa), e.g."
    " --param k_scale=3.07 --param hinge_width=100. Inputs: 'step' (paper Fig. 7), 'fast-ramp' (the"
    " paper's 0.1 s ramp, Fig. 10), 'ramp' (the real etch ramp, β = 1.5 µm/min, ≈ 2.7 h; large implicit"
    " steps validated against a resolved window)."
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("simulate", help=HELP, description=DESCRIPTION)
    parser.add_argument("--input", choices=("step", "ramp", "fast-ramp"), default="step")
    parser.add_argument(
        "--flaps", type=int, default=3, help=f"number of flaps, 1 to {MAX_FLAPS} (default 3)"
    )
    parser.add_argument("--fluid", choices=("air", "koh"), default="air", help="default air")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override a HingeDesign field or the flap size (flap_length, flap_width; MICRO "
        "units), repeatable",
    )
    parser.add_argument(
        "--t1", type=float, default=None, help="end time, µs (default: 2000 step, 1.2 T ramps)"
    )
    parser.add_argument(
        "--solver",
        choices=("auto", "kvaerno5", "tsit5"),
        default="auto",
        help="auto (default): Tsit5, switching to Kvaerno5 when the problem turns stiff",
    )
    parser.add_argument("--rtol", type=float, default=None, help="default 1e-7")
    parser.add_argument("--atol", type=float, default=None, help="default 1e-9")
    parser.add_argument(
        "--n-save", type=int, default=2001, help="samples, at least 2 (default 2001)"
    )
    parser.add_argument(
        "--band", type=float, default=0.02, help="settling band, in (0, 1) (default 0.02)"
    )
    parser.add_argument("--format", choices=("csv", "npz"), default="csv")
    add_figures_argument(parser)
    add_out_argument(parser)
    parser.set_defaults(func=run)


def _parse_params(items: list[str]) -> dict[str, float]:
    try:
        params = hinge_params(items, flaps=True)
    except ValueError as error:
        fail(str(error))
    for name, values in params.items():
        if len(values) != 1:
            fail(f"--param {name}: give one value (every hinge of the chain takes it).")
    return {name: values[0] for name, values in params.items()}


def check_arguments(args: argparse.Namespace) -> dict[str, float]:
    """Every number of the command line checked before JAX is imported: `CLIError` (exit 2, one
    line) for a bad one. Returns the parsed `--param` overrides."""
    params = _parse_params(args.param)
    int_range(args.flaps, "--flaps", 1, MAX_FLAPS, why=" (longer chains: use the Python API)")
    int_range(args.n_save, "--n-save", 2, MAX_SAMPLES)
    if args.t1 is not None:
        positive(args.t1, "--t1", "µs, the end of the run; it starts at 0")
    for flag, value in (("--rtol", args.rtol), ("--atol", args.atol)):
        if value is not None:
            positive(value, flag)
    in_range(args.band, "--band", 0.0, 1.0, what=" (a fraction of the target angle)")
    return params


def write_trajectory(trajectory, path: Path, *, fmt: str = "csv", time_unit: str = "us") -> Path:
    """Write times, θ, θ̇, τ to CSV (units in the header) or NPZ (plus a `units` entry)."""
    import numpy as np

    times = np.asarray(trajectory.times)
    theta = np.asarray(trajectory.theta)
    theta_dot = np.asarray(trajectory.theta_dot)
    tau = np.asarray(trajectory.tau)
    n = theta.shape[1]
    units = {
        "time": time_unit,
        "theta": "rad",
        "theta_dot": f"rad/{time_unit}",
        "tau": "pN*m" if time_unit == "us" else "N*m",
    }
    import io

    buffer = io.BytesIO()
    if fmt == "npz":
        path = path.with_suffix(".npz")
        np.savez(
            buffer, times=times, theta=theta, theta_dot=theta_dot, tau=tau, units=json.dumps(units)
        )
        return write_atomic(path, buffer.getvalue())
    path = path.with_suffix(".csv")
    columns = [f"time [{units['time']}]"]
    columns += [f"theta_{j + 1} [rad]" for j in range(n)]
    columns += [f"theta_dot_{j + 1} [{units['theta_dot']}]" for j in range(n)]
    columns += [f"tau_{j + 1} [{units['tau']}]" for j in range(n)]
    data = np.column_stack([times, theta, theta_dot, tau])
    np.savetxt(buffer, data, delimiter=",", header=",".join(columns), comments="", fmt="%.12g")
    return write_atomic(path, buffer.getvalue())


# The figures `write_figures` draws, named after the input.
FIGURE_PATTERNS = ("*_angles.png", "*_frames.png", "*_animation.gif")


def run(args: argparse.Namespace) -> int:
    params = check_arguments(args)
    # A bad --param is refused before the folder is taken.
    design, pattern = _design(args, params)
    output = OutputFolder(
        Path(args.out),
        command="simulate",
        owns=("trajectory.*", "metrics.json", *FIGURE_PATTERNS),
        overwrite=args.overwrite,
    )
    with output:
        code, lines, problem = _run(args, params, design, pattern, output.dir)
    for line in lines:
        print(line.replace(str(output.dir), str(output.out)))
    if problem:
        print_error("simulate", problem)
    return code


def _design(args: argparse.Namespace, params: dict[str, float]):
    """The literature `HingeDesign` in the chosen fluid with the `--param` values, and the
    accordion of `--flaps` flaps with the flap size among them (`FLAP_PARAMS`); a one-line exit
    for a bad one."""
    from origami_jax.chain import Accordion
    from origami_jax.system import AIR, KOH_SOLUTION, HingeDesign

    fluid = {"air": AIR, "koh": KOH_SOLUTION}[args.fluid]
    hinge = {k: v for k, v in params.items() if k not in FLAP_PARAMS}
    flaps = {k: v for k, v in params.items() if k in FLAP_PARAMS}
    try:
        # A misplaced name such as units= is a runtime TypeError, reported below.
        design = HingeDesign.literature(
            fluid=fluid,
            **hinge,  # pyright: ignore[reportArgumentType]
        )
        return design, Accordion(args.flaps, **flaps)  # pyright: ignore[reportArgumentType]
    except (TypeError, ValueError) as error:
        fail(f"bad --param: {error}")


def _run(args: argparse.Namespace, params: dict[str, float], design, pattern, out: Path):
    """The run itself, writing into `out` (the staging folder). Returns the exit code, the lines
    to print and a one-line problem to report (or `None`)."""
    import diffrax
    import jax.numpy as jnp

    import origami_jax.simulation as sim
    from origami_jax._result_codes import message
    from origami_jax.system import MICRO

    n = args.flaps
    system = pattern(design)
    k, b = system.hinges.stiffness, system.drag.coefficient
    solver = {
        "auto": sim.default_solver,
        "kvaerno5": sim.implicit_solver,
        "tsit5": diffrax.Tsit5,
    }[args.solver]()
    rtol = sim.DEFAULT_RTOL if args.rtol is None else args.rtol
    atol = sim.DEFAULT_ATOL if args.atol is None else args.atol
    # A progress bar for the long ramps only: it calls back into Python, and a compiled program
    # that does cannot be kept in the persistent compilation cache (a step solves in milliseconds).
    progress = (
        diffrax.NoProgressMeter()
        if args.input == "step"
        else diffrax.TqdmProgressMeter(refresh_steps=200)
    )
    extra: dict = {}
    ramp = None
    if args.input in ("step", "fast-ramp"):
        if args.input == "step":
            inputs = sim.Step()
            default_t1, max_steps = 2000.0, 200_000
        else:
            ramp = inputs = sim.fast_ramp(
                system.hinges.target, duration=MICRO.time(sim.FAST_RAMP_DURATION_SI)
            )
            default_t1, max_steps = 1.2 * float(ramp.duration(system)), 500_000
        trajectory = sim.simulate(
            system,
            inputs,
            sim.SolveOptions(
                saveat=sim.SaveAt(n=args.n_save),
                solver=solver,
                rtol=rtol,
                atol=atol,
                max_steps=max_steps,
                throw=False,
                progress_meter=progress,
            ),
            t1=default_t1 if args.t1 is None else args.t1,
        )
    else:
        beta = MICRO.length(sim.KOH_ETCH_RATE_SI) / MICRO.time(1.0)
        ramp = inputs = sim.EtchRamp(beta)
        slow = sim.simulate_slow_ramp(
            system,
            ramp,
            sim.SLOW_RAMP_OPTIONS.replace(
                saveat=sim.SaveAt(n=args.n_save),
                max_steps=max(20 * args.n_save, 4096),
                progress_meter=progress,
            ),
        )
        trajectory = slow.trajectory
        extra = {
            "ramp_duration_us": float(ramp.duration(system)),
            "ramp_duration_hours": float(ramp.duration(system)) * 1e-6 / 3600,
            "validation_window_us": float(slow.window.times[-1]),
            "quasi_static_error_rad": jnp.asarray(slow.quasi_static_error).tolist(),
            "large_step_error_rad": jnp.asarray(slow.large_step_error).tolist(),
            "window_succeeded": bool(slow.window.succeeded),
        }
    ok = bool(trajectory.succeeded)
    path = write_trajectory(trajectory, out / "trajectory", fmt=args.format)
    report = {
        "input": args.input,
        "flaps": n,
        "fluid": design.fluid.name,
        "units": {"time": "us", "angle": "rad", "stiffness": "pN*m/rad", "drag": "pN*m*us^2/rad^2"},
        "stiffness": jnp.asarray(k).tolist(),
        "drag": jnp.asarray(b).tolist(),
        "params": params,
        "result": "successful" if ok else message(trajectory.result, sim.RESULTS),
        "succeeded": ok,
        # What the trajectory file holds, so that a copy cut short is told from a shorter run.
        "samples": int(jnp.shape(trajectory.times)[0]),
        "t1": float(trajectory.times[-1]),
        "stats": _json_stats(trajectory.stats),
        **extra,
    }
    metrics = None
    if ok:
        metrics = sim.response_metrics(trajectory, band=args.band)
        report["metrics"] = metrics.as_dict()
    write_atomic(out / "metrics.json", dumps_json(report))
    lines = [f"trajectory: {path}", f"metrics: {out / 'metrics.json'}"]
    if metrics is not None:
        for j in range(n):
            lines.append(
                f"joint {j + 1}: rise {float(metrics.rise_time[j]):.4g} µs, overshoot "
                f"{float(metrics.overshoot[j]):.3g} %, peak at {float(metrics.peak_time[j]):.4g} µs"
                + (" [rise ill-conditioned]" if bool(metrics.rise_ill_conditioned[j]) else "")
                + (" [settling ill-posed]" if bool(metrics.settling_ill_posed[j]) else "")
            )
    if not ok:
        return EXIT_FAILED, lines, f"solve failed: {report['result']}"
    if args.figures != "none":
        write_figures(
            system,
            trajectory,
            metrics,
            out,
            ramp=ramp,
            name=args.input,
            animation=args.figures == "all",
        )
    return EXIT_OK, lines, None


def write_figures(
    system,
    trajectory,
    metrics,
    out: Path,
    *,
    ramp=None,
    name: str = "step",
    animation: bool = True,
) -> list[Path]:
    """Joint angles (PNG), frames strip (PNG) and, with `animation`, the animation (GIF) into
    `out`."""
    import matplotlib.pyplot as plt

    from origami_jax.plotting import chain as chain_plots

    long_run = float(trajectory.times[-1]) > 1e5
    scale, label, unit = (1e-6, "time [s]", "s") if long_run else (1.0, "time [µs]", "µs")
    desired = None if ramp is None else (lambda t: ramp.desired(t, system)[0])
    fig = chain_plots.plot_joint_angles(
        trajectory,
        metrics,
        time_scale=scale,
        time_label=label,
        desired=desired,
        title=f"{name} response",
    )
    paths = [out / f"{name}_angles.png", out / f"{name}_frames.png", out / f"{name}_animation.gif"]
    fig.savefig(paths[0], dpi=120)
    plt.close(fig)
    t_max = None
    if metrics is not None and ramp is None:
        # Show the fold itself, not the long ringing tail.
        t_max = 3.0 * float(max(metrics.peak_time.max(), metrics.t90.max()))
    fig = chain_plots.folding_frames(
        system, trajectory, paths[1], n_frames=6, t_max=t_max, time_scale=scale, time_unit=unit
    )
    plt.close(fig)
    if not animation:
        return paths[:2]
    chain_plots.animate_folding(
        system, trajectory, paths[2], t_max=t_max, time_scale=scale, time_unit=unit
    )
    return paths


def _json_stats(stats) -> dict:
    """Solver statistics as JSON: counts as ints, `switch_time` (µs) as a float, `null` if never."""
    import numpy as np

    out = {}
    for key, value in stats.items():
        value = np.asarray(value)
        if np.issubdtype(value.dtype, np.integer):
            out[key] = int(value)
        else:
            out[key] = float(value) if bool(np.isfinite(value)) else None
    return out
