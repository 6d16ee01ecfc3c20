"""A Miura-ori sheet folding under step release: the closed-loop engine vs MuJoCo and a bar-and-hinge model.

The sheet: `n × n` parallelograms (200 µm sides, 60°) whose hinges are released at ``t = 0`` towards
Schenk and Guest's folding parameter ``θ = 45°`` (a folded state that closes every loop), literature
bilayer hinges, KOH solution, no contact (none of the peers has panel contact). Three models of it:

- **ours**: `origami_jax.loops` (rigid panels on a spanning tree, vertex-loop closure as constraints,
  Baumgarte, augmented-Lagrangian solve), panel drag, explicit Tsit5 at rtol 1e-6, jitted;
- **MuJoCo** (C, `mujoco.rollout` in a loop): the same panels as nested bodies with hinge joints on the
  same spanning tree (stiffness, `springref` = target), each cut crease as two `connect` equality
  constraints at its ends (MuJoCo's soft constraints; MuJoCo has no spring across an equality
  constraint, so the cut creases carry no hinge spring there), linear joint damping for the fluid
  (MuJoCo has no panel drag), `implicitfast` at a fixed step;
- **bar-and-hinge** (`benchmarks._bar_hinge`, NumPy + `scipy.integrate.solve_ivp`): Origami Simulator's
  and MERLIN's model written here as the peer: point masses, bars, dihedral springs on creases and on
  facet diagonals, mass-proportional damping, RK45.

The three dissipate differently (quadratic panel drag, linear joint damping, nodal damping), so they
take different times to settle; what they must share is the end: every crease at its target (the
targets close the loops, so the rigid sheet's equilibrium is the target state). Answers are compared
there first (each peer's final angles against the targets and ours), then timed: a trajectory to
``t1`` per model (steps/s), a batch with scattered hinges (±10 % stiffness per crease, release times
scattered over 20 µs; sheets/s; ours vmapped, MuJoCo one rollout per member), compile time, and the
scaling of one trajectory's cost per step with the sheet size.

Run: ``python -m benchmarks --only loops`` (``--quick``: 3×3 and 5×5 sheets, small batches).
"""

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

from ._bar_hinge import bar_hinge_model
from ._harness import Result, Timing, time_calls

T1 = 1500.0  # µs: every model has settled by then
MJ_DT = 0.02  # µs, MuJoCo's fixed step
ANSWER_TOL = (
    0.02  # rad: the peers' end states against the targets (soft constraints, compliant bars)
)


def _pattern(n: int):
    pattern = load_pattern(miura_sheet(n, n), name=f"miura_{n}x{n}")
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    return pattern, pattern.system(design, contact=False, check_rigid=False)


def _solve(system, t1, n_save=51, rtol=1e-6, atol=1e-9):
    return sim.simulate(
        system,
        sim.Step(),
        t1=t1,
        n_save=n_save,
        rtol=rtol,
        atol=atol,
        solver=diffrax.Tsit5(),
        max_steps=200_000,
        throw=False,
    )


# ---- MuJoCo --------------------------------------------------------------------------------


def _mjcf(system, damping: np.ndarray, dt: float) -> str:
    mechanism = system.mechanism
    tree = mechanism.tree
    parents = tree.parents
    points = np.asarray(tree.points)
    axes = np.asarray(tree.axes)
    frames = np.asarray(tree.frames)
    masses = np.asarray(tree.masses)
    cgs = np.asarray(tree.cgs)
    inertias = np.asarray(tree.inertias)
    k = np.asarray(system.hinges.stiffness)
    target = np.asarray(system.hinges.target)
    children: dict[int, list[int]] = {}
    for i, p in enumerate(parents):
        children.setdefault(p, []).append(i)

    def f(values) -> str:
        return " ".join(f"{v:.17g}" for v in values)

    def body(i: int) -> str:
        parent_point = points[parents[i]] if parents[i] >= 0 else np.zeros(3)
        rotation = frames[i, :3, :3]
        cg = frames[i, :3, 3] + rotation @ cgs[i] - points[i]
        inertia = rotation @ inertias[i] @ rotation.T
        full = (
            inertia[0, 0],
            inertia[1, 1],
            inertia[2, 2],
            inertia[0, 1],
            inertia[0, 2],
            inertia[1, 2],
        )
        inner = "".join(body(c) for c in children.get(i, []))
        return (
            f'<body name="b{i}" pos="{f(points[i] - parent_point)}">'
            f'<inertial pos="{f(cg)}" mass="{masses[i]:.17g}" fullinertia="{f(full)}"/>'
            f'<joint name="h{i}" type="hinge" axis="{f(axes[i])}" pos="0 0 0" '
            f'stiffness="{k[i]:.17g}" springref="{target[i]:.17g}" damping="{damping[i]:.17g}"/>'
            f"{inner}</body>"
        )

    equality = ""
    for c, ((a, b), ends) in enumerate(zip(mechanism.cut_bodies, mechanism.cut_ends, strict=True)):
        for end in np.asarray(ends):
            anchor = end - (points[a] if a >= 0 else np.zeros(3))
            name1 = f"b{a}" if a >= 0 else "world"
            equality += (
                f'<connect body1="{name1}" body2="b{b}" anchor="{f(anchor)}" '
                f'solref="{4 * dt:.17g} 1"/>'
            )
        del c
    return (
        '<mujoco><compiler angle="radian"/>'
        f'<option timestep="{dt:.17g}" integrator="implicitfast" gravity="0 0 0">'
        '<flag contact="disable"/></option>'
        f"<worldbody>{''.join(body(c) for c in children.get(-1, []))}</worldbody>"
        f"<equality>{equality}</equality></mujoco>"
    )


def _mujoco_model(system, *, dt: float = MJ_DT, damping_ratio: float = 1.0):
    mechanism = system.mechanism
    inertia = np.diagonal(np.asarray(mechanism.tree.mass_matrix(np.zeros(mechanism.n_tree))))
    k = np.asarray(system.hinges.stiffness)[: mechanism.n_tree]
    damping = 2 * damping_ratio * np.sqrt(k * inertia)
    return mujoco.MjModel.from_xml_string(_mjcf(system, damping, dt))


def _mujoco_run(models, nstep: int, data=None):
    """Roll every model out from flat at rest for `nstep` steps; the final joint angles `(b, n_T)`."""
    models = models if isinstance(models, list) else [models]
    data = data or mujoco.MjData(models[0])
    size = mujoco.mj_stateSize(models[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    initial = np.zeros((len(models), size))
    state, _ = rollout.rollout(models, data, initial, nstep=nstep)
    model = models[0]
    order = [int(model.joint(f"h{i}").qposadr[0]) for i in range(model.njnt)]
    return state[:, -1, 1 + np.asarray(order)]  # FULLPHYSICS: time, qpos, ...; our hinge order


# ---- benchmark ------------------------------------------------------------------------------


def run(quick: bool) -> list[Result]:
    jax.config.update("jax_enable_x64", True)
    n = 5 if quick else 10
    batch = 8 if quick else 64
    scaling = (3, 5) if quick else (5, 10, 15, 20)
    repeats = 1 if quick else 3
    rows: list[Result] = []

    pattern, system = _pattern(n)
    targets = np.asarray(system.hinges.target)
    m_tree = system.mechanism.n_tree

    # Ours: compile apart, then time one trajectory.
    start = time.perf_counter()
    solve = jax.jit(lambda s: _solve(s, T1)).lower(system).compile()
    compile_s = time.perf_counter() - start
    trajectory = solve(system)
    ours_final = np.asarray(trajectory.theta[-1])
    steps = int(trajectory.stats["num_steps"])
    drift = float(np.max(pattern.closure_residual(np.asarray(trajectory.theta))))
    if not bool(trajectory.succeeded) or np.max(np.abs(ours_final - targets)) > 1e-3:
        raise AssertionError(f"ours did not fold: {np.max(np.abs(ours_final - targets))}")
    ours = time_calls(lambda: solve(system).theta, repeats=repeats)

    # MuJoCo: the same folding, same spanning tree, cut creases as connect constraints.
    model = _mujoco_model(system)
    nstep = int(round(T1 / MJ_DT))
    mj_final = _mujoco_run(model, nstep)[0]
    mj_error = float(np.max(np.abs(mj_final - targets[:m_tree])))
    if mj_error > ANSWER_TOL:
        raise AssertionError(f"MuJoCo ends {mj_error:.3g} rad from the targets")
    data = mujoco.MjData(model)
    mj = time_calls(lambda: _mujoco_run(model, nstep, data), repeats=repeats)
    rows.append(
        Result(
            name=f"miura {n}x{n} step release, one trajectory to {T1:g} us vs MuJoCo",
            ours=ours,
            peer_name=f"MuJoCo rollout (C), dt {MJ_DT} us",
            peer=mj,
            compile_s=compile_s,
            max_abs_difference=float(np.max(np.abs(mj_final - ours_final[:m_tree]))),
            notes=(
                f"ours: {steps} Tsit5 steps ({steps / ours.median:.3g} steps/s), closure drift "
                f"{drift:.1e} rad; MuJoCo: {nstep} steps ({nstep / mj.median:.3g} steps/s), ends "
                f"{mj_error:.2e} rad from the targets (soft connect constraints)"
            ),
            extra={
                "creases": pattern.n_creases,
                "loops": pattern.n_loops,
                "ours_steps": steps,
                "ours_steps_per_s": steps / ours.median,
                "mujoco_steps_per_s": nstep / mj.median,
                "closure_drift": drift,
            },
        )
    )

    # Bar-and-hinge (SciPy).
    bars = bar_hinge_model(pattern, system)
    start = time.perf_counter()
    sol, x = bars.simulate(T1, n_save=51)
    bh_time = time.perf_counter() - start
    bh_final = bars.crease_angles(x[-1], pattern.n_creases)
    bh_error = float(np.max(np.abs(bh_final - targets)))
    if sol.status != 0 or bh_error > ANSWER_TOL:
        raise AssertionError(f"bar-and-hinge ends {bh_error:.3g} rad from the targets")
    rows.append(
        Result(
            name=f"miura {n}x{n} step release, one trajectory to {T1:g} us vs bar-and-hinge",
            ours=ours,
            peer_name="bar-and-hinge (NumPy, scipy solve_ivp RK45)",
            peer=Timing(bh_time, bh_time, bh_time, 1),
            compile_s=compile_s,
            max_abs_difference=float(np.max(np.abs(bh_final - ours_final))),
            notes=(
                f"bar-and-hinge: {bars.n_nodes} nodes, {len(bars.bars)} bars, "
                f"{len(bars.hinges)} hinges, {sol.nfev} right-hand sides "
                f"({sol.nfev / 6 / bh_time:.3g} steps/s), ends {bh_error:.2e} rad from the targets "
                "(compliant bars)"
            ),
            extra={"bar_hinge_nfev": int(sol.nfev)},
        )
    )

    # A batch with scattered hinges: sheets/s.
    rng = np.random.default_rng(0)
    m = system.n_hinges
    factor = jnp.asarray(1 + 0.1 * rng.uniform(-1, 1, (batch, m)))
    release = jnp.asarray(rng.uniform(0, 20.0, (batch, m)))

    def member(f, r):
        h = system.hinges
        hinges = type(h)(h.stiffness * f, h.target, h.radius, r)
        scattered = type(system)(
            system.mechanism, hinges, system.drag, system.contact, system.units
        )
        return _solve(scattered, T1).theta[-1]

    start = time.perf_counter()
    batched = jax.jit(jax.vmap(member)).lower(factor, release).compile()
    batch_compile = time.perf_counter() - start
    finals = np.asarray(batched(factor, release))
    if np.max(np.abs(finals - targets)) > 1e-3:
        raise AssertionError("a batch member did not fold")
    ours_batch = time_calls(lambda: batched(factor, release), repeats=1)
    models = []
    for b in range(min(batch, 8)):
        copy = _mujoco_model(system)
        copy.jnt_stiffness[:] = np.asarray(system.hinges.stiffness[:m_tree] * factor[b, :m_tree])
        models.append(copy)
    mj_batch = time_calls(lambda: _mujoco_run(models, nstep), repeats=1)
    per_sheet_mj = mj_batch.median / len(models)
    rows.append(
        Result(
            name=f"miura {n}x{n}, batch of {batch} with scattered hinges vs MuJoCo",
            ours=ours_batch,
            peer_name=f"MuJoCo rollout over {len(models)} models (C), scaled to {batch}",
            peer=Timing(per_sheet_mj * batch, per_sheet_mj * batch, per_sheet_mj * batch, 1),
            compile_s=batch_compile,
            per_item=batch,
            notes=(
                f"ours {batch / ours_batch.median:.3g} sheets/s; MuJoCo {1 / per_sheet_mj:.3g} "
                "sheets/s (release times scattered for ours only: MuJoCo's rollout has no per-joint "
                "release)"
            ),
            extra={
                "batch": batch,
                "ours_sheets_per_s": batch / ours_batch.median,
                "mujoco_sheets_per_s": 1 / per_sheet_mj,
            },
        )
    )

    # Scaling: cost per step with the sheet size (a short run, steps/s).
    for size in scaling:
        rows.append(_scaling_row(size))
    return rows


def _scaling_row(size: int, horizon: float = 60.0) -> Result:
    """Cost per step of a short run of a `size` × `size` sheet: ours and MuJoCo."""
    p, s = _pattern(size)
    start = time.perf_counter()
    short = jax.jit(lambda s: _solve(s, horizon, n_save=2)).lower(s).compile()
    compile_s = time.perf_counter() - start
    steps = int(short(s).stats["num_steps"])
    timing = time_calls(lambda: short(s).theta, repeats=1)
    mj_model = _mujoco_model(s)
    mj_steps = int(round(horizon / MJ_DT))
    mj_t = time_calls(lambda: _mujoco_run(mj_model, mj_steps), repeats=1)
    return Result(
        name=f"scaling: miura {size}x{size} ({p.n_creases} creases), {horizon:g} us",
        ours=timing,
        peer_name="MuJoCo rollout (C)",
        peer=mj_t,
        compile_s=compile_s,
        notes=(
            f"ours {steps / timing.median:.3g} steps/s ({steps} steps), MuJoCo "
            f"{mj_steps / mj_t.median:.3g} steps/s"
        ),
        extra={
            "size": size,
            "creases": p.n_creases,
            "ours_steps_per_s": steps / timing.median,
            "mujoco_steps_per_s": mj_steps / mj_t.median,
        },
    )


if __name__ == "__main__":
    for row in run(quick=True):
        print(row.line())
