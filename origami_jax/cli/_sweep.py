"""`origami-jax sweep`: Run a batch sweep over designs from a TOML config, chunked, resumable."""

import argparse
import contextlib
import dataclasses
import time
from pathlib import Path

from .._exported import note_programs_used
from ._common import (
    EXIT_FAILED,
    EXIT_OK,
    Interrupted,
    OutputFolder,
    add_solver_arguments,
    fail,
    out_path,
    solver_choice,
    write_atomic,
)

DESCRIPTION = """\
Run a batch sweep over designs from a TOML config, chunked, resumable.

The config names the model (and its input), its settings, the design space (grid, Latin hypercube,
uniform samples or a table) and the parameters with their ranges; see examples/sweep_*.toml.
Writes OUT/sweep.nc (NetCDF, parameters as coordinates, units as attributes), OUT/chunks/ (one file
per finished chunk: an interrupted sweep continues with --resume), OUT/plots/ and OUT/summary.txt.
A folder holding a sweep is never overwritten: continue it with --resume (the stored chunks are
checked; an unreadable or foreign one is set aside as chunks/NAME.bad and recomputed), or choose
another --out. A second sweep on a folder in use by a running one is refused. Ctrl-C, a full disk
or a kill keep every finished chunk: continue with --resume.
Exit codes: 0 all designs succeeded, 1 some designs failed (marked in `result`) or the run stopped
(disk full), 2 bad config or a folder in use, 130 interrupted.

--solver, --dt and --newton-iterations choose the net-fold model's solver (as its config's
solver, dt and newton_iterations settings do; give them in one place): implicit-step folds every
design in fixed implicit Euler steps of --dt µs (implicit-bdf2: BDF2 steps, second order), the same work for every member of a chunk. The
solver is part of the sweep's settings (sweep.json, sweep.nc's settings): --resume continues with
the same one only.
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="Run a batch sweep over designs from a TOML config, chunked, resumable.",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("config", type=Path, nargs="?", help="sweep configuration (TOML)")
    parser.add_argument(
        "--out",
        type=out_path,
        default=Path("origami_out/sweep"),
        help="output folder, created if missing (default: ./origami_out/sweep)",
    )
    parser.add_argument("--resume", action="store_true", help="continue the sweep stored in --out")
    parser.add_argument("--no-plots", action="store_true", help="skip the summary plots")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--list-models", action="store_true", help="list the models the sweep knows"
    )
    add_solver_arguments(parser, "the config's, else tsit5 (net-fold model only)")
    parser.set_defaults(func=run)


def _list_models() -> None:
    from ..sweep import available_models

    for name, description in available_models().items():
        print(f"{name}: {description}")


@contextlib.contextmanager
def stored_sweep_errors(out: Path):
    """A sweep storing its chunks in `out` (`sweep`, `yield`): bad input and a folder in use are
    one-line usage errors, a failed write (a full disk) a one-line failure, Ctrl-C an interruption
    that says how many chunks are kept for `--resume`."""
    from ..sweep import SweepBusyError

    with chunks_kept_on_interrupt(out):
        try:
            yield
        except (FileExistsError, ValueError, SweepBusyError) as error:
            fail(str(error))
        except OSError as error:
            fail(f"{error.strerror or error}", EXIT_FAILED)


@contextlib.contextmanager
def chunks_kept_on_interrupt(out: Path):
    """Ctrl-C anywhere in a run that stores chunks in `out` (`sweep`, `yield`; its figures and
    summary included): an interruption that says how many chunks are kept for `--resume`."""
    try:
        yield
    except KeyboardInterrupt:
        stored = len(list((out / "chunks").glob("part-*.nc")))
        raise Interrupted(
            f"interrupted; the {stored} finished chunk(s) are kept in {out / 'chunks'}: continue "
            "with --resume."
        ) from None


def run(args: argparse.Namespace) -> int:
    if args.list_models:
        _list_models()
        return EXIT_OK
    if args.config is None:
        fail("give a CONFIG.toml (or --list-models).")
    from ..sweep import load_config

    try:
        # Resuming: a net-fold store of the old default seam tolerance keeps it.
        config = load_config(args.config, resume_from=Path(args.out) if args.resume else None)
    except (ValueError, OSError) as error:
        message = str(error).removeprefix(f"{args.config}: ")  # the file named once
        fail(f"bad config {args.config}: {message}")
    config = _with_solver_flags(args, config)
    # The summary and plots describe the dataset: replaced together (the sweep itself decides,
    # through its manifest, that this run may write here). The folder is held for the whole run
    # (the sweep's store borrows its lock): another run into it meanwhile is refused.
    owns = ("summary.txt",) if args.no_plots else ("summary.txt", "plots/*.png")
    output = OutputFolder(
        Path(args.out), command="sweep", owns=owns, overwrite=True, lend=True, exclusive=True
    )
    with output, chunks_kept_on_interrupt(output.out):
        return _run(args, config, output)


_ENGINE_SETTINGS = ("solver", "dt", "newton_iterations")


def _with_solver_flags(args: argparse.Namespace, config):
    """`config` with the net-fold model's solver set by `--solver`, `--dt` and
    `--newton-iterations` (checked first: one-line exits); unchanged without `--solver`."""
    if args.solver is None and args.dt is None and args.newton_iterations is None:
        return config
    if config.kernel.name != "net-fold":
        fail(
            f"--solver, --dt and --newton-iterations choose the net-fold model's solver; "
            f"{args.config} sweeps {config.kernel.name}."
        )
    choice = solver_choice(args, float(config.kernel.settings["t_end_us"]), "the config's t_end")
    model = {k: v for k, v in config.raw.get("model", {}).items() if k not in ("name", "input")}
    named = sorted(set(model) & set(_ENGINE_SETTINGS))
    if named:
        fail(
            f"{args.config} sets {', '.join(named)} in [model]: give the solver there or on the "
            "command line, not both."
        )
    assert choice is not None  # --dt or --newton-iterations without --solver already exited
    engine: dict = {"solver": choice["solver"]}
    if "dt_us" in choice:
        engine.update(dt=choice["dt_us"], newton_iterations=choice["newton_iterations"])
    from ..sweep import get_model

    try:
        kernel = get_model("net-fold", **model, **engine)
    except ValueError as error:
        fail(f"bad config {args.config}: {error}")
    return dataclasses.replace(config, kernel=kernel)


def _run(args: argparse.Namespace, config, output: OutputFolder) -> int:
    from ..sweep import sweep

    out = output.out
    print(
        f"[sweep] model {config.kernel.name}: {config.space.size} designs over "
        f"{', '.join(config.space.names)} -> {out}",
        flush=True,
    )
    start = time.perf_counter()
    with stored_sweep_errors(out):
        dataset = sweep(
            config.kernel,
            config.space,
            chunk_size=config.chunk_size,
            out=out,
            resume=args.resume,
            progress=not args.no_progress,
        )
    elapsed = time.perf_counter() - start
    # A rerun of this command line reads the sweep's executables while it starts (`prefetch`).
    note_programs_used()
    n, failed = dataset.attrs["n_designs"], dataset.attrs["n_failed"]
    lines = [
        f"model: {config.kernel.name}",
        *(
            [f"solver: {config.kernel.settings['solver']}"]
            if "solver" in (config.kernel.settings or {})
            else []
        ),
        f"designs: {n} ({failed} failed), parameters: {', '.join(config.space.names)}",
        f"wall time this run: {elapsed:.1f} s (compilation included)",
        f"  of which compiling {dataset.attrs['compile_s']:.1f} s, computing and storing chunks "
        f"{dataset.attrs['run_s']:.1f} s",
        f"dataset: {out / 'sweep.nc'}",
    ]
    if failed:
        codes = dataset["result"].values
        meanings = dict(
            zip(
                dataset["result"].attrs.get("flag_values", []),
                str(dataset["result"].attrs.get("flag_meanings", "")).split(),
                strict=False,
            )
        )
        for code in sorted(set(codes[codes != 0].tolist())):
            lines.append(
                f"  result {code} ({meanings.get(code, '?')}): {(codes == code).sum()} designs"
            )
    if not args.no_plots:
        from ..plotting import sweep as sweep_plots

        paths = sweep_plots.summary_plots(
            dataset, output.dir / "plots", metrics=config.plot_metrics
        )
        lines.append(f"plots: {len(paths)} in {out / 'plots'}")
    write_atomic(output.dir / "summary.txt", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return EXIT_FAILED if failed else EXIT_OK
