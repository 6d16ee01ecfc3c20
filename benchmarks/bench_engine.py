"""The fixed-step engine (`ImplicitStep`) on a cube net with contact: one step, one fold, a batch.

The net and the peer are those of `bench_net`: `cube_net_01` (six 200 µm SiNx squares, literature
bilayer hinges, KOH solution, the exact plate contact `PlateContact`), folded from flat by a step
release to 1500 µs and checked to close the cube; the scattered batch (±10 % stiffness per crease,
release times over 20 µs) and MuJoCo (C, `mujoco.rollout` over one model per net, one thread per
core) as there. Ours in fixed implicit Euler steps of 2.5 µs (`ImplicitStep(dt=2.5)`, its default Newton
iterations, halvings and collision chords: 600 steps), beside the adaptive default of `bench_net`
(explicit Tsit5 at the default tolerances) on the same nets:

- one step, compiled, from the fold's state at 300 µs (mid-fold, before the panels meet: a
  step's work is fixed but for the collision check's loop), ms per step;
- one fold, warm, ours fixed steps against ours adaptive (compile apart, in `compile_s`);
- the batch: nets/s of the fixed steps against MuJoCo over the same nets on every core, and of
  the adaptive engine over the same nets. Ours on every core as `origami_jax.sweep` computes a
  batch on a CPU: the batch in chunks (`jax.vmap` within a chunk), one chunk per core at a time,
  each compiled call from its own thread (XLA computes a small vmapped solve on about one core).
  Chunks of `FIXED_CHUNK` nets for the fixed steps (or of its largest divisor that divides the
  batch), of one net for the adaptive engine (the net kernels' `cpu_chunk_size`: its step counts
  spread under contact, and a chunk steps until its slowest member is done);
- the batch end to end: ours from tracing and compiling the batched fold to its first answer
  against MuJoCo from building its models to its first rollout (one cold call each);
- a crease pattern with closed loops (`LOOPS_PATTERN`, the Miura 3×3: its loops held by the fixed
  steps' penalty, by the adaptive solver's constrained accelerations): one fold each, warm.

Every batch's members are checked to close the cube before they are timed; each fold's verdict is
the net's (`Net.assess`).

Run: ``python -m benchmarks --only engine`` (``--quick``: a batch of 4, one repeat; the batch from
``ENGINE_BATCH``), or ``python -m benchmarks.bench_engine [--quick] [--batch N] [--json PATH]``.
"""

import concurrent.futures
import functools
import math
import os
import time

import diffrax
import jax
import jax.numpy as jnp
import numpy as np

import origami_jax.simulation as sim
from origami_jax.loops import load_pattern
from origami_jax.net import load_net
from origami_jax.simulation import _implicit
from origami_jax.system import KOH_SOLUTION, HingeDesign

from . import bench_net
from ._harness import Result, Timing, time_calls
from ._mujoco_tree import release_controls

DT = 2.5  # µs: the fixed step the docs use for cube nets
T1 = bench_net.T1
N_SAVE = bench_net.N_SAVE
CONTACT_STATE_US = 300.0  # the per-step row's state: mid-fold
# Nets per compiled call of the fixed steps' batch: on 2 cores chunks of 4 gave 0.10-0.11 s per
# net, of 1 0.13, of 16 0.11, one call over 16 on one thread 0.22 (benchmarks/history.md, "The
# batch on every core").
FIXED_CHUNK = 4
# The closed-loop row: a Miura sheet, long enough to fold in the paper's dynamics.
LOOPS_PATTERN = "miura_3x3"
LOOPS_T1 = 3000.0


def _fixed(system, dt=DT, scheme="euler"):
    solver = sim.ImplicitStep(dt=dt, scheme=scheme)
    return sim.simulate(
        system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=N_SAVE), solver=solver), t1=T1
    )


def _adaptive(system):
    return sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(
            saveat=sim.SaveAt(n=N_SAVE), solver=diffrax.Tsit5(), max_steps=200_000, throw=False
        ),
        t1=T1,
    )


def _progress(message: str) -> None:
    print(f"[engine {time.strftime('%H:%M:%S')}] {message}", flush=True)


def _compiled(fn, *args):
    start = time.perf_counter()
    compiled = jax.jit(fn).lower(*args).compile()
    return compiled, time.perf_counter() - start


def _on_every_core(member, args, chunk: int, workers: int):
    """`member` over the batch `args` (arrays with the batch first) as `origami_jax.sweep` runs a
    batch on a CPU: `jax.vmap(member)` compiled for `chunk` members (the batch divisible by it),
    the chunks computed `workers` at a time, each call from its own thread (XLA releases the GIL
    while it computes). Returns ``(run, compile_s)``, `run()` the batch's outputs in order."""
    batch = args[0].shape[0]
    if batch % chunk:
        raise ValueError(f"a batch of {batch} does not split into chunks of {chunk}")
    chunks = [tuple(a[i : i + chunk] for a in args) for i in range(0, batch, chunk)]
    compiled, compile_s = _compiled(jax.vmap(member), *chunks[0])
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=workers)

    def run():
        parts = pool.map(lambda part: jax.block_until_ready(compiled(*part)), chunks)
        return jax.tree.map(lambda *xs: np.concatenate(xs), *parts)

    return run, compile_s


def run(quick: bool, batch: int | None = None) -> list[Result]:
    jax.config.update("jax_enable_x64", True)
    repeats = 1 if quick else 3
    if batch is None:
        # `ENGINE_BATCH`: a larger batch where a device fills it (benchmarks/device_run.sh).
        batch = int(os.environ.get("ENGINE_BATCH", 4 if quick else 16))
    net = load_net(bench_net.NET)
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    # The paper's dynamics in the bath (no fluid inertia, released at once), as bench_net's.
    system = net.system(design, contact="plate", added_mass=False, viscous=False)
    targets = np.asarray(system.hinges.target)
    contact = system.contact
    rows: list[Result] = []

    # One fold, fixed steps and adaptive.
    _progress("compiling one fold, fixed steps")
    fixed, fixed_compile = _compiled(_fixed, system)
    _progress("compiling one fold, adaptive")
    adaptive, adaptive_compile = _compiled(_adaptive, system)
    folds = {}
    for name, solve in (("fixed", fixed), ("adaptive", adaptive)):
        trajectory = solve(system)
        report = net.assess(system, trajectory)
        if report.verdict != "folded":
            raise AssertionError(f"ours ({name} steps): {report.summary()}")
        bench_net._check(f"ours ({name})", net, np.asarray(trajectory.theta[-1])[None], targets)
        folds[name] = trajectory
    steps = int(folds["fixed"].stats["num_steps"])
    adaptive_steps = int(folds["adaptive"].stats["num_steps"])
    fixed_time = time_calls(lambda: fixed(system).theta, repeats=repeats, warmup=0)
    adaptive_time = time_calls(lambda: adaptive(system).theta, repeats=repeats, warmup=0)
    difference = float(
        np.max(
            np.abs(np.asarray(folds["fixed"].theta[-1]) - np.asarray(folds["adaptive"].theta[-1]))
        )
    )
    rows.append(
        Result(
            name=f"{bench_net.NET} (plate contact) one fold to {T1:g} us: ImplicitStep dt {DT:g} us "
            f"vs adaptive Tsit5",
            ours=fixed_time,
            peer_name="ours, adaptive Tsit5 at the default tolerances",
            peer=adaptive_time,
            compile_s=fixed_compile,
            max_abs_difference=difference,
            notes=(
                f"warm; fixed: {steps} steps, newton_error "
                f"{float(folds['fixed'].stats['newton_error']):.1e} rad; adaptive: {adaptive_steps} "
                f"steps, compile {adaptive_compile:.1f} s; both fold the cube (final angles compared)"
            ),
            extra={
                "fixed_steps": steps,
                "adaptive_steps": adaptive_steps,
                "adaptive_compile_s": adaptive_compile,
                "fixed_ms_per_step": 1e3 * fixed_time.median / steps,
            },
        )
    )
    print(rows[-1].line(), flush=True)

    # The same fold in BDF2 steps: its cost against Euler's and its distance from the adaptive fold.
    _progress("compiling one fold, BDF2 steps")
    bdf2, bdf2_compile = _compiled(functools.partial(_fixed, scheme="bdf2"), system)
    bdf2_fold = bdf2(system)
    report = net.assess(system, bdf2_fold)
    if report.verdict != "folded":
        raise AssertionError(f"ours (BDF2 steps): {report.summary()}")
    bdf2_time = time_calls(lambda: bdf2(system).theta, repeats=repeats, warmup=0)
    final = {name: np.asarray(folds[name].theta[-1]) for name in folds}
    bdf2_final = np.asarray(bdf2_fold.theta[-1])
    rows.append(
        Result(
            name=f"{bench_net.NET} (plate contact) one fold to {T1:g} us: ImplicitStep BDF2 dt "
            f"{DT:g} us vs Euler",
            ours=bdf2_time,
            peer_name=f"ours, ImplicitStep Euler dt {DT:g} us",
            peer=fixed_time,
            compile_s=bdf2_compile,
            max_abs_difference=float(np.max(np.abs(bdf2_final - final["adaptive"]))),
            notes=(
                f"warm; difference: BDF2's final angles from the adaptive fold's (Euler's: "
                f"{difference:.1e} rad); newton_error {float(bdf2_fold.stats['newton_error']):.1e}"
                " rad; both fold the cube"
            ),
            extra={"euler_from_adaptive_rad": difference},
        )
    )
    print(rows[-1].line(), flush=True)

    # One step from a state in contact.
    index = int(round(CONTACT_STATE_US / T1 * (N_SAVE - 1)))
    q, v = folds["fixed"].theta[index], folds["fixed"].theta_dot[index]
    solver = sim.ImplicitStep(dt=DT)
    step_fn = jax.jit(
        lambda q, v: _implicit._step(
            system, sim.Step(), solver, CONTACT_STATE_US + DT, DT, q, v, None
        )
    )
    one_step = time_calls(lambda: step_fn(q, v)[0], repeats=max(repeats, 5) * 4, warmup=1)
    report = contact.report(system.mechanism, q)
    rows.append(
        Result(
            name=f"{bench_net.NET} (plate contact) one ImplicitStep step (dt {DT:g} us), compiled",
            ours=one_step,
            notes=(
                f"from the fold's state at {CONTACT_STATE_US:g} us ({int(report['engaged'])} primitive "
                f"pairs engaged of {contact.tables.n_primitives}); {solver.newton_iterations} Newton "
                f"iterations, {solver.halvings} trials per line search, {solver.ccd_pieces} "
                "collision chords"
            ),
            extra={"primitive_pairs": contact.tables.n_primitives},
        )
    )
    print(rows[-1].line(), flush=True)

    # A scattered batch: fixed steps, adaptive, and MuJoCo over the same nets.
    m = net.n_creases
    factor, release = bench_net.scattered_draws(batch, m)
    args = (jnp.asarray(factor), jnp.asarray(release))

    def fixed_member(f, r):
        return _fixed(bench_net._scattered(system, f, r)).theta[-1]

    def adaptive_member(f, r):
        return _adaptive(bench_net._scattered(system, f, r)).theta[-1]

    per_net = {}
    compile_s = {}
    first_call = {}
    # Ours and MuJoCo at their best: one thread per core of the machine (2 on the CI-sized CPU).
    threads = os.cpu_count() or 2
    # Chunks of FIXED_CHUNK nets, or of its largest divisor that divides the batch (10 nets: 2).
    chunks = {"fixed": math.gcd(batch, FIXED_CHUNK), "adaptive": 1}
    workers = threads
    if jax.default_backend() != "cpu":  # an accelerator computes the whole batch in one call
        chunks, workers = {"fixed": batch, "adaptive": batch}, 1
    for name, member in (("fixed", fixed_member), ("adaptive", adaptive_member)):
        _progress(f"compiling a batch of {batch} in chunks of {chunks[name]}, {name}")
        batched, compile_s[name] = _on_every_core(member, args, chunks[name], workers)
        start = time.perf_counter()
        finals = np.asarray(batched())
        first_call[name] = time.perf_counter() - start
        bench_net._check(f"ours (batch, {name})", net, finals, targets)
        per_net[name] = time_calls(batched, repeats=repeats, warmup=0)
    _progress(f"MuJoCo over the batch of {batch} on {threads} threads")
    start = time.perf_counter()
    dt_mj, nstep = bench_net.mujoco_step(system)
    models = bench_net.scattered_mujoco(system, design, dt_mj, factor)
    controls = release_controls(release, nstep, dt_mj)
    finals = bench_net._mujoco_final(models, controls, bench_net._datas(models[0], threads))
    mujoco_first = time.perf_counter() - start  # its models built and the batch rolled out once
    bench_net._check("MuJoCo (batch)", net, finals, targets)
    mujoco = bench_net.mujoco_batch_seconds(models, controls, threads, repeats=repeats)
    for name, label in (("fixed", f"ImplicitStep dt {DT:g} us"), ("adaptive", "adaptive Tsit5")):
        timing = per_net[name]
        rows.append(
            Result(
                name=f"{bench_net.NET} (plate contact) with scattered hinges, nets/s: ours "
                f"{label} over {batch} in chunks of {chunks[name]} on {workers} threads vs MuJoCo "
                f"over the same {batch} on {threads} threads",
                ours=timing,
                peer_name=f"MuJoCo rollout over {batch} models (C), {threads} threads",
                peer=mujoco,
                compile_s=compile_s[name],
                per_item=batch,
                notes=(
                    f"per net; ours {batch / timing.median:.3g} nets/s, MuJoCo "
                    f"{batch / mujoco.median:.3g} nets/s; every member of both closes the cube"
                ),
                extra={
                    "batch": batch,
                    "chunk": chunks[name],
                    "threads": workers,
                    "ours_nets_per_s": batch / timing.median,
                    "mujoco_nets_per_s": batch / mujoco.median,
                },
            )
        )
        print(rows[-1].line(), flush=True)
    # End to end: what a user waits for the first answer, ours from tracing and compiling the
    # batched fold to its first result, MuJoCo from building its models to its first rollout.
    for name, label in (("fixed", f"ImplicitStep dt {DT:g} us"), ("adaptive", "adaptive Tsit5")):
        total = compile_s[name] + first_call[name]
        rows.append(
            Result(
                name=f"{bench_net.NET} (plate contact) with scattered hinges, end to end (compile "
                f"included): ours {label} over {batch} in chunks of {chunks[name]} on {workers} "
                f"threads vs MuJoCo over the same {batch} on {threads} threads",
                ours=Timing.once(total),
                peer_name=f"MuJoCo: {batch} models built, one rollout (C), {threads} threads",
                peer=Timing.once(mujoco_first),
                per_item=batch,
                notes=(
                    f"per net, one cold call each: ours {compile_s[name]:.1f} s tracing and "
                    f"compiling + {first_call[name]:.1f} s running; MuJoCo {mujoco_first:.2f} s"
                ),
                extra={
                    "batch": batch,
                    "compile_s": compile_s[name],
                    "first_call_s": first_call[name],
                    "mujoco_first_s": mujoco_first,
                },
            )
        )
        print(rows[-1].line(), flush=True)
    rows.append(_closed_loops_row(repeats))
    print(rows[-1].line(), flush=True)
    return rows


def _closed_loops_row(repeats: int) -> Result:
    """`LOOPS_PATTERN` (closed loops held by the fixed steps' penalty, by the adaptive solver's
    constrained accelerations) folded to `LOOPS_T1` from the fixed steps' pre-fold, in the paper's
    dynamics with plate contact: one fold each, warm; both must fold it to the same angles."""
    pattern = load_pattern(LOOPS_PATTERN)
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    system = pattern.system(design, contact="plate", added_mass=False, viscous=False)
    start = pattern.start_state(system, bias=sim.FIXED_STEP_PRE_FOLD)[0]

    def fold(solver):
        options = sim.SolveOptions(
            saveat=sim.SaveAt(n=N_SAVE), solver=solver, max_steps=200_000, throw=False
        )
        return lambda system: sim.simulate(system, sim.Step(), options, t1=LOOPS_T1, theta0=start)

    _progress(f"compiling {LOOPS_PATTERN}, fixed steps and adaptive")
    fixed, fixed_compile = _compiled(fold(sim.ImplicitStep(dt=DT)), system)
    adaptive, adaptive_compile = _compiled(fold(diffrax.Tsit5()), system)
    folds, drift = {}, {}
    for name, solve in (("fixed", fixed), ("adaptive", adaptive)):
        trajectory = solve(system)
        report = pattern.assess(system, trajectory, bias=sim.FIXED_STEP_PRE_FOLD)
        if report.verdict != "folded":
            raise AssertionError(f"ours ({name} steps) on {LOOPS_PATTERN}: {report.summary()}")
        folds[name], drift[name] = trajectory, report.closure_drift
    difference = float(np.max(np.abs(folds["fixed"].theta[-1] - folds["adaptive"].theta[-1])))
    steps = {name: int(folds[name].stats["num_steps"]) for name in folds}
    fixed_time = time_calls(lambda: fixed(system).theta, repeats=repeats, warmup=0)
    return Result(
        name=f"{LOOPS_PATTERN} ({pattern.n_loops} closed loops, plate contact) one fold to "
        f"{LOOPS_T1:g} us: ImplicitStep dt {DT:g} us vs adaptive Tsit5",
        ours=fixed_time,
        peer_name="ours, adaptive Tsit5 at the default tolerances",
        peer=time_calls(lambda: adaptive(system).theta, repeats=repeats, warmup=0),
        compile_s=fixed_compile,
        max_abs_difference=difference,
        notes=(
            f"warm, from a {sim.FIXED_STEP_PRE_FOLD:g} rad pre-fold; fixed: {steps['fixed']} steps, "
            f"closure drift {drift['fixed']:.1e} rad; adaptive: {steps['adaptive']} steps, "
            f"closure drift {drift['adaptive']:.1e} rad, compile {adaptive_compile:.1f} s; both "
            "fold it (final angles compared)"
        ),
        extra={
            "fixed_steps": steps["fixed"],
            "adaptive_steps": steps["adaptive"],
            "adaptive_compile_s": adaptive_compile,
            "closure_drift_fixed": drift["fixed"],
            "closure_drift_adaptive": drift["adaptive"],
        },
    )


if __name__ == "__main__":
    import argparse

    from ._harness import dump_json

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat (and a batch of 4)")
    parser.add_argument("--batch", type=int, default=None, help="nets in the scattered batch")
    parser.add_argument("--json", default=None, help="write the rows as JSON here")
    args = parser.parse_args()
    rows = run(quick=args.quick, batch=args.batch)
    for row in rows:
        print(row.line())
    if args.json:
        dump_json(args.json, rows)
