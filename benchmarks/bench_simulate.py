"""One step response of the 3-flap accordion: origami_jax.simulate (diffrax) vs scipy LSODA + Pinocchio.

Peer: `scipy.integrate.solve_ivp(method="LSODA")` with a right-hand side from Pinocchio's articulated-body
algorithm (`pin.aba`) plus the hinge springs and quadratic drag — what a robotics user would write. Same
model (literature hinges in air, MICRO units), same tolerances, answers compared on the samples first.
Ours with three solvers: the default (`StiffnessSwitching`: Tsit5, Kvaerno5 once stiff; in air it stays
explicit), Kvaerno5 alone (`implicit_solver()`) and Tsit5 alone.
"""

import numpy as np

from ._harness import Result, compile_jitted, loop_flops, time_calls

RTOL = 1e-8
ATOL = 1e-10
SAME_ANSWER_RAD = 1e-5


def _pinocchio_rhs(chain, k, b, tau):
    import pinocchio as pin

    model = pin.Model()
    parent = 0
    axes = np.asarray(chain.axes)
    points = np.asarray(chain.points)
    poses = np.asarray(chain.cg_poses)
    if not np.allclose(axes, [1.0, 0.0, 0.0]):
        raise ValueError("the peer model is written for hinges along x (the accordion)")
    previous = np.zeros(3)
    for i in range(chain.n_joints):
        placement = pin.SE3(np.eye(3), points[i] - previous)
        previous = points[i]
        joint = model.addJoint(parent, pin.JointModelRX(), placement, f"hinge_{i + 1}")
        inertia = pin.Inertia(
            float(chain.masses[i]),
            poses[i, :3, 3] - points[i],
            poses[i, :3, :3] @ np.asarray(chain.inertias[i]) @ poses[i, :3, :3].T,
        )
        model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
        parent = joint
    model.gravity = pin.Motion.Zero()
    data = model.createData()
    n = chain.n_joints
    k, b, tau = (np.asarray(x, dtype=float) for x in (k, b, tau))

    def rhs(t, y):
        q, v = y[:n], y[n:]
        torque = tau - k * q - b * v * np.abs(v)
        return np.concatenate([v, pin.aba(model, data, q, v, torque)])

    return rhs


def _literature_rhs():
    """Our right-hand side of the literature accordion step on the flat state ``(θ, θ̇)``, as `simulate`
    evaluates it (torque ``K θ_des``), for FLOP counts."""
    import jax.numpy as jnp

    from origami_jax.chain import accordion_system
    from origami_jax.system import MICRO, HingeDesign

    system = accordion_system(HingeDesign.literature(MICRO), 3)
    tau = system.hinges.stiffness * system.hinges.target

    def rhs(y):
        theta, theta_dot = y[:3], y[3:]
        acc = system.accelerations(theta, theta_dot, tau)
        return jnp.concatenate([theta_dot, acc])

    return rhs


def accordion_solve_flops(steps: int, *, implicit: bool) -> float | None:
    """Lower bound of the FLOPs of `steps` solver steps of the accordion (see `loop_flops`): 6
    right-hand sides per step (Tsit5's 6 new stages with FSAL; for Kvaerno5 at least one chord
    iteration in each of its 6 implicit stages), plus one Jacobian per step when `implicit`."""
    import jax

    rhs = _literature_rhs()
    flops = loop_flops(rhs, np.zeros(6), evaluations=6 * steps)
    if implicit and flops is not None:
        jacobian = loop_flops(jax.jacfwd(rhs), np.zeros(6), evaluations=steps)
        flops = None if jacobian is None else flops + jacobian
    return flops


def _switch_note(switch_time: float) -> str:
    if np.isnan(switch_time):  # not a switching solver
        return ""
    if np.isinf(switch_time):
        return "; explicit throughout (no stiffness detected)"
    return f"; turned implicit at t = {switch_time:g} us"


def lsoda_peer(system, ts: np.ndarray, repeats: int):
    """The peer of the step-response rows: scipy's LSODA on Pinocchio's `aba` with the hinge springs
    and quadratic drag of the paper's accordion `system`, from flat at rest over `ts` (µs). Returns
    its solution (answers compared against it) and its timing."""
    from scipy.integrate import solve_ivp

    chain, k, b = system.mechanism, system.hinges.stiffness, system.drag.coefficient
    rhs = _pinocchio_rhs(chain, k, b, np.asarray(k * system.hinges.target))

    def peer():
        return solve_ivp(
            rhs, (0.0, ts[-1]), np.zeros(6), method="LSODA", t_eval=ts, rtol=RTOL, atol=ATOL
        )

    reference = peer()
    if not reference.success:
        raise RuntimeError(f"LSODA failed: {reference.message}")
    return reference, time_calls(peer, repeats=repeats, warmup=0)


def run(quick: bool) -> list[Result]:
    import diffrax
    import equinox as eqx
    import jax.numpy as jnp

    import origami_jax.simulation as sim
    from origami_jax.chain import accordion_system
    from origami_jax.system import HingeDesign

    system = accordion_system(HingeDesign.literature(), 3)
    k, b = system.hinges.stiffness, system.drag.coefficient
    inputs = sim.Step()
    # Past ~0.5 ms the three coupled flaps ring so irregularly that two correct solvers at rtol 1e-8
    # drift apart by ~1e-4 rad (local errors amplified); 500 µs covers the fold, the peaks and the first
    # ringing, where the answers agree to ~1e-6 rad.
    t1 = 300.0 if quick else 500.0
    n_save = 201
    ts = np.linspace(0.0, t1, n_save)
    repeats = 3 if quick else 10

    reference, peer_timing = lsoda_peer(system, ts, repeats)

    rows = []
    solvers = (
        ("default: tsit5 -> kvaerno5 when stiff", sim.default_solver()),
        ("kvaerno5", sim.implicit_solver()),
        ("tsit5", diffrax.Tsit5()),
    )
    for name, solver in solvers:

        def ours(stiffness, drag, solver=solver):
            scaled = eqx.tree_at(
                lambda s: (s.hinges.stiffness, s.drag.coefficient), system, (stiffness, drag)
            )
            trajectory = sim.simulate(
                scaled,
                inputs,
                sim.SolveOptions(saveat=sim.SaveAt(n=n_save), solver=solver, rtol=RTOL, atol=ATOL),
                t1=t1,
            )
            switch = trajectory.stats.get("switch_time", jnp.nan)
            return trajectory.theta, trajectory.stats["num_steps"], switch

        compiled, compile_s, _ = compile_jitted(ours, k, b)
        theta, steps, switch = compiled(k, b)
        difference = float(np.max(np.abs(np.asarray(theta) - reference.y[:3].T)))
        if difference > SAME_ANSWER_RAD:
            raise RuntimeError(f"{name}: answers differ by {difference:.2e} rad; not timing")
        timing = time_calls(lambda compiled=compiled: compiled(k, b), repeats=repeats)
        # Explicit steps (Tsit5, and the default while it stays explicit): 6 right-hand sides per step,
        # also a lower bound for any implicit step the switching solver takes.
        implicit = name == "kvaerno5"
        flops = accordion_solve_flops(int(steps), implicit=implicit)
        flop_note = (
            "; FLOP = XLA count of one right-hand side x 6"
            + (" + one Jacobian" if implicit else "")
            + " per step x steps (lower bound: no solver arithmetic or linear algebra)"
        )
        rows.append(
            Result(
                name=f"accordion step {t1:.0f} us ({name}, rtol {RTOL:g})",
                ours=timing,
                peer_name="scipy LSODA + pinocchio.aba",
                peer=peer_timing,
                compile_s=compile_s,
                max_abs_difference=difference,
                flops=flops,
                notes=f"{int(steps)} diffrax steps; LSODA {reference.nfev} RHS calls"
                + _switch_note(float(switch))
                + flop_note,
            )
        )
    return rows
