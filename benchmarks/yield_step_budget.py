"""A step budget against one pass: `yield_estimate` of `cube_net_01` under the default scatter in
vmapped chunks of 16, two at once, with and without `step_budget` (the samples' results must be the
same), and the lockstep's member-steps counted from the samples' own step counts, also tiled to a
GPU's chunk widths.

Run: ``python -m benchmarks.yield_step_budget [SAMPLES [BUDGET]]`` (default 256 samples, a budget
of 4,000 steps; about 10 minutes on 2 cores). Not part of ``python -m benchmarks``: it compares two
settings of our own code, there is no peer.
"""

import dataclasses
import sys
import time

import jax
import numpy as np

import origami_jax.fab_yield as ojy
from origami_jax.net import FOLD_KERNEL_SOLVE, load_net

NET, CHUNK, WORKERS = "cube_net_01", 16, 2


def lockstep(steps: np.ndarray, width: int) -> int:
    """Member-steps of chunks of `width` that each step until their slowest member is done."""
    return int(sum(width * steps[i : i + width].max() for i in range(0, len(steps), width)))


def main(n: int = 256, budget: int = 4000) -> None:
    jax.config.update("jax_enable_x64", True)
    run = ojy.RunOptions(chunk_size=CHUNK, workers=WORKERS, progress=False)
    common = dict(n_samples=n, seed=0, solve=FOLD_KERNEL_SOLVE.replace(t1=1500.0))
    # The paper's dynamics in the bath (no fluid inertia, released at once): 1500 µs runs.
    net = load_net(NET).with_model(added_mass=False, viscous=False)
    one = ojy.yield_estimate(net, ojy.Scatter(), run=run, **common)
    print(f"one pass: {one.seconds_per_sample:.3f} s/sample", flush=True)
    steps = np.asarray(one.dataset["num_steps"].values)
    print(
        f"steps: median {np.median(steps):g}, 90th percentile {np.percentile(steps, 90):g}, "
        f"max {steps.max()}"
    )
    start = time.perf_counter()
    budgeted = dataclasses.replace(run, step_budget=budget)
    two = ojy.yield_estimate(net, ojy.Scatter(), run=budgeted, **common)
    print(
        f"budget {budget}: {two.seconds_per_sample:.3f} s/sample "
        f"({two.dataset.attrs['stragglers']} stragglers; wall {time.perf_counter() - start:.0f} s "
        "with its compilation)"
    )
    for name in ("verdict", "num_steps", "final_angle"):
        np.testing.assert_array_equal(two.dataset[name].values, one.dataset[name].values)
    print(f"ratio {one.seconds_per_sample / two.seconds_per_sample:.2f}x (same samples)")
    for width in (CHUNK, 500, 1000):
        tiled = steps if width == CHUNK else np.resize(steps, 10 * width)
        over = tiled > budget
        budgeted = lockstep(np.minimum(tiled, budget), width) + (
            lockstep(tiled[over], width) if over.any() else 0
        )
        print(f"lockstep at width {width}: {lockstep(tiled, width) / budgeted:.2f}x fewer steps")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
