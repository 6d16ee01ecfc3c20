"""Run every ``benchmarks/bench_*.py``: ``python -m benchmarks [--quick] [--only NAME] [--json PATH]``."""

import argparse
import importlib
import pkgutil
import sys
from pathlib import Path

import jax

from ._harness import Result, dump_json, machine_description
from ._report import results_markdown, throughput_figure


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="smoke run: small sizes, few repeats")
    parser.add_argument(
        "--only", action="append", default=[], help="run only bench_<NAME> (repeatable)"
    )
    parser.add_argument("--json", type=Path, default=None, help="write all results as JSON here")
    parser.add_argument(
        "--float32", action="store_true", help="leave JAX in float32 (default float64)"
    )
    parser.add_argument(
        "--markdown",
        type=Path,
        default=None,
        help="write the results as a Markdown section here (paste into benchmarks/RESULTS.md)",
    )
    parser.add_argument(
        "--figure", type=Path, default=None, help="throughput-vs-batch-size PNG here"
    )
    args = parser.parse_args(argv)
    if not args.float32:
        jax.config.update("jax_enable_x64", True)

    here = Path(__file__).parent
    names = sorted(m.name for m in pkgutil.iter_modules([str(here)]) if m.name.startswith("bench_"))
    if args.only:
        names = [n for n in names if n.removeprefix("bench_") in args.only or n in args.only]
    print("machine:", ", ".join(f"{k}={v}" for k, v in machine_description().items()))
    results: list[Result] = []
    failed = []
    for name in names:
        module = importlib.import_module(f"benchmarks.{name}")
        print(f"\n== {name} ==", flush=True)
        try:
            rows = module.run(quick=args.quick)
        except Exception as error:  # report and carry on: one broken peer must not hide the rest
            failed.append(name)
            print(f"{name} FAILED: {type(error).__name__}: {error}", file=sys.stderr)
            continue
        for row in rows:
            print(row.line(), flush=True)
        results.extend(rows)
    if args.json:
        dump_json(args.json, results)
        print(f"\nresults written to {args.json}")
    if args.markdown:
        title = f"{jax.default_backend().upper()} ({'quick' if args.quick else 'full'} run)"
        args.markdown.write_text(results_markdown(results, title=title, quick=args.quick))
        print(f"Markdown written to {args.markdown}")
    if args.figure and throughput_figure(results, args.figure):
        print(f"figure written to {args.figure}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
