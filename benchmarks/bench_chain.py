"""Forward dynamics of the 3-flap accordion (issue #3): ours (jitted, single and vmapped) vs Pinocchio ABA.

Answers are compared first (hinge springs and drag off, so both solve the same rigid-body problem); compile
time is reported apart from run time; the per-state ratio is Pinocchio's single-call C++ time over ours.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pinocchio as pin

import origami_jax.chain as oc
import origami_jax.system as osys

from ._harness import Result, compile_jitted, time_calls


def _pinocchio_model(chain: oc.Chain) -> pin.Model:
    # Same construction as tests/chain_cases.py: joint frames at the hinge points, world-aligned at θ = 0.
    model = pin.Model()
    parent, previous = 0, np.zeros(3)
    for i in range(chain.n_joints):
        joint_id = model.addJoint(
            parent,
            pin.JointModelRevoluteUnaligned(np.asarray(chain.axes[i])),
            pin.SE3(np.eye(3), np.asarray(chain.points[i]) - previous),
            f"hinge_{i}",
        )
        rotation = np.asarray(chain.cg_poses[i, :3, :3])
        inertia = rotation @ np.asarray(chain.inertias[i]) @ rotation.T
        lever = np.asarray(chain.cg_poses[i, :3, 3] - chain.points[i])
        model.appendBodyToJoint(
            joint_id, pin.Inertia(float(chain.masses[i]), lever, inertia), pin.SE3.Identity()
        )
        parent, previous = joint_id, np.asarray(chain.points[i])
    model.gravity = pin.Motion.Zero()
    return model


def run(quick: bool) -> list[Result]:
    n_states = 1_000 if quick else 10_000
    repeats = 5 if quick else 20
    design = osys.HingeDesign.literature()
    chain = oc.accordion_system(design, 3).mechanism
    rng = np.random.default_rng(0)
    theta = rng.uniform(-np.pi, np.pi, size=(n_states, 3))
    theta_dot = rng.normal(scale=0.05, size=(n_states, 3))
    tau = rng.normal(scale=1e3, size=(n_states, 3))

    def single(chain, q, v, t):
        return oc.forward_dynamics(chain, q, v, t)

    def batched(chain, q, v, t):
        return jax.vmap(single, in_axes=(None, 0, 0, 0))(chain, q, v, t)

    q0, v0, t0 = (jnp.asarray(x[0]) for x in (theta, theta_dot, tau))
    qs, vs, ts = (jnp.asarray(x) for x in (theta, theta_dot, tau))
    single_c, single_compile, single_flops = compile_jitted(single, chain, q0, v0, t0)
    batched_c, batched_compile, batched_flops = compile_jitted(batched, chain, qs, vs, ts)

    model = _pinocchio_model(chain)
    data = model.createData()
    reference = np.stack(
        [pin.aba(model, data, q, v, t) for q, v, t in zip(theta, theta_dot, tau, strict=True)]
    )
    ours = np.asarray(batched_c(chain, qs, vs, ts))
    difference_batched = float(np.max(np.abs(ours - reference)))
    difference_single = float(
        np.max(np.abs(np.asarray(single_c(chain, q0, v0, t0)) - reference[0]))
    )
    scale = float(np.max(np.abs(reference)))

    def pinocchio_single():
        return pin.aba(model, data, theta[0], theta_dot[0], tau[0])

    def pinocchio_loop():
        for q, v, t in zip(theta, theta_dot, tau, strict=True):
            pin.aba(model, data, q, v, t)

    peer_single = time_calls(pinocchio_single, repeats=repeats * 50)
    peer_loop = time_calls(pinocchio_loop, repeats=max(repeats // 4, 3))

    rows = [
        Result(
            name="accordion3 forward_dynamics, single call (jit)",
            ours=time_calls(lambda: single_c(chain, q0, v0, t0), repeats=repeats * 50),
            peer_name="pinocchio.aba (single call)",
            peer=peer_single,
            compile_s=single_compile,
            max_abs_difference=difference_single,
            flops=single_flops,
            notes=f"|θ̈| scale {scale:.3g} rad/µs²",
        ),
        Result(
            name=f"accordion3 forward_dynamics, vmap over {n_states} states",
            ours=time_calls(lambda: batched_c(chain, qs, vs, ts), repeats=repeats),
            peer_name=f"pinocchio.aba (Python loop over {n_states})",
            peer=peer_loop,
            compile_s=batched_compile,
            max_abs_difference=difference_batched,
            flops=batched_flops,
            per_item=n_states,
        ),
    ]
    per_state = rows[1].ours.median / n_states
    ratio = per_state / peer_single.median
    print(
        f"per-state: ours vmapped {per_state * 1e9:.0f} ns, pinocchio.aba single C++ call "
        f"{peer_single.median * 1e9:.0f} ns (incl. Python binding overhead) -> ours/pinocchio = "
        f"{ratio:.2f} (issue #3 target: <= 3); FLOP per state {batched_flops / n_states:.0f} "
        f"(single-call graph {single_flops:.0f}); max |diff| {difference_batched:.2e} of {scale:.3g}",
        flush=True,
    )
    rows[1].extra["ours_per_state_over_pinocchio_single"] = ratio
    rows[1].extra["throughput"] = _throughput(batched, chain, qs, vs, ts, quick)
    rows[1].extra["peer_throughput"] = n_states / peer_loop.median
    return rows


def _throughput(batched, chain, qs, vs, ts, quick: bool) -> dict[int, float]:
    """States per second of the vmapped kernel against batch size (one compilation per size)."""
    sizes = (1, 10, 100, 1_000) if quick else (1, 10, 100, 1_000, 10_000, 100_000)
    rates = {}
    for size in sizes:
        reps = -(-size // qs.shape[0])  # tile the random states up to the size
        q, v, t = (jnp.tile(x, (reps, 1))[:size] for x in (qs, vs, ts))
        compiled, _, _ = compile_jitted(batched, chain, q, v, t)
        args = (chain, q, v, t)
        timing = time_calls(lambda c=compiled, a=args: c(*a), repeats=5 if quick else 20)
        rates[size] = size / timing.median
    return rates
