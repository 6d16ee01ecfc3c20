"""A cube net folding with contact: ours vs MuJoCo (C) with the same panels, hinge springs and contacts.

The net: `cube_net_01` (six 200 µm SiNx squares, five creases to 90°, literature bilayer hinges, KOH
solution), folded from flat by a step release; ours with panel drag and the net's default contact,
`PlateContact` (the plates' exact geometry, IPC barrier, continuous collision detection; rows
named "plate contact"; ``NET_CONTACT=sampled`` times the sampled `PanelContact`, the rows of the
files recorded before 2026-12-04 without a model in their names), explicit Tsit5 at the default tolerances, jitted. MuJoCo (`benchmarks._mujoco_tree`): the
same bodies, inertias, hinge axes and spring constants on the same tree, switched-on springs (an
actuator per hinge whose control steps from 0 to 1 at its release time), linear joint damping at
critical for each hinge (MuJoCo has no panel drag), each panel a thin convex prism with frictionless
soft contacts, `implicitfast` at a fixed step of 1/200 of the shortest hinge period, `mujoco.rollout`.

The two dissipate differently, so they take different paths; what they must share is the end: the
closed cube (every crease at 90°, every seam closed). Answers are compared there first (final angles
against the targets, and the seams' gaps from the net's own rigid folding), then timed: one
trajectory (compile apart), and a batch with scattered hinges (±10 % stiffness per crease, release
times over 20 µs) in nets/s: ours `jax.vmap` over the batch, MuJoCo one rollout over a list of
models, on one thread and on two (beside a GPU, two only; the target is MuJoCo's throughput on 2
cores). MJX (MuJoCo on accelerators, the `mujoco-mjx` package) is the accelerator peer: where JAX
has a GPU, both batches hold the issue's 1,000 nets (64 with `--quick`) and MJX rolls the same
models out on the GPU beside ours; on a CPU its row runs only when ``NET_MJX=1`` asks for it (there
it is many times slower than C MuJoCo, a check that the peer runs and agrees, not a throughput).

At equal accuracy too: a fixed-step integrator and an adaptive one at its default tolerance do not
make the same error. Each model's path (the hinge angles at the saved times) is compared with its own
converged path (ours at rtol 1e-10; MuJoCo at 1/16 of its step, with the contact softness of its
step), and the batch is timed again with ours at the tolerance that makes MuJoCo's path error
(rtol 1e-5: the verdicts of a 16-net batch are the same from rtol 1e-4 to 1e-10). And once more with
the contact removed (the panels then pass through each other): not a folding but a floor, what the
tree, the hinges and the drag cost at the steps a contact-free run takes, so that the row above it
can be split into what the contact costs and what the rest does.

Run: ``python -m benchmarks --only net`` (``--quick``: smaller batches, one repeat).
"""

import os
import time

import diffrax
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import rollout

import origami_jax.simulation as sim
from origami_jax.net import load_net
from origami_jax.system import KOH_SOLUTION, HingeDesign

from . import _mjx_tree
from ._harness import Result, Timing, time_calls
from ._mujoco_tree import critical_damping, hinge_period_step, release_controls, tree_model

NET = "cube_net_01"
# The contact model timed (`Net.system(contact=...)`), named in the rows of the plate model.
CONTACT = os.environ.get("NET_CONTACT", "plate")
LABEL = f"{NET} ({CONTACT} contact)"
T1 = 1500.0  # µs: both have folded and settled by then
N_SAVE = 301
# rad: each model's final angles against the 90° targets (the verdict allows 3°). Ours rests on the
# contact's activation layer (ĝ = 1 µm, 0.005 rad over a 200 µm edge, per resting contact), deeper
# for the softer hinges of the scattered batch (−10 % stiffness): 0.0103 rad seen in a batch of 16.
ANSWER_TOL = 0.02
# Of the 200 µm edge: a closed cube (an open seam gapes ~100 µm). Looser than the verdict's 1 %:
# ours holds resting panels at the contact's activation standoff (1 µm), a few tenths of a degree
# off 90°, which opens a seam by a few µm; the answers are compared on angles.
SEAM_TOL = 0.05
SCATTER, RELEASE_SPAN = 0.1, 20.0  # ±10 % stiffness, release times uniform over 20 µs
# Equal accuracy: each model's path error against its own converged solution (ours at rtol 1e-10;
# MuJoCo at 1/16 of its step with the same contact softness), largest over the saved samples. At
# MuJoCo's step it is ~3e-2 rad (contact events shift in time); ours reaches that at rtol 1e-5.
REFERENCE_RTOL, EQUAL_RTOL = 1e-10, 1e-5
MUJOCO_REFINE = 16
ATOL_PER_RTOL = sim.DEFAULT_ATOL / sim.DEFAULT_RTOL  # the defaults' ratio


def _solve(system, rtol=sim.DEFAULT_RTOL):
    # `rtol` traced: one compiled solve for every tolerance.
    return sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(
            saveat=sim.SaveAt(n=N_SAVE),
            solver=diffrax.Tsit5(),
            rtol=rtol,
            atol=ATOL_PER_RTOL * rtol,
            max_steps=200_000,
            throw=False,
        ),
        t1=T1,
    )


def _scattered(system, factor, release, contact=True):
    h = system.hinges
    hinges = type(h)(h.stiffness * factor, h.target, h.radius, release)
    kept = system.contact if contact else None
    return type(system)(system.mechanism, hinges, system.drag, kept, system.units)


def _mujoco(system, design, dt, damped_for=None):
    """The MuJoCo model of `system`'s net: its springs, joint damping at critical for the hinge
    stiffness `damped_for` (default the system's own)."""
    tree = system.mechanism
    k = np.asarray(system.hinges.stiffness)
    return tree_model(
        tree,
        stiffness=k,
        target=np.asarray(system.hinges.target),
        damping=critical_damping(tree, k if damped_for is None else damped_for),
        dt=dt,
        thickness=float(design.t_structural),
    )


def mujoco_step(system) -> tuple[float, int]:
    """MuJoCo's fixed step (1/200 of the shortest hinge period, µs) and its step count to `T1`."""
    dt = hinge_period_step(system.mechanism, np.asarray(system.hinges.stiffness))
    return dt, int(round(T1 / dt))


def scattered_draws(count: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness factors and release times (µs) of `count` scattered nets, `(count, m)` each."""
    rng = np.random.default_rng(0)
    factor = 1 + SCATTER * rng.uniform(-1, 1, (count, m))
    return factor, rng.uniform(0, RELEASE_SPAN, (count, m))


def scattered_mujoco(system, design, dt: float, factor: np.ndarray) -> list:
    """One MuJoCo model per row of `factor` `(b, m)`: the net with its hinge stiffness scaled."""
    k = np.asarray(system.hinges.stiffness)
    targets = np.asarray(system.hinges.target)
    models = []
    for row in factor:
        model = _mujoco(system, design, dt)
        model.actuator_gainprm[:, 0] = k * row * targets
        model.actuator_gainprm[:, 1] = -k * row
        models.append(model)
    return models


def mujoco_batch_seconds(models, controls, threads: int, repeats: int = 1) -> Timing:
    """Rollout time of `models` under `controls` with one `MjData` per thread (no warm-up call: a
    C rollout has nothing to compile)."""
    data = _datas(models[0], threads)
    return time_calls(lambda: _mujoco_final(models, controls, data), repeats=repeats, warmup=0)


def _datas(model, threads: int):
    """What `rollout.rollout` takes for `threads` threads: one `MjData`, or a list of them."""
    datas = [mujoco.MjData(model) for _ in range(threads)]
    return datas if threads > 1 else datas[0]


def mujoco_path(system, design, dt_rule: float, refine: int) -> np.ndarray:
    """MuJoCo's hinge angles at the saved times `(N_SAVE, h)` (the first at rest) from flat under a
    step release, at `dt_rule / refine` with the contact softness of `dt_rule` (`solref` scales with
    the step it is built for), so that only the step changes."""
    model = _mujoco(system, design, dt_rule)
    dt = dt_rule / refine
    model.opt.timestep = dt
    nstep = int(round(T1 / dt))
    controls = release_controls(np.zeros((1, system.n_hinges)), nstep, dt)
    angles = _mujoco_angles([model], controls, mujoco.MjData(model))[0]  # (nstep, h)
    times = np.arange(1, nstep + 1) * dt
    saved = np.linspace(0.0, T1, N_SAVE)
    return np.stack(
        [
            np.interp(saved, np.r_[0.0, times], np.r_[0.0, angles[:, j]])
            for j in range(angles.shape[1])
        ],
        axis=1,
    )


def _mujoco_angles(models, controls, data) -> np.ndarray:
    """Roll every model out from flat at rest under its controls; hinge angles after each step
    `(b, nstep, h)`."""
    model = models[0]
    size = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state, _ = rollout.rollout(
        models, data, np.zeros((len(models), size)), controls, nstep=controls.shape[1]
    )
    order = [int(model.joint(f"h{i}").qposadr[0]) for i in range(model.njnt)]
    return state[:, :, 1 + np.asarray(order)]


def _mujoco_final(models, controls, data) -> np.ndarray:
    """Final hinge angles `(b, h)` of `_mujoco_angles`."""
    return _mujoco_angles(models, controls, data)[:, -1]


def _check(name: str, net, finals: np.ndarray, targets: np.ndarray) -> float:
    """Largest angle error of `finals` `(b, h)`; raises if any member is not a closed cube."""
    error = float(np.max(np.abs(finals - targets)))
    gaps = max(float(np.max(net.seam_gaps(f))) for f in finals)
    if error > ANSWER_TOL or gaps > SEAM_TOL * 200.0:
        raise AssertionError(
            f"{name} does not close the cube: angle error {error:.3g} rad, seam {gaps:.3g} µm"
        )
    return error


def _per_net_row(name, ours_s, mujoco_s, batch_mj, threads, compile_s, notes, extra) -> Result:
    """A throughput row: seconds per net, ours against MuJoCo's rollout over `batch_mj` models on
    `threads` threads (nets/s of both in `extra`)."""
    return Result(
        name=name,
        ours=Timing.once(ours_s),
        peer_name=f"MuJoCo rollout over {batch_mj} models (C), {threads} thread(s)",
        peer=Timing.once(mujoco_s),
        compile_s=compile_s,
        notes=notes,
        extra={
            **extra,
            "batch_mujoco": batch_mj,
            "mujoco_threads": threads,
            "ours_nets_per_s": 1 / ours_s,
            "mujoco_nets_per_s": 1 / mujoco_s,
        },
    )


def _progress(message: str) -> None:
    # Each stage announced as it starts: a run cut short by a time limit (a lent GPU's lease) still
    # says where its time went.
    print(f"[net {time.strftime('%H:%M:%S')}] {message}", flush=True)


def _kept(rows: list[Result], row: Result) -> None:
    # Each row printed as soon as it is measured, for the same reason.
    rows.append(row)
    print(row.line(), flush=True)


def run(quick: bool) -> list[Result]:
    jax.config.update("jax_enable_x64", True)
    accelerated = jax.default_backend() != "cpu"
    batch_mj = 64 if quick else 1000
    # On a CPU a wider vmap buys little per net (RESULTS.md); on a GPU the whole batch.
    batch_ours = batch_mj if accelerated else (16 if quick else 128)
    # A batch of 1,000 on a lent GPU is timed once: its device time is scarce, and one call of a
    # batch that size already averages over its members.
    repeats = 1 if quick or accelerated else 3
    net = load_net(NET)
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    # The paper's dynamics in the bath (no fluid inertia, released at once): MuJoCo's bodies
    # carry no added mass.
    system = net.system(design, contact=CONTACT, added_mass=False, viscous=False)
    targets = np.asarray(system.hinges.target)
    m = net.n_creases

    # Ours: compile apart, check the verdict, then time.
    _progress(f"{NET}: compiling ours (one trajectory, {jax.default_backend()})")
    default_rtol = jnp.asarray(sim.DEFAULT_RTOL)
    start = time.perf_counter()
    solve = jax.jit(_solve).lower(system, default_rtol).compile()
    compile_s = time.perf_counter() - start
    trajectory = solve(system, default_rtol)
    report = net.assess(system, trajectory)
    if report.verdict != "folded":
        raise AssertionError(f"ours: {report.summary()}")
    ours_final = np.asarray(trajectory.theta[-1])
    _check("ours", net, ours_final[None], targets)
    steps = int(trajectory.stats["num_steps"])
    ours = time_calls(lambda: solve(system, default_rtol).theta, repeats=repeats)

    # MuJoCo: step 1/200 of the shortest hinge period.
    _progress("MuJoCo, one trajectory; then each one's path error against its converged path")
    dt, nstep = mujoco_step(system)
    model = _mujoco(system, design, dt)
    data = mujoco.MjData(model)
    controls = release_controls(np.zeros((1, m)), nstep, dt)
    mj_final = _mujoco_final([model], controls, data)
    mj_error = _check("MuJoCo", net, mj_final, targets)
    mj = time_calls(lambda: _mujoco_final([model], controls, data), repeats=repeats)

    # Accuracy of each against its own converged path (module constants).
    reference = np.asarray(solve(system, jnp.asarray(REFERENCE_RTOL)).theta)
    ours_path_error = {
        rtol: float(np.max(np.abs(np.asarray(solve(system, jnp.asarray(rtol)).theta) - reference)))
        for rtol in (sim.DEFAULT_RTOL, EQUAL_RTOL)
    }
    mj_path_error = float(
        np.max(
            np.abs(
                mujoco_path(system, design, dt, 1) - mujoco_path(system, design, dt, MUJOCO_REFINE)
            )
        )
    )
    accuracy = (
        f"path error against its own converged path: ours {ours_path_error[sim.DEFAULT_RTOL]:.1e} "
        f"rad at rtol {sim.DEFAULT_RTOL:g}, {ours_path_error[EQUAL_RTOL]:.1e} at {EQUAL_RTOL:g}; "
        f"MuJoCo {mj_path_error:.1e} rad at its step (against 1/{MUJOCO_REFINE} of it)"
    )
    rows: list[Result] = []
    _kept(
        rows,
        Result(
            name=f"{LABEL} folding, one trajectory to {T1:g} us vs MuJoCo",
            ours=ours,
            peer_name=f"MuJoCo rollout (C), dt {dt:.3g} us, mesh contacts",
            peer=mj,
            compile_s=compile_s,
            max_abs_difference=float(np.max(np.abs(mj_final[0] - ours_final))),
            notes=(
                f"ours: {steps} Tsit5 steps ({steps / ours.median:.3g} steps/s), verdict "
                f"{report.verdict}, max penetration {report.max_penetration:.2g} um; MuJoCo: "
                f"{nstep} steps ({nstep / mj.median:.3g} steps/s), ends {mj_error:.1e} rad from "
                f"the targets; {accuracy}"
            ),
            extra={
                "ours_steps": steps,
                "ours_steps_per_s": steps / ours.median,
                "mujoco_steps_per_s": nstep / mj.median,
                "mujoco_dt_us": dt,
                "ours_path_error_rad": ours_path_error[sim.DEFAULT_RTOL],
                "ours_path_error_equal_rtol_rad": ours_path_error[EQUAL_RTOL],
                "mujoco_path_error_rad": mj_path_error,
            },
        ),
    )

    # A batch with scattered hinges: nets/s.
    factor, release = scattered_draws(batch_mj, m)

    def member(f, r, rtol):
        return _solve(_scattered(system, f, r), rtol).theta[-1]

    args = (jnp.asarray(factor[:batch_ours]), jnp.asarray(release[:batch_ours]))
    _progress(f"compiling ours over a batch of {batch_ours}")
    start = time.perf_counter()
    batched = jax.jit(jax.vmap(member, in_axes=(0, 0, None))).lower(*args, default_rtol).compile()
    batch_compile = time.perf_counter() - start
    per_net = {}
    for rtol in (sim.DEFAULT_RTOL, EQUAL_RTOL):
        _progress(f"ours over the batch at rtol {rtol:g}")
        rtol_array = jnp.asarray(rtol)
        _check(f"ours (batch, rtol {rtol:g})", net, np.asarray(batched(*args, rtol_array)), targets)
        # Compiled ahead and called once above: no warm-up call.
        per_net[rtol] = (
            time_calls(lambda r=rtol_array: batched(*args, r), repeats=1, warmup=0).median
            / batch_ours
        )
    per_net_ours = per_net[sim.DEFAULT_RTOL]
    where_ours = (
        f"on the {jax.default_backend().upper()}" if accelerated else "XLA's threads on every core"
    )
    _progress(f"MuJoCo over the batch of {batch_mj}")
    models = scattered_mujoco(system, design, dt, factor)
    controls = release_controls(release, nstep, dt)
    mj_finals = _mujoco_final(models, controls, _datas(model, 2))
    _check("MuJoCo (batch)", net, mj_finals, targets)
    # The target is MuJoCo's throughput on 2 cores: rollout's thread pool, one MjData per thread.
    # Beside a GPU the one-thread row is left out (the lease's time goes to the GPU rows).
    for threads in (2,) if accelerated else (1, 2):
        per_net_mj = mujoco_batch_seconds(models, controls, threads).median / batch_mj
        _kept(
            rows,
            _per_net_row(
                f"{LABEL} with scattered hinges, nets/s: ours vmap over {batch_ours} vs "
                f"MuJoCo over {batch_mj} on {threads} thread{'s' if threads > 1 else ''}",
                per_net_ours,
                per_net_mj,
                batch_mj,
                threads,
                batch_compile,
                f"per net; ours {1 / per_net_ours:.3g} nets/s ({where_ours}), "
                f"MuJoCo {1 / per_net_mj:.3g} nets/s; every member of both batches closes the "
                f"cube (±{SCATTER:.0%} stiffness, release over {RELEASE_SPAN:g} us)",
                {"batch_ours": batch_ours},
            ),
        )
    # At equal accuracy (the same path error as MuJoCo at its step), against MuJoCo on two threads.
    _kept(
        rows,
        _per_net_row(
            f"{LABEL} with scattered hinges, nets/s at equal accuracy: ours rtol {EQUAL_RTOL:g} "
            f"vmap over {batch_ours} vs MuJoCo over {batch_mj} on 2 threads",
            per_net[EQUAL_RTOL],
            per_net_mj,
            batch_mj,
            2,
            batch_compile,
            f"per net; {accuracy}; every member closes the cube",
            {"rtol": EQUAL_RTOL, "batch_ours": batch_ours},
        ),
    )
    if not _mjx_tree.available():
        print("MJX row skipped: mujoco.mjx does not import (pip install mujoco-mjx)")
    elif accelerated or os.environ.get("NET_MJX") == "1":
        batch_mjx = batch_mj if accelerated else (16 if quick else 64)
        _progress(f"MJX over {batch_mjx} of the batch's models")
        _kept(
            rows,
            _mjx_row(
                net,
                targets,
                models[:batch_mjx],
                release[:batch_mjx],
                nstep,
                mj_finals[:batch_mjx],
                per_net[EQUAL_RTOL],
                batch_ours,
                batch_compile,
                repeats,
            ),
        )
    else:
        print("MJX row skipped on a CPU (NET_MJX=1 runs it: a check, not a throughput)")

    # The same batch with the contact removed (the panels pass through each other): a floor, what
    # the rest of the right-hand side costs at the steps a contact-free folding takes.
    def free_member(f, r, rtol):
        trajectory = _solve(_scattered(system, f, r, contact=False), rtol)
        return trajectory.theta[-1], trajectory.stats["num_steps"]

    _progress("ours over the batch with the contact removed")
    start = time.perf_counter()
    free = jax.jit(jax.vmap(free_member, in_axes=(0, 0, None))).lower(*args, default_rtol).compile()
    free_compile = time.perf_counter() - start
    equal_rtol = jnp.asarray(EQUAL_RTOL)
    _, free_steps = jax.device_get(free(*args, equal_rtol))
    per_net_free = (
        time_calls(lambda: free(*args, equal_rtol), repeats=repeats, warmup=0).median / batch_ours
    )
    _kept(
        rows,
        _per_net_row(
            f"{NET} with scattered hinges and NO contact (a floor), nets/s: ours rtol "
            f"{EQUAL_RTOL:g} vmap over {batch_ours} vs MuJoCo (with contact) on 2 threads",
            per_net_free,
            per_net_mj,
            batch_mj,
            2,
            free_compile,
            f"per net; the panels pass through each other, so this is not a folding: it is "
            f"what the tree, hinges and drag cost at the {int(free_steps.max())} steps (batch "
            f"maximum) a contact-free run takes; with contact at the same rtol: "
            f"{per_net[EQUAL_RTOL] / per_net_free:.3g}x this",
            {
                "rtol": EQUAL_RTOL,
                "batch_ours": batch_ours,
                "ours_steps_max": int(free_steps.max()),
                "ours_steps_mean": float(free_steps.mean()),
            },
        ),
    )
    return rows


def _mjx_row(
    net, targets, models, release, nstep, mj_finals, per_net_ours, batch_ours, compile_s, repeats
) -> Result:
    """MJX over `models` (C models of the scattered batch) with their `release` times, on JAX's
    default device, against ours at equal accuracy (`per_net_ours`, seconds per net); answers
    checked against the cube and against C MuJoCo's finals of the same models first."""
    batch = len(models)
    gains, release = jnp.asarray(_mjx_tree.gains_of(models)), jnp.asarray(release)
    start = time.perf_counter()
    rollout = jax.jit(_mjx_tree.batched_rollout(models[0], nstep)).lower(gains, release).compile()
    mjx_compile = time.perf_counter() - start
    finals = np.asarray(rollout(gains, release))
    _check("MJX (batch)", net, finals, targets)
    difference = float(np.max(np.abs(finals - mj_finals)))
    per_net_mjx = (
        time_calls(lambda: rollout(gains, release), repeats=repeats, warmup=0).median / batch
    )
    backend = jax.default_backend()
    return Result(
        name=(
            f"{LABEL} with scattered hinges, nets/s at equal accuracy: ours rtol {EQUAL_RTOL:g} "
            f"vmap over {batch_ours} vs MJX over {batch} ({backend})"
        ),
        ours=Timing.once(per_net_ours),
        peer_name=f"MJX {mujoco.__version__}, {nstep} steps of {models[0].opt.timestep:.3g} us",
        peer=Timing.once(per_net_mjx),
        compile_s=compile_s,
        max_abs_difference=difference,
        notes=(
            f"per net; MJX compile {mjx_compile:.1f} s; MJX's final angles against C MuJoCo's "
            f"for the same models: {difference:.1e} rad; every member closes the cube"
        ),
        extra={
            "rtol": EQUAL_RTOL,
            "batch_ours": batch_ours,
            "batch_mjx": batch,
            "backend": backend,
            "mjx_compile_s": mjx_compile,
            "ours_nets_per_s": 1 / per_net_ours,
            "mjx_nets_per_s": 1 / per_net_mjx,
        },
    )


if __name__ == "__main__":
    for row in run(quick=True):
        print(row.line())
