"""Response metrics of a folding: rise time, overshoot, peak time, settling time, final error.

Every metric is per joint and differentiable. Crossing times are roots of the dense output: between two
samples the response is the cubic Hermite interpolant of `(θ, θ̇)` (of `(θ̇, θ̈)` for the peak), the same
kind of interpolant diffrax's implicit solvers use for their own dense output, here on the (finer) sample
grid. The root is found by bisection on values with stopped gradients, then one Newton step on the live
values, `t* ← t* − (p(t*) − level) / p'(t*)`; since the residual is zero at the root, its derivative is
exactly the implicit-function-theorem derivative `dt*/dp = −(∂p/∂p_) / ṗ`. Peak values use the envelope
theorem (`θ̇ = 0` at the peak) and so need no correction.

The response is normalised per joint, `y = θ / θ_target`, so a fold to −π rises from 0 to 1 as well.

Two situations make a metric jump with the parameters; they are flagged, not hidden (docs/physics.md,
"Response metrics"):
- **Rise time, grazing peak.** The first crossing of the 90 % (or 10 %) level jumps by a whole oscillation
  when a local peak grazes the level. Flagged when a local maximum up to the first one past the crossing
  lies within `graze_tol` of a level and is followed by a dip deeper than `graze_tol` (small ringing
  wiggles on a ramp only move the crossing by a fraction of a wiggle).
- **Settling under quadratic-only drag.** `B θ̇|θ̇|` damps small oscillations ever more weakly (amplitude
  decays like 1/t, not exponentially), so the last exit from the band is late and depends on how long the
  run is. Flagged when the response is outside the band at the end of the run or entered it for good only
  in the last `1 − settle_fraction` of the run (a run at least twice as long as the settling time is
  required to call it well posed).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._validate import is_traced
from ._simulate import Trajectory

_BISECTIONS = 48


def _hermite(s, h, y0, v0, y1, v1):
    """Cubic Hermite value and time derivative at fraction `s` of an interval of length `h`."""
    s2, s3 = s * s, s * s * s
    value = (
        (2 * s3 - 3 * s2 + 1) * y0
        + (s3 - 2 * s2 + s) * h * v0
        + (-2 * s3 + 3 * s2) * y1
        + (s3 - s2) * h * v1
    )
    slope = (
        (6 * s2 - 6 * s) * y0
        + (3 * s2 - 4 * s + 1) * h * v0
        + (-6 * s2 + 6 * s) * y1
        + (3 * s2 - 2 * s) * h * v1
    ) / h
    return value, slope


def _crossing(times, y, v, k, level):
    """Time where the Hermite interpolant on `[times[k], times[k+1]]` equals `level` (a sign change of
    `y − level` over the interval is assumed), differentiable by the implicit function theorem."""
    t0, t1 = times[k], times[k + 1]
    data = (y[k], v[k], y[k + 1], v[k + 1])
    frozen = jax.lax.stop_gradient((t0, t1, *data, level))
    ft0, ft1, fy0, fv0, fy1, fv1, flevel = frozen
    fh = ft1 - ft0
    rising = fy1 >= fy0

    def bisect(_, bracket):
        lo, hi = bracket
        mid = 0.5 * (lo + hi)
        value, _ = _hermite(mid, fh, fy0, fv0, fy1, fv1)
        below = (value < flevel) == rising
        return jnp.where(below, mid, lo), jnp.where(below, hi, mid)

    lo, hi = jax.lax.fori_loop(0, _BISECTIONS, bisect, (jnp.zeros_like(fh), jnp.ones_like(fh)))
    s_root = jax.lax.stop_gradient(0.5 * (lo + hi))
    h = t1 - t0
    value, slope = _hermite(s_root, h, *data)
    safe_slope = jnp.where(slope == 0, 1.0, slope)
    return t0 + s_root * h - (value - level) / safe_slope


def _first_up_crossing(times, y, v, level):
    g = y - level
    mask = (g[:-1] < 0) & (g[1:] >= 0)
    found = jnp.any(mask)
    k = jnp.argmax(mask)
    t = _crossing(times, y, v, k, level)
    return jnp.where(found, t, jnp.nan), found, k


def _peak(times, y, v, a):
    n = y.shape[0]
    k = jnp.argmax(y)
    # The peak lies where θ̇ changes sign next to the largest sample.
    left = jnp.clip(jnp.where(v[k] >= 0, k, k - 1), 0, n - 2)
    interior = (k > 0) & (k < n - 1)
    sign_change = (v[left] >= 0) & (v[left + 1] <= 0)
    refine = interior & sign_change
    t_refined = _crossing(times, v, a, left, 0.0)
    t_peak = jnp.where(refine, t_refined, times[k])
    # Envelope theorem: θ̇ = 0 at the peak, so the value needs no implicit correction.
    t_frozen = jax.lax.stop_gradient(t_peak)
    h = times[left + 1] - times[left]
    s = (t_frozen - times[left]) / h
    value, _ = _hermite(s, h, y[left], v[left], y[left + 1], v[left + 1])
    return t_peak, jnp.where(refine, value, y[k])


def _joint_metrics(times, y, v, a, band, low, high, graze_tol, settle_fraction):
    n = y.shape[0]
    t10, found10, k10 = _first_up_crossing(times, y, v, low)
    t90, found90, k90 = _first_up_crossing(times, y, v, high)
    t_peak, y_peak = _peak(times, y, v, a)

    # Grazing: local maxima up to the first one after the 90 % crossing, close to either level.
    idx = jnp.arange(n)
    local_max = jnp.zeros(n, bool).at[1:-1].set((y[1:-1] >= y[:-2]) & (y[1:-1] > y[2:]))
    after90 = local_max & (idx > k90)
    first_after90 = jnp.where(jnp.any(after90), jnp.argmax(after90), n)
    # Only a peak followed by a real dip can move the first crossing by much: ringing wiggles on a ramp
    # (dips far smaller than `graze_tol`) shift it by a fraction of a wiggle at most.
    local_min = jnp.zeros(n, bool).at[1:-1].set((y[1:-1] <= y[:-2]) & (y[1:-1] < y[2:]))
    next_min = jax.lax.cummin(jnp.where(local_min, idx, n - 1), reverse=True)
    next_min = jnp.concatenate([next_min[1:], jnp.array([n - 1])])
    dips = (y - y[next_min]) > graze_tol
    considered = local_max & dips & (idx <= first_after90)
    grazes_high = considered & (jnp.abs(y - high) < graze_tol)
    grazes_low = considered & (jnp.abs(y - low) < graze_tol) & (idx <= k10 + 1)
    t90_ill = jnp.any(grazes_high) | ~found90
    rise_ill = t90_ill | jnp.any(grazes_low) | ~found10

    # Settling: last exit from the band |y − 1| ≤ band.
    outside = jnp.abs(y - 1.0) > band
    any_outside = jnp.any(outside)
    m = n - 1 - jnp.argmax(outside[::-1])
    settled = ~outside[-1]
    m_safe = jnp.minimum(m, n - 2)
    level = 1.0 + band * jnp.sign(y[m_safe] - 1.0)
    t_exit = _crossing(times, y, v, m_safe, level)
    t_settle = jnp.where(settled, jnp.where(any_outside, t_exit, times[0]), times[-1])
    late = t_settle > times[0] + settle_fraction * (times[-1] - times[0])
    return dict(
        t10=t10,
        t90=t90,
        rise_time=t90 - t10,
        rise_ill_conditioned=rise_ill,
        t90_ill_conditioned=t90_ill,
        peak_time=t_peak,
        peak_value=y_peak,
        overshoot=100.0 * jnp.maximum(y_peak - 1.0, 0.0),
        settling_time=t_settle,
        settled=settled,
        settling_ill_posed=~settled | late,
    )


class ResponseMetrics(eqx.Module):
    """Per-joint response metrics, each shape `(n,)`; times in the trajectory's units (MICRO: µs).

    **Fields:**
    - `rise_time`: `t90 − t10`, first crossings of `low` and `high` (default 10 % and 90 %) of the target;
      NaN when a level is never reached (then `rise_ill_conditioned` is set).
    - `t10`, `t90`: the two crossing times.
    - `rise_ill_conditioned`: a local peak grazes a level (within `graze_tol`), so the first-crossing rise
      time can jump by an oscillation under a small parameter change; or a level was not reached.
    - `t90_ill_conditioned`: the same for `t90` alone (the `high` level grazed or never reached).
    - `overshoot`: percent above the target at the highest peak (0 when never above).
    - `peak_time`, `peak_value`: time and normalised value `θ/θ_target` of the highest peak (the last
      sample when the response is still rising at the end).
    - `settling_time`: last entry into the band `|θ/θ_target − 1| ≤ band` (the run's end when not settled).
    - `settled`: inside the band at the end of the run.
    - `settling_ill_posed`: not settled, or settled only in the last `1 − settle_fraction` of the run.
    - `final_error`: `θ(t_end) − θ_target`, rad.
    - `target`: the target angles, rad.
    - `band`: the settling band (fraction of the target).
    """

    rise_time: Float[Array, " n"]
    t10: Float[Array, " n"]
    t90: Float[Array, " n"]
    rise_ill_conditioned: Bool[Array, " n"]
    t90_ill_conditioned: Bool[Array, " n"]
    overshoot: Float[Array, " n"]
    peak_time: Float[Array, " n"]
    peak_value: Float[Array, " n"]
    settling_time: Float[Array, " n"]
    settled: Bool[Array, " n"]
    settling_ill_posed: Bool[Array, " n"]
    final_error: Float[Array, " n"]
    target: Float[Array, " n"]
    band: float = eqx.field(static=True, default=0.02)

    def as_dict(self) -> dict[str, list]:
        """Plain Python lists per field (for JSON)."""
        out = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            out[name] = value if isinstance(value, float) else jnp.asarray(value).tolist()
        return out


def response_metrics(
    trajectory: Trajectory,
    *,
    band: float = 0.02,
    low: float = 0.1,
    high: float = 0.9,
    graze_tol: float = 0.02,
    settle_fraction: float = 0.5,
) -> ResponseMetrics:
    """Rise time, overshoot, peak time, settling time and final error of each joint of `trajectory`.

    **Arguments:**
    - `trajectory`: from [`origami_jax.simulation.simulate`][]; its `target` sets 100 %.
    - `band`: settling band as a fraction of the target (default 2 %).
    - `low`, `high`: rise-time levels (default 10 % and 90 %).
    - `graze_tol`: how close (fraction of the target) a local peak may come to a level before the rise
      time is flagged ill-conditioned.
    - `settle_fraction`: the settling time is flagged ill-posed when later than this fraction of the run.

    **Returns:** a [`origami_jax.simulation.ResponseMetrics`][]. Differentiable with respect to anything the
    trajectory depends on (flags and crossing indices carry no gradient).

    **Raises:** `ValueError` when a joint's target is 0 (the metrics are fractions of it); under
    `jit` or `vmap`, where the target is traced, the same check runs in the compiled program.
    `ValueError` for a trajectory solved without its accelerations (`SaveAt(accelerations=False)`).
    """
    message = "response_metrics: a joint's target is 0; the metrics are fractions of the target."
    accelerations = trajectory.theta_ddot
    if not is_traced(accelerations, trajectory.theta) and _left_out(
        np.asarray(accelerations), np.asarray(trajectory.theta)
    ):
        raise ValueError(
            "response_metrics needs the trajectory's accelerations, which this solve did not "
            "compute: simulate with SaveAt(accelerations=True) (the default)."
        )
    if is_traced(trajectory.target):
        return _metrics(trajectory, band, low, high, graze_tol, settle_fraction, message)
    if np.any(np.asarray(trajectory.target) == 0):
        raise ValueError(message)
    # Checked here, the compiled program has no runtime check: no callback into Python, so the
    # compilation cache can keep it between processes.
    return _metrics(trajectory, band, low, high, graze_tol, settle_fraction, None)


def _left_out(accelerations: np.ndarray, theta: np.ndarray) -> bool:
    """Whether a trajectory's accelerations were not computed (`SaveAt(accelerations=False)`): NaN
    at every sample where the solve succeeded (its rows past a failure are inf either way)."""
    solved = np.isfinite(theta)
    return bool(np.any(solved)) and bool(np.all(np.isnan(accelerations[solved])))


@eqx.filter_jit
def _metrics(trajectory, band, low, high, graze_tol, settle_fraction, message: str | None):
    target = trajectory.target
    if message is not None:
        target = eqx.error_if(target, jnp.any(target == 0), message)
    y = trajectory.theta / target
    v = trajectory.theta_dot / target
    a = trajectory.theta_ddot / target
    per_joint = jax.vmap(_joint_metrics, in_axes=(None, 1, 1, 1, None, None, None, None, None))(
        trajectory.times, y, v, a, band, low, high, graze_tol, settle_fraction
    )
    return ResponseMetrics(
        **per_joint,
        final_error=trajectory.theta[-1] - target,
        target=target,
        band=band,
    )
