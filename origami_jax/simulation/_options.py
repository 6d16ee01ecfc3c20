"""How a folding simulation is solved and saved: `SolveOptions` and `SaveAt`, one object each.

Every setting of the numerical solve has one default, here. `simulate`, the fold of a pattern, the
sweep kernels and the yield estimate all take a `SolveOptions`; a pattern fills in only what it
decides itself (its fold's duration, when `t1` is `None`).
"""

import dataclasses
from typing import Any

import diffrax
import equinox as eqx
import jax
import numpy as np
from jaxtyping import ArrayLike, Float

from .._validate import is_traced
from ._implicit import ImplicitStep
from ._switching import implicit_solver

DEFAULT_RTOL = 1e-7
"""Default relative tolerance (error per step, relative to |θ| and |θ̇|)."""
DEFAULT_ATOL = 1e-9
"""Default absolute tolerance, in the system's units (rad and rad/time unit). In `MICRO` a 3-flap
accordion step moves θ by π and θ̇ by ~0.1 rad/µs, so 1e-9 is far below both."""
DEFAULT_MAX_STEPS = 16_384
"""Default step budget of one solve."""
DEFAULT_N_SAVE = 2001
"""Default number of evenly spaced samples (both ends included)."""


def _as_value(x):
    """A number as a NumPy float64 array, so that `eqx.filter_jit` traces it (a Python float would be
    static: each new value a new compilation); arrays and tracers are kept as they are."""
    if x is None or isinstance(x, jax.Array | np.ndarray):
        return x
    if isinstance(x, bool | str | bytes):
        # `np.asarray("1e-5", float)` and `True` would pass as numbers: refuse what is not one.
        raise ValueError(
            f"SolveOptions and SaveAt take numbers (or arrays) for times and tolerances, got {x!r}."
        )
    return np.asarray(x, dtype=float)


class SaveAt(eqx.Module):
    """What a solve keeps, in the manner of `diffrax.SaveAt`.

    **Fields:**
    - `ts`: sample times (time units, within the time span, non-decreasing), or `None` for `n`
      evenly spaced samples including both ends.
    - `n` (static): the number of evenly spaced samples when `ts` is `None` (at least 2; default
      `DEFAULT_N_SAVE`).
    - `dense` (static): keep diffrax's dense output (`Trajectory.evaluate`; default `False`).
    - `accelerations` (static): compute `Trajectory.theta_ddot` at the samples from the equations
      of motion (default `True`). `False` leaves it NaN, and the solve's program one right-hand
      side smaller (with contact, the larger part of a model's program): for callers that read
      angles, rates and torques only (a net's fold and its verdict, a sweep's fold kernel).

    Metrics refine crossings between samples with cubic Hermite interpolation of ``(θ, θ̇)``, so keep
    several samples per oscillation period.
    """

    ts: Float[ArrayLike, " t"] | None = eqx.field(default=None, converter=_as_value)
    n: int = eqx.field(static=True, default=DEFAULT_N_SAVE)
    dense: bool = eqx.field(static=True, default=False)
    accelerations: bool = eqx.field(static=True, default=True)

    def __check_init__(self):
        if self.ts is None and (
            isinstance(self.n, bool) or not isinstance(self.n, int) or self.n < 2
        ):
            raise ValueError(f"SaveAt(n=...) must be an integer of at least 2, got {self.n!r}.")
        if self.ts is not None and np.ndim(self.ts) != 1:
            raise ValueError(
                f"SaveAt(ts=...) must be one-dimensional sample times, got shape {np.shape(self.ts)}."
            )


class SolveOptions(eqx.Module):
    """How to solve: one object for every numerical setting of a simulation.

    **Fields** (units: the system's; `MICRO`: µs):
    - `t1`: the end time, or `None` where the caller decides it (a pattern's fold time; `simulate`
      then needs its own `t1=`).
    - `saveat`: a [`origami_jax.simulation.SaveAt`][] (default: `DEFAULT_N_SAVE` even samples).
    - `solver`: any diffrax ODE solver, or [`origami_jax.simulation.ImplicitStep`][]; `None` for
      [`origami_jax.simulation.default_solver`][].
    - `rtol`, `atol`: the step-size controller's tolerances (defaults `DEFAULT_RTOL`,
      `DEFAULT_ATOL`). Numbers are kept as arrays (also `t1`, `dt0`, `saveat.ts`), so that a new
      value passed through `jit` does not compile a new solve.
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

    t1: Float[ArrayLike, ""] | None = eqx.field(default=None, converter=_as_value)
    saveat: SaveAt = SaveAt()
    solver: Any = None
    rtol: Float[ArrayLike, ""] = eqx.field(default=DEFAULT_RTOL, converter=_as_value)
    atol: Float[ArrayLike, ""] = eqx.field(default=DEFAULT_ATOL, converter=_as_value)
    stepsize_controller: diffrax.AbstractStepSizeController | None = None
    dt0: Float[ArrayLike, ""] | None = eqx.field(default=None, converter=_as_value)
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
            raise ValueError(
                f"SolveOptions(max_steps=...) must be a positive integer, got {self.max_steps!r}."
            )
        if not isinstance(self.saveat, SaveAt):
            raise ValueError(
                f"SolveOptions(saveat=...) must be an origami_jax.simulation.SaveAt, got "
                f"{type(self.saveat).__name__}."
            )

    def replace(self, **changes: Any) -> "SolveOptions":
        """A copy with the given fields changed (`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)

    def number(self, name: str) -> Any:
        """The field `name` (`t1`, `rtol`, `atol`, `dt0`) as a Python float when it is a known
        scalar (the options keep numbers as arrays, so that a new value traces, not compiles);
        `None`, a traced value or an array of several as it is."""
        value = getattr(self, name)
        if value is None or is_traced(value) or np.ndim(value) != 0:
            return value
        return float(np.asarray(value))


SOLVER_NAMES = ("tsit5", "kvaerno5", "implicit-step", "implicit-bdf2")
"""The solvers a command line (`--solver`) or a sweep's config (`solver = ...`) names: see
`named_solver`."""
FIXED_STEP_SOLVERS = {"implicit-step": "euler", "implicit-bdf2": "bdf2"}
"""The names of `SOLVER_NAMES` that take fixed steps (`dt`), and their `ImplicitStep.scheme`."""


def named_solver(name: str, *, dt: float | None = None, newton_iterations: int | None = None):
    """The solver called `name` (one of `SOLVER_NAMES`), as `SolveOptions(solver=...)` takes it:

    - `"tsit5"`: `diffrax.Tsit5()`, adaptive explicit Runge–Kutta (order 5);
    - `"kvaerno5"`: [`origami_jax.simulation.implicit_solver`][], adaptive L-stable ESDIRK, for
      stiff runs;
    - `"implicit-step"`: [`origami_jax.simulation.ImplicitStep`][] with the fixed step `dt` (time
      units; required) and `newton_iterations` (default the engine's, 6): implicit Euler;
    - `"implicit-bdf2"`: the same engine with the second-order scheme (`scheme="bdf2"`).

    **Raises:** `ValueError` for an unknown name, a missing or bad `dt`, or `dt`/`newton_iterations`
    given with an adaptive solver (which takes no fixed step).
    """
    if name not in SOLVER_NAMES:
        raise ValueError(f"unknown solver {name!r}; the solvers are {', '.join(SOLVER_NAMES)}.")
    if name not in FIXED_STEP_SOLVERS:
        if dt is not None or newton_iterations is not None:
            raise ValueError(
                f"dt and newton_iterations set the implicit-step engine's fixed steps; {name} "
                "chooses its own steps (drop them, or choose implicit-step or implicit-bdf2)."
            )
        return implicit_solver() if name == "kvaerno5" else diffrax.Tsit5()
    if dt is None:
        raise ValueError(f"the {name} engine needs dt, its fixed step (time units).")
    if isinstance(dt, bool) or not isinstance(dt, int | float):
        raise ValueError(f"dt must be a number (time units), got {dt!r}.")
    extra = {} if newton_iterations is None else {"newton_iterations": newton_iterations}
    return ImplicitStep(dt=float(dt), scheme=FIXED_STEP_SOLVERS[name], **extra)


FIT_RTOL = 1e-8
"""Relative tolerance of the solves inside a fit (`origami_jax.design.design`, `calibrate`), ten times
tighter than `DEFAULT_RTOL`: the fit's Jacobian is the forward-mode derivative of an adaptive solve,
whose step-size decisions add tolerance-level noise to the residuals; checked against central
differences (step 1e-4 in z) that noise is divided by the step, and the fit stops on a relative
change of 1e-6."""
FIT_ATOL = 1e-10
"""Absolute tolerance of the solves inside a fit (see `FIT_RTOL`), two orders below `FIT_RTOL`
like `DEFAULT_ATOL` below `DEFAULT_RTOL`."""
FIT_N_SAVE = 1201
"""Samples of each response inside a fit: the metrics refine crossings between samples by cubic
Hermite interpolation, so a few dozen samples per oscillation suffice; 1201 over a run of 6× the
longest rise time gives ~200 per rise."""
FIT_OPTIONS = SolveOptions(
    saveat=SaveAt(n=FIT_N_SAVE),
    solver=diffrax.Tsit5(),
    rtol=FIT_RTOL,
    atol=FIT_ATOL,
)
"""The default solve of `origami_jax.design.design` and `calibrate` (their `t1` comes from the
targets). `Tsit5`, not the switching default: under the fit's multi-start `vmap` the switching
solver would run both of its branches; for the accordion in air Tsit5 compiles ~6× and runs ~10×
faster than Kvaerno5, with derivatives matching finite differences. Pass
`solver=implicit_solver()` for stiff cases (very stiff hinges, KOH at high drag). The fit always
solves with `throw=False` and `diffrax.ForwardMode()` (its Jacobian is forward mode)."""

SLOW_RAMP_N_SAVE = 1001
"""Samples of the slow etch ramp's large-step solve (each one a step end)."""
SLOW_RAMP_OPTIONS = SolveOptions(
    saveat=SaveAt(n=SLOW_RAMP_N_SAVE),
    solver=implicit_solver(),
    rtol=1e-8,
    atol=1e-10,
    max_steps=20 * SLOW_RAMP_N_SAVE,
    land_on_samples=True,
)
"""The default large-step solve of `simulate_slow_ramp`: L-stable Kvaerno5 (hour-long steps need it
from the first step), every sample a step end (`land_on_samples`, which `simulate_slow_ramp`
always sets), a budget of 20 steps per sample."""
SLOW_RAMP_WINDOW_OPTIONS = SolveOptions(
    saveat=SaveAt(n=3001), rtol=1e-9, atol=1e-13, max_steps=65_536
)
"""The default resolved check of `simulate_slow_ramp` over its start window (`t1` is the window):
tight enough to resolve the ringing of ~1e-8 rad that the large steps do not."""
