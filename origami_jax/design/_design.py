"""`design` and `calibrate`: hinge parameters that make a folding chain meet targets, through the simulation.

Stages: unconstrained ``z`` → bounded parameters (`ParameterSpace`) → `HingeDesign` → `FoldingSystem`
(the settings' layout, e.g. `origami_jax.chain.Accordion`) → `simulate` (forward-mode sensitivities, `diffrax.ForwardMode`) → `response_metrics` → dimensionless
residual rows (`Targets`) → Levenberg–Marquardt from several starts at once (`fit_batch`) → the best start,
its metrics next to the targets, the sensitivity of every metric to every parameter, an identifiability
verdict and, for targets that are not met, how far off they are and why.
"""

import functools
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any, cast

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Float

from .._runtime_errors import checks_as_nan
from ..chain import Accordion
from ..simulation import (
    FIT_OPTIONS,
    AbstractInput,
    EtchRamp,
    ImplicitStep,
    SolveOptions,
    Step,
    response_metrics,
    simulate,
)
from ..system import AbstractLayout, HingeDesign
from ._identify import identifiability
from ._lstsq import evaluate_with_jacobian, fit_batch
from ._report import DesignResult, build_report
from ._space import ParameterSpace, parameter_space
from ._targets import (
    KINDS,
    Targets,
    achieved_values,
    ill_conditioned_rows,
    metric_values,
    residual,
    time_horizon,
)

DEFAULT_TOLERANCE = 0.05
"""A target counts as met when its achieved value is within 5 % of it (relative; overshoot and final
angle relative to ``max(|target|, floor)``, see `Targets`)."""


class SimulationSettings(eqx.Module):
    """What each candidate design builds and how it is simulated (all in the design's units, MICRO:
    µs).

    **Fields:**
    - `layout`: what the design builds (static), an [`origami_jax.system.AbstractLayout`][]; default
      the accordion with `n_flaps` flaps ([`origami_jax.chain.Accordion`][]).
    - `inputs`: the input (default the step `Step()` to the system's hinge targets, paper Eq. 12;
      for a pattern that releases its hinges over a ramp, a net in a liquid, `design` gives that
      release, `with_pattern_release`), or a function `HingeDesign -> AbstractInput`.
    - `options`: the solve, a [`origami_jax.simulation.SolveOptions`][] with its end time `t1` (default
      [`origami_jax.simulation.FIT_OPTIONS`][]: Tsit5, rtol 1e-8, 1201 samples). Rise times, peaks
      and settling must happen well inside `t1`. Its sample count is part of the compiled fit, which
      runs `simulate` under `jit`, where sample counts are not padded. The fit always solves with
      `throw=False` and `diffrax.ForwardMode()`. With the fixed-step engine
      (`solver=ImplicitStep(dt=...)`) the derivatives are those of the discrete map (the implicit
      function theorem at every step), and its sample times must be evenly spaced (`SaveAt(n=...)`).
    - `horizon` (static): with the fixed-step engine, `t1` as a number, from which it takes its
      step count (the fit traces `options`, and with it `options.t1`; a new run length compiles a
      new fit there); `None` with the adaptive solvers, whose fits a new `t1` does not recompile.
    """

    layout: AbstractLayout = eqx.field(static=True)
    inputs: AbstractInput | Callable | None
    options: SolveOptions
    horizon: float | None = eqx.field(static=True)

    def __init__(
        self,
        t1: float | None = None,
        *,
        n_flaps: int = 3,
        layout: AbstractLayout | None = None,
        inputs: AbstractInput | Callable | None = None,
        options: SolveOptions | None = None,
    ):
        """**Arguments:** `t1`, the run length (time units), or `options.t1` (one of them, or both
        equal); `n_flaps`, the accordion's flaps when `layout` is `None`; `layout`, `inputs`,
        `options` as the fields (`options` default `FIT_OPTIONS`)."""
        options = FIT_OPTIONS if options is None else options
        if t1 is None:
            t1 = options.t1
        elif options.t1 is not None and float(options.t1) != float(t1):
            raise ValueError(
                f"SimulationSettings got t1={t1} and SolveOptions(t1={float(options.t1)}); give one."
            )
        if t1 is None:
            raise ValueError(
                "SimulationSettings needs a run length: t1=... or SolveOptions(t1=...)."
            )
        if not float(t1) > 0:
            raise ValueError(f"t1 must be a positive run length, got {t1}.")
        saveat = options.saveat
        if saveat.ts is None and saveat.n < 16:
            raise ValueError(
                f"SaveAt(n=...) must be at least 16 to resolve the response, got {saveat.n}."
            )
        self.layout = Accordion(int(n_flaps)) if layout is None else layout
        self.inputs = inputs
        if isinstance(options.solver, ImplicitStep) and saveat.ts is not None:
            raise ValueError(
                "ImplicitStep fixes its steps from the sample times, which a fit traces: give "
                "SaveAt(n=...) (evenly spaced samples), not SaveAt(ts=...)."
            )
        ramped = getattr(inputs, "ramp", None) is not None
        if isinstance(options.solver, ImplicitStep) and self.n_loops > 0 and not ramped:
            # A fit starts flat, and its simulations are traced: `simulate` cannot check there.
            raise ValueError(
                "a fit starts its closed-loop pattern flat, where ImplicitStep cannot choose the "
                "folding branch under a sudden release: give inputs=Step(ramp=...) (a release over "
                "a ramp) or an adaptive solver."
            )
        self.options = options.replace(t1=float(t1))
        self.horizon = float(t1) if isinstance(options.solver, ImplicitStep) else None

    @property
    def n_hinges(self) -> int:
        return self.layout.n_hinges

    @property
    def n_loops(self) -> int:
        """The layout's closed loops (0 for chains and nets)."""
        return int(getattr(self.layout, "n_loops", 0))

    @property
    def t1(self) -> Float[Array, ""]:
        """The run length, time units."""
        return jnp.asarray(self.options.t1)


def response(
    hinge: HingeDesign, settings: SimulationSettings, layout: AbstractLayout | None = None
):
    """Simulate `hinge` as `settings` say: `(Trajectory, ResponseMetrics)` (not jitted; composes).
    `layout`: the pattern built instead of `settings.layout` (the same one with fitted geometry)."""
    system = (settings.layout if layout is None else layout)(hinge)
    if settings.inputs is None:
        inputs = Step()
        # A pattern of panels (a net) carries the fluid's inertia in a liquid by default; the
        # accordion's extended fluid is asked for by name, with the step of the paper's figures.
        pattern = settings.layout if layout is None else layout
        if hasattr(pattern, "nominal_release_ramp") and system.mechanism.carries_added_inertia:
            warnings.warn(
                "the panels carry the fluid's inertia (a net in a liquid, by default) and are "
                "released at once: they are flung past their targets. Give the release "
                "(inputs=Step(ramp=net.nominal_release_ramp(hinge))) or the paper's dynamics "
                "(net.with_model(added_mass=False, viscous=False)).",
                stacklevel=3,
            )
    elif isinstance(settings.inputs, AbstractInput):
        inputs = settings.inputs
    else:
        inputs = settings.inputs(hinge)
    options = settings.options.replace(throw=False, adjoint=diffrax.ForwardMode())
    if isinstance(options.solver, ImplicitStep):
        # Its step count is fixed from the run length, which must be a known number here, not the
        # traced `options.t1` (the forward-mode adjoint does not apply: the engine's derivatives
        # are its own, by the implicit function theorem).
        horizon = cast(float, settings.horizon)  # set with the engine (`SimulationSettings`)
        trajectory = simulate(system, inputs, options.replace(t1=None), t1=horizon)
    else:
        trajectory = simulate(system, inputs, options)
    return trajectory, response_metrics(trajectory)


class _Problem(eqx.Module):
    hinge: HingeDesign
    space: ParameterSpace
    targets: Targets
    settings: SimulationSettings


def with_pattern_release(settings: SimulationSettings, hinge: HingeDesign) -> SimulationSettings:
    """`settings` whose layout is a pattern that releases its hinges over a ramp (a net in a
    liquid: `nominal_release_ramp(hinge)`, the one ramp of every candidate, as a sweep's) and
    whose input is the default: with that release as the input, as the pattern's `fold` has it.

    **Raises:** `ValueError` where the run (`options.t1`) ends within the ramp."""
    nominal = getattr(settings.layout, "nominal_release_ramp", None)
    if settings.inputs is not None or nominal is None:
        return settings
    ramp = nominal(hinge)
    if ramp is None:
        return settings
    t1 = float(settings.options.t1)
    if t1 <= ramp:
        raise ValueError(
            f"the run ({t1:g} time units) ends within the pattern's release ramp ({ramp:g}): "
            "no hinge is whole before the end; give a longer t1, or the paper's dynamics "
            "(with_model(added_mass=False, viscous=False, release_ramp=None))."
        )
    return eqx.tree_at(lambda s: s.inputs, settings, Step(ramp=ramp), is_leaf=lambda x: x is None)


def _all_metrics(metrics) -> Array:
    """Every metric of every joint, in `KINDS` order (overshoot as a fraction), shape
    `(len(KINDS) n,)`."""
    values = metric_values(metrics)
    return jnp.concatenate([values[kind] for kind in KINDS])


def _residual_fn(z, problem: _Problem):
    x = problem.space.to_physical(z)
    hinge = problem.space.apply(problem.hinge, x)
    layout = problem.space.apply_pattern(problem.settings.layout, x)
    trajectory, metrics = response(hinge, problem.settings, layout)
    r = residual(problem.targets, metrics, trajectory)
    aux = dict(
        x=x,
        achieved=achieved_values(problem.targets, metrics),
        flags=ill_conditioned_rows(problem.targets, metrics),
        simulation_ok=trajectory.succeeded,
    )
    return r, _all_metrics(metrics), aux


@eqx.filter_jit
def _evaluate(problem: _Problem, z) -> dict[str, Any]:
    x = problem.space.to_physical(z)
    hinge = problem.space.apply(problem.hinge, x)
    layout = problem.space.apply_pattern(problem.settings.layout, x)
    trajectory, metrics = response(hinge, problem.settings, layout)
    r = residual(problem.targets, metrics, trajectory)
    return dict(
        residual=r,
        achieved=achieved_values(problem.targets, metrics),
        flags=ill_conditioned_rows(problem.targets, metrics),
        trajectory=trajectory,
        metrics=metrics,
    )


@eqx.filter_jit
def _fit_and_start(problem: _Problem, z0s, solver, max_steps: int):
    """Every start's fit and the first start's evaluation (the report's "before"), in one program:
    they are independent, and XLA:CPU runs independent parts of a program side by side (measured on
    2 cores, paired with the two run one after the other: 5–16 % less wall time for a single-start
    calibration of the accordion)."""
    batch = fit_batch(_residual_fn, z0s, problem, solver=solver, max_steps=max_steps)
    return batch, _evaluate(problem, z0s[0])


def _library_only(settings: SimulationSettings) -> bool:
    """Whether the fit runs only this package's code, whose checks cannot fire there: every value it
    tries lies within the bounds, checked against each parameter's physical range, and failed
    simulations come back as result codes. Its program is then traced with equinox's checks as NaN,
    so that the compilation cache keeps it (`origami_jax._runtime_errors`); a user's input function
    or layout keeps its checks raising."""
    own = lambda obj: type(obj).__module__.startswith("origami_jax.")  # noqa: E731
    inputs = settings.inputs
    return own(settings.layout) and (inputs is None or isinstance(inputs, (Step, EtchRamp)))


def _starts(space: ParameterSpace, start: Array, n_starts: int, key) -> np.ndarray:
    """The given start plus `n_starts − 1` Latin-hypercube points in the inner 90 % of the z-box,
    `(n_starts, p)` (host)."""
    z0 = space.to_unconstrained(np.asarray(start), xp=np)[None, :]
    if n_starts <= 1:
        return z0
    extra = _latin_hypercube(key, n_starts - 1, space.size)
    return np.concatenate([z0, np.asarray(extra, dtype=z0.dtype)], axis=0)


@functools.partial(jax.jit, static_argnums=(1, 2))
def _latin_hypercube(key, m: int, p: int) -> Array:
    """`m` Latin-hypercube points in the inner 90 % of the unit box, as log-odds `(m, p)`. One
    compiled program: run eagerly, its dozen operations were a dozen programs compiled on a first
    call. `key=None`: the default seed."""
    key = jax.random.key(0) if key is None else key
    k1, k2 = jax.random.split(key)
    strata = jax.vmap(lambda k: jax.random.permutation(k, m))(jax.random.split(k1, p)).T
    u = (strata + jax.random.uniform(k2, (m, p))) / m
    s = 0.05 + 0.9 * u
    return jnp.log(s) - jnp.log1p(-s)


def design(
    hinge: HingeDesign,
    targets: Targets,
    free: Sequence[str],
    options: SolveOptions | None = None,
    *,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    settings: SimulationSettings | None = None,
    n_starts: int = 8,
    key: Any = None,
    solver: optx.AbstractLeastSquaresSolver | optx.AbstractMinimiser | None = None,
    max_steps: int = 48,
    tolerance: float = DEFAULT_TOLERANCE,
    throw: bool = True,
) -> DesignResult:
    """Find free hinge parameters that make the folding meet `targets`, by least squares through the
    simulation, from several starts at once.

    **Arguments:**
    - `hinge`: a [`origami_jax.system.HingeDesign`][]: fixed values, and the first start of the free ones.
    - `targets`: [`origami_jax.design.Targets`][] (per-joint metrics and/or a measured curve), in the
      design's units (MICRO: µs).
    - `free`: names of the free parameters, e.g. ``["k_scale", "b_scale"]`` or
      ``["hinge_width", "t_hinge"]`` (see [`origami_jax.design.parameter_space`][]); the
      accordion's ``"flap_length"`` and ``"flap_width"`` are its pattern's (`settings.layout`).
    - `bounds`: ``{name: (lower, upper)}`` in the design's units; default a factor 100 around the start.
      Enforced by a sigmoid reparametrisation (log-scaled for positive bounds), never by clipping.
    - `options`: how each candidate is simulated, a [`origami_jax.simulation.SolveOptions`][]
      (default [`origami_jax.simulation.FIT_OPTIONS`][]: Tsit5 at rtol 1e-8, ten times tighter than
      `simulate`'s default, see `FIT_RTOL`; change one setting with
      ``FIT_OPTIONS.replace(rtol=1e-9)``). Its `t1`, the run length, defaults to the targets'
      horizon (`time_horizon`). Give it here or in `settings`, not both.
    - `settings`: [`origami_jax.design.SimulationSettings`][]: the layout, the input and the options;
      by default a step input on the accordion with the targets' joint count of flaps.
    - `n_starts`: starting points: `hinge`'s values plus Latin-hypercube points inside the bounds, all
      solved in one vmapped batch; the best is reported, every start is listed.
    - `key`: PRNG key for the extra starts (default: a fixed seed, so results are reproducible).
    - `solver`: the optimiser, an optimistix least-squares solver (default: a Levenberg–Marquardt,
      `origami_jax.design.default_solver`), or a minimiser such as `optimistix.BFGS`.
    - `max_steps`: optimiser steps per start.
    - `tolerance`: relative miss below which a target counts as met.
    - `throw`: raise a `RuntimeError` when no start produced a usable answer (every simulation failed).
      Targets that cannot be met and an optimiser that ran out of steps never raise: they are reported
      in the result (`reached`, `verdict`, `result`).

    **Returns:** a [`origami_jax.design.DesignResult`][].

    **Raises:** `ValueError` for unknown parameters, bad bounds, targets for another number of joints,
    no run length, or options given both here and in `settings`.
    """
    if settings is None:
        options = FIT_OPTIONS if options is None else options
        horizon = time_horizon(targets) if options.t1 is None else options.t1
        if horizon is None:
            raise ValueError(
                "Give the run length as SolveOptions(t1=...): the targets hold no time to derive it "
                "from."
            )
        settings = SimulationSettings(
            n_flaps=targets.n_joints, options=options.replace(t1=float(horizon))
        )
    elif options is not None:
        raise ValueError(
            "design got options and settings: give the options once, in "
            "SimulationSettings(options=...)."
        )
    if settings.n_hinges != targets.n_joints:
        raise ValueError(
            f"targets are for {targets.n_joints} hinges but the system has {settings.n_hinges}."
        )
    settings = with_pattern_release(settings, hinge)
    if n_starts < 1:
        raise ValueError(f"n_starts must be at least 1, got {n_starts}.")
    space = parameter_space(hinge, free, bounds, pattern=settings.layout)
    start = space.read(hinge, settings.layout)
    problem = _Problem(hinge, space, targets, settings)
    z0s = _starts(space, start, n_starts, key)
    with checks_as_nan(_library_only(settings)):
        fitted = _fit_and_start(problem, z0s, solver, max_steps)
    batch, before = jax.device_get(fitted)
    best = batch.best()
    ok = bool(~batch.nonfinite[best]) and bool(batch.aux["simulation_ok"][best])
    if throw and not ok:
        raise RuntimeError(
            "design: no start produced a finite residual (the simulations failed or a targeted metric "
            "was undefined at every start). Check the bounds and the run length t1, or pass "
            "throw=False to inspect the starts."
        )
    return build_report(
        problem=problem,
        batch=batch,
        best=best,
        start=start,
        before=before,
        tolerance=tolerance,
        identify=identifiability,
        metric_kinds=KINDS,
    )


def calibrate(
    hinge: HingeDesign,
    targets: Targets,
    free: Sequence[str],
    options: SolveOptions | None = None,
    *,
    n_starts: int = 1,
    **kwargs,
) -> DesignResult:
    """Calibrate unknown parameters to measured metrics or a measured θ(t) curve.

    The same computation as [`origami_jax.design.design`][] (its `options` and all its keyword arguments apply), but a
    local fit from `hinge`'s values (literature or prior estimates) by default: `n_starts=1`. Pass more
    starts when the prior is poor.
    """
    return design(hinge, targets, free, options, n_starts=n_starts, **kwargs)


def evaluate(result: DesignResult, which="after"):
    """Re-simulate a result's start (`"before"`), solution (`"after"`) or any other values of its free
    parameters (an array, shape `(p,)`, inside the bounds): `(Trajectory, ResponseMetrics)`.

    Compiled once per problem structure (a few seconds on first use, shared with `residual_at`), then
    a single simulation per call.
    """
    problem = result._problem
    if isinstance(which, str):
        if which not in ("before", "after"):
            raise ValueError(f"which must be 'before', 'after' or parameter values, got {which!r}.")
        x = result.start if which == "before" else result.values
    else:
        x = np.asarray(which, dtype=float)
        if x.shape != (len(result.names),):
            raise ValueError(
                f"give one value per free parameter {result.names}, got shape {x.shape}."
            )
    out = _evaluate(problem, problem.space.to_unconstrained(jnp.asarray(np.asarray(x))))
    return out["trajectory"], out["metrics"]


def residual_and_jacobian(result: DesignResult, x: Float[Array, " p"] | None = None):
    """Residual rows and ``∂r/∂z`` at parameters `x` (default the solution), computed exactly as the
    optimiser computes them; for checks against finite differences. Returns `(r, J, z)`."""
    problem = result._problem
    x = result.values if x is None else x  # pyright: ignore[reportAssignmentType] (host array)
    z = problem.space.to_unconstrained(jnp.asarray(np.asarray(x)))
    r, jac, _, _, _ = eqx.filter_jit(evaluate_with_jacobian)(_residual_fn, z, problem)
    return r, jac, z


def residual_at(result: DesignResult, z: Float[Array, " p"]) -> Float[Array, " r"]:
    """Residual rows at unconstrained `z` (forward simulation only; shares `design`'s compilation)."""
    return _evaluate(result._problem, z)["residual"]
