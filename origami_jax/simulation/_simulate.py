"""Integrate a folding system's equations of motion under an open-loop input: `simulate`, `Trajectory`.

The stages read top to bottom: input torque → generalized force (hinge springs, drag, contact) →
forward dynamics → diffrax solve → samples and result code. The state is the pytree ``(q, v)`` of the
system's mechanism (hinge angles and rates for chains and trees); units are the system's (default
`MICRO`: µm, µs, ng).
"""

import dataclasses
import functools
from typing import cast

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._exported import SOLVE_COMPILE, exported_call
from .._runtime_errors import checks_as_nan
from .._validate import check_finite, is_traced
from ..system import FoldingSystem, HingeDrag
from ._guard import AbstractWrappedController, ContactGuard
from ._implicit import ImplicitStep, check_off_bifurcation, integrate, steps_per_interval
from ._inputs import AbstractInput
from ._options import DEFAULT_ATOL, DEFAULT_RTOL, SaveAt, SolveOptions
from ._results import RESULTS, promote
from ._switching import TURNED_STIFF, StiffnessSwitching


def default_solver() -> diffrax.AbstractSolver:
    """[`origami_jax.simulation.StiffnessSwitching`][]: explicit Tsit5 while the problem is non-stiff,
    L-stable implicit Kvaerno5 from the first stiff stretch on (LSODA's strategy).

    Stiff-capable like Kvaerno5 alone, and ~10× faster on a non-stiff folding (the 3-flap accordion in
    air: 12 ms against 110 ms for Kvaerno5, 26 ms for scipy LSODA with a Pinocchio right-hand side).
    Under `vmap` both branches run; batches should name their solver (see the sweep kernels).
    """
    return StiffnessSwitching()


def default_controller(
    rtol: float | Float[ArrayLike, ""],
    atol: float | Float[ArrayLike, ""],
    solver: diffrax.AbstractSolver | None = None,
) -> diffrax.PIDController:
    """The step-size controller `simulate` uses with `solver` (default: the default solver).

    - Explicit Runge–Kutta solvers (`diffrax.Tsit5()`, ...): diffrax's integral controller
      (`PIDController(rtol, atol)`). On the accordion step at rtol 1e-8 it takes 7–10 % fewer steps
      than the PID below (678 against 753 over 2 ms at a 20 µm hinge, 1704 against 1826 at 200 µm):
      more rejected steps, fewer in all.
    - Everything else, the switching default included: `PIDController(pcoeff=0.3, icoeff=0.3)`,
      measured 2.6× faster than the integral controller for Kvaerno5 on the accordion step.
    """
    if isinstance(solver, diffrax.AbstractERK):
        return diffrax.PIDController(rtol=rtol, atol=atol)
    return diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.3)


class Trajectory(eqx.Module):
    """A simulated folding: samples of the hinges, the input torque, solver statistics, the result code.

    **Fields:**
    - `times`: sample times, time units, shape `(t,)`.
    - `theta`: hinge angles, rad, shape `(t, n)`.
    - `theta_dot`: joint rates, rad/time, shape `(t, n)`.
    - `theta_ddot`: joint accelerations from the equations of motion, rad/time², shape `(t, n)`.
    - `tau`: the input torque, torque units, shape `(t, n)`.
    - `target`: the angles the response is measured against (rad, `(n,)`): the input's target, else the
      last sample.
    - `stats`: diffrax's statistics (`num_steps`, `num_accepted_steps`, `num_rejected_steps`, `max_steps`);
      with [`origami_jax.simulation.StiffnessSwitching`][] (the default) also `switch_time`, the time the
      solver turned implicit (`inf` if it never did); with [`origami_jax.simulation.ImplicitStep`][]
      also `newton_error` (the largest Newton update left at the end of a step, rad) and
      `contacts_left_out` (steps in which a contact pair outside the step's working set came within
      the activation gap: `ImplicitStep.active_pairs`).
    - `result`: a [`origami_jax.simulation.RESULTS`][] code; samples after a failure are `inf`.
    - `solution`: the diffrax solution with dense output when `SaveAt(dense=True)`, else `None`.
    - `state`: the mechanism's samples ``(q, v)`` when its coordinates are not its hinge angles (else
      `None`: they are `theta` and `theta_dot`).
    """

    times: Float[Array, " t"]
    theta: Float[Array, "t n"]
    theta_dot: Float[Array, "t n"]
    theta_ddot: Float[Array, "t n"]
    tau: Float[Array, "t n"]
    target: Float[Array, " n"]
    stats: dict[str, Array]
    result: RESULTS
    solution: diffrax.Solution | None = None
    state: tuple[Array, Array] | None = None

    @property
    def n_joints(self) -> int:
        return self.theta.shape[-1]

    @property
    def succeeded(self) -> jax.Array:
        """True where the solve succeeded (boolean array; batched trajectories give one per member)."""
        value = self.result._value
        if is_traced(value):
            return jnp.asarray(value == RESULTS.successful._value)
        # On the host: `==` on a device array compiles a program in each new process.
        return jax.device_put(np.asarray(value) == int(RESULTS.successful._value))

    def evaluate(self, t: Float[ArrayLike, ""]) -> tuple[Float[Array, " n"], Float[Array, " n"]]:
        """Dense output: `(θ(t), θ̇(t))` anywhere in the solved interval (needs
        `SaveAt(dense=True)`)."""
        if self.solution is None:
            raise ValueError(
                "This trajectory has no dense output: simulate with "
                "SolveOptions(saveat=SaveAt(dense=True))."
            )
        return self.solution.evaluate(t)  # pyright: ignore[reportArgumentType] (a real scalar)


# Jitted (a nested jit is inlined by XLA, so the compiled program is the same) because diffrax traces the
# vector field many times per solve: each explicit and implicit stage, the Jacobian, the root finder's
# implicit derivative. A jitted function is traced once per signature and its jaxpr reused; this halved
# the tracing time of a default-solver solve of the accordion (7.7 s to 3.7 s). `filter_jit`, because
# inputs may hold Python callables (`UserTorque`).
def _make_vector_field(forward_mode_only: bool):
    @eqx.filter_jit
    def vector_field(t, y, args):
        system, inputs = args
        q, v = y
        mechanism = system.mechanism
        theta, theta_dot = mechanism.hinge_angles(q), mechanism.hinge_rates(q, v)
        tau = inputs.torque(t, theta, theta_dot, system)
        return v, system.accelerations(q, v, tau, forward_mode_only=forward_mode_only)

    return vector_field


_vector_field = _make_vector_field(False)
# Under `diffrax.ForwardMode` only forward-mode derivatives are taken, so the dynamics may use a faster
# forward-only rule (the chain's complex-step JVP): a forward-mode solve of the accordion with 2
# tangents took 9–10 ms instead of 22 ms.
_vector_field_forward_mode = _make_vector_field(True)


class _Integration(eqx.Module):
    """How `simulate` integrates: everything but the system, the input and the time span."""

    solver: diffrax.AbstractSolver
    controller: diffrax.AbstractStepSizeController
    dt0: Array | None
    progress_meter: diffrax.AbstractProgressMeter
    adjoint: diffrax.AbstractAdjoint
    max_steps: int = eqx.field(static=True)
    dense: bool = eqx.field(static=True)
    throw: bool = eqx.field(static=True)
    land_on_samples: bool = eqx.field(static=True)
    accelerations: bool = eqx.field(static=True)


def on_one_device(tree):
    """`tree` with every array leaf committed to the device of its first committed one (else the
    default device). `jit` compiles one program per pattern of committed and uncommitted arguments,
    and a run continued from a state placed on a device (the command line's exported solve returns
    its results so) would otherwise compile its solve again: a cube net's, ~10 s."""
    arrays = [x for x in jax.tree.leaves(tree) if isinstance(x, jax.Array | np.ndarray)]
    placed = [x for x in arrays if isinstance(x, jax.Array) and x.committed]
    # Nothing to do, or arrays spread over several devices (the caller's layout: left as it is).
    if len(placed) == len(arrays) or any(len(x.sharding.device_set) > 1 for x in placed):
        return tree
    device = placed[0].sharding if placed else jax.devices()[0]

    def commit(x):
        if isinstance(x, np.ndarray) or (isinstance(x, jax.Array) and not x.committed):
            return jax.device_put(x, device)
        return x

    return jax.tree.map(commit, tree)


def _samples(system: FoldingSystem, inputs: AbstractInput, times, q, v, accelerations: bool):
    """Hinge angles, rates and accelerations (NaN unless `accelerations`: `SaveAt.accelerations`)
    and the input torque at the samples; rows past a failure are inf (and their NaN gradients kept
    out)."""
    ok = jnp.all(jnp.isfinite(q), axis=-1, keepdims=True) & jnp.all(
        jnp.isfinite(v), axis=-1, keepdims=True
    )
    q_safe = jnp.where(ok, q, 0.0)
    v_safe = jnp.where(ok, v, 0.0)
    mechanism = system.mechanism
    if mechanism.coordinates_are_hinge_angles:
        theta, theta_dot = q, v
        theta_safe, theta_dot_safe = q_safe, v_safe
    else:
        theta_safe = jax.vmap(mechanism.hinge_angles)(q_safe)
        theta_dot_safe = jax.vmap(mechanism.hinge_rates)(q_safe, v_safe)
        theta = jnp.where(ok, theta_safe, jnp.inf)
        theta_dot = jnp.where(ok, theta_dot_safe, jnp.inf)
    tau = jax.vmap(lambda t, th, thd: inputs.torque(t, th, thd, system))(
        times, theta_safe, theta_dot_safe
    )
    if accelerations:
        theta_ddot = _hinge_accelerations(system, q_safe, v_safe, tau)
    else:
        theta_ddot = jnp.full_like(theta_dot_safe, jnp.nan)
    return theta, theta_dot, jnp.where(ok, theta_ddot, jnp.inf), jnp.where(ok, tau, jnp.inf)


def _hinge_accelerations(system: FoldingSystem, q, v, tau):
    """The hinges' accelerations at the samples `(q, v)` (finite) under their input torques `tau`,
    from the equations of motion."""
    mechanism = system.mechanism
    if system.contact is None:
        force = jax.vmap(system.generalized_force)(q, v, tau)
        # All samples in one call: a mechanism's rows path (the chain's runs on scalars with its
        # custom JVP outside the vmap over samples; its array path was ~7x slower per sample, a
        # third of a vmapped sweep's time).
        acceleration = mechanism.forward_dynamics(q, v, force)
    else:
        # With contact the force is most of the program: vmapped over the samples it compiled a
        # second, batched copy of it, which took XLA longer than the whole solve (7 s against
        # 5 s for a cube net). One sample at a time compiles one unbatched copy (~1.5 s) and costs
        # a right-hand side per sample, a few percent of the solve's.

        def one_sample(state):
            q, v, torque = state
            return mechanism.forward_dynamics(q, v, system.generalized_force(q, v, torque))

        acceleration = jax.lax.map(one_sample, (q, v, tau))
    if mechanism.coordinates_are_hinge_angles:
        return acceleration
    # θ̈ = d/dt θ̇(q, v) along (q̇, v̇) = (v, v̇).
    return jax.vmap(lambda q, v, a: jax.jvp(mechanism.hinge_rates, (q, v), (v, a))[1])(
        q, v, acceleration
    )


def _diffusion(t, y, args):
    """How a Brownian increment ``(dW_q, dW_v)`` moves the state: ``(0, M⁻¹ L dW_v)`` (`Agitation`;
    ``dW_q`` has no components: the coordinates move only with the velocities)."""
    system, _ = args
    q, _ = y
    mechanism = system.mechanism
    diffusion = system.agitation.diffusion(mechanism, system.drag, system.units, q)
    return jnp.zeros(q.shape + (0,), q.dtype), diffusion


def _agitated(system: FoldingSystem, span, term: diffrax.ODETerm, y0) -> diffrax.AbstractTerm:
    """`term` with the agitation's random force added (a `diffrax.VirtualBrownianTree` seeded by
    `system.agitation.key`: the same path whatever steps the solver takes)."""
    t0, t1 = span
    q0, v0 = y0
    agitation = system.agitation
    brownian = diffrax.VirtualBrownianTree(
        t0,
        t1,
        tol=agitation.resolution * (t1 - t0),
        shape=(
            jax.ShapeDtypeStruct((0,), q0.dtype),
            jax.ShapeDtypeStruct(v0.shape, v0.dtype),
        ),
        key=agitation.key,
    )
    return diffrax.MultiTerm(term, diffrax.ControlTerm(_diffusion, brownian))


def _agitated_solver(system: FoldingSystem, solver, q0):
    """The solver of an agitated system (default `diffrax.Heun`: its noise depends on ``q`` only,
    so Itô and Stratonovich calculus agree; or the fixed-step engine, which adds the random impulse
    to each implicit step); refuses the solvers that cannot take a random force."""
    if solver is None:
        solver = diffrax.Heun()
    if isinstance(solver, StiffnessSwitching):
        raise ValueError(
            f"an agitated system needs a solver for stochastic equations ({type(solver).__name__} "
            f"is not one): leave solver unset (diffrax.Heun), or pass e.g. diffrax.Heun(), "
            f"diffrax.SPaRK() or ImplicitStep(dt=...)."
        )
    if isinstance(solver, ImplicitStep) and solver.scheme != "euler":
        raise ValueError(
            f"an agitated system takes ImplicitStep's Euler scheme (its random impulse is balanced "
            f"against implicit Euler's steps), not {solver.scheme!r}: pass "
            f"ImplicitStep(dt=..., scheme='euler') (--solver implicit-step)."
        )
    system.agitation.check_drag(system.mechanism, system.drag, q0)
    return solver


def _controller_and_field(system: FoldingSystem, inputs: AbstractInput, ts, how: _Integration):
    """The step-size controller (with the contact guard and the input's corners) and vector field."""
    controller = how.controller
    if system.contact is not None and isinstance(
        controller, diffrax.AbstractAdaptiveStepSizeController
    ):
        controller = ContactGuard(controller)
    jumps = inputs.jump_times(system)
    jump_ts = None if jumps is None else jnp.atleast_1d(jumps)
    step_ts = ts if how.land_on_samples else None
    if jump_ts is not None or step_ts is not None:
        controller = diffrax.ClipStepSizeController(controller, step_ts=step_ts, jump_ts=jump_ts)
    forward_mode_only = isinstance(how.adjoint, diffrax.ForwardMode)
    vector_field = _vector_field_forward_mode if forward_mode_only else _vector_field
    return controller, diffrax.ODETerm(vector_field)


def _checked_result(solution_result, q, v, saved, how: _Integration):
    """The solve's result as a `RESULTS` code (a non-finite saved sample is a failure); raises on
    failure when `how.throw`."""
    result = promote(solution_result)
    # Non-finite saved values counted by a dot product: XLA:CPU compiles a reduction over all the
    # samples into a tree of reduce-window kernels (~0.1 s of a first call), a dot into one kernel.
    bad = ~jnp.isfinite(jnp.concatenate([q, v], axis=-1)) & saved[:, None]
    finite = jnp.dot(jnp.ravel(bad).astype(q.dtype), jnp.ones(bad.size, q.dtype)) == 0
    result = RESULTS.where(
        (result == RESULTS.successful) & ~finite, RESULTS.nonfinite_state, result
    )
    if how.throw:
        q = result.error_if(q, result != RESULTS.successful)
    return result, q


def _trajectory(
    system, inputs, times, q, v, stats, result, solution, accelerations: bool
) -> Trajectory:
    theta, theta_dot, theta_ddot, tau = _samples(system, inputs, times, q, v, accelerations)
    target = inputs.target(system)
    target = theta[-1] if target is None else jnp.asarray(target, dtype=theta.dtype)
    return Trajectory(
        times=times,
        theta=theta,
        theta_dot=theta_dot,
        theta_ddot=theta_ddot,
        tau=tau,
        target=target,
        stats=stats,
        result=result,
        solution=solution,
        state=None if system.mechanism.coordinates_are_hinge_angles else (q, v),
    )


def _solver(how: _Integration, phase: str | None = None) -> diffrax.AbstractSolver:
    """`how.solver`, restricted to one `phase` of the switching solver if given, with the stage loops
    forward-mode autodiff needs under `diffrax.ForwardMode` (diffrax does that for its own
    Runge–Kutta solvers, but cannot see inside the switching one)."""
    solver = how.solver
    if phase is not None:
        solver = dataclasses.replace(cast(StiffnessSwitching, solver), phase=phase)
    if isinstance(solver, StiffnessSwitching) and isinstance(how.adjoint, diffrax.ForwardMode):
        solver = solver.with_scan_kind("lax")
    return solver


def _stats(solution: diffrax.Solution) -> dict[str, Array]:
    return {k: jnp.asarray(val) for k, val in solution.stats.items()}


def _solve(system: FoldingSystem, inputs: AbstractInput, span, y0, ts, how: _Integration):
    t0, t1 = span
    solver = _solver(how)
    controller, term = _controller_and_field(system, inputs, ts, how)
    if system.agitation is not None:
        term = _agitated(system, span, term, y0)
    switching = isinstance(solver, StiffnessSwitching)
    solution = diffrax.diffeqsolve(
        term,
        solver,
        t0,
        t1,
        how.dt0,
        y0,
        (system, inputs),
        saveat=diffrax.SaveAt(ts=ts, dense=how.dense, solver_state=switching),
        stepsize_controller=controller,
        adjoint=how.adjoint,
        max_steps=how.max_steps,
        throw=how.throw,
        progress_meter=how.progress_meter,
    )
    q, v = cast(tuple[Array, Array], solution.ys)  # SaveAt(ts=...) always saves ys
    saved = jnp.ones(q.shape[:1], dtype=bool)
    result, q = _checked_result(solution.result, q, v, saved, how)
    stats = _stats(solution)
    if switching:
        # Time at which the solver turned implicit (inf: it never did); see `StiffnessSwitching`.
        _, switch = cast(tuple, solution.solver_state)  # saved: SaveAt(solver_state=True) above
        stats["switch_time"] = switch.switch_time
    times = cast(Array, solution.ts)
    solution = solution if how.dense else None
    return _trajectory(system, inputs, times, q, v, stats, result, solution, how.accelerations)


class _RecordNext(AbstractWrappedController):
    """Wraps a controller and keeps the end of the next step it proposes in its state, so that a
    solve stopped after a step can be continued with exactly that next step."""

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        tnext, state = self.controller.init(terms, t0, t1, y0, dt0, args, func, error_order)
        return tnext, (state, jnp.asarray(tnext))

    def adapt_step_size(
        self, t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state
    ):
        inner, _ = controller_state
        keep, next_t0, next_t1, made_jump, inner, result = self.controller.adapt_step_size(
            t0, t1, y0, y1_candidate, args, y_error, error_order, inner
        )
        return keep, next_t0, next_t1, made_jump, (inner, jnp.asarray(next_t1)), result


class _Handover(eqx.Module):
    """Where a solve with explicit steps stopped at the switch: what the implicit phase starts from."""

    turned: Array
    t: Array
    y: tuple[Array, Array]
    tnext: Array
    solver_state: object
    controller_state: object
    made_jump: object


def _solve_until_stiff(
    system: FoldingSystem, inputs: AbstractInput, span, y0, ts, how: _Integration
) -> tuple[Trajectory, _Handover]:
    """The default solver's explicit phase: Tsit5 with the stiffness test, stopping after the step
    at which the switch turns. Samples after that step are inf (the implicit phase computes them)."""
    t0, t1 = span
    solver = _solver(how, "explicit")
    controller, term = _controller_and_field(system, inputs, ts, how)
    saveat = diffrax.SaveAt(
        subs=[diffrax.SubSaveAt(ts=ts), diffrax.SubSaveAt(t1=True)],
        solver_state=True,
        controller_state=True,
        made_jump=True,
    )
    solution = diffrax.diffeqsolve(
        term,
        solver,
        t0,
        t1,
        how.dt0,
        y0,
        (system, inputs),
        saveat=saveat,
        stepsize_controller=_RecordNext(controller),
        adjoint=how.adjoint,
        max_steps=how.max_steps,
        throw=False,  # `TURNED_STIFF` is not a failure; real ones raise below
        progress_meter=how.progress_meter,
    )
    (q, v), (q_end, v_end) = cast(list, solution.ys)
    times, t_end = cast(list, solution.ts)
    _, switch = cast(tuple, solution.solver_state)
    turned = switch.stiff
    result = promote(solution.result)
    result = RESULTS.where(turned & (result == promote(TURNED_STIFF)), RESULTS.successful, result)
    result, q = _checked_result(result, q, v, jnp.isfinite(times), how)
    stats = _stats(solution)
    stats["switch_time"] = switch.switch_time
    inner, tnext = cast(tuple, solution.controller_state)
    handover = _Handover(
        turned=turned,
        t=t_end[0],
        y=(q_end[0], v_end[0]),
        tnext=tnext,
        solver_state=solution.solver_state,
        controller_state=inner,
        made_jump=solution.made_jump,
    )
    trajectory = _trajectory(system, inputs, times, q, v, stats, result, None, how.accelerations)
    return trajectory, handover


def _solve_from_switch(
    system: FoldingSystem, inputs: AbstractInput, t1, ts, how: _Integration, start: _Handover
) -> Trajectory:
    """The default solver's implicit phase: Kvaerno5 from where `_solve_until_stiff` stopped, with
    its solver state, controller state and next step, so the steps are those of a single solve.
    Samples before the switch repeat the switch state (`_stitched` takes them from the first phase).
    """
    solver = _solver(how, "implicit")
    controller, term = _controller_and_field(system, inputs, ts, how)
    solution = diffrax.diffeqsolve(
        term,
        solver,
        start.t,
        t1,
        start.tnext - start.t,
        start.y,
        (system, inputs),
        saveat=diffrax.SaveAt(ts=jnp.maximum(ts, start.t)),
        stepsize_controller=controller,
        adjoint=how.adjoint,
        max_steps=how.max_steps,
        throw=how.throw,
        progress_meter=how.progress_meter,
        solver_state=start.solver_state,
        controller_state=start.controller_state,
        made_jump=start.made_jump,
    )
    q, v = cast(tuple[Array, Array], solution.ys)
    result, q = _checked_result(solution.result, q, v, jnp.ones(q.shape[:1], dtype=bool), how)
    stats = _stats(solution)
    times = cast(Array, solution.ts)
    return _trajectory(system, inputs, times, q, v, stats, result, None, how.accelerations)


@eqx.filter_jit
def _stitched(explicit: Trajectory, implicit: Trajectory, ts, t_switch) -> Trajectory:
    """One trajectory from the two phases: samples up to the switch from the explicit one, later
    ones from the implicit one; step counts added."""
    later = ts > t_switch

    def pick(a, b):
        return jnp.where(later.reshape(later.shape + (1,) * (a.ndim - 1)), b, a)

    samples = lambda t: (t.times, t.theta, t.theta_dot, t.theta_ddot, t.tau, t.state)  # noqa: E731
    stitched = jax.tree.map(pick, samples(explicit), samples(implicit))
    stats = dict(explicit.stats)
    for key in ("num_steps", "num_accepted_steps", "num_rejected_steps"):
        stats[key] = explicit.stats[key] + implicit.stats[key]
    trajectory = eqx.tree_at(samples, implicit, stitched, is_leaf=lambda x: x is None)
    return eqx.tree_at(lambda t: t.stats, trajectory, stats)


def _solve_lazily(system: FoldingSystem, inputs: AbstractInput, span, y0, ts, how: _Integration):
    """The default solver in two programs (top-level calls only): the explicit phase, then, only
    if the run turned stiff, the implicit phase from the switch. A run that never turns stiff
    compiles no implicit solver; one that does gets the steps of a single solve (the samples and
    statistics of the one-program solve, bitwise when measured). Each phase has the step budget
    `max_steps`, so a run that turns stiff may take up to twice as many steps before it reports
    `max_steps_reached`; with a progress meter each phase shows its own bar."""
    with checks_as_nan():  # top-level calls only: see `simulate`
        explicit, start = exported_call(
            "solve_until_stiff",
            _solve_until_stiff,
            _solve_until_stiff_jit,
            system,
            inputs,
            span,
            y0,
            ts,
            how,
            options=SOLVE_COMPILE,
        )
    if not bool(start.turned) or not float(start.t) < float(span[1]):
        return explicit
    with checks_as_nan():
        implicit = exported_call(
            "solve_from_switch",
            _solve_from_switch,
            _solve_from_switch_jit,
            system,
            inputs,
            span[1],
            ts,
            how,
            start,
            options=SOLVE_COMPILE,
        )
    return _stitched(explicit, implicit, ts, start.t)


def _solve_explicit_phase(
    system: FoldingSystem, inputs: AbstractInput, span, y0, ts, how: _Integration
) -> Trajectory:
    """The default solver under differentiation (`jax.grad`, `jax.jvp`, ...): its explicit phase
    only. The derivative of the implicit phase is most of the compiled program (the Newton
    iterations' and the linear solves' transposes), and the common runs never reach it; a run that
    turns stiff ends with `RESULTS.stiff_while_differentiated` (raised with `throw`), whose message
    says how to differentiate both phases. A run that does not turn stiff gets the steps, samples
    and derivatives of the one-program solve."""
    trajectory, start = _solve_until_stiff_jit(system, inputs, span, y0, ts, how)
    stiff = start.turned & (start.t < span[1])
    result = RESULTS.where(stiff, RESULTS.stiff_while_differentiated, trajectory.result)
    theta = result.error_if(trajectory.theta, stiff) if how.throw else trajectory.theta
    return eqx.tree_at(lambda t: (t.result, t.theta), trajectory, (result, theta))


def _is_differentiated(*values) -> bool:
    """True when a leaf carries a derivative (a JVP or linearisation tracer, possibly inside `vmap`'s
    batch tracer). Tracer classes are matched by name: JAX does not export them."""
    for leaf in jax.tree_util.tree_leaves(values):
        while isinstance(leaf, jax.core.Tracer):
            if type(leaf).__name__ in ("JVPTracer", "LinearizeTracer"):
                return True
            leaf = getattr(leaf, "val", None)  # vmap's BatchTracer: look inside
    return False


_solve_jit = eqx.filter_jit(_solve)
_solve_until_stiff_jit = eqx.filter_jit(_solve_until_stiff)
_solve_from_switch_jit = eqx.filter_jit(_solve_from_switch)

_MIN_PADDED_SAMPLES = 16


def padded_sample_count(n: int) -> int:
    """The sample count a top-level `simulate` solves for when asked for `n` samples: the next power
    of two (at least 16). Every `n` up to it shares one compiled solve; the extra samples repeat the
    last sample time and are cut off before the trajectory is returned (their cost: at most as many
    again interpolations and accelerations at the samples, none in the steps)."""
    return max(_MIN_PADDED_SAMPLES, 1 << (int(n) - 1).bit_length())


def _padded(ts: Array, size: int) -> Array:
    """`ts` (concrete) followed by its last time up to length `size`, built on the host: no compiled
    program depends on `len(ts)`."""
    host = np.asarray(ts)
    return jax.device_put(np.concatenate([host, np.full(size - host.shape[0], host[-1])]))


def _first_samples(trajectory: Trajectory, n: int) -> Trajectory:
    """The first `n` samples of a trajectory solved on padded sample times, cut on the host: a copy
    of a few kilobytes (~0.3 ms), where a compiled slice is one more program for a first call to
    compile (~0.1 s)."""
    parts = {"samples": lambda t: (t.times, t.theta, t.theta_dot, t.theta_ddot, t.tau)}
    if trajectory.state is not None:
        parts["state"] = lambda t: t.state
    if trajectory.solution is not None:
        parts["dense"] = lambda t: (t.solution.ts, t.solution.ys)
    leaves, tree = jax.tree.flatten({name: get(trajectory) for name, get in parts.items()})
    cut = jax.device_put(
        [np.asarray(x)[:n] for x in leaves], [x.sharding if x.committed else None for x in leaves]
    )
    for name, value in jax.tree.unflatten(tree, cut).items():
        trajectory = eqx.tree_at(parts[name], trajectory, value)
    return trajectory


def _implicit_solve(
    system, inputs, solver, t0, ts, q0, v0, steps: int, accelerations: bool
) -> Trajectory:
    q, v, stats, result = integrate(system, inputs, solver, t0, ts, q0, v0, steps)
    return _trajectory(system, inputs, ts, q, v, stats, result, None, accelerations)


_implicit_solve_jit = eqx.filter_jit(_implicit_solve)


def _host_times(t0, t1, ts, n_save: int) -> tuple[np.ndarray, np.ndarray]:
    """``(t0, ts)`` on the host for `ImplicitStep` (its step count is fixed from them): `ts`, or
    `SaveAt(n=...)` evenly spaced times from `t0` to `t1`; raises when any of them is traced."""
    if is_traced(t0, t1, ts):
        raise ValueError(
            "ImplicitStep fixes its step count from the time span and sample times, so t0, t1 and "
            "SaveAt(ts=...) must be known values (not traced under jit or vmap)."
        )
    start, end = float(t0), float(t1)
    times = np.linspace(start, end, n_save) if ts is None else np.asarray(ts, dtype=float)
    if times.ndim != 1 or times.size < 1 or not np.all(np.isfinite(times)):
        raise ValueError(
            "SaveAt(ts=...) must be a non-empty one-dimensional array of finite times."
        )
    if np.any(np.diff(times) < 0) or times[0] < start or times[-1] > end:
        raise ValueError(
            f"SaveAt(ts=...) must be non-decreasing and within [t0, t1] = [{start:g}, {end:g}]."
        )
    return np.asarray(start), times


def _simulate_implicit(system, inputs, solver, times, q0, v0, *, saveat: SaveAt, throw: bool):
    """`simulate` with the fixed-step engine ([`origami_jax.simulation.ImplicitStep`][]): the step
    count between samples is fixed on the host from `times` ``(t0, ts)`` (host arrays), part of
    the compiled solve; called outside any transformation, the sample count is padded as the
    adaptive solve's is. The tolerances, controller, `dt0`, `max_steps` and `adjoint` do not
    apply."""
    mechanism = system.mechanism
    if mechanism.n_coordinates != mechanism.n_velocities:
        raise ValueError(
            "ImplicitStep needs a mechanism whose velocities are its coordinates' rates (chains and "
            "panel trees); use the adaptive solvers for this one."
        )
    if saveat.dense:
        raise ValueError(
            "ImplicitStep has no dense output; ask for samples (SaveAt(n=...) or SaveAt(ts=...))."
        )
    accelerations = saveat.accelerations
    t0, ts = times
    steps = steps_per_interval(solver, t0, ts)
    top_level = not is_traced(system, inputs, q0, v0)
    n_samples = ts.shape[0]
    if not top_level:  # the caller's program, compiled for its own samples and steps
        trajectory = _implicit_solve_jit(
            system, inputs, solver, t0, ts, q0, v0, steps, accelerations
        )
    else:
        check_off_bifurcation(system, inputs, t0, q0, v0)
        # As the adaptive solve's samples, padded to a power of two (the padding's intervals are
        # empty: no steps), so that another sample count within it and the same steps per
        # interval compiles nothing. (The steps per interval traced under a power of two, with a
        # conditional around each step, ran a cube net's fold 1.5× slower and compiled 10 s
        # longer: the count stays static.)
        ts = np.concatenate([ts, np.full(padded_sample_count(n_samples) - n_samples, ts[-1])])
        trajectory = _implicit_solve_jit(
            system, inputs, solver, t0, ts, q0, v0, steps, accelerations
        )
        trajectory = _first_samples(trajectory, n_samples)
    if throw:
        if top_level:
            if trajectory.result != RESULTS.successful:
                raise eqx.EquinoxRuntimeError(f"simulate: {RESULTS[trajectory.result]}")
        else:
            failed = trajectory.result != RESULTS.successful
            theta = trajectory.result.error_if(trajectory.theta, failed)
            trajectory = eqx.tree_at(lambda t: t.theta, trajectory, theta)
    return trajectory


# Argument checks of `simulate` (tier 1 when the values are known, tier 2 when traced: see
# `origami_jax._validate`). A bad time span or tolerance otherwise runs the solver to its step budget
# and ends with a misleading "max steps" (a negative t1 even integrated backwards and succeeded).
def _end_time(t1, options_t1):
    """The end time from `simulate(t1=...)` or `SolveOptions(t1=...)`: one of them, or both equal."""
    if t1 is None and options_t1 is None:
        raise ValueError("simulate needs an end time: give t1=... or SolveOptions(t1=...).")
    if t1 is None or options_t1 is None:
        return options_t1 if t1 is None else t1
    if is_traced(t1, options_t1):
        return eqx.error_if(
            jnp.asarray(t1, dtype=float),
            jnp.asarray(t1) != jnp.asarray(options_t1),
            "simulate: t1 and SolveOptions(t1=...) differ; give one of them.",
        )
    if np.shape(t1) != np.shape(options_t1) or np.any(np.asarray(t1) != np.asarray(options_t1)):
        raise ValueError(
            f"simulate got t1={np.asarray(t1)} and SolveOptions(t1={np.asarray(options_t1)}); "
            "give one of them."
        )
    return t1


def _checked_span(t0, t1) -> tuple[Array, Array]:
    t0, t1 = jnp.asarray(t0, dtype=float), jnp.asarray(t1, dtype=float)
    if t0.ndim or t1.ndim:
        raise ValueError(f"t0 and t1 must be scalars, got shapes {t0.shape} and {t1.shape}.")
    if is_traced(t0, t1):
        bad = ~(jnp.isfinite(t0) & jnp.isfinite(t1) & (t1 > t0))
        return t0, eqx.error_if(t1, bad, "simulate: t0 and t1 must be finite, with t1 > t0.")
    for name, value in (("t0", float(t0)), ("t1", float(t1))):
        if not np.isfinite(value):
            raise ValueError(f"{name} must be a finite time, got {value}.")
    if not float(t1) > float(t0):
        raise ValueError(
            f"t1 must be greater than t0 (the run goes forward in time from t0 = {float(t0):g}), "
            f"got t1 = {float(t1):g}."
        )
    return t0, t1


def _checked_tolerance(value, name: str) -> Array:
    array = jnp.asarray(value, dtype=float)
    if array.ndim:
        raise ValueError(f"SolveOptions({name}=...) must be a scalar, got shape {array.shape}.")
    if is_traced(array):
        bad = ~(jnp.isfinite(array) & (array > 0))
        return eqx.error_if(
            array, bad, f"simulate: SolveOptions({name}=...) must be positive and finite."
        )
    if not (np.isfinite(float(array)) and float(array) > 0):
        example = DEFAULT_RTOL if name == "rtol" else DEFAULT_ATOL
        raise ValueError(
            f"SolveOptions({name}=...) must be a positive finite tolerance (e.g. {example:g}), "
            f"got {float(array)!r}."
        )
    return array


def _checked_times(ts, t0, t1) -> Array:
    ts = jnp.asarray(ts, dtype=float)
    if ts.ndim != 1 or ts.shape[0] < 1:
        raise ValueError(
            f"SaveAt(ts=...) must be a non-empty one-dimensional array, got shape {ts.shape}."
        )
    ts = check_finite(ts, "SaveAt(ts=...)")
    if is_traced(ts, t0, t1):
        outside = jnp.any(ts < t0) | jnp.any(ts > t1) | jnp.any(jnp.diff(ts) < 0)
        return eqx.error_if(
            ts, outside, "simulate: SaveAt(ts=...) must be increasing and within [t0, t1]."
        )
    host = np.asarray(ts)
    if np.any(np.diff(host) < 0):
        raise ValueError("SaveAt(ts=...) must be non-decreasing (sample times in order).")
    if host[0] < float(t0) or host[-1] > float(t1):
        raise ValueError(
            f"SaveAt(ts=...) must lie within [t0, t1] = [{float(t0):g}, {float(t1):g}], got "
            f"[{host[0]:g}, {host[-1]:g}]."
        )
    return ts


def _checked_first_step(dt0) -> Array | None:
    """`dt0` known: `None` or a positive finite step (diffrax would check it in the compiled solve)."""
    if dt0 is None:
        return None
    step = np.asarray(dt0, dtype=float)
    if step.ndim or not (np.isfinite(step) and step > 0):
        raise ValueError(
            f"SolveOptions(dt0=...) must be a positive finite first step (or None), got {dt0!r}."
        )
    return jnp.asarray(step)


def _check_system_values(system: FoldingSystem) -> None:
    """Concrete numbers of `system` (a system built outside `jit`): hinges and drag finite, no NaN
    anywhere, positive stiffness, non-negative hinge drag. Traced systems (a sweep's batch) are left
    to their builder."""
    for path, leaf in jax.tree_util.tree_leaves_with_path(system):
        if is_traced(leaf) or not eqx.is_inexact_array(leaf):
            continue
        where = jax.tree_util.keystr(path).lstrip(".")
        # A mechanism or contact model may use infinity on purpose (a limit that is not there).
        physics = where.startswith(("hinges", "drag"))
        values = np.asarray(leaf)
        if np.any(np.isnan(values)) or (physics and not np.all(np.isfinite(values))):
            raise ValueError(
                f"the system's {where} contains NaN or inf; check the values that built it."
            )
    stiffness = system.hinges.stiffness
    if not is_traced(stiffness) and np.any(np.asarray(stiffness) <= 0):
        raise ValueError(
            f"the hinge stiffness must be positive (torque/rad), got {np.asarray(stiffness)}."
        )
    coefficient = getattr(system.drag, "coefficient", None)
    if (
        isinstance(system.drag, HingeDrag)
        and not is_traced(coefficient)
        and np.any(np.asarray(coefficient) < 0)
    ):
        raise ValueError(
            f"the drag coefficient must be >= 0 (a negative drag adds energy), got "
            f"{np.asarray(coefficient)}."
        )


def simulate(
    system: FoldingSystem,
    inputs: AbstractInput,
    options: SolveOptions | None = None,
    *,
    t1: Float[ArrayLike, ""] | None = None,
    t0: Float[ArrayLike, ""] = 0.0,
    theta0: Float[ArrayLike, " n"] | None = None,
    theta_dot0: Float[ArrayLike, " n"] | None = None,
) -> Trajectory:
    """Simulate the folding of `system` under `inputs`:
    ``M v̇ + C v + G = J_hᵀ (τ(t, θ, θ̇) − K θ) + f_drag + f_contact``.

    Works under `jax.jit`, `jax.vmap` (batch the system, the input or the options' numbers) and
    `jax.grad` (reverse mode through diffrax's checkpointed adjoint). The compiled solve is cached
    per structure (mechanism size, solver, `saveat.dense`, `throw`, `max_steps`, the input's type and
    its Python functions), not per value: times, tolerances, initial state, targets, release times
    and every physical number are traced, so a new value reruns without compiling. The sample count
    (`saveat.n` or the length of `saveat.ts`) is padded to the next power of two
    (`padded_sample_count`): a new count within it costs a few milliseconds, not a new solve (under
    `jit` or `vmap` the caller's program is compiled for its own count, and nothing is padded). See
    [`origami_jax.enable_compilation_cache`][] to keep compiled solves between processes. Called
    outside any transformation with the default solver, the solve runs as two programs: explicit
    steps up to the switch, then, only for a run that turns stiff, implicit ones from there, so a
    non-stiff run never compiles the implicit solver (its first call compiles in about a third of
    the time); the steps, samples and statistics are those of the single program. Differentiated
    (`jax.grad`, `jax.jvp`, ...), the default solver compiles its explicit phase only (a third of
    the gradient's compile time): a run that turns stiff then ends with
    `RESULTS.stiff_while_differentiated`; pass `SolveOptions(solver=StiffnessSwitching())` to
    differentiate both phases.

    **Arguments:**
    - `system`: a [`origami_jax.system.FoldingSystem`][] (e.g. from
      [`origami_jax.chain.accordion_system`][]); its units fix every other unit below.
    - `inputs`: a [`origami_jax.simulation.Step`][], [`origami_jax.simulation.EtchRamp`][],
      [`origami_jax.simulation.UserTorque`][] or your own `AbstractInput`.
    - `options`: how to solve and what to save, a [`origami_jax.simulation.SolveOptions`][]
      (default `SolveOptions()`: every setting's default is there). Its fields as they apply here:
        - `saveat`: a [`origami_jax.simulation.SaveAt`][]: sample times `ts` (within `[t0, t1]`), or
          `n` evenly spaced samples including both ends; `dense=True` keeps diffrax's dense output
          (`Trajectory.evaluate`).
        - `solver`: any diffrax ODE solver; default [`origami_jax.simulation.default_solver`][]
          (Tsit5 switching to Kvaerno5 when the problem turns stiff; differentiated, its Tsit5 phase
          only, see above). Explicit solvers (`diffrax.Tsit5()`) are faster on the non-stiff fast
          ramp in air but can give wrong gradients in stiff regimes at loose tolerances. Or
          [`origami_jax.simulation.ImplicitStep`][]`(dt=...)`: the fixed-step engine (implicit
          Euler with Newton iterations capped by the contact's collision detection), robust through
          contact and with the same work for every member of a batch, but first-order accurate and
          dissipative; the tolerances, controller, `dt0`, `max_steps`, `adjoint` and dense output do
          not apply to it, and its time span and sample times must be known values. A system
          with `agitation` (random forcing, `origami_jax.system.Agitation`) is solved as a
          stochastic equation, by default with `diffrax.Heun` (docs/physics.md, "Agitation"),
          or by `ImplicitStep` (a random impulse in each implicit step: under contact too).
        - `rtol`, `atol`: step-size controller tolerances (`DEFAULT_RTOL`, `DEFAULT_ATOL`). Metrics
          of the accordion step agree with rtol 1e-9 to about 1e-6 relative.
        - `stepsize_controller`: overrides [`origami_jax.simulation.default_controller`][] (an
          integral controller for explicit Runge–Kutta solvers, a PID controller otherwise). Input
          corners are added as `jump_ts` in either case.
        - `dt0`: first step (default: diffrax's estimate).
        - `max_steps`: step budget; running out gives `RESULTS.max_steps_reached`.
        - `throw`: raise on failure (default). Pass `throw=False` in batches and read
          `Trajectory.result`.
        - `progress_meter`: e.g. `diffrax.TqdmProgressMeter()` for long runs.
        - `adjoint`: diffrax adjoint (default `RecursiveCheckpointAdjoint`;
          `diffrax.ForwardMode()` for `jax.jvp`/`jax.jacfwd`).
        - `land_on_samples`: make every sample time a step end (`step_ts`). Needed when steps are
          far longer than the dynamics (the slow etch ramp): interpolating inside a step of hours
          with end rates that carry unresolved µs ringing would be wrong by up to `h·|Δθ̇|/4`; see
          [`origami_jax.simulation.simulate_slow_ramp`][].
    - `t1`: end time, time units (MICRO: µs); or `options.t1`. One of them is needed; given both,
      they must agree.
    - `t0`: start time, time units (default 0).
    - `theta0`, `theta_dot0`: initial coordinates and velocities (hinge angles in rad and rates in
      rad/time for chains and trees), default the mechanism's flat rest state.

    **Returns:** a [`origami_jax.simulation.Trajectory`][].

    **Raises:** `ValueError`, before anything compiles, for inconsistent shapes and for values that
    cannot give an answer: no `t1` (or two different ones), `t1 <= t0` or a non-finite time,
    `rtol`, `atol` or `dt0` not positive and finite, sample times outside `[t0, t1]` or decreasing,
    a non-finite initial state, or a system whose concrete stiffness is not positive or whose drag
    or any other number is negative where it must not be or not finite (`SaveAt(n < 2)` and
    `max_steps < 1` already raise when the options are built). When these values are traced
    (`simulate` under `jit` or `vmap`) the same conditions raise at run time (`eqx.error_if`). With
    `throw=True`, `equinox.EquinoxRuntimeError` carrying the result message when the solve fails
    (steps exhausted, step size collapsed, non-finite state). Called outside any transformation,
    that error is raised in Python from the result code, after the compiled solve returns: the
    solve then calls nothing back, so the compilation cache can keep it for the next process.
    """
    if options is None:
        options = SolveOptions()
    elif not isinstance(options, SolveOptions):
        raise ValueError(
            f"options must be an origami_jax.simulation.SolveOptions, got {type(options).__name__}."
        )
    t1 = _end_time(t1, options.t1)
    saveat = options.saveat
    ts, n_save, dense = saveat.ts, saveat.n, saveat.dense
    solver, throw, dt0 = options.solver, options.throw, options.dt0
    rtol, atol, stepsize_controller = options.rtol, options.atol, options.stepsize_controller
    if not isinstance(system, FoldingSystem):
        raise ValueError(
            f"system must be a FoldingSystem (e.g. origami_jax.chain.accordion_system(design)), "
            f"got {type(system).__name__}."
        )
    if not isinstance(inputs, AbstractInput):
        raise ValueError(
            f"inputs must be a Step, EtchRamp, UserTorque (an AbstractInput), got {type(inputs)}."
        )
    mechanism = system.mechanism
    target = inputs.target(system)
    n = system.n_hinges
    if target is not None and jnp.shape(target) != (n,):
        raise ValueError(
            f"the input is for {jnp.shape(target)} hinges but the system has {n} hinges."
        )
    _check_system_values(system)
    span_given = (t0, t1)
    t0, t1 = _checked_span(t0, t1)
    q_rest, v_rest = mechanism.rest_state()
    q0 = q_rest if theta0 is None else jnp.asarray(theta0, dtype=float)
    v0 = v_rest if theta_dot0 is None else jnp.asarray(theta_dot0, dtype=float)
    if q0.shape != q_rest.shape or v0.shape != v_rest.shape:
        raise ValueError(
            f"theta0 and theta_dot0 must have shapes {q_rest.shape} and {v_rest.shape}."
        )
    q0 = check_finite(q0, "theta0")
    v0 = check_finite(v0, "theta_dot0")
    if system.agitation is not None:
        solver = _agitated_solver(system, solver, q0)
    if isinstance(solver, ImplicitStep):
        times = _host_times(*span_given, ts, n_save)
        return _simulate_implicit(system, inputs, solver, times, q0, v0, saveat=saveat, throw=throw)
    ts = jnp.linspace(t0, t1, n_save) if ts is None else _checked_times(ts, t0, t1)
    n_samples = ts.shape[0]
    # Called outside any transformation, the solve runs on sample times padded to a size bucket, so
    # that a new sample count within it reuses the compiled solve (under `jit`/`vmap` the caller's
    # program is compiled for its own sample count anyway, and padding would only add work).
    pad = not is_traced(system, inputs, t0, t1, q0, v0, ts, rtol, atol, dt0, stepsize_controller)
    if pad:
        ts = _padded(ts, padded_sample_count(n_samples))
        dt0 = _checked_first_step(dt0)
    chosen = solver is not None
    solver = default_solver() if solver is None else solver
    if stepsize_controller is None:
        # Tolerances as arrays, so a new value does not compile a new solve.
        stepsize_controller = default_controller(
            _checked_tolerance(rtol, "rtol"), _checked_tolerance(atol, "atol"), solver
        )
    how = _Integration(
        solver=solver,
        controller=stepsize_controller,
        dt0=None if dt0 is None else jnp.asarray(dt0, dtype=float),
        progress_meter=(
            diffrax.NoProgressMeter() if options.progress_meter is None else options.progress_meter
        ),
        adjoint=(
            diffrax.RecursiveCheckpointAdjoint() if options.adjoint is None else options.adjoint
        ),
        max_steps=options.max_steps,
        dense=dense,
        # Outside any transformation every input was checked above and a failure is raised below,
        # from the result code: the compiled solve then needs no callback into Python and the
        # compilation cache can keep it (`origami_jax._runtime_errors`).
        throw=throw and not pad,
        land_on_samples=options.land_on_samples,
        accelerations=saveat.accelerations,
    )
    lazy = (
        pad
        and isinstance(solver, StiffnessSwitching)
        and solver.phase == "both"
        and not solver.start_implicit
        and not dense
        and isinstance(how.adjoint, diffrax.RecursiveCheckpointAdjoint)
    )
    # A top-level call with the default solver compiles its implicit phase only for a run that
    # turns stiff (`_solve_lazily`); differentiated, the default solver compiles its explicit phase
    # only (`_solve_explicit_phase`); under other transformations the solve stays one program.
    explicit_only = (
        not chosen
        and not dense
        and isinstance(how.adjoint, (diffrax.RecursiveCheckpointAdjoint, diffrax.ForwardMode))
        and _is_differentiated(system, inputs, t0, t1, q0, v0, ts)
    )
    if lazy:
        solve = _solve_lazily
    elif explicit_only:
        solve = _solve_explicit_phase
    elif pad:
        # A top-level call with a named solver (the command line's Tsit5): its traced program
        # from disk where it was exported before, as the default solver's explicit phase.
        solve = functools.partial(exported_call, "solve", _solve, _solve_jit, options=SOLVE_COMPILE)
    else:
        solve = _solve_jit
    try:
        # The context covers the trace and the asynchronous dispatch, not the run (`_solve_lazily`
        # sets it around its own calls, since it waits for the first phase between them).
        with checks_as_nan(pad and not lazy):
            arguments = (system, inputs, (t0, t1), (q0, v0), ts, how)
            trajectory = solve(*(on_one_device(arguments) if pad else arguments))
    except TypeError as error:
        # diffrax's default adjoint is a `custom_vjp`: JAX's own message names neither the cause
        # nor the fix.
        if "forward-mode autodiff" in str(error) and not isinstance(
            how.adjoint, diffrax.ForwardMode
        ):
            raise TypeError(
                "simulate was differentiated in forward mode (jax.jvp, jax.jacfwd), which its "
                "default adjoint does not support: pass "
                "SolveOptions(adjoint=diffrax.ForwardMode()) (or use reverse mode, jax.grad)."
            ) from error
        raise
    if not pad:
        return trajectory
    if throw and trajectory.result != RESULTS.successful:
        raise eqx.EquinoxRuntimeError(f"simulate: {RESULTS[trajectory.result]}")
    return _first_samples(trajectory, n_samples)
