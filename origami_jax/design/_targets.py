"""What a design or calibration aims at: per-joint response metrics and/or a measured θ(t) curve.

Each target becomes residual rows ``√w (achieved − target) / scale``, dimensionless, so that rise times of
tens of µs, an overshoot of 0.39 and angles in radians weigh alike: ``scale = max(|target|, floor)`` with
floors of 0.01 for overshoot (one percentage point) and 0.01 rad for final angles (times must be
positive, so they need none). A measured curve contributes ``√(w / (m·n)) (θ_sim(tᵢ) − θᵢ) / |θ_target|``
for its `m` samples and `n` joints: its sum of squares is `w` times the mean squared relative error.

Target values and weights are traced (changing them does not recompile); which joints carry which target
is static, fixed by the NaN pattern of the values.
"""

from collections.abc import Mapping, Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..simulation import ResponseMetrics, Trajectory

KINDS = ("rise_time", "overshoot", "peak_time", "settling_time", "final_angle", "t90")
"""Metric target kinds, in residual order."""

KIND_UNITS = {
    "rise_time": "time",
    "overshoot": "fraction",
    "peak_time": "time",
    "settling_time": "time",
    "final_angle": "rad",
    "t90": "time",
}
_FLOORS = {
    "rise_time": 0.0,
    "overshoot": 0.01,
    "peak_time": 0.0,
    "settling_time": 0.0,
    "final_angle": 0.01,
    "t90": 0.0,
}
_TIME_KINDS = ("rise_time", "peak_time", "settling_time", "t90")


class MeasuredCurve(eqx.Module):
    """A measured response θ(t) to fit as a whole.

    **Fields:**
    - `times`: sample times, shape `(m,)`, time units of the design (MICRO: µs), increasing, within the run.
    - `theta`: measured angles, rad, shape `(m, n)` (NaN where a joint was not measured at a time).
    - `weight`: weight of the whole curve relative to a single metric target (default 1).
    """

    times: Float[Array, " m"]
    theta: Float[Array, "m n"]
    weight: Float[Array, ""]

    def __init__(self, times: ArrayLike, theta: ArrayLike, weight: float = 1.0):
        times = np.asarray(times, dtype=float)
        theta = np.asarray(theta, dtype=float)
        if times.ndim != 1 or times.size < 2:
            raise ValueError(
                f"MeasuredCurve.times must be 1-D with >= 2 samples, got {times.shape}."
            )
        if theta.ndim != 2 or theta.shape[0] != times.size:
            raise ValueError(
                f"MeasuredCurve.theta must have shape (m, n) = ({times.size}, n), got {theta.shape}."
            )
        if np.any(np.diff(times) <= 0) or not np.all(np.isfinite(times)):
            raise ValueError("MeasuredCurve.times must be finite and strictly increasing.")
        if weight < 0:
            raise ValueError(f"MeasuredCurve.weight must be >= 0, got {weight}.")
        self.times = jnp.asarray(times)
        self.theta = jnp.asarray(theta)
        self.weight = jnp.asarray(float(weight))


class Targets(eqx.Module):
    """Targets for [`origami_jax.design.design`][] / [`origami_jax.design.calibrate`][].

    Every metric target is one value per joint (NaN for a joint without that target), in the design's
    units (MICRO: µs for times):
    - `rise_time`: 10–90 % rise time; `peak_time`: time of the highest peak; `settling_time`: 2 % settling
      time (ill-posed under quadratic-only drag: see `origami_jax.simulation.ResponseMetrics`).
    - `overshoot`: **fraction** above the target angle at the highest peak (0.39 for 39 %).
    - `final_angle`: θ at the end of the run, rad.
    - `t90`: when a joint first reaches 90 % of its target angle: when it has all but finished
      folding. A crease's finish as a target: smooth in the parameters where a folding that rings
      makes `settling_time` jump from one swing to the next (e.g. a net's creases all finishing
      within 10 % of each other).
    - `curve`: a [`origami_jax.design.MeasuredCurve`][].
    - `weights`: ``{kind: weight}``, a scalar or one per joint (default 1).

    **Raises:** `ValueError` when nothing is targeted, lengths disagree, times are not positive or a
    weight is negative.
    """

    values: dict[str, Float[Array, " n"]]
    weights: dict[str, Float[Array, " n"]]
    curve: MeasuredCurve | None
    rows: tuple[tuple[str, int], ...] = eqx.field(static=True)
    n_joints: int = eqx.field(static=True)

    def __init__(
        self,
        *,
        rise_time: Sequence[float] | ArrayLike | None = None,
        overshoot: Sequence[float] | ArrayLike | None = None,
        peak_time: Sequence[float] | ArrayLike | None = None,
        settling_time: Sequence[float] | ArrayLike | None = None,
        final_angle: Sequence[float] | ArrayLike | None = None,
        t90: Sequence[float] | ArrayLike | None = None,
        curve: MeasuredCurve | None = None,
        weights: Mapping[str, float | Sequence[float]] | None = None,
    ):
        given = dict(
            rise_time=rise_time,
            overshoot=overshoot,
            peak_time=peak_time,
            settling_time=settling_time,
            final_angle=final_angle,
            t90=t90,
        )
        weights = dict(weights or {})
        for kind in weights:
            if kind not in KINDS:
                raise ValueError(f"weights: unknown target kind {kind!r}; kinds are {KINDS}.")
        n = None if curve is None else int(curve.theta.shape[1])
        values, weight_arrays, rows = {}, {}, []
        for kind in KINDS:
            if given[kind] is None:
                continue
            array = np.atleast_1d(np.asarray(given[kind], dtype=float))
            if array.ndim != 1:
                raise ValueError(
                    f"{kind} must be one value per joint (NaN: no target), got {array.shape}."
                )
            if n is None:
                n = array.size
            if array.size != n:
                raise ValueError(
                    f"{kind} has {array.size} values but other targets are for {n} joints; give one "
                    "value per joint and NaN where a joint has no such target."
                )
            finite = np.isfinite(array)
            if kind in _TIME_KINDS and np.any(array[finite] <= 0):
                raise ValueError(f"{kind} targets must be positive times, got {array}.")
            weight = np.broadcast_to(np.asarray(weights.get(kind, 1.0), dtype=float), (n,))
            if np.any(weight < 0):
                raise ValueError(f"weights[{kind!r}] must be >= 0, got {weight}.")
            values[kind] = jnp.asarray(np.where(finite, array, 0.0))
            weight_arrays[kind] = jnp.asarray(np.array(weight))
            rows.extend((kind, j) for j in range(n) if finite[j])
        if not rows and curve is None:
            raise ValueError(
                "Targets: nothing to aim at; give a metric target or a measured curve."
            )
        self.values = values
        self.weights = weight_arrays
        self.curve = curve
        self.rows = tuple(rows)
        assert n is not None  # from a target or the curve, checked above
        self.n_joints = int(n)

    @property
    def labels(self) -> list[str]:
        """One label per metric residual row, e.g. ``"rise_time[joint 1]"`` (joints counted from 1)."""
        return [f"{kind}[joint {j + 1}]" for kind, j in self.rows]

    def target_values(self) -> Float[Array, " r"]:
        """Target value of each metric row, in its unit (see `KIND_UNITS`)."""
        return jnp.stack([self.values[k][j] for k, j in self.rows]) if self.rows else jnp.zeros(0)

    def scales(self) -> Float[Array, " r"]:
        if not self.rows:
            return jnp.zeros(0)
        return jnp.stack(
            [jnp.maximum(jnp.abs(self.values[k][j]), _FLOORS[k]) for k, j in self.rows]
        )

    def row_weights(self) -> Float[Array, " r"]:
        return jnp.stack([self.weights[k][j] for k, j in self.rows]) if self.rows else jnp.zeros(0)


def metric_values(metrics: ResponseMetrics) -> dict[str, Array | np.ndarray]:
    """Each target kind's metric `(n,)` (NumPy or JAX, as `metrics` holds them), in the target's
    unit (overshoot as a fraction)."""
    return {
        "rise_time": metrics.rise_time,
        "overshoot": metrics.overshoot / 100.0,
        "peak_time": metrics.peak_time,
        "settling_time": metrics.settling_time,
        "final_angle": metrics.target + metrics.final_error,
        "t90": metrics.t90,
    }


def achieved_values(targets: Targets, metrics: ResponseMetrics) -> Float[Array, " r"]:
    """The metric of each target row, in the target's unit (overshoot as a fraction)."""
    if not targets.rows:
        return jnp.zeros(0)
    per_kind = metric_values(metrics)
    return jnp.stack([per_kind[k][j] for k, j in targets.rows])


def ill_conditioned_rows(targets: Targets, metrics: ResponseMetrics) -> Array:
    """Per metric row: True where the achieved metric is flagged (grazing crossing, ill-posed settling)."""
    if not targets.rows:
        return jnp.zeros(0, bool)
    no = jnp.zeros_like(metrics.rise_ill_conditioned)
    per_kind = {
        "rise_time": metrics.rise_ill_conditioned,
        "overshoot": no,
        "peak_time": no,
        "settling_time": metrics.settling_ill_posed,
        "final_angle": no,
        "t90": metrics.t90_ill_conditioned,  # the 90 % crossing grazed, or never reached
    }
    return jnp.stack([per_kind[k][j] for k, j in targets.rows])


def _hermite_at(times, theta, theta_dot, t):
    """Cubic Hermite interpolation of the samples ``(θ, θ̇)`` at times `t`, shape `(m, n)`."""
    k = jnp.clip(jnp.searchsorted(times, t, side="right") - 1, 0, times.shape[0] - 2)
    t0, t1 = times[k], times[k + 1]
    h = (t1 - t0)[:, None]
    s = ((t - t0) / (t1 - t0))[:, None]
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * theta[k]
        + (s3 - 2 * s2 + s) * h * theta_dot[k]
        + (-2 * s3 + 3 * s2) * theta[k + 1]
        + (s3 - s2) * h * theta_dot[k + 1]
    )


def curve_residual(curve: MeasuredCurve, trajectory: Trajectory) -> Float[Array, " c"]:
    """Residual rows of a measured curve (see the module docstring); NaN samples give 0."""
    simulated = _hermite_at(trajectory.times, trajectory.theta, trajectory.theta_dot, curve.times)
    measured = curve.theta
    ok = jnp.isfinite(measured)
    count = jnp.maximum(jnp.sum(ok), 1)
    scale = jnp.maximum(jnp.abs(trajectory.target), 1e-2)
    error = jnp.where(ok, (simulated - jnp.where(ok, measured, 0.0)) / scale, 0.0)
    return (jnp.sqrt(curve.weight / count) * error).ravel()


def residual(
    targets: Targets, metrics: ResponseMetrics, trajectory: Trajectory
) -> Float[Array, " r"]:
    """All residual rows: metric rows (in `targets.rows` order), then the curve's."""
    parts = []
    if targets.rows:
        error = (achieved_values(targets, metrics) - targets.target_values()) / targets.scales()
        parts.append(jnp.sqrt(targets.row_weights()) * error)
    if targets.curve is not None:
        parts.append(curve_residual(targets.curve, trajectory))
    return jnp.concatenate(parts)


def time_horizon(targets: Targets) -> float | None:
    """A run length that covers the targets: 6× the longest rise time, 4× the longest peak time, 3×
    the longest settling time (which must end before half the run to be well posed) or `t90`, or
    the end of the measured curve (the longest of these); `None` if none is targeted."""
    candidates = []
    for kind, factor in (
        ("rise_time", 6.0),
        ("peak_time", 4.0),
        ("settling_time", 3.0),
        ("t90", 3.0),
    ):
        rows = [j for k, j in targets.rows if k == kind]
        if rows:
            candidates.append(factor * float(jnp.max(targets.values[kind][jnp.asarray(rows)])))
    if targets.curve is not None:
        candidates.append(float(targets.curve.times[-1]))
    return max(candidates) if candidates else None
