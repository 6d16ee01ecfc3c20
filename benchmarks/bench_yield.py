"""Yield of a cube net under fabrication scatter: samples/s of `yield_estimate` vs MuJoCo (C).

Ours: `origami_jax.fab_yield.yield_estimate` of `cube_net_01` under the default `Scatter()` (film
stress, thicknesses, hinge widths, drag and release times per crease, their documented spreads),
each sample a folding with panel drag and contact to 1500 µs and a verdict, through the sweep
engine (chunks `vmap`-ped, a chunk of one sample unbatched, sharded over the local devices:
one CPU device unless XLA is told otherwise). Compile apart: a first estimate of one chunk compiles the chunk's program, the timed
one reuses it (same chunk size).

Peer: the MuJoCo model of the nets benchmark (`bench_net`: same tree, inertias, axes and spring
constants, critical joint damping, mesh contacts, `implicitfast` at 1/200 of the shortest hinge
period) rolled out over the same number of nets with that benchmark's scatter (±10 % stiffness,
release over 20 µs; MuJoCo's cost per net does not depend on the values) on one thread and on
two. What is compared is throughput: the two models dissipate differently, and the verdict
needs the contact and seams MuJoCo does not report, so no answer is compared here (`bench_net`
compares the end states of the same nets).

Run: ``python -m benchmarks --only yield`` (10,000 samples: about an hour on 2 cores; ``--quick``:
64 samples).
"""

import argparse
import os
import time

import jax

from origami_jax.fab_yield import RunOptions, Scatter, yield_estimate
from origami_jax.net import FOLD_KERNEL_SOLVE, load_net
from origami_jax.system import KOH_SOLUTION, HingeDesign

from ._harness import Result, Timing
from ._mujoco_tree import release_controls
from .bench_net import (
    NET,
    T1,
    mujoco_batch_seconds,
    mujoco_step,
    scattered_draws,
    scattered_mujoco,
)


def PAPER_NET():  # noqa: N802 (a constant, built on first use)
    """The net with the paper's dynamics in the bath (no fluid inertia, released at once): what
    the MuJoCo peer models (its bodies carry no added mass)."""
    return load_net(NET).with_model(added_mass=False, viscous=False)


def _estimate(n_samples: int, chunk: int | None = None, workers: int | None = None, **kwargs):
    """`kwargs`: more `RunOptions` (`progress`, `out`, `resume`)."""
    return yield_estimate(
        PAPER_NET(),
        Scatter(),
        n_samples=n_samples,
        seed=0,
        solve=FOLD_KERNEL_SOLVE.replace(t1=T1),
        run=RunOptions(
            chunk_size=chunk, workers=workers, progress=kwargs.pop("progress", False), **kwargs
        ),
    )


def _timed(n_samples: int, chunk: int | None, workers: int | None, **kwargs):
    """An estimate, its wall seconds per sample (compile excluded: the kernel is compiled by an
    earlier call of the same chunk size) and its process CPU seconds per sample (the call's CPU
    seconds per wall second of computing, times its wall seconds per sample)."""
    cpu = os.times()
    estimate = _estimate(n_samples, chunk, workers, **kwargs)
    used = os.times()
    seconds = used.user - cpu.user + used.system - cpu.system
    run_s = estimate.dataset.attrs["run_s"]
    per_sample = estimate.seconds_per_sample
    return estimate, per_sample, seconds / run_s * per_sample if run_s > 0 else 0.0


def _mujoco_seconds(n_nets: int, threads: int) -> float:
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    system = PAPER_NET().system(design)
    dt, nstep = mujoco_step(system)
    factor, release = scattered_draws(n_nets, system.hinges.stiffness.shape[0])
    models = scattered_mujoco(system, design, dt, factor)
    controls = release_controls(release, nstep, dt)
    return mujoco_batch_seconds(models, controls, threads).median


def run(quick: bool, n_samples: int | None = None, out: str | None = None) -> list[Result]:
    jax.config.update("jax_enable_x64", True)
    n_samples = (64 if quick else 10_000) if n_samples is None else n_samples
    accelerated = jax.default_backend() != "cpu"
    stored = {"out": out, "resume": True} if out is not None else {}
    if accelerated:
        # Chunks of n_samples / 8 there: no smaller estimate compiles the same program, and the
        # estimate reports its own compile time apart from its computing time.
        estimate, ours, ours_cpu = _timed(n_samples, None, None, progress=out is not None, **stored)
        compile_s = float(estimate.dataset.attrs["compile_s"])
    else:
        start = time.perf_counter()
        _estimate(1)  # compiles the default chunk's program (one sample per call on a CPU)
        compile_s = time.perf_counter() - start
        estimate, ours, ours_cpu = _timed(n_samples, None, None, progress=out is not None, **stored)
    size, workers = estimate.dataset.attrs["chunk_size"], estimate.dataset.attrs["workers"]
    rows = []
    if quick:
        # The sweep's former CPU default for this kernel: wide chunks one after another.
        _estimate(16, 16, 1)
        _, wide, wide_cpu = _timed(n_samples, 16, 1)
        rows.append(
            Result(
                name=f"{NET} yield, {n_samples} samples, s/sample: chunks of {size} x {workers} "
                "at once vs chunks of 16 one at a time",
                ours=Timing.once(ours),
                peer_name="ours, 16-wide vmapped chunks, one at a time",
                peer=Timing.once(wide),
                compile_s=compile_s,
                notes=f"CPU s/sample: {ours_cpu:.3g} vs {wide_cpu:.3g}",
                extra={"ours_cpu_s": ours_cpu, "wide_cpu_s": wide_cpu},
            )
        )
    # MuJoCo over at most 1,000 nets (its cost per net is flat in the count).
    n_mj = min(n_samples, 1000)
    # Beside a GPU only the target's two threads (the lease's time goes to the GPU).
    for threads in (2,) if accelerated else (1, 2):
        peer = _mujoco_seconds(n_mj, threads) / n_mj
        rows.append(
            Result(
                name=f"{NET} yield, {n_samples} samples, samples/s: ours vs MuJoCo on "
                f"{threads} thread{'s' if threads > 1 else ''}",
                ours=Timing.once(ours),
                peer_name=f"MuJoCo rollout over {n_mj} scattered models (C), {threads} thread(s)",
                peer=Timing.once(peer),
                compile_s=compile_s,
                notes=(
                    f"per sample; ours {1 / ours:.3g} samples/s ({size} per compiled call, "
                    f"{workers} calls at once; CPU {ours_cpu:.3g} s/sample), yield "
                    f"{estimate.fraction:.4f} {estimate.interval} ({estimate.counts}); MuJoCo "
                    f"{1 / peer:.3g} nets/s"
                ),
                extra={
                    "n_samples": n_samples,
                    "chunk_size": size,
                    "workers": workers,
                    "ours_samples_per_s": 1 / ours,
                    "ours_cpu_s_per_sample": ours_cpu,
                    "mujoco_nets_per_s": 1 / peer,
                    "mujoco_threads": threads,
                    "yield": estimate.fraction,
                    "interval": list(estimate.interval),
                    "counts": estimate.counts,
                },
            )
        )
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=64, help="samples (default 64)")
    parser.add_argument(
        "--out", default=None, help="store the samples here and resume an interrupted run"
    )
    args = parser.parse_args()
    for row in run(quick=args.samples <= 64, n_samples=args.samples, out=args.out):
        print(row.line())
