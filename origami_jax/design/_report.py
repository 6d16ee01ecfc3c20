"""The answer of a design or calibration: parameters, metrics next to targets, sensitivities, verdicts.

A `DesignResult` is host-side (NumPy values and strings), built once after the compiled fit, and turns
into JSON with `to_dict()`. It never hides a miss: every target row says how far off it is, flagged
metrics (grazing crossings, ill-posed settling) are listed, parameters at their bounds are named and the
identifiability verdict says which parameter combinations the targets actually determine.
"""

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from .._result_codes import message
from ..system import HingeDesign
from ._identify import Identifiability
from ._lstsq import RESULTS
from ._space import parameter_unit
from ._targets import KIND_UNITS, metric_values


@dataclasses.dataclass(frozen=True)
class TargetRow:
    """One target next to what the design achieves.

    **Fields:** `label` (e.g. ``"rise_time[joint 2]"``, or ``"curve"``), `kind`, `joint` (0-based; -1 for
    the curve), `unit`, `target`, `achieved`, `before` (at the start), `error` (achieved − target, in
    `unit`; for the curve, the RMS of the relative angle error), `relative_error` (error / scale, see
    `Targets`), `met` (within the tolerance), `ill_conditioned` (the achieved metric is flagged: a grazing
    crossing or an ill-posed settling time).
    """

    label: str
    kind: str
    joint: int
    unit: str
    target: float
    achieved: float
    before: float
    error: float
    relative_error: float
    met: bool
    ill_conditioned: bool


def _curve_rms(residual: np.ndarray, n_rows: int, weight: float) -> float:
    curve = residual[n_rows:]
    return float(np.sqrt(np.sum(curve**2) / weight)) if weight > 0 else float("nan")


@dataclasses.dataclass(frozen=True)
class DesignResult:
    """Result of [`origami_jax.design.design`][] / [`origami_jax.design.calibrate`][].

    **Fields** (units: the design's, `units`; MICRO = µm, µs, ng, MPa):
    - `names`, `values` (the solution), `start`, `lower`, `upper`; `parameters` as ``{name: value}``.
    - `at_bound`: ``{name: "lower" | "upper"}`` for parameters pinned at a bound.
    - `hinge`: the `HingeDesign` at the solution; `pattern`: the pattern simulated (an
      `origami_jax.chain.Accordion` by default), its geometry at the solution when it was free.
    - `targets`: [`origami_jax.design.TargetRow`][]s, every target next to its achieved value.
    - `residual`: residual rows at the solution; `cost` ``½‖r‖²``; `residual_jacobian` ``∂r/∂z``, the
      Jacobian the optimiser used, with respect to the unconstrained variables `z` of the solution.
    - `iterations`: optimiser steps of the best start; `result`: its
      [`origami_jax.design.RESULTS`][] code, `result_message` in words.
    - `starts`: every start (initial and final parameters, cost, steps, result).
    - `metric_labels`, `metrics`, `metrics_before`: every metric of every joint (rise, overshoot as a
      fraction, peak time, settling time, final angle) at the solution and at the start.
    - `sensitivity`: ``∂metric/∂log x``, shape `(metrics, p)`: change of each metric per unit relative
      change of each parameter at the solution (for linearly scaled ones, per change by the whole
      range ``upper − lower``).
    - `jacobian`: ``∂metric/∂x``, shape `(metrics, p)`, in metric units per parameter unit.
    - `identifiability`: [`origami_jax.design.Identifiability`][] of the targets' residuals.
    - `reached`: every target met within `tolerance`; `verdict`: one paragraph; `warnings`: list.
    """

    names: tuple[str, ...]
    values: np.ndarray
    start: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    units: str
    at_bound: dict[str, str]
    hinge: HingeDesign
    targets: list[TargetRow]
    residual: np.ndarray
    residual_jacobian: np.ndarray
    z: np.ndarray
    cost: float
    iterations: int
    result: RESULTS
    result_message: str
    starts: list[dict[str, Any]]
    metric_labels: list[str]
    metrics: np.ndarray
    metrics_before: np.ndarray
    sensitivity: np.ndarray
    jacobian: np.ndarray
    identifiability: Identifiability
    tolerance: float
    reached: bool
    verdict: str
    warnings: list[str]
    pattern: Any = None
    _problem: Any = dataclasses.field(repr=False, compare=False, default=None)

    @property
    def parameters(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, self.values, strict=True)}

    @property
    def succeeded(self) -> bool:
        """The optimiser converged (it may still have missed unreachable targets: see `reached`)."""
        return bool(self.result == RESULTS.successful)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able dictionary."""
        return {
            "units": self.units,
            "parameters": {
                n: {
                    "value": float(v),
                    "start": float(s),
                    "lower": float(lo),
                    "upper": float(hi),
                    "unit": parameter_unit(n) or "dimensionless",
                    "at_bound": self.at_bound.get(n),
                }
                for n, v, s, lo, hi in zip(
                    self.names, self.values, self.start, self.lower, self.upper, strict=True
                )
            },
            "targets": [dataclasses.asdict(row) for row in self.targets],
            "reached": self.reached,
            "verdict": self.verdict,
            "warnings": list(self.warnings),
            "cost": self.cost,
            "residual": self.residual.tolist(),
            "iterations": self.iterations,
            "optimiser_result": self.result_message or "successful",
            "starts": self.starts,
            "metrics": {
                label: {"before": float(b), "after": float(a)}
                for label, a, b in zip(
                    self.metric_labels, self.metrics, self.metrics_before, strict=True
                )
            },
            "sensitivity_per_log_parameter": {
                label: dict(zip(self.names, map(float, row), strict=True))
                for label, row in zip(self.metric_labels, self.sensitivity, strict=True)
            },
            "identifiability": self.identifiability.to_dict(),
            "tolerance": self.tolerance,
        }

    def summary(self) -> str:
        """A short human-readable report."""
        lines = [f"Parameters ({self.units} units):"]
        for n, v, s in zip(self.names, self.values, self.start, strict=True):
            bound = f"  [at {self.at_bound[n]} bound]" if n in self.at_bound else ""
            lines.append(f"  {n:<24} {v:12.6g}   (start {s:.6g}){bound}")
        lines.append("Targets:                       target     achieved     before     error")
        for row in self.targets:
            flag = "" if row.met else "  MISSED"
            flag += "  (ill-conditioned)" if row.ill_conditioned else ""
            lines.append(
                f"  {row.label:<26} {row.target:10.4g} {row.achieved:12.4g} {row.before:10.4g} "
                f"{100 * row.relative_error:+8.2f} %{flag}"
            )
        lines.append(
            f"Optimiser: {self.result_message or 'successful'}, {self.iterations} steps, "
            f"cost {self.cost:.4g}"
        )
        lines.append(f"Identifiability: {self.identifiability.verdict}")
        lines.append(f"Verdict: {self.verdict}")
        lines.extend(f"Warning: {w}" for w in self.warnings)
        return "\n".join(lines)


def _message(result: RESULTS) -> str:
    return message(result, RESULTS) if result != RESULTS.successful else ""


def optimiser_warning(result: RESULTS, steps: int, *, targets_met: bool, tolerance: float) -> str:
    """The report's line on an optimiser that did not stop on its own test (`result` not
    successful), after `steps` steps. One that spent its budget with every target met gave a usable
    answer: its own message ("try increasing max_steps") would read as a failure."""
    if targets_met and result == RESULTS.max_steps_reached:
        return (
            f"Optimiser: stopped at its step budget ({steps} steps) with every target met within "
            f"{100 * tolerance:g} %; more steps (max_steps) would only refine the fit."
        )
    return f"Optimiser: {_message(result)}"


def _take(tree, i):
    return jax.tree_util.tree_map(lambda x: x[i], tree)


def build_report(*, problem, batch, best, start, before, tolerance, identify, metric_kinds):
    # On the host: `design` hands over the fit on the host (op-by-op JAX on these small arrays cost
    # ~4 ms per report, as much as a simulation).
    space = problem.space
    layout = problem.settings.layout  # names the hinges in labels
    targets = jax.device_get(problem.targets)
    names = space.names
    n = targets.n_joints
    z = np.asarray(batch.z[best])
    x = np.asarray(batch.aux["x"][best])  # the physical values at `z`, from the fit
    lower, upper = np.asarray(space.lower), np.asarray(space.upper)
    dx_dz = space.to_physical_jacobian(z, xp=np)
    # The sensitivity's variable: u = log x (log-scaled parameters) or x / (upper − lower) (linear).
    du_dz = dx_dz * np.where(np.asarray(space.log), 1.0 / x, 1.0 / (upper - lower))
    with np.errstate(divide="ignore", invalid="ignore"):
        jac_r = np.asarray(batch.jacobian[best])
        sens_r = jac_r / du_dz
        jac_m = np.asarray(batch.extra_jacobian[best])
        sensitivity = jac_m / du_dz
        jacobian = jac_m / dx_dz
    ident = identify(sens_r, names)

    aux = _take(batch.aux, best)
    r = np.asarray(batch.residual[best])
    achieved = np.asarray(aux["achieved"])
    flags = np.asarray(aux["flags"])
    target_values = np.asarray(targets.target_values())
    scales = np.asarray(targets.scales())
    before_achieved = np.asarray(before["achieved"])
    rows = []
    for i, (kind, j) in enumerate(targets.rows):
        error = achieved[i] - target_values[i]
        rel = error / scales[i]
        rows.append(
            TargetRow(
                label=f"{kind}[{layout.hinge_name(j)}]",
                kind=kind,
                joint=j,
                unit=KIND_UNITS[kind],
                target=float(target_values[i]),
                achieved=float(achieved[i]),
                before=float(before_achieved[i]),
                error=float(error),
                relative_error=float(rel),
                met=bool(np.isfinite(rel) and abs(rel) <= tolerance),
                ill_conditioned=bool(flags[i]),
            )
        )
    if targets.curve is not None:
        weight = float(targets.curve.weight)
        n_rows = len(targets.rows)
        rms = _curve_rms(r, n_rows, weight)
        rms_before = _curve_rms(np.asarray(before["residual"]), n_rows, weight)
        rows.append(
            TargetRow(
                "curve",
                "curve",
                -1,
                "relative angle (RMS)",
                0.0,
                rms,
                rms_before,
                rms,
                rms,
                bool(np.isfinite(rms) and rms <= tolerance),
                False,
            )
        )

    at_bound_code = space.at_bound(x, gradient=np.nan_to_num(sens_r).T @ np.nan_to_num(r))
    at_bound = {
        name: ("lower" if code < 0 else "upper")
        for name, code in zip(names, at_bound_code, strict=True)
        if code != 0
    }
    result = _take(batch.result, best)
    result_message = _message(result)
    nonfinite = bool(batch.nonfinite[best])

    warnings = []
    for row in rows:
        if row.ill_conditioned:
            crossing = (
                "a peak grazes the 90 % level (or it is not reached)"
                if row.kind == "t90"
                else "a peak grazes a rise-time level (or a level is not reached)"
            )
            why = (
                f"{crossing}, so the first-crossing time can jump by an oscillation under a small "
                "parameter change"
                if row.kind in ("rise_time", "t90")
                else "the response is not settled for good well before the end of the run (quadratic-only "
                "drag rings down like 1/t), so the value depends on the run length"
            )
            warnings.append(f"{row.label} is ill-conditioned at the solution: {why}.")
    missed = [row for row in rows if not row.met]
    if result_message:
        warnings.append(
            optimiser_warning(
                result,
                int(batch.num_steps[best]),
                targets_met=not missed and not nonfinite,
                tolerance=tolerance,
            )
        )
    if not ident.identifiable or ident.weak:
        warnings.append(f"Identifiability: {ident.verdict}")
    losses = np.asarray(batch.loss)
    zs = np.asarray(batch.z)
    finite = np.isfinite(losses) & ~np.asarray(batch.nonfinite)
    for k in range(zs.shape[0]):
        if k == best or not finite[k]:
            continue
        close_loss = losses[k] <= 1.01 * losses[best] + 1e-12
        far = np.max(np.abs(zs[k] - zs[best])) > 0.5
        if close_loss and far:
            warnings.append(
                f"Start {k} reached different parameters with the same cost: the targets have several "
                "equally good solutions."
            )
            break
    # Starts that stopped at a clearly higher cost: the landscape has other local minima, so the
    # best of these starts need not be the best there is.
    worse = finite & (losses > 1.5 * losses[best] + 1e-12)
    multimodal = bool(np.any(worse))
    if multimodal:
        warnings.append(
            f"{int(np.sum(worse))} of {losses.size} starts stopped in worse local minima (costs up to "
            f"{float(np.max(losses[worse])):.3g} against {float(losses[best]):.3g}): the cost has "
            "several minima, so a better one may exist; try more starts (n_starts)."
        )

    if nonfinite:
        verdict = (
            "Failed: the residual is not finite at the best start (a simulation failed, or a targeted "
            "metric is undefined there, e.g. 90 % never reached within the run)."
        )
        reached = False
    elif not missed:
        verdict = f"All {len(rows)} targets met within {100 * tolerance:g} %."
        reached = True
    else:
        reached = False
        misses = "; ".join(
            f"{row.label}: target {row.target:.4g}, achieved {row.achieved:.4g} "
            f"({100 * row.relative_error:+.1f} %)"
            for row in missed
        )
        if at_bound:
            pinned = ", ".join(f"{k} at its {v} bound" for k, v in at_bound.items())
            verdict = (
                f"Unreachable within the bounds: {len(missed)} of {len(rows)} targets missed ({misses}). "
                f"{pinned}: the optimum lies beyond the bounds; widen them if that is physical."
            )
        elif multimodal or r.size <= ident.rank:
            # As many independent directions as targets (or starts that disagree): an exact fit may
            # well exist, so do not blame the targets.
            verdict = (
                f"Targets missed: {len(missed)} of {len(rows)} ({misses}), with no parameter at a "
                "bound. The optimiser may have stopped in a local minimum"
                + (" (the starts disagree)" if multimodal else "")
                + "; try more starts (n_starts) before concluding that the targets conflict."
            )
        else:
            verdict = (
                f"Not all targets can be met at once: {len(missed)} of {len(rows)} missed ({misses}). "
                "No parameter is at a bound, so the targets conflict within this model; this is the "
                "least-squares compromise (change the weights to trade one target against another)."
            )

    all_metrics = np.asarray(batch.extra[best])
    before_values = metric_values(before["metrics"])  # on the host: no device program
    before_metrics = np.concatenate([np.asarray(before_values[kind]) for kind in metric_kinds])
    labels = [f"{kind}[{layout.hinge_name(j)}]" for kind in metric_kinds for j in range(n)]
    starts = []
    for k in range(zs.shape[0]):
        starts.append(
            {
                "parameters": dict(zip(names, map(float, batch.aux["x"][k]), strict=True)),
                "cost": float(losses[k]),
                "steps": int(batch.num_steps[k]),
                "result": _message(_take(batch.result, k)) or "successful",
                "best": k == best,
            }
        )
    hinge = space.apply(problem.hinge, jnp.asarray(x))
    pattern = space.apply_pattern(problem.settings.layout, [float(v) for v in x])
    return DesignResult(
        names=tuple(names),
        values=x,
        start=np.asarray(start),
        lower=lower,
        upper=upper,
        units=problem.hinge.units.name,
        at_bound=at_bound,
        hinge=hinge,
        targets=rows,
        residual=r,
        residual_jacobian=jac_r,
        z=z,
        cost=float(losses[best]),
        iterations=int(batch.num_steps[best]),
        result=result,
        result_message=result_message,
        starts=starts,
        metric_labels=labels,
        metrics=all_metrics,
        metrics_before=before_metrics,
        sensitivity=sensitivity,
        jacobian=jacobian,
        identifiability=ident,
        tolerance=tolerance,
        reached=reached,
        verdict=verdict,
        warnings=warnings,
        pattern=pattern,
        _problem=problem,
    )
