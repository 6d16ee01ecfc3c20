"""Yield of a cube net under fabrication scatter: samples/s of `yield_estimate` vs MuJoCo (C).

Ours: `origami_jax.fab_yield.yield_estimate` of `cube_net_01` under the default `Scatter()` (film
stress, thicknesses, hinge widths, drag and release times per crease, their documented spreads),
each sample a folding with panel drag and contact to 1500 µs and a verdict, through the sweep
engine (chunks `vmap`-ped, sharded over the local devices: one CPU device unless XLA is told
otherwise). Compile apart: a first estimate of one chunk compiles the chunk's program, the timed
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

import time

import jax

from origami_jax.fab_yield import Scatter, yield_estimate
from origami_jax.net import load_net
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


def _estimate(n_samples: int, chunk: int):
    return yield_estimate(
        NET, Scatter(), n_samples=n_samples, seed=0, t_end=T1, chunk_size=chunk, progress=False
    )


def _mujoco_seconds(n_nets: int, threads: int) -> float:
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    system = load_net(NET).system(design)
    dt, nstep = mujoco_step(system)
    factor, release = scattered_draws(n_nets, system.hinges.stiffness.shape[0])
    models = scattered_mujoco(system, design, dt, factor)
    controls = release_controls(release, nstep, dt)
    return mujoco_batch_seconds(models, controls, threads).median


def run(quick: bool) -> list[Result]:
    jax.config.update("jax_enable_x64", True)
    n_samples, chunk = (64, 16) if quick else (10_000, 256)
    start = time.perf_counter()
    _estimate(chunk, chunk)  # compiles the chunk's program
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    estimate = _estimate(n_samples, chunk)
    ours = (time.perf_counter() - start) / n_samples
    # MuJoCo over at most 1,000 nets (its cost per net is flat in the count).
    n_mj = min(n_samples, 1000)
    rows = []
    for threads in (1, 2):
        peer = _mujoco_seconds(n_mj, threads) / n_mj
        rows.append(
            Result(
                name=f"{NET} yield, {n_samples} samples, samples/s: ours vs MuJoCo on "
                f"{threads} thread{'s' if threads > 1 else ''}",
                ours=Timing(ours, ours, ours, 1),
                peer_name=f"MuJoCo rollout over {n_mj} scattered models (C), {threads} thread(s)",
                peer=Timing(peer, peer, peer, 1),
                compile_s=compile_s,
                notes=(
                    f"per sample; ours {1 / ours:.3g} samples/s (chunks of {chunk}, compile and "
                    f"the first chunk of {chunk} apart), yield {estimate.fraction:.3f} "
                    f"({estimate.counts}); MuJoCo {1 / peer:.3g} nets/s"
                ),
                extra={
                    "n_samples": n_samples,
                    "chunk_size": chunk,
                    "ours_samples_per_s": 1 / ours,
                    "mujoco_nets_per_s": 1 / peer,
                    "mujoco_threads": threads,
                    "yield": estimate.fraction,
                },
            )
        )
    return rows


if __name__ == "__main__":
    for row in run(quick=True):
        print(row.line())
