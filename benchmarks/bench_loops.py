"""A Miura-ori sheet folding under step release: the closed-loop engine vs MuJoCo and a bar-and-hinge model.

The sheet: `n × n` parallelograms (200 µm sides, 60°) whose hinges are released at ``t = 0`` towards
Schenk and Guest's folding parameter ``θ = 45°`` (a folded state that closes every loop), literature
bilayer hinges, KOH solution with the paper's dynamics (no added fluid inertia: the peers' bodies
carry none), no contact (none of the peers has panel contact). Three models of it:

- **ours**: `origami_jax.loops` (rigid panels on a spanning tree, vertex-loop closure as constraints,
  Baumgarte, augmented-Lagrangian solve), panel drag, explicit Tsit5 at rtol 1e-6, jitted;
- **MuJoCo** (C, `mujoco.rollout` in a loop): the same panels as nested bodies with hinge joints on the
  same spanning tree (stiffness, `springref` = target), each cut crease as two `connect` equality
  constraints at its ends (MuJoCo's soft constraints; MuJoCo has no spring across an equality
  constraint, so the cut creases carry no hinge spring there), linear joint damping for the fluid
  (MuJoCo has no panel drag), `implicitfast` at a fixed step;
- **bar-and-hinge** (`benchmarks._bar_hinge`, NumPy + `scipy.integrate.solve_ivp`): Origami Simulator's
  and MERLIN's model written here as the peer: point masses, bars, dihedral springs on creases and on
  facet diagonals (stiff: `bar_hinge_model`), dashpots beside the springs and a nodal drag, damping
  critical for its slowest mode, RK45.

The three dissipate differently (quadratic panel drag, linear joint damping, nodal damping), so they
take different times to settle; what they must share is the end: every crease at its target (the
targets close the loops, so the rigid sheet's equilibrium is the target state, and it is an exact
equilibrium of the bar-and-hinge model too). Answers are compared there first (each peer's final
angles against the targets and ours), then timed: a trajectory to ``t1`` per model (steps/s), a batch
with scattered hinges (±10 % stiffness per crease, all released at 0; sheets/s; ours vmapped,
MuJoCo one rollout per member), compile time, and the scaling of the cost per step with the sheet
size.

Run: ``python -m benchmarks --only loops --quick`` (5×5 sheet to 1.5 ms, a vmapped batch of 8,
scaling 3×3 and 5×5). Without ``--quick``: the 10×10 sheet to 3 ms, a vmapped batch of
``LOOPS_BATCH`` members (default 8) extrapolated to the issue's 1000 (labelled), MuJoCo's batch on
``LOOPS_MJ_BATCH`` members (default 8; one 10×10 rollout to 3 ms takes minutes, so a run on a small
machine sets 2), scaling over ``LOOPS_SIZES`` (default 5,10,20) with ours compiled up to
``LOOPS_OURS_MAX`` (default 20) and the peers at every size. Measured on the shared 2-core machine
(2026-12-02, fifth session, one core): ours compiles the 10×10 solve in 20–27 s and the 20×20 one in 24–25 s
(6 min for the 10×10 before that session's changes); the peers' long rollouts take most of a full
run (~20 min with ``LOOPS_MJ_BATCH=2``). benchmarks/RESULTS.md has the figures.
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
from origami_jax.fold._catalogue_loops import miura_sheet
from origami_jax.loops import load_pattern
from origami_jax.system import KOH_SOLUTION, HingeDesign

from ._bar_hinge import bar_hinge_model, folded_positions
from ._harness import Result, Timing, time_calls
from ._mujoco_tree import critical_damping, hinge_period_step, tree_mjcf

T1 = 1500.0  # µs: every model has settled by then on a 5×5 sheet
# µs, the 10×10 sheet: ours (quadratic panel drag) was still 0.044 rad from its targets at 1500 µs
T1_LARGE = 3000.0
ANSWER_TOL = 0.02  # rad: MuJoCo's end state against the targets (soft connect constraints)


def _pattern(n: int):
    pattern = load_pattern(miura_sheet(n, n), name=f"miura_{n}x{n}")
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    # The paper's dynamics in the bath (the peers' bodies carry no added mass), released at once.
    paper = {"added_mass": False, "viscous": False}
    return pattern, pattern.system(design, contact=False, check_rigid=False, **paper)


def _solve(system, t1, n_save=51, rtol=1e-6, atol=1e-9):
    return sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(
            saveat=sim.SaveAt(n=n_save),
            rtol=rtol,
            atol=atol,
            solver=diffrax.Tsit5(),
            max_steps=200_000,
            throw=False,
        ),
        t1=t1,
    )


# ---- MuJoCo --------------------------------------------------------------------------------


def _mjcf(system, damping: np.ndarray, dt: float) -> str:
    """The sheet's spanning tree with MuJoCo's joint springs, each cut crease closed by two
    `connect` constraints at its ends."""
    mechanism = system.mechanism
    tree = mechanism.tree
    points = np.asarray(tree.points)
    n = mechanism.n_tree
    equality = ""
    for (a, b), ends in zip(mechanism.cut_bodies, mechanism.cut_ends, strict=True):
        for end in np.asarray(ends):
            anchor = end - (points[a] if a >= 0 else np.zeros(3))
            name1 = f"b{a}" if a >= 0 else "world"
            equality += (
                f'<connect body1="{name1}" body2="b{b}" '
                f'anchor="{" ".join(f"{v:.17g}" for v in anchor)}" solref="{4 * dt:.17g} 1"/>'
            )
    return tree_mjcf(
        tree,
        stiffness=np.asarray(system.hinges.stiffness)[:n],
        target=np.asarray(system.hinges.target)[:n],
        damping=damping,
        dt=dt,
        springs="joint",
        equality=equality,
    )


def _mujoco_dt(system) -> float:
    """MuJoCo's fixed step (µs): 1/200 of the shortest hinge period of the spanning tree, the rule of
    the nets benchmark. Stable far beyond it (a 5×5 sheet to 0.8 µs); what a finer step changes is
    the path on the way (reported beside the single trajectory), not the folded end state."""
    mechanism = system.mechanism
    return hinge_period_step(
        mechanism.tree, np.asarray(system.hinges.stiffness)[: mechanism.n_tree]
    )


def _mujoco_model(system, *, dt: float | None = None, damping_ratio: float = 1.0):
    mechanism = system.mechanism
    dt = _mujoco_dt(system) if dt is None else dt
    k = np.asarray(system.hinges.stiffness)[: mechanism.n_tree]
    damping = critical_damping(mechanism.tree, k, damping_ratio)
    return mujoco.MjModel.from_xml_string(_mjcf(system, damping, dt))


def scattered_models(system, factor: np.ndarray) -> list:
    """One MuJoCo model per row of `factor` `(b, m)`: the sheet with its tree hinges' stiffness
    scaled by that row (the cut creases carry no spring in MuJoCo, `_mjcf`)."""
    m_tree = system.mechanism.n_tree
    stiffness = np.asarray(system.hinges.stiffness)[:m_tree]
    models = []
    for row in np.asarray(factor):
        model = _mujoco_model(system)
        model.jnt_stiffness[:] = stiffness * row[:m_tree]
        models.append(model)
    return models


def _mujoco_states(models, nstep: int, data=None):
    """Roll every model out from flat at rest for `nstep` steps: joint angles after every step
    `(b, nstep, n_T)`, in our hinge order."""
    models = models if isinstance(models, list) else [models]
    data = data or mujoco.MjData(models[0])
    size = mujoco.mj_stateSize(models[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state, _ = rollout.rollout(models, data, np.zeros((len(models), size)), nstep=nstep)
    model = models[0]
    order = [int(model.joint(f"h{i}").qposadr[0]) for i in range(model.njnt)]
    return state[:, :, 1 + np.asarray(order)]  # FULLPHYSICS: time, qpos, ...


def _mujoco_run(models, nstep: int, data=None, chunk: int = 8):
    """The final joint angles `(b, n_T)` of `_mujoco_states`, rolled out `chunk` models at a time
    (a rollout holds every step of every model it is given)."""
    models = models if isinstance(models, list) else [models]
    data = data or mujoco.MjData(models[0])
    return np.concatenate(
        [
            _mujoco_states(models[i : i + chunk], nstep, data)[:, -1]
            for i in range(0, len(models), chunk)
        ]
    )


def _mujoco_path(model, nstep: int):
    """One model's joint angles after every step `(nstep, n_T)`."""
    return _mujoco_states(model, nstep)[0]


# ---- benchmark ------------------------------------------------------------------------------

BATCH_TARGET = 1000  # the batch; measured where it fits, else extrapolated (labelled)
BH_TOL = 1e-3  # rad: the bar-and-hinge end state against the targets (see `_bar_hinge_row`)


def _sizes() -> tuple[int, ...]:
    return tuple(int(v) for v in os.environ.get("LOOPS_SIZES", "5,10,20").split(","))


def _ours_max() -> int:
    """Largest sheet ours is compiled for in the scaling rows (``LOOPS_OURS_MAX``, default 20)."""
    return int(os.environ.get("LOOPS_OURS_MAX", "20"))


def _scattered(system, factor, release):
    """`system` with its hinge stiffnesses scaled by `factor` and released at `release` `(m,)`."""
    h = system.hinges
    hinges = type(h)(h.stiffness * factor, h.target, h.radius, release)
    return type(system)(system.mechanism, hinges, system.drag, system.contact, system.units)


def _ratio(ours: float, peer: float) -> str:
    return f"ours/peer time {ours / peer:.3g}"


def run(quick: bool) -> list[Result]:
    jax.config.update("jax_enable_x64", True)
    n = 5 if quick else 10
    batch = 8 if quick else BATCH_TARGET
    scaling = (3, 5) if quick else _sizes()
    repeats = 1 if quick else 2
    rows: list[Result] = []

    pattern, base = _pattern(n)
    m = base.n_hinges
    # Every hinge released at t = 0 (the step), as an array: the batch's scattered release times then
    # reuse the same compiled solve.
    system = _scattered(base, jnp.ones(m), jnp.zeros(m))
    targets = np.asarray(system.hinges.target)
    m_tree = system.mechanism.n_tree

    # Ours: compile apart, then time one trajectory.
    start = time.perf_counter()
    t1 = T1 if n <= 5 else T1_LARGE
    solve = jax.jit(lambda s: _solve(s, t1)).lower(system).compile()
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    trajectory = jax.block_until_ready(solve(system))
    first_s = time.perf_counter() - start
    ours_final = np.asarray(trajectory.theta[-1])
    steps = int(trajectory.stats["num_steps"])
    drift = float(np.max(pattern.closure_residual(np.asarray(trajectory.theta))))
    if not bool(trajectory.succeeded) or np.max(np.abs(ours_final - targets)) > 1e-3:
        raise AssertionError(f"ours did not fold: {np.max(np.abs(ours_final - targets))}")
    if repeats > 1:
        ours = time_calls(lambda: solve(system).theta, repeats=repeats - 1, warmup=0)
        samples = [first_s, ours.median]
        ours = Timing.of(samples)
    else:
        ours = Timing.once(first_s)

    # MuJoCo: the same folding, same spanning tree, cut creases as connect constraints.
    mj_dt = _mujoco_dt(system)
    model = _mujoco_model(system, dt=mj_dt)
    nstep = int(round(t1 / mj_dt))
    data = mujoco.MjData(model)
    start = time.perf_counter()
    mj_final = _mujoco_run(model, nstep, data)[0]
    mj_first = time.perf_counter() - start
    mj_error = float(np.max(np.abs(mj_final - targets[:m_tree])))
    if mj_error > ANSWER_TOL:
        raise AssertionError(f"MuJoCo ends {mj_error:.3g} rad from the targets")
    # Its own step error: the same rollout at a quarter of the step, on the way and at the end.
    fine_model = _mujoco_model(system, dt=mj_dt / 4)
    coarse_path = _mujoco_path(model, nstep)
    fine_path = _mujoco_path(fine_model, 4 * nstep)[3::4]
    mj_step_error = float(np.max(np.abs(coarse_path - fine_path)))
    mj = (
        time_calls(lambda: _mujoco_run(model, nstep, data), repeats=repeats - 1, warmup=0)
        if (repeats > 1)
        else Timing.once(mj_first)
    )
    rows.append(
        Result(
            name=f"miura {n}x{n} step release, one trajectory to {t1:g} us vs MuJoCo",
            ours=ours,
            peer_name=f"MuJoCo rollout (C), dt {mj_dt:.3g} us",
            peer=mj,
            compile_s=compile_s,
            max_abs_difference=float(np.max(np.abs(mj_final - ours_final[:m_tree]))),
            notes=(
                f"{pattern.n_creases} creases, {pattern.n_loops} loops; ours: {steps} Tsit5 steps "
                f"({steps / ours.median:.3g} steps/s), closure drift {drift:.1e} rad; MuJoCo: "
                f"{nstep} steps ({nstep / mj.median:.3g} steps/s), ends {mj_error:.2e} rad from "
                f"the targets (soft connect constraints), its path within {mj_step_error:.1e} rad "
                f"of the same rollout at dt/4; {_ratio(ours.median, mj.median)}"
            ),
            extra={
                "creases": pattern.n_creases,
                "loops": pattern.n_loops,
                "ours_steps": steps,
                "ours_steps_per_s": steps / ours.median,
                "mujoco_steps_per_s": nstep / mj.median,
                "closure_drift": drift,
                "mujoco_dt_us": mj_dt,
                "mujoco_step_error": mj_step_error,
            },
        )
    )
    rows.append(_bar_hinge_row(n, t1, pattern, system, ours, compile_s, ours_final, steps))

    # A batch with scattered hinges (±10 % stiffness, release over 20 µs): sheets/s.
    rng = np.random.default_rng(0)
    factor = jnp.asarray(1 + 0.1 * rng.uniform(-1, 1, (batch, m)))
    # Stiffness only: with release times scattered over 20 µs a member of 8 took another branch at
    # the flat state and ended 2.75 rad from the targets (the release order picks the branch), and
    # MuJoCo's rollout has no per-joint release; every member is released at t = 0.
    release = jnp.zeros((batch, m))
    # vmapped: one compiled program runs the measured members (all of them in the quick run; in the
    # full run `LOOPS_BATCH`, default 8, extrapolated to the 1000).
    measured = batch if quick else min(batch, int(os.environ.get("LOOPS_BATCH", "8")))

    # Twice the single trajectory's span: the softer members (−10 %) released last settle later.
    def member(f, r):
        return _solve(_scattered(system, f, r), 2 * t1).theta[-1]

    start = time.perf_counter()
    batched = jax.jit(jax.vmap(member)).lower(factor[:measured], release[:measured]).compile()
    batch_compile = time.perf_counter() - start
    finals = np.asarray(batched(factor[:measured], release[:measured]))
    if np.max(np.abs(finals - targets)) > 1e-3:
        error = np.max(np.abs(finals - targets))
        raise AssertionError(f"a batch member ends {error:.3g} rad from the targets")
    ours_batch = time_calls(
        lambda: batched(factor[:measured], release[:measured]), repeats=1, warmup=0
    )
    ours_per_sheet = ours_batch.median / measured
    ours_label = f"ours vmapped over {measured}" + (
        f", EXTRAPOLATED to {batch}" if measured < batch else ""
    )
    mj_members = min(batch, int(os.environ.get("LOOPS_MJ_BATCH", "8")))
    models = scattered_models(system, np.asarray(factor[:mj_members]))
    # The same span as ours' batch, and the same check of where the members end.
    mj_finals = []
    mj_batch = time_calls(
        lambda: mj_finals.append(_mujoco_run(models, 2 * nstep)), repeats=1, warmup=0
    )
    mj_batch_error = float(np.max(np.abs(mj_finals[-1] - targets[:m_tree])))
    if mj_batch_error > ANSWER_TOL:
        raise AssertionError(
            f"a MuJoCo batch member ends {mj_batch_error:.3g} rad from the targets"
        )
    per_sheet_mj = mj_batch.median / mj_members
    total = ours_per_sheet * batch
    rows.append(
        Result(
            name=f"miura {n}x{n}, batch of {batch} with scattered hinges vs MuJoCo",
            ours=Timing.once(total),
            peer_name=f"MuJoCo rollout over {mj_members} models (C)"
            + (f", EXTRAPOLATED to {batch}" if batch > mj_members else ""),
            peer=Timing.once(per_sheet_mj * batch),
            compile_s=batch_compile,
            per_item=batch,
            notes=(
                f"{ours_label}: {1 / ours_per_sheet:.3g} sheets/s; MuJoCo {1 / per_sheet_mj:.3g} "
                f"sheets/s; both to {2 * t1:g} us, stiffness scattered ±10 %, all released at 0, "
                f"every member within {max(float(np.max(np.abs(finals - targets))), mj_batch_error):.1e} "
                f"rad of the targets; {_ratio(ours_per_sheet, per_sheet_mj)}"
            ),
            extra={
                "batch": batch,
                "ours_sheets_per_s": 1 / ours_per_sheet,
                "mujoco_sheets_per_s": 1 / per_sheet_mj,
                "measured": measured,
                "extrapolated": measured < batch,
            },
        )
    )

    # Scaling: cost per step with the sheet size.
    for size in scaling:
        if size == n:
            reuse, built = (solve, compile_s, steps, ours, t1), (pattern, base)
        else:
            reuse = built = None
        rows.extend(_scaling_rows(size, reuse=reuse, built=built))
    return rows


def _bar_hinge_row(n, t1, pattern, system, ours, compile_s, ours_final, steps) -> Result:
    """One trajectory of the bar-and-hinge peer, its end state checked against the targets.

    The targets close every loop, so in the bar-and-hinge model they are an exact equilibrium: every
    bar at its rest length, every facet flat, every crease spring at rest (the force there is
    checked to round-off below). The compliant bars and facets change the path, not the end state;
    what is left at ``t1`` is the slowest mode's decay, ``exp(−ω_min t1)`` with the damping critical
    for that mode (`bar_hinge_model`), far below `BH_TOL` (1e-3 rad, the check ours passes)."""
    targets = np.asarray(system.hinges.target)
    bars = bar_hinge_model(pattern, system)
    folded = folded_positions(pattern, system, targets)
    residual = float(np.max(np.abs(bars.forces(folded, np.zeros_like(folded))[bars.free])))
    scale = float(np.max(bars.bar_stiffness * bars.bar_length))
    if residual > 1e-10 * scale:
        raise AssertionError(
            f"the targets are not an equilibrium of the bar-and-hinge model: {residual}"
        )
    start = time.perf_counter()
    sol, x = bars.simulate(t1, bars.SolveOptions(saveat=bars.SaveAt(n=51)))
    bh_time = time.perf_counter() - start
    angles = bars.crease_angles(x, pattern.n_creases)
    bh_error = float(np.max(np.abs(angles[-1] - targets)))
    if sol.status != 0 or bh_error > BH_TOL:
        raise AssertionError(f"bar-and-hinge ends {bh_error:.3g} rad from the targets")
    bh_steps = sol.nfev / 6
    facet = float(np.max(np.abs(bars.angles(x)[:, bars.hinge_crease < 0])))
    lengths = np.linalg.norm(x[:, bars.bars[:, 1]] - x[:, bars.bars[:, 0]], axis=-1)
    strain = float(np.max(np.abs(lengths / bars.bar_length - 1)))
    return Result(
        name=f"miura {n}x{n} step release, one trajectory to {t1:g} us vs bar-and-hinge",
        ours=ours,
        peer_name="bar-and-hinge (NumPy, scipy solve_ivp RK45)",
        peer=Timing.once(bh_time),
        compile_s=compile_s,
        max_abs_difference=float(np.max(np.abs(angles[-1] - ours_final))),
        notes=(
            f"ours {steps / ours.median:.3g} steps/s; bar-and-hinge: {bars.n_nodes} nodes, "
            f"{len(bars.bars)} bars, {len(bars.hinges)} hinges, {sol.nfev} right-hand sides "
            f"(~{bh_steps:.0f} steps, {bh_steps / bh_time:.3g} steps/s), ends {bh_error:.1e} rad "
            f"from the targets; on the way its facets bend up to {facet:.2g} rad and its bars "
            f"stretch up to {100 * strain:.2g} % (compliant panels); "
            f"{_ratio(ours.median, bh_time)}"
        ),
        extra={
            "bar_hinge_nfev": int(sol.nfev),
            "bar_hinge_steps_per_s": bh_steps / bh_time,
            "bar_hinge_error": bh_error,
            "bar_hinge_peak_facet_rad": facet,
            "bar_hinge_peak_strain": strain,
        },
    )


def _scaling_rows(size: int, horizon: float = 60.0, reuse=None, built=None) -> list[Result]:
    """Cost per step of one `size` × `size` sheet: ours (the main trajectory's figures where `reuse`
    gives them, else a `horizon` run compiled here; left out above `_ours_max`), MuJoCo and the
    bar-and-hinge model over `horizon`."""
    p, s = built if built is not None else _pattern(size)
    mj_dt = _mujoco_dt(s)
    mj_model = _mujoco_model(s, dt=mj_dt)
    mj_steps = int(round(horizon / mj_dt))
    mj_t = time_calls(lambda: _mujoco_run(mj_model, mj_steps), repeats=1)
    bars = bar_hinge_model(p, s)
    start = time.perf_counter()
    sol, _ = bars.simulate(horizon, bars.SolveOptions(saveat=bars.SaveAt(n=2)))
    bh_s = time.perf_counter() - start
    bh_rate = sol.nfev / 6 / bh_s
    mj_rate = mj_steps / mj_t.median
    base = {"size": size, "creases": p.n_creases, "mujoco_steps_per_s": mj_rate}
    base["bar_hinge_steps_per_s"] = bh_rate
    name = f"scaling: miura {size}x{size} ({p.n_creases} creases, {p.n_loops} loops)"
    if reuse is None and size > _ours_max():
        return [
            Result(
                name=f"{name}, peers only: MuJoCo in the 'ours' column",
                ours=mj_t,
                peer_name="bar-and-hinge (NumPy/SciPy)",
                peer=Timing.once(bh_s),
                notes=(
                    f"ours not compiled above {_ours_max()}x{_ours_max()} (LOOPS_OURS_MAX; the "
                    f"compile time grows with the sheet); MuJoCo {mj_rate:.3g} steps/s, "
                    f"bar-and-hinge {bh_rate:.3g} steps/s over {horizon:g} us"
                ),
                extra=base,
            )
        ]
    if reuse is None:
        start = time.perf_counter()
        short = jax.jit(lambda s: _solve(s, horizon, n_save=2)).lower(s).compile()
        compile_s = time.perf_counter() - start
        steps = int(short(s).stats["num_steps"])
        timing = time_calls(lambda: short(s).theta, repeats=1)
        span = f"{horizon:g} us"
    else:
        _, compile_s, steps, timing, t1 = reuse
        span = f"{t1:g} us (the trajectory above)"
    rate = steps / timing.median
    base["ours_steps_per_s"] = rate
    return [
        Result(
            name=f"{name} vs MuJoCo, steps/s",
            ours=Timing.once(1 / rate),
            peer_name="MuJoCo rollout (C), per step",
            peer=Timing.once(1 / mj_rate),
            compile_s=compile_s,
            notes=(
                f"ours {rate:.3g} steps/s ({steps} Tsit5 steps over {span}), MuJoCo "
                f"{mj_rate:.3g} steps/s, bar-and-hinge {bh_rate:.3g} steps/s (RK45, {horizon:g} "
                f"us); per step, ours/MuJoCo {mj_rate / rate:.3g}, ours/bar-and-hinge "
                f"{bh_rate / rate:.3g} (a step of each is not the same span of time)"
            ),
            extra=base,
        )
    ]


if __name__ == "__main__":
    for row in run(quick=True):
        print(row.line())
