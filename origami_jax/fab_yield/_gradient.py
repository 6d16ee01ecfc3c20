"""The yield's gradient with respect to the nominal values of the scattered parameters, by the
score-function (likelihood-ratio) estimator: no derivative of any simulation, so it holds with
contact, jams and misfolds, and it is unbiased for the Monte Carlo yield itself.

If a parameter ``x`` is drawn from a density ``p(x; μ)`` around its nominal value ``μ``, the
yield ``Y(μ) = E[f(x)]`` (``f`` = 1 for a folded sample, 0 otherwise) has the derivative

    dY/dμ = E[f(x) ∂ ln p(x; μ)/∂μ]

(differentiate the integral ``∫ f(x) p(x; μ) dx`` under the sign; ``f`` need not be smooth,
only ``p``). With the standard draws ``z`` of `Scatter` the scores are

| spread | ``x`` | ``∂ ln p / ∂μ`` |
|---|---|---|
| normal, absolute | ``μ + w z`` | ``z / w`` |
| normal, relative | ``μ (1 + w z)`` | ``((z² − 1) + z / w) / μ`` |
| lognormal | ``μ exp(w z)`` | ``z / (w μ)`` |

A uniform spread has none (its support moves with ``μ``): its gradient is refused. The mean of
``(f_i − b_i) s_i`` over the samples estimates the gradient, with ``b_i`` the yield of the *other*
samples (a baseline that keeps the estimate unbiased, ``E[s] = 0``, and removes most of its variance
when the yield is near 0 or 1); its standard error is the sample standard deviation of those terms
over ``√n``.
"""

import dataclasses

import numpy as np

from ..simulation import VERDICT_CODES, FoldVerdict
from ._scatter import PARAMETERS, Spread, standard_draws


@dataclasses.dataclass(frozen=True)
class YieldGradient:
    """The derivative of the yield with respect to one parameter's nominal value.

    **Fields:**
    - `parameter`: the name (`PARAMETERS`).
    - `per`: `"crease"`: `gradient` is `(m,)`, ``dY/dμ_j`` for each crease's nominal ``μ_j`` in
      `unit`; `"net"` (one draw shared by every crease): `gradient` is a scalar, the derivative
      along all creases' nominal values moved together: per unit relative change (``dY/d ln μ``)
      for a relative spread, per `unit` of a common shift for an absolute one.
    - `gradient`, `standard_error`: the estimate and its standard error (same shape). The
      estimate's error is about normal for a few tens of samples or more.
    - `unit`: what `gradient` is per, in the units of `PARAMETERS` (e.g. `"1/um"`: per µm).
    - `n_samples`.
    """

    parameter: str
    per: str
    gradient: np.ndarray | float
    standard_error: np.ndarray | float
    unit: str
    n_samples: int

    def summary(self) -> str:
        """One line for people."""
        values = np.atleast_1d(self.gradient)
        errors = np.atleast_1d(self.standard_error)
        body = ", ".join(f"{g:+.3g} ± {e:.2g}" for g, e in zip(values, errors, strict=True))
        return f"d yield / d {self.parameter} ({self.per}, {self.unit}): {body}"


def score(spread: Spread, z: np.ndarray, nominal: np.ndarray) -> np.ndarray:
    """``∂ ln p(x; μ)/∂μ`` of the draws ``x = spread.transform(μ, z)`` (module docstring), shape of
    `z` `(n, m)`; `nominal` `(m,)`. For a per-net spread pass the one shared column of `z` and
    `nominal` = 1 (relative) to get the score along the relative change of every crease's nominal.

    **Raises:** `ValueError` for a uniform spread or a zero width (no density to differentiate).
    """
    w = spread.width
    if spread.distribution == "uniform":
        raise ValueError(
            "a uniform spread has no score function (its support moves with the nominal value); "
            "use a normal or lognormal spread for the parameters you want the gradient of."
        )
    if w == 0:
        raise ValueError("a parameter without scatter (width 0) has no yield gradient estimate.")
    nominal = np.asarray(nominal, dtype=float)
    if spread.distribution == "lognormal":
        return z / (w * nominal)
    if not spread.relative:
        return z / w
    return ((z * z - 1) + z / w) / nominal


def score_gradient(
    folded: np.ndarray, scores: np.ndarray
) -> tuple[np.ndarray | np.floating, np.ndarray | np.floating]:
    """The score-function estimate of ``dY/dμ`` and its standard error from each sample's outcome
    `folded` `(n,)` (1 or 0) and scores `(n, ...)` (`score`), with the leave-one-out baseline."""
    f = np.asarray(folded, dtype=float)
    n = len(f)
    if n < 2:
        raise ValueError(f"a gradient estimate needs at least 2 samples, got {n}.")
    baseline = (np.sum(f) - f) / (n - 1)
    terms = (f - baseline).reshape((n,) + (1,) * (scores.ndim - 1)) * scores
    return np.mean(terms, axis=0), np.std(terms, axis=0, ddof=1) / np.sqrt(n)


def yield_gradient(estimate, parameters=None) -> dict[str, YieldGradient]:
    """The yield's gradient with respect to the nominal values of the scattered parameters, from the
    samples of a `YieldEstimate` (module docstring: the score-function estimator). No simulation
    runs: it reweights the samples the estimate already has, contact and all.

    This answers "which way should the process or the drawing move?": e.g. a positive
    `misfit_strain` gradient says nets of this design fold more often with a more stressed film.
    Its noise is the Monte Carlo's (`standard_error`); compare gradients larger than about two
    standard errors.

    **Arguments:** `estimate` from `yield_estimate`; `parameters` the names to differentiate
    (default: every parameter with a normal or lognormal spread of non-zero width).

    **Returns:** `{name: YieldGradient}`.

    **Raises:** `ValueError` for a parameter that is unknown, not scattered or uniformly scattered,
    or an estimate without its nominal values (built by hand).
    """
    nominal = getattr(estimate, "nominal", None)
    if nominal is None:
        raise ValueError("the estimate has no nominal values; use one from yield_estimate.")
    active = estimate.scatter.active()
    if parameters is None:
        names = [n for n, s in active.items() if s.distribution != "uniform"]
    else:
        names = [parameters] if isinstance(parameters, str) else list(parameters)
        for name in names:
            if name not in PARAMETERS:
                raise ValueError(
                    f"unknown parameter {name!r}; the known ones are {list(PARAMETERS)}."
                )
            if name not in active:
                raise ValueError(
                    f"{name} is not scattered in this estimate (width 0): no gradient."
                )
    m = len(next(iter(nominal.values())))
    draws = standard_draws(estimate.seed, estimate.n_samples, m)
    codes = np.asarray(estimate.dataset["verdict"].values)
    folded = codes == VERDICT_CODES[FoldVerdict.FOLDED]
    out = {}
    for name in names:
        spread = active[name]
        unit = PARAMETERS[name][0]
        if spread.per == "net":
            # Lognormal spreads are always relative (`Spread`).
            scores = score(spread, draws[name][:, 0], np.asarray(1.0))
            unit = "per unit relative change of every nominal" if spread.relative else f"1/{unit}"
        else:
            scores = score(spread, draws[name], nominal[name])
            unit = "1" if unit == "1" else f"1/{unit}"
        gradient, error = score_gradient(folded, scores)
        out[name] = YieldGradient(
            parameter=name,
            per=spread.per,
            gradient=gradient,
            standard_error=error,
            unit=unit,
            n_samples=estimate.n_samples,
        )
    return out
