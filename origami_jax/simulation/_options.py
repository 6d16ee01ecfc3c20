"""How a folding simulation is solved and saved: `SolveOptions` and `SaveAt`, one object each.

Every setting of the numerical solve has one default, here. `simulate`, the fold of a pattern, the
sweep kernels and the yield estimate all take a `SolveOptions`; a pattern fills in only what it
decides itself (its fold's duration, when `t1` is `None`).
"""

import dataclasses
from typing import Any

import diffrax
import equinox as eqx
from jaxtyping import ArrayLike, Float

DEFAULT_RTOL = 1e-7
"""Default relative tolerance (error per step, relative to |θ| and |θ̇|)."""
DEFAULT_ATOL = 1e-9
"""Default absolute tolerance, in the system's units (rad and rad/time unit). In `MICRO` a 3-flap
accordion step moves θ by π and θ̇ by ~0.1 rad/µs, so 1e-9 is far below both."""
DEFAULT_MAX_STEPS = 16_384
"""Default step budget of one solve."""
DEFAULT_N_SAVE = 2001
"""Default number of evenly spaced samples (both ends included)."""


class SaveAt(eqx.Module):
    """What a solve keeps, in the manner of `diffrax.SaveAt`.

    **Fields:**
    - `ts`: sample times (time units, within the time span, non-decreasing), or `None` for `n`
      evenly spaced samples including both ends.
    - `n` (static): the number of evenly spaced samples when `ts` is `None` (at least 2; default
      `DEFAULT_N_SAVE`).
    - `dense` (static): keep diffrax's dense output (`Trajectory.evaluate`; default `False`).

    Metrics refine crossings between samples with cubic Hermite interpolation of ``(θ, θ̇)``, so keep
    several samples per oscillation period.
    """

    ts: Float[ArrayLike, " t"] | None = None
    n: int = eqx.field(static=True, default=DEFAULT_N_SAVE)
    dense: bool = eqx.field(static=True, default=False)

    def __check_init__(self):
        if self.ts is None and (
            isinstance(self.n, bool) or not isinstance(self.n, int) or self.n < 2
        ):
            raise ValueError(f"SaveAt(n=...) must be an integer of at least 2, got {self.n!r}.")


class SolveOptions(eqx.Module):
    """How to solve: one object for every numerical setting of a simulation.

    **Fields** (units: the system's; `MICRO`: µs):
    - `t1`: the end time, or `None` where the caller decides it (a pattern's fold time; `simulate`
      then needs its own `t1=`).
    - `saveat`: a [`origami_jax.simulation.SaveAt`][] (default: `DEFAULT_N_SAVE` even samples).
    - `solver`: any diffrax ODE solver, or [`origami_jax.simulation.ImplicitStep`][]; `None` for
      [`origami_jax.simulation.default_solver`][].
    - `rtol`, `atol`: the step-size controller's tolerances (defaults `DEFAULT_RTOL`,
      `DEFAULT_ATOL`; arrays or floats: a new value does not compile a new solve).
    - `stepsize_controller`: overrides [`origami_jax.simulation.default_controller`][].
    - `dt0`: the first step (default: diffrax's estimate).
    - `max_steps` (static): the step budget (default `DEFAULT_MAX_STEPS`); running out gives
      `RESULTS.max_steps_reached`.
    - `throw` (static): raise on failure (default); `False` in batches, then read the result code.
    - `progress_meter`: e.g. `diffrax.TqdmProgressMeter()` (default none).
    - `adjoint`: diffrax adjoint (default `RecursiveCheckpointAdjoint`; `diffrax.ForwardMode()` for
      `jax.jvp`/`jax.jacfwd`).
    - `land_on_samples` (static): make every sample time a step end (`step_ts`), for steps far
      longer than the dynamics (the slow etch ramp).

    Change one setting with `options.replace(rtol=1e-9)`.
    """

    t1: Float[ArrayLike, ""] | None = None
    saveat: SaveAt = SaveAt()
    solver: Any = None
    rtol: Float[ArrayLike, ""] = DEFAULT_RTOL
    atol: Float[ArrayLike, ""] = DEFAULT_ATOL
    stepsize_controller: diffrax.AbstractStepSizeController | None = None
    dt0: Float[ArrayLike, ""] | None = None
    max_steps: int = eqx.field(static=True, default=DEFAULT_MAX_STEPS)
    throw: bool = eqx.field(static=True, default=True)
    progress_meter: diffrax.AbstractProgressMeter | None = None
    adjoint: diffrax.AbstractAdjoint | None = None
    land_on_samples: bool = eqx.field(static=True, default=False)

    def __check_init__(self):
        if (
            isinstance(self.max_steps, bool)
            or not isinstance(self.max_steps, int)
            or self.max_steps < 1
        ):
            raise ValueError(f"max_steps must be a positive integer, got {self.max_steps!r}.")
        if not isinstance(self.saveat, SaveAt):
            raise ValueError(
                f"saveat must be an origami_jax.simulation.SaveAt, got {type(self.saveat).__name__}."
            )

    def replace(self, **changes: Any) -> "SolveOptions":
        """A copy with the given fields changed (`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)
