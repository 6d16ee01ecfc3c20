"""The real etch ramp (T = l/β ≈ 2.7 h at β = 1.5 µm/min) made affordable, with its error stated.

Why it is cheap. Under the computed-torque law the desired trajectory `θ_des(t)` solves the equations of
motion exactly (`θ̈_des = 0` between corners, and `τ` is built from `θ_des`, `θ̇_des`). The only departure
from it is launched at the corners, where `θ̇_des` jumps by `β/ρ` (≈ 3e-10 rad/µs) while the hinges start at
rest: a free oscillation of amplitude about `(β/ρ)/ω` (≈ 7e-9 rad for ω ≈ 0.05 rad/µs), weakly damped by
quadratic drag. Everything else is a straight line, which any Runge–Kutta method integrates exactly.

So we solve the **full model** with the L-stable implicit Kvaerno5 and steps as long as the tolerance
allows (minutes to an hour): the µs ringing is far below `atol` and is damped numerically instead of being
resolved. Every sample is made a step end (`land_on_samples=True`): interpolating inside a step of an hour
from end rates that carry the unresolved ringing would be wrong by `h·|Δθ̇|/4`, up to 1e-2 rad (measured).

What it costs in accuracy is checked, not assumed: the same model is solved at tight tolerance, resolving
the ringing, over a window at the start (`window`, default 30 periods of the slowest hinge), and the largest
departure from `θ_des` there — the quasi-static error — is reported next to the large-step solution's own
largest departure from `θ_des` at its samples. Measured on the literature accordion in KOH (T = 2.73 h,
`n_save = 501`): 795 implicit steps; the resolved full model departs from `θ_des` by at most 2.0e-8 rad
over its first 20 ms, and the large-step samples by 1.8e-15 rad — against folds of π. The stated error of
the large-step answer is therefore the ringing it does not resolve, ≈ 2e-8 rad (relative 6e-9).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..system import FoldingSystem
from ._inputs import EtchRamp
from ._options import SLOW_RAMP_OPTIONS, SLOW_RAMP_WINDOW_OPTIONS, SolveOptions
from ._simulate import Trajectory, simulate


class SlowRampResult(eqx.Module):
    """The slow ramp and its validation.

    **Fields:**
    - `trajectory`: the full model over `[0, (1 + tail) T]` with large implicit steps, samples at step ends.
    - `window`: the full model at tight tolerance over `[0, window]`, ringing resolved.
    - `quasi_static_error`: max over the window of `|θ − θ_des|`, rad, per joint `(n,)`.
    - `large_step_error`: max over the large-step samples of `|θ − θ_des|`, rad, per joint `(n,)`.
    - `period`: the slowest hinge's small-oscillation period `2π sqrt(M_ii(0)/k_i)`, time units.
    """

    trajectory: Trajectory
    window: Trajectory
    quasi_static_error: Float[Array, " n"]
    large_step_error: Float[Array, " n"]
    period: Float[Array, ""]


def _departure(system: FoldingSystem, ramp: EtchRamp, trajectory: Trajectory) -> Array:
    theta_des = jax.vmap(lambda t: ramp.desired(t, system)[0])(trajectory.times)
    return jnp.max(jnp.abs(trajectory.theta - theta_des), axis=0)


def simulate_slow_ramp(
    system: FoldingSystem,
    ramp: EtchRamp,
    options: SolveOptions | None = None,
    *,
    tail: float = 0.2,
    window: float | None = None,
    window_options: SolveOptions | None = None,
) -> SlowRampResult:
    """Simulate an etch ramp of hours with the full model and check it against a resolved window.

    **Arguments:**
    - `system`, `ramp`: as for [`origami_jax.simulation.simulate`][] (a mechanism whose coordinates
      are its hinge angles).
    - `options`: the large-step solve over `[0, (1 + tail) T]` (default `SLOW_RAMP_OPTIONS`: 1001
      samples, L-stable Kvaerno5, rtol 1e-8, atol 1e-10). Every sample is made a step end
      (`land_on_samples` is set); its `t1` must be `None` (the ramp decides it).
    - `tail`: run on after the ramp ends, as a fraction of `T`.
    - `window`: length of the resolved check at the start, time units (default 30 periods).
    - `window_options`: the resolved check's solve (default `SLOW_RAMP_WINDOW_OPTIONS`; its `t1`
      must be `None`: `window` decides it).

    **Returns:** a [`origami_jax.simulation.SlowRampResult`][].

    **Raises:** `ValueError` when either options carry a `t1`.
    """
    options = SLOW_RAMP_OPTIONS if options is None else options
    window_options = SLOW_RAMP_WINDOW_OPTIONS if window_options is None else window_options
    if options.t1 is not None or window_options.t1 is not None:
        raise ValueError(
            "simulate_slow_ramp decides its end times (the ramp's duration and the window): "
            "give SolveOptions(t1=None)."
        )
    q_rest, _ = system.mechanism.rest_state()
    inertia = jnp.diag(system.mechanism.mass_matrix(q_rest))
    period = jnp.max(2 * jnp.pi * jnp.sqrt(inertia / system.hinges.stiffness))
    t1 = (1.0 + tail) * ramp.duration(system)
    trajectory = simulate(system, ramp, options.replace(land_on_samples=True), t1=t1)
    # From here `window` is an Array (the parameter's declared type is the caller's float).
    window = (
        30.0 * period  # pyright: ignore[reportAssignmentType]
        if window is None
        else jnp.asarray(window, dtype=float)
    )
    resolved = simulate(system, ramp, window_options, t1=window)
    return SlowRampResult(
        trajectory=trajectory,
        window=resolved,
        quasi_static_error=_departure(system, ramp, resolved),
        large_step_error=_departure(system, ramp, trajectory),
        period=period,
    )
