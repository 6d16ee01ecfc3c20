"""The two engines judge scattered cube nets alike: the adaptive default and the fixed implicit
steps (`ImplicitStep(dt=2.5)`, Euler and BDF2), on the same draws of the default fabrication
scatter.

The contact issue's test: verdicts agree on at least 99 % of 1,000 scattered cube nets, and the
two yields lie within each other's Wilson intervals. Both estimates settle the samples still moving
at 1500 µs (`yield_estimate`'s `t_settle`, 8000 µs), so the engines are compared where the nets come
to rest. (Before 2026-12-05 the second estimate in one process reused the first one's kernel, the
adaptive one: the cache of kernels did not key on the solver. The CLI's figures, one process per
engine, were not affected.) Slow: about 4.5 s (adaptive), 0.9 s (Euler) and 1.0 s (BDF2) per
sample on a loaded 2-core machine (2026-12-06), ~100 minutes for the three; `ENGINE_AGREEMENT_SAMPLES`
runs fewer (the 99 % then needs at most one disagreement in a hundred).
"""

import os

import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.fab_yield import RunOptions, yield_estimate
from origami_jax.net import FOLD_KERNEL_SOLVE, load_net

SAMPLES = int(os.environ.get("ENGINE_AGREEMENT_SAMPLES", "1000"))
# The paper's dynamics in the bath (released at once, no fluid inertia), as measured below.
PAPER = load_net("cube_net_01").with_model(added_mass=False, viscous=False)


@pytest.fixture(scope="module")
def estimates():
    run = RunOptions(progress=False)
    return {
        name: yield_estimate(PAPER, n_samples=SAMPLES, seed=11, solve=solve, run=run)
        for name, solve in (
            ("adaptive", FOLD_KERNEL_SOLVE),
            ("fixed", FOLD_KERNEL_SOLVE.replace(solver=sim.ImplicitStep(dt=2.5))),
            ("bdf2", FOLD_KERNEL_SOLVE.replace(solver=sim.ImplicitStep(dt=2.5, scheme="bdf2"))),
        )
    }


@pytest.mark.slow
@pytest.mark.parametrize("fixed", ["fixed", "bdf2"])
def test_the_two_engines_agree_on_which_nets_fold(estimates, fixed):
    """The yield's question, folded or not: the same answer on at least 99 % of the samples, and
    each yield within the other's Wilson interval (200 samples of seed 5 through the CLI,
    2026-12-05: 198 of 200 alike, yields 0.030 and 0.020; seed 11, 2026-12-06: 200 of 200 alike
    for Euler and for BDF2, and 998 of 1000 for BDF2, yields 0.035 adaptive and 0.037 BDF2, in
    3292 s and 750 s)."""
    folded = {name: np.asarray(e.dataset["folded"]) for name, e in estimates.items()}
    assert np.mean(folded["adaptive"] == folded[fixed]) >= 0.99
    adaptive, other = estimates["adaptive"], estimates[fixed]
    assert adaptive.interval[0] <= other.fraction <= adaptive.interval[1]
    assert other.interval[0] <= adaptive.fraction <= other.interval[1]


@pytest.mark.slow
@pytest.mark.xfail(
    strict=False,
    reason="not met: on 1000 samples of seed 11 (2026-12-06) BDF2 judged 979 alike (97.9 %); on "
    "the first 200, 197 (Euler 193; 182 of 200 of seed 5, 2026-12-05); the rest are jammed against "
    "misfolded (BDF2 at 1.25 µs: 195 of 200 alike). Not the reference's own scatter: the adaptive "
    "solve at 100x tighter tolerances (rtol 1e-9) judged 199 of the 200 as the default does, BDF2 "
    "196 as it does (2026-12-07): the fixed steps' own, walls that lock edge on edge in fixed "
    "steps and slide past each other in the adaptive solve, or the reverse (docs/guides/yield.md)",
)
def test_every_verdict_of_the_two_engines_agrees(estimates):
    """Every verdict (folded, jammed, misfolded, unfinished) alike on at least 99 % of the samples,
    for the fixed steps' more faithful scheme, BDF2 (Euler's numerical damping settles some
    samples the adaptive solve leaves ringing, and the reverse)."""
    verdicts = {name: np.asarray(e.dataset["verdict"]) for name, e in estimates.items()}
    agreement = np.mean(verdicts["adaptive"] == verdicts["bdf2"])
    assert agreement >= 0.99, (agreement, {n: e.counts for n, e in estimates.items()})
