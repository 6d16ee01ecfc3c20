"""`origami-jax sweep`: Run a batch sweep over designs from a TOML config, chunked, resumable."""

import argparse
import sys
import time
from pathlib import Path

from ._common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, add_out_argument, prepare_out

DESCRIPTION = """\
Run a batch sweep over designs from a TOML config, chunked, resumable.

The config names the model (and its input), its settings, the design space (grid, Latin hypercube,
uniform samples or a table) and the parameters with their ranges; see examples/sweep_*.toml.
Writes OUT/sweep.nc (NetCDF, parameters as coordinates, units as attributes), OUT/chunks/ (one file
per finished chunk: an interrupted sweep continues with --resume), OUT/plots/ and OUT/summary.txt.
Exit codes: 0 all designs succeeded, 1 some designs failed (marked in `result`), 2 bad config.
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="Run a batch sweep over designs from a TOML config, chunked, resumable.",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("config", type=Path, nargs="?", help="sweep configuration (TOML)")
    add_out_argument(parser, default=Path("origami_out/sweep"))
    parser.add_argument("--resume", action="store_true", help="continue the sweep stored in --out")
    parser.add_argument("--no-plots", action="store_true", help="skip the summary plots")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--list-models", action="store_true", help="list the models the sweep knows"
    )
    parser.set_defaults(func=run)


def _list_models() -> None:
    from ..sweep import available_models

    for name, description in available_models().items():
        print(f"{name}: {description}")


def run(args: argparse.Namespace) -> int:
    if args.list_models:
        _list_models()
        return EXIT_OK
    if args.config is None:
        print("origami-jax sweep: give a CONFIG.toml (or --list-models).", file=sys.stderr)
        return EXIT_USAGE
    from ..sweep import load_config, sweep

    try:
        config = load_config(args.config)
    except (ValueError, OSError) as error:
        print(f"origami-jax sweep: bad config {args.config}: {error}", file=sys.stderr)
        return EXIT_USAGE

    out = prepare_out(Path(args.out))
    print(
        f"[sweep] model {config.kernel.name}: {config.space.size} designs over "
        f"{', '.join(config.space.names)} -> {out}",
        flush=True,
    )
    start = time.perf_counter()
    try:
        dataset = sweep(
            config.kernel,
            config.space,
            chunk_size=config.chunk_size,
            out=out,
            resume=args.resume,
            progress=not args.no_progress,
        )
    except (FileExistsError, ValueError) as error:
        print(f"origami-jax sweep: {error}", file=sys.stderr)
        return EXIT_USAGE
    elapsed = time.perf_counter() - start
    n, failed = dataset.attrs["n_designs"], dataset.attrs["n_failed"]
    lines = [
        f"model: {config.kernel.name}",
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

        paths = sweep_plots.summary_plots(dataset, out / "plots", metrics=config.plot_metrics)
        lines.append(f"plots: {len(paths)} in {out / 'plots'}")
    (out / "summary.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return EXIT_FAILED if failed else EXIT_OK
