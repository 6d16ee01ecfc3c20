"""Folding on until the panels settle: a run judged `unfinished` because it was still moving is
continued from its last state, one segment at a time.

How long a folding takes is not known before it is run (a cube net in the etch bath closes in
~1.4 ms, in air it rings for tens of ms), so a fixed end time is either too short (the verdict says
`unfinished`) or wasted. `fold_until_settled` runs one segment, judges it, and while the verdict is
`unfinished` with a successful solve (time ran out, not the step budget), or `folded` while its
panels still move (within the tolerances at the last sample, not at rest: walls bouncing on each
other's edges, whose final sample is a snapshot of the swing), runs the next segment from the
last state. Every segment has the same length and sample count, so the continuations reuse the
first segment's compiled solve; `join_trajectories` joins them into one `Trajectory`, and `assess`
judges runs padded to the next power of two of samples (at least 1024), so the growing run compiles
a verdict only when it crosses one (2 verdicts for 8 segments of 201 samples).
"""

from collections.abc import Callable

import jax
import numpy as np

from .._limits import FOLD_SEGMENT, MAX_FOLD_SEGMENTS
from ._implicit import start_bias
from ._inputs import Step
from ._options import SolveOptions
from ._simulate import Trajectory, simulate
from ._verdict import AbstractFoldReport

_STEP_COUNTS = ("num_steps", "num_accepted_steps", "num_rejected_steps", "contacts_left_out")


def join_trajectories(first: Trajectory, then: Trajectory) -> Trajectory:
    """`first` followed by `then`, a run continued from `first`'s last sample (its first sample is
    that one, and is dropped): samples (and states, where the runs keep them) concatenated, step
    counts added (the fixed-step engine's `newton_error`, the larger), the later result code (and the first stiffness switch, if `first` had one). Dense
    output is not joined: evaluate each run's own."""
    if first.theta.ndim != 2 or then.theta.ndim != 2:
        raise ValueError("join_trajectories joins single runs, not batches.")
    if first.theta.shape[-1] != then.theta.shape[-1]:
        raise ValueError(
            f"join_trajectories: runs of {first.theta.shape[-1]} and {then.theta.shape[-1]} "
            "coordinates cannot be joined."
        )
    fields = ("times", "theta", "theta_dot", "theta_ddot", "tau")
    joined = {f: _joined(getattr(first, f), getattr(then, f)) for f in fields}
    stats = dict(then.stats)
    for key in _STEP_COUNTS:
        if key in first.stats and key in then.stats:
            stats[key] = first.stats[key] + then.stats[key]
    if "newton_error" in first.stats and "newton_error" in then.stats:
        # The fixed-step engine's largest Newton update left at the end of a step: of the whole run.
        errors = (np.asarray(first.stats["newton_error"]), np.asarray(then.stats["newton_error"]))
        stats["newton_error"] = jax.device_put(np.maximum(*errors))
    if "switch_time" in first.stats and np.isfinite(float(first.stats["switch_time"])):
        stats["switch_time"] = first.stats["switch_time"]
    state = None
    if first.state is not None and then.state is not None:
        state = tuple(map(_joined, first.state, then.state))
    return Trajectory(**joined, target=then.target, stats=stats, result=then.result, state=state)


def _joined(first, then):
    """`first`'s samples, then `then`'s without its first (the shared one). On the host: an eager
    concatenation would compile a program for every new run length."""
    return jax.device_put(np.concatenate([np.asarray(first), np.asarray(then)[1:]]))


def fold_until_settled(
    system,
    inputs,
    judge: Callable[[Trajectory], AbstractFoldReport],
    options: SolveOptions | None = None,
    *,
    segment: float = FOLD_SEGMENT,
    max_segments: int = MAX_FOLD_SEGMENTS,
    t0: float = 0.0,
    theta0=None,
    theta_dot0=None,
    on_continue: Callable[[float, float], None] | None = None,
    first: float | None = None,
) -> tuple[Trajectory, AbstractFoldReport, int]:
    """Simulate `system` under `inputs` for `segment` (time units of the system; default 1000, µs in
    the default units), judge the run with `judge`, and while the panels still move with a
    successful solve (the verdict `unfinished`, or `folded` but not `settled`: `still_moving`)
    continue from the last state for another `segment`, up to `max_segments` segments in all
    (default 8).

    **Arguments:** `judge` maps a trajectory to its `FoldReport` (e.g. ``lambda tr:
    net.assess(system, tr)``); `options`, a [`origami_jax.simulation.SolveOptions`][] for every
    segment (default ``SolveOptions(throw=False)``, so that a failed segment is reported by the
    verdict; its `t1` must be `None`: the segments decide it); `t0`, `theta0`, `theta_dot0` the
    start (defaults: the system's rest); `on_continue(end, next_end)` is called before each
    continuation (e.g. to print progress); `first`, the first segment's length where it differs
    (default `segment`: a release ramp's run is the ramp and its settling, each continuation
    only the settling; the end time is traced, so the continuations reuse the first's compiled
    solve).

    **Returns:** `(trajectory, report, segments)`: the joined run, its verdict, how many segments
    it took. The verdict is the whole run's (the same `judge` on the joined trajectory).

    **Raises:** `ValueError` for a non-positive or non-finite `segment`, `max_segments < 1`, or
    options with a `t1`.
    """
    first = segment if first is None else first
    for name, value in (("segment", segment), ("first", first)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive, finite time, got {value}.")
    if int(max_segments) != max_segments or max_segments < 1:
        raise ValueError(f"max_segments must be a whole number >= 1, got {max_segments}.")
    options = SolveOptions(throw=False) if options is None else options
    if options.t1 is not None:
        raise ValueError("fold_until_settled runs segments: give segment=, not SolveOptions(t1=).")

    def run(start, length, theta, theta_dot):
        return simulate(
            system,
            inputs,
            options,
            t0=start,
            t1=start + length,
            theta0=theta,
            theta_dot0=theta_dot,
        )

    trajectory = run(t0, first, theta0, theta_dot0)
    report = judge(trajectory)
    segments = 1
    while still_moving(report) and bool(trajectory.succeeded) and segments < max_segments:
        end = float(trajectory.times[-1])
        if on_continue is not None:
            on_continue(end, end + segment)
        more = run(end, segment, trajectory.theta[-1], trajectory.theta_dot[-1])
        trajectory = join_trajectories(trajectory, more)
        report = judge(trajectory)
        segments += 1
    return trajectory, report, segments


def still_moving(report: AbstractFoldReport) -> bool:
    """Whether a fold report's panels still move at its end: `unfinished`, or `folded` (within the
    tolerances at the last sample) without having `settled` — a folding worth continuing."""
    if report.verdict == "unfinished":
        return True
    return report.verdict == "folded" and not report.settled


def fold_pattern(
    pattern,
    system,
    inputs=None,
    options: SolveOptions | None = None,
    *,
    t1: float | None = None,
    segment: float = FOLD_SEGMENT,
    max_segments: int = MAX_FOLD_SEGMENTS,
    bias: float = 0.0,
    tolerances=None,
    on_continue: Callable[[float, float], None] | None = None,
    first: float | None = None,
) -> tuple[Trajectory, AbstractFoldReport]:
    """The fold of a pattern (`AbstractPattern.fold`): `system` (one `pattern` built) simulated
    from `pattern.start_state(system, bias=bias)` and judged by `pattern.assess` (a closed-loop
    pattern folded by `ImplicitStep` from flat starts from `FIXED_STEP_PRE_FOLD`: `start_bias`).

    With `t1` (time units of the system: µs by default), one run to `t1`. Without it, runs of
    `segment` continued while the panels still move (`still_moving`), up to
    `max_segments` in all (`fold_until_settled`; `first`, the first segment's length where it
    differs), where the pattern's state is its hinge angles (`pattern.continues_from_angles`);
    otherwise one segment.

    **Arguments:** `inputs` (default a step release, `Step()`); `tolerances` (a
    `VerdictTolerances`, for `assess`); `on_continue(end, next_end)`, called before each
    continuation; `options`, the [`origami_jax.simulation.SolveOptions`][] of every segment
    (samples, solver, tolerances, step budget, progress meter; default
    ``SolveOptions(throw=False)``; its `t1` is this function's: give `t1=`).

    **Returns:** `(trajectory, report)`, the whole run and its `FoldReport`.
    """
    options = SolveOptions(throw=False) if options is None else options
    if options.t1 is not None:
        t1 = options.t1 if t1 is None else t1
        options = options.replace(t1=None)
    if t1 is not None:
        segment, max_segments, first = float(t1), 1, None
    elif not pattern.continues_from_angles:
        max_segments = 1
    bias = start_bias(pattern, options.solver, bias)
    theta0, theta_dot0 = pattern.start_state(system, bias=bias)
    trajectory, report, _ = fold_until_settled(
        system,
        Step() if inputs is None else inputs,
        lambda run: pattern.assess(system, run, bias=bias, tolerances=tolerances),
        options,
        segment=segment,
        max_segments=max_segments,
        theta0=theta0,
        theta_dot0=theta_dot0,
        on_continue=on_continue,
        first=first,
    )
    return trajectory, report
