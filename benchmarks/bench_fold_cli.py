"""Time to a net's fold verdict on the command line: `origami-jax fold cube_net_01`, end to end.

The contact issue's targets for the fold command on the 2-core machine: warm (the compiled
programs, and the traced solve, read from the cache folder) at most 3 s, cold (an empty cache
folder) at most 15 s, in air at most 30 s. Each run is a new process, timed from its start to its
exit (imports, the system's build, compilation or its loading, the fold, the verdict, the files):

- **bath**: the command's defaults (KOH, the fluid's inertia, the quasi-static release: 40 ms of
  ramp and a fifth of it after), with its figures;
- **bath, no figures**: the same with `--no-figures` (the angle plot, frames and GIF cost ~2 s
  warm);
- **air**: `--fluid air` (the paper's step release; the net rings, and the command folds on in
  segments until it settles, up to its 8000 µs cap), with its figures.

Cold runs use a fresh cache folder (`ORIGAMI_JAX_CACHE`), warm runs the folder the cold run
filled. Both run with the package's Python bytecode compiled, as an installation has it
(`bench_compile.command_env`). No peer: no other tool folds a net with plate contact from a FOLD file in one command;
the rows record the targets' figures.

Run: `python -m benchmarks --only fold_cli [--quick]` (three cold runs, each with an empty cache
folder, and three warm runs of each case, about 5 minutes on 2 cores; the quick run: one of each).
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ._harness import Result, Timing
from .bench_compile import ROOT, command_env

TARGETS_S = {"warm": 3.0, "cold": 15.0, "air": 30.0}
"""The contact issue's targets (s, 2-core machine): warm and cold in the bath; in air."""

CASES = {
    "bath": [],
    "bath, no figures": ["--no-figures"],
    "air": ["--fluid", "air"],
}


def _fold_wall(argv: list[str], env: dict[str, str]) -> float:
    """Seconds of one fold command; exit status 1 is a verdict other than folded (in air the net
    is still ringing at the cap: `unfinished`), a result like any other."""
    start = time.perf_counter()
    process = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=ROOT)
    elapsed = time.perf_counter() - start
    if process.returncode not in (0, 1) or "verdict:" not in process.stdout:
        raise RuntimeError(f"{' '.join(argv[2:5])}... failed: {process.stderr[-2000:]}")
    return elapsed


def fold_times(cold_runs: int, warm_runs: int) -> dict[str, dict[str, list[float]]]:
    """Wall seconds of `cold_runs` cold runs (each with a cache folder of its own) and `warm_runs`
    warm runs (with the last cold run's folder) of each case, each a new process."""
    env = command_env()
    times: dict[str, dict[str, list[float]]] = {}
    with tempfile.TemporaryDirectory(prefix="bench_fold_cli_") as tmp:
        for case, flags in CASES.items():
            argv = [sys.executable, "-m", "origami_jax", "fold", "cube_net_01", *flags]
            argv += ["--overwrite", "--out", str(Path(tmp) / "out")]
            cold = []
            for run_index in range(cold_runs):
                env["ORIGAMI_JAX_CACHE"] = str(Path(tmp) / f"cache-{len(times)}-{run_index}")
                cold.append(_fold_wall(argv, env))
            warm = [_fold_wall(argv, env) for _ in range(warm_runs)]
            times[case] = {"cold": cold, "warm": warm}
    return times


def run(quick: bool) -> list[Result]:
    times = fold_times(cold_runs=1 if quick else 3, warm_runs=1 if quick else 3)
    rows = []
    for case, runs in times.items():
        target = TARGETS_S["air"] if case == "air" else None
        for kind in ("cold", "warm"):
            goal = target if target is not None else TARGETS_S[kind]
            rows.append(
                Result(
                    f"CLI fold cube_net_01 ({case}), {kind} cache (new process)",
                    Timing.of(runs[kind]),
                    notes=f"target <= {goal:g} s",
                    extra={"target_s": goal, "wall_s": runs[kind]},
                )
            )
    return rows
