"""Contact on a pattern of many panels: the plate contact's broad phase against every pair, and
MuJoCo's collision on the same plates.

The pattern: an accordion strip of `squares` 100 µm squares (`origami_jax.fold.chain_fold`), its
creases alternately valley and mountain at 170°, the literature bilayer hinges in air (each as
wide as its crease). Two states:
curled (each crease at 6 % of its target: only neighbours within reach) and stacked (105.8 %: past
the target, every panel pressed onto the ones around it in the stack, pairs engaged). Past
`BROAD_PHASE_MIN_PAIRS` primitive pairs (a strip of ~53 squares) `PlateContact.force` boxes each
body and evaluates only the primitive pairs of boxes within reach; the peer row evaluates every
pair (the same terms and many exact zeros, the broad phase turned off for that trace). Both are
checked equal (to 1e-12 of the largest force) before anything is timed.

MuJoCo (`benchmarks._mujoco_tree`): the same panels as thin convex prisms on the same tree, at the
same joint angles; timed `mj_kinematics` + `mj_collision` (its broad phase, sweep-and-prune, and
its narrow phase, the prisms' convex collision), a part of what ours does (ours also turns the
barrier into generalised forces). Checked first: every pair of bodies MuJoCo finds in contact is a
pair our broad phase keeps (its prisms are inset by a thickness, ours reach farther: the barrier's
activation gap), so the boxes miss no contact MuJoCo sees. Ours runs on one compiled call per
state (XLA's threads); MuJoCo's collision is single-threaded C.

Run: ``python -m benchmarks --only broad_phase`` (``--quick``: 100 squares only, fewer repeats).
"""

import time

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from origami_jax.contact import _plates
from origami_jax.fold import chain_fold
from origami_jax.net import hinges_within_creases, load_net
from origami_jax.system import AIR, HingeDesign

from ._harness import Result, time_calls
from ._mujoco_tree import critical_damping, hinge_period_step, tree_model

SIDE = 100.0  # µm, each square
ANGLE_DEG = 170.0  # each crease's target, alternately valley and mountain
STATES = {"curled": 0.06, "stacked": 1.058}  # of the targets


def strip(squares: int):
    """The accordion strip of `squares` squares (`load_net` of `chain_fold`) and its system in air."""
    angles = np.radians([ANGLE_DEG if i % 2 else -ANGLE_DEG for i in range(1, squares)])
    fold = chain_fold(angles, np.full(squares - 1, SIDE), width=SIDE, base_length=SIDE)
    net = load_net(fold, name=f"strip_{squares}")
    design = hinges_within_creases(HingeDesign.literature(fluid=AIR), net.crease_lengths)
    return net, design, net.system(design)


def _force_program(system, broad: bool):
    """`contact.force(mechanism, q, 0)` compiled, with or without the broad phase (chosen while
    tracing); returns (compiled, compile seconds)."""
    contact, mechanism = system.contact, system.mechanism
    saved = _plates.BROAD_PHASE_MIN_PAIRS
    _plates.BROAD_PHASE_MIN_PAIRS = saved if broad else 1 << 62
    try:
        q = jnp.zeros(mechanism.n_bodies)
        start = time.perf_counter()
        compiled = (
            jax.jit(lambda q: contact.force(mechanism, q, jnp.zeros_like(q))).lower(q).compile()
        )
        return compiled, time.perf_counter() - start
    finally:
        _plates.BROAD_PHASE_MIN_PAIRS = saved


def _mujoco(system, design):
    tree = system.mechanism
    k = np.asarray(system.hinges.stiffness)
    model = tree_model(
        tree,
        stiffness=k,
        target=np.asarray(system.hinges.target),
        damping=critical_damping(tree, k),
        dt=hinge_period_step(tree, k),
        thickness=float(design.t_structural),
    )
    return model, mujoco.MjData(model)


def _mujoco_body_pairs(model, data) -> set[tuple[int, int]]:
    """The pairs of our body indices (moving bodies 0…b−1 in tree order, the base b) in contact."""
    base = model.nbody - 1  # MuJoCo's world body 0 holds the base geom
    pairs = set()
    for contact in data.contact[: data.ncon]:
        a, b = (int(model.geom_bodyid[g]) for g in contact.geom)
        a, b = (base if x == 0 else x - 1 for x in (a, b))
        pairs.add((min(a, b), max(a, b)))
    return pairs


def _check_bodies(system, q, model, data) -> int:
    """Every body pair MuJoCo finds in contact at `q` is one our broad phase keeps; returns the
    number of MuJoCo's pairs."""
    contact = system.contact
    x = contact.vertices(system.mechanism, q)
    near = np.asarray(contact._near_bodies(x, x, contact.activation))
    data.qpos[:] = np.asarray(q)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_collision(model, data)
    pairs = _mujoco_body_pairs(model, data)
    missed = [(a, b) for a, b in pairs if not (near[a, b] or near[b, a])]
    if missed:
        raise AssertionError(f"the broad phase drops body pairs MuJoCo finds in contact: {missed}")
    return len(pairs)


def _rows(squares: int, repeats: int) -> list[Result]:
    net, design, system = strip(squares)
    contact = system.contact
    n_pairs = contact.tables.n_primitives
    if n_pairs <= _plates.BROAD_PHASE_MIN_PAIRS:
        raise ValueError(f"{squares} squares: {n_pairs} primitive pairs, below the broad phase's")
    broad, broad_compile = _force_program(system, broad=True)
    whole, whole_compile = _force_program(system, broad=False)
    model, data = _mujoco(system, design)
    target = jnp.asarray(net.intended_angles)
    rows = []
    for state, fraction in STATES.items():
        q = target * fraction
        ours, every = np.asarray(broad(q)), np.asarray(whole(q))
        scale = max(float(np.abs(every).max()), 1e-300)
        difference = float(np.abs(ours - every).max())
        if difference > 1e-12 * scale:
            raise AssertionError(f"{state}: the broad phase changes the force by {difference:g}")
        engaged = _check_bodies(system, q, model, data)
        ours_t = time_calls(lambda q=q: broad(q), repeats=repeats)
        every_t = time_calls(lambda q=q: whole(q), repeats=repeats)
        qpos = np.asarray(q)

        def mujoco_collision(qpos=qpos):
            data.qpos[:] = qpos
            mujoco.mj_kinematics(model, data)
            mujoco.mj_collision(model, data)
            return data.ncon

        mujoco_t = time_calls(mujoco_collision, repeats=repeats * 10)
        label = f"strip of {squares} squares ({n_pairs} primitive pairs), {state}"
        extra = {
            "squares": squares,
            "primitive_pairs": int(n_pairs),
            "state_fraction_of_target": fraction,
            "mujoco_body_pairs_in_contact": engaged,
            "max_abs_force": scale,
        }
        rows.append(
            Result(
                f"{label}: plate contact force, broad phase vs every pair",
                ours_t,
                peer_name="ours, every primitive pair (broad phase off)",
                peer=every_t,
                compile_s=broad_compile,
                max_abs_difference=difference,
                notes=f"every-pair program compiled in {whole_compile:.1f} s",
                extra=extra | {"compile_every_pair_s": whole_compile},
            )
        )
        rows.append(
            Result(
                f"{label}: plate contact force (broad phase) vs MuJoCo collision",
                ours_t,
                peer_name="MuJoCo mj_kinematics + mj_collision (C, one thread)",
                peer=mujoco_t,
                compile_s=broad_compile,
                notes="MuJoCo finds contacts; ours also turns them into generalised forces",
                extra=extra,
            )
        )
    return rows


def run(quick: bool) -> list[Result]:
    sizes = (100,) if quick else (100, 200)
    rows = []
    for squares in sizes:
        rows.extend(_rows(squares, repeats=5 if quick else 20))
    return rows
