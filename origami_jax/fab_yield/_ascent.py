"""Maximising the Monte Carlo yield over the fabrication's nominal values: stochastic gradient ascent
along the score-function gradient (`yield_gradient`), one yield estimate per iteration.

Each iteration estimates the yield at the current nominal values (`yield_estimate(...,
process=...)`), takes its gradient from the same samples (nothing is differentiated through a
simulation, so contact, jams and misfolds are fine) and steps:

- **in spread widths.** Every parameter is moved in the coordinate its spread is drawn in, measured
  in units of the spread's width ``w``: ``ln μ`` for a relative spread (normal or lognormal; one
  width is the relative standard deviation), ``μ`` for an absolute one. So the gradient's
  components are comparable across parameters (each is "yield per one standard deviation of the
  fabrication"), and the step cannot outrun what the estimate sees: the Monte Carlo yield is the
  pass/fail rule averaged over the spread's density, so it varies on the scale of one width and the
  gradient measured at ``μ`` describes it over a fraction of one.
- **a trust region, not the raw gradient.** The component with the largest gradient moves by
  `step` widths (default 0.5: the nets drawn after the step overlap most of those drawn before it,
  so the gradient that chose the direction still holds; 1 width or more can jump over a narrow
  optimum), the others in proportion. The raw gradient's size is a poor step length: it ranges over
  orders of magnitude between a yield near 0 and one near ½, and near 0 or 1 it is mostly noise.
- **shrunk by its significance.** Each component ``g`` with standard error ``s`` is first
  multiplied by ``max(0, 1 − s²/g²)`` (positive-part James–Stein shrinkage: a component within one
  standard error of zero does not move, one at 2 standard errors moves 75 %), so noise in the
  parameters that do not matter does not random-walk them.
- **halved when the yield fell.** With common random numbers (below) a lower yield than the
  previous iterate's is a comparison on the same fabricated nets: the step overshot, and the next
  one is half as long (a fixed normalised step would oscillate about the optimum).
- **within bounds.** The new values are clipped into `bounds`; a component already at its bound
  and pushing against it is left out (so it does not shrink the others' steps); a positive
  parameter's absolute step at most halves it.

It stops after `steps` steps, or when no component's gradient is larger than `significance` (2)
standard errors (no direction is supported by the samples: at an optimum, or where every sample
folds or every sample fails and the estimator is exactly 0), or when every move is blocked by the
bounds.

**Common random numbers.** By default every iteration uses the same seed, so the same standard
draws: the nets at iteration ``k`` are the nets at iteration 0 with their nominal values moved. Two
iterates' yields are then a paired comparison (`YieldAscent.paired`: the samples gained and lost,
McNemar's exact test), the yield along the path changes only where the design did, and the halving
rule above reacts to the design rather than to resampling noise. The price: the ascent climbs the
yield of these `n_samples` nets, and the best iterate (chosen among noisy estimates of the same
nets) is biased upwards: re-estimate it on fresh draws (`confirm_samples`) before quoting it.
`fresh_draws=True` uses a new seed every iteration instead (plain stochastic gradient ascent, no
pairing).
"""

import dataclasses
import math
import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ..simulation import VERDICT_CODES, FoldVerdict
from ..system import KOH_SOLUTION, HingeDesign
from ._estimate import (
    _GLOBAL,
    RunOptions,
    YieldEstimate,
    _nominal,
    _process,
    as_pattern,
    yield_estimate,
)
from ._gradient import YieldGradient, yield_gradient
from ._scatter import PARAMETERS, Scatter, Spread


@dataclasses.dataclass(frozen=True)
class AscentIterate:
    """One iteration of `yield_ascent`.

    **Fields:**
    - `nominal`: the moved parameters' nominal values here, `{name: (m,)}` (µm, µs, 1).
    - `estimate`: the `YieldEstimate` at those values (its `fraction`, `interval`, `counts`,
      `seed`, samples).
    - `gradient`: `{name: YieldGradient}` from the estimate's samples.
    - `step`: the trust region used to leave this iterate, in spread widths (0 for the last).
    """

    nominal: dict[str, np.ndarray]
    estimate: YieldEstimate
    gradient: dict[str, YieldGradient]
    step: float


@dataclasses.dataclass(frozen=True)
class YieldAscent:
    """The iterations of `yield_ascent` (or `ascend`) and the best of them.

    **Fields:**
    - `parameters`: the moved parameters' names.
    - `iterates`: the `AscentIterate`s, the start first.
    - `best`: the index of the iterate with the highest lower confidence limit of the yield (the
      highest yield when every iterate has the same number of samples; the earliest of equals).
      Its yield is the best of several noisy estimates, so biased upwards; `confirmation` is the
      honest figure.
    - `confirmation`: the best iterate re-estimated on fresh draws (`confirm_samples`), or `None`.
    - `stopped`: why the ascent stopped, for people.
    - `common_random_numbers`: whether every iterate used the same draws.
    """

    parameters: tuple[str, ...]
    iterates: tuple[AscentIterate, ...]
    best: int
    confirmation: YieldEstimate | None
    stopped: str
    common_random_numbers: bool

    @property
    def yields(self) -> np.ndarray:
        """Each iterate's Monte Carlo yield, `(k,)`."""
        return np.array([it.estimate.fraction for it in self.iterates])

    @property
    def intervals(self) -> np.ndarray:
        """Each iterate's confidence interval, `(k, 2)`."""
        return np.array([it.estimate.interval for it in self.iterates], dtype=float)

    def path(self, name: str) -> np.ndarray:
        """A moved parameter's nominal values along the ascent, `(k, m)`."""
        if name not in self.parameters:
            raise ValueError(f"{name!r} was not moved; the moved ones are {list(self.parameters)}.")
        return np.stack([it.nominal[name] for it in self.iterates])

    def paired(self, a: int = 0, b: int | None = None) -> dict[str, Any]:
        """Iterate `b` (default the best) against iterate `a` (default the start) on the same
        fabricated nets: the samples that fold at `b` but not at `a` (`gained`), the reverse
        (`lost`), and McNemar's exact two-sided p-value (a binomial test of the discordant pairs;
        McNemar, Psychometrika 12, 1947), the chance of a split at least this uneven if the two
        designs had the same yield. Needs common random numbers.

        **Raises:** `ValueError` when the two iterates were not estimated on the same draws.
        """
        from scipy.stats import binomtest

        b = self.best if b is None else b
        first, second = self.iterates[a].estimate, self.iterates[b].estimate
        if (first.seed, first.n_samples) != (second.seed, second.n_samples):
            raise ValueError(
                "the two iterates were estimated on different draws (fresh_draws=True): compare "
                "their intervals instead."
            )
        code = VERDICT_CODES[FoldVerdict.FOLDED]
        f0 = np.asarray(first.dataset["verdict"].values) == code
        f1 = np.asarray(second.dataset["verdict"].values) == code
        gained, lost = int(np.sum(f1 & ~f0)), int(np.sum(f0 & ~f1))
        p = binomtest(gained, gained + lost, 0.5).pvalue if gained + lost else 1.0
        return {"gained": gained, "lost": lost, "p_value": float(p)}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: every iterate's nominal values, yield, interval, counts and gradient, the
        best, the confirmation and why it stopped (no samples)."""
        rows = []
        for it in self.iterates:
            e = it.estimate
            rows.append(
                {
                    "nominal": {k: v.tolist() for k, v in it.nominal.items()},
                    "yield": e.fraction,
                    "interval": list(e.interval),
                    "counts": dict(e.counts),
                    "n_samples": e.n_samples,
                    "seed": e.seed,
                    "gradient": {
                        k: {
                            "per": g.per,
                            "unit": g.unit,
                            "gradient": np.asarray(g.gradient).tolist(),
                            "standard_error": np.asarray(g.standard_error).tolist(),
                        }
                        for k, g in it.gradient.items()
                    },
                    "step_widths": it.step,
                }
            )
        out = {
            "parameters": list(self.parameters),
            "iterations": rows,
            "best": self.best,
            "stopped": self.stopped,
            "common_random_numbers": self.common_random_numbers,
            "confirmation": None if self.confirmation is None else self.confirmation.to_dict(),
        }
        if self.common_random_numbers and len(self.iterates) > 1:
            out["best_vs_start"] = self.paired()
        return out

    def summary(self) -> str:
        """A line per iterate (yield, interval, nominal values, the largest gradient in standard
        errors), the best, the paired comparison with the start and the confirmation."""
        lines = []
        for k, it in enumerate(self.iterates):
            e = it.estimate
            low, high = e.interval
            values = "; ".join(
                f"{n} " + ", ".join(f"{v:.4g}" for v in _distinct(it.nominal[n]))
                for n in self.parameters
            )
            lines.append(
                f"{k:>3}: yield {e.fraction:.3f} [{low:.3f}, {high:.3f}]  {values}  "
                f"|g|/SE max {_largest_t(it.gradient):.1f}"
                + ("  <- best" if k == self.best else "")
            )
        lines.append(f"stopped: {self.stopped}")
        best = self.iterates[self.best].estimate
        if self.common_random_numbers and self.best > 0:
            p = self.paired()
            lines.append(
                f"best vs start on the same {best.n_samples} nets: {p['gained']} gained, "
                f"{p['lost']} lost (McNemar exact p = {p['p_value']:.2g})"
            )
        if self.confirmation is None:
            lines.append(
                f"best yield {best.fraction:.3f} is the best of {len(self.iterates)} noisy "
                "estimates (biased upwards): re-estimate it on fresh draws (confirm_samples)."
            )
        else:
            c = self.confirmation
            lines.append(
                f"best re-estimated on fresh draws (seed {c.seed}): yield {c.fraction:.3f} "
                f"[{c.interval[0]:.3f}, {c.interval[1]:.3f}] over {c.n_samples} samples"
            )
        return "\n".join(lines)


def _distinct(values: np.ndarray) -> np.ndarray:
    """One value when every crease has the same, else all of them."""
    values = np.asarray(values)
    return values[:1] if np.all(values == values[0]) else values


def _largest_t(gradient: Mapping[str, YieldGradient]) -> float:
    t = [_t(g.gradient, g.standard_error) for g in gradient.values()]
    return float(max((np.max(x) for x in t), default=0.0))


def _t(g, se) -> np.ndarray:
    """|g| / SE, 0 where both are 0 (no sample on one side: no information)."""
    g, se = np.abs(np.atleast_1d(g)), np.atleast_1d(se)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(se > 0, g / np.where(se > 0, se, 1.0), np.where(g > 0, np.inf, 0.0))


def _relative(spread: Spread) -> bool:
    return spread.distribution == "lognormal" or bool(spread.relative)


def _number(value, name: str, *, low: float, strict: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(f"{name} must be a number, got {value!r}.")
    value = float(value)
    if not math.isfinite(value) or (value <= low if strict else value < low):
        raise ValueError(
            f"{name} must be finite and {'>' if strict else '>='} {low:g}, got {value}."
        )
    return value


def check_ascent(
    scatter: Scatter,
    parameters: str | Sequence[str],
    start: Mapping[str, np.ndarray],
    *,
    steps: int,
    step: float,
    significance: float,
    bounds: Mapping[str, Any] | None,
) -> tuple[tuple[str, ...], dict[str, tuple[float, float]]]:
    """The checked parameter names and bounds of an ascent (before anything compiles): every name
    known, scattered by a normal or lognormal spread of non-zero width, `steps` an integer >= 1,
    `step` > 0, `significance` >= 0, bounds `(low, high)` with ``low < high`` around every crease's
    start. Default bounds: ``(0, ∞)`` (release times ``[0, ∞)``).

    **Raises:** `ValueError`, one line saying what to change."""
    names = (parameters,) if isinstance(parameters, str) else tuple(parameters)
    if not names:
        raise ValueError("give at least one parameter to move, e.g. parameters='misfit_strain'.")
    if len(set(names)) != len(names):
        raise ValueError(f"parameters name one twice: {list(names)}.")
    for name in names:
        if name not in PARAMETERS:
            raise ValueError(f"unknown parameter {name!r}; the known ones are {list(PARAMETERS)}.")
        spread = getattr(scatter, name)
        if spread.width == 0:
            raise ValueError(
                f"{name} does not scatter (width 0), so the samples say nothing about moving it: "
                f"give it a normal or lognormal spread, e.g. Spread('normal', 0.01)."
            )
        if spread.distribution == "uniform":
            raise ValueError(
                f"{name} has a uniform spread, which has no score function (its support moves "
                "with the nominal value): use a normal spread (a uniform half-width a has the "
                "standard deviation a/√3)."
            )
        if name == "release" and _relative(spread):
            raise ValueError(
                "release with a relative spread cannot leave nominal times of 0: give it an "
                "absolute width in µs (relative = false)."
            )
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1:
        raise ValueError(f"steps (the step budget) must be an integer >= 1, got {steps!r}.")
    _number(step, "step (the trust region, in spread widths)", low=0.0, strict=True)
    _number(significance, "significance (in standard errors)", low=0.0, strict=False)
    bounds = {} if bounds is None else bounds
    if not isinstance(bounds, Mapping):
        raise ValueError(f"bounds must be a mapping name -> (low, high), got {bounds!r}.")
    stray = sorted(set(bounds) - set(names))
    if stray:
        raise ValueError(f"bounds for {stray}, which are not moved; moved: {list(names)}.")
    out = {}
    for name in names:
        pair = bounds.get(name, (0.0, math.inf))
        try:
            low, high = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise ValueError(f"bounds of {name} must be (low, high), got {pair!r}.") from None
        if math.isnan(low) or math.isnan(high) or not low < high:
            raise ValueError(f"bounds of {name} must have low < high, got ({low}, {high}).")
        x0 = np.asarray(start[name], dtype=float)
        positive = name != "release"
        inside = (x0 > low if positive and low <= 0 else x0 >= low) & (x0 <= high)
        if not np.all(inside):
            raise ValueError(
                f"the start of {name} {x0.tolist()} is not inside its bounds ({low:g}, {high:g}): "
                "widen the bounds or start inside them (process=, release_times=)."
            )
        out[name] = (low, high)
    return names, out


def _direction(
    scatter: Scatter, names, nominal: Mapping[str, np.ndarray], gradient
) -> dict[str, np.ndarray]:
    """Each parameter's gradient in its spread coordinate per spread width (`_ascent` docstring),
    shrunk by its significance, `(m,)` per crease or `(1,)` per net."""
    out = {}
    for name in names:
        spread = getattr(scatter, name)
        g = np.atleast_1d(np.asarray(gradient[name].gradient, dtype=float))
        se = np.atleast_1d(np.asarray(gradient[name].standard_error, dtype=float))
        scale = spread.width * np.ones_like(g)
        if spread.per == "crease" and _relative(spread):
            scale = scale * nominal[name]  # dY/d ln μ = μ dY/dμ
        t = np.maximum(_t(g, se), 1.0)  # below 1 standard error: no move
        shrink = 1.0 - 1.0 / t**2
        out[name] = scale * g * shrink
    return out


def _move(spread: Spread, name: str, x: np.ndarray, d: np.ndarray, bound) -> np.ndarray:
    """`x` moved by `d` spread widths (`(m,)` or `(1,)`, broadcast), clipped into `bound`."""
    low, high = bound
    if _relative(spread):
        new = x * np.exp(spread.width * d)
    else:
        new = x + spread.width * d
        if name != "release":
            new = np.maximum(new, 0.5 * x)  # a positive value is at most halved
    return np.clip(new, low, high)


@dataclasses.dataclass(frozen=True)
class AscentSettings:
    """How a yield ascent steps and when it stops (`ascend`, `yield_ascent`; module docstring).

    **Fields:**
    - `steps`: the step budget (5); `step`: the trust region in spread widths (0.5);
      `significance`: stop when no gradient component exceeds this many standard errors (2).
    - `bounds`: `{name: (low, high)}` in the parameter's unit, for every crease (default
      ``(0, ∞)``; release times ``[0, ∞)``).
    - `fresh_draws`: a new seed every iteration (plain stochastic gradient ascent) instead of the
      same draws (common random numbers; default).
    - `confirm_samples`, `confirm_seed`: re-estimate the best iterate with this many samples on a
      seed no iterate used (default the next one after them); 0 (default) skips it.
    - `confidence`, `interval`: the level and method of the yield's interval in `yield_ascent`'s
      estimates (`YieldEstimate.with_interval`; 0.95, `"wilson"`): the best iterate is the one
      with the highest lower limit.

    Checked by `ascend` before any estimate (`check_ascent`).
    """

    steps: int = 5
    step: float = 0.5
    significance: float = 2.0
    bounds: Mapping[str, Any] | None = None
    fresh_draws: bool = False
    confirm_samples: int = 0
    confirm_seed: int | None = None
    confidence: float = 0.95
    interval: str = "wilson"


def ascend(
    estimate_at: Callable[[dict[str, np.ndarray], int, int, str], YieldEstimate],
    start: Mapping[str, Any],
    scatter: Scatter,
    parameters: str | Sequence[str],
    n_samples: int,
    seed: int = 0,
    *,
    settings: AscentSettings | None = None,
) -> YieldAscent:
    """Stochastic gradient ascent of a Monte Carlo yield over nominal values, with any estimator:
    the loop of `yield_ascent` (module docstring), which builds `estimate_at` from
    `yield_estimate`. Use it to drive another Monte Carlo (or a synthetic yield, as the tests do).

    **Arguments:**
    - `estimate_at(nominal, seed, n_samples, label)`: the yield estimate with every parameter's
      nominal values `nominal` (`{name: (m,)}` for every name of `PARAMETERS`) on the draws of
      `seed` (`label`: `"iterate-00"`, ..., or `"confirmation"`, e.g. a folder name); it must
      return a `YieldEstimate` whose `nominal`, `seed`, `n_samples`, `scatter` and
      `dataset["verdict"]` are those of its samples (what `yield_gradient` reads).
    - `start`: the nominal values to start from, `{name: (m,)}` for every parameter.
    - `scatter`: the `Scatter` the estimates draw from; `parameters`: the names to move (one or
      several), each with a normal or lognormal spread.
    - `n_samples`, `seed`: per iteration; iteration ``k`` uses `seed` (or ``seed + k`` with
      `fresh_draws`).
    - `settings`: an `AscentSettings` (the step budget, trust region, significance, bounds,
      fresh draws and the confirmation; default `AscentSettings()`).

    **Returns:** a `YieldAscent`.

    **Raises:** `ValueError` (before any estimate) as `check_ascent`, and for `n_samples` < 2 or a
    negative `confirm_samples`.
    """
    settings = AscentSettings() if settings is None else settings
    if not isinstance(settings, AscentSettings):
        raise ValueError(f"settings must be an AscentSettings, got {type(settings).__name__}.")
    steps, step, significance = settings.steps, settings.step, settings.significance
    bounds, fresh_draws = settings.bounds, settings.fresh_draws
    confirm_samples, confirm_seed = settings.confirm_samples, settings.confirm_seed
    if isinstance(n_samples, bool) or not isinstance(n_samples, int | np.integer) or n_samples < 2:
        raise ValueError(f"n_samples must be an integer >= 2 (for a gradient), got {n_samples!r}.")
    if (
        isinstance(confirm_samples, bool)
        or not isinstance(confirm_samples, int | np.integer)
        or confirm_samples < 0
    ):
        raise ValueError(f"confirm_samples must be an integer >= 0, got {confirm_samples!r}.")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}.")
    if confirm_seed is not None:
        last = int(seed) + (int(steps) if fresh_draws else 0)
        if isinstance(confirm_seed, bool) or not isinstance(confirm_seed, int | np.integer):
            raise ValueError(f"confirm_seed must be an integer >= 0, got {confirm_seed!r}.")
        if int(seed) <= confirm_seed <= last or confirm_seed < 0:
            raise ValueError(
                f"confirm_seed {confirm_seed} is one the iterates may use ({seed}-{last}) or "
                "negative: give another (fresh draws are the point of the confirmation)."
            )
    missing = sorted(set(PARAMETERS) - set(start))
    if missing:
        raise ValueError(f"start lacks nominal values of {missing}.")
    nominal = {n: np.array(start[n], dtype=float) for n in PARAMETERS}
    names, limits = check_ascent(
        scatter,
        parameters,
        nominal,
        steps=steps,
        step=step,
        significance=significance,
        bounds=bounds,
    )
    iterates: list[AscentIterate] = []
    trust = float(step)
    stopped = f"the step budget ({steps} steps) is spent"
    for k in range(int(steps) + 1):
        draw_seed = int(seed) + (k if fresh_draws else 0)
        current = {n: v.copy() for n, v in nominal.items()}
        estimate = estimate_at(current, draw_seed, int(n_samples), f"iterate-{k:02d}")
        gradient = yield_gradient(estimate, list(names))
        here = {n: nominal[n].copy() for n in names}
        if iterates and estimate.fraction < iterates[-1].estimate.fraction:
            trust /= 2
        if k == int(steps):
            iterates.append(AscentIterate(here, estimate, gradient, 0.0))
            break
        if _largest_t(gradient) <= significance:
            iterates.append(AscentIterate(here, estimate, gradient, 0.0))
            if estimate.fraction in (0.0, 1.0):
                every = "failed" if estimate.fraction == 0.0 else "folded"
                stopped = (
                    f"every sample {every} at iterate {k}: the samples show no direction (widen the "
                    "scatter or start elsewhere)"
                )
            else:
                stopped = (
                    f"no gradient component above {significance:g} standard errors at iterate {k} "
                    "(an optimum within the noise; more samples resolve it further)"
                )
            break
        direction = _direction(scatter, names, nominal, gradient)
        for name in names:  # a component pushing against its bound does not set the scale
            low, high = limits[name]
            d, x = direction[name], nominal[name]
            at_bound = (d < 0) & (x <= low) | (d > 0) & (x >= high)  # (m,), or (1,) vs (m,)
            if d.shape != x.shape:  # one move for every crease: blocked if any crease is
                at_bound = np.any(at_bound, keepdims=True)
            direction[name] = np.where(at_bound, 0.0, d)
        largest = max(float(np.max(np.abs(d))) for d in direction.values())
        if largest == 0:
            iterates.append(AscentIterate(here, estimate, gradient, 0.0))
            stopped = f"every supported move is blocked by the bounds at iterate {k}"
            break
        moved = {}
        for name in names:
            d = trust * direction[name] / largest
            moved[name] = _move(getattr(scatter, name), name, nominal[name], d, limits[name])
        iterates.append(AscentIterate(here, estimate, gradient, trust))
        if all(np.array_equal(moved[n], nominal[n]) for n in names):
            stopped = f"every move is blocked by the bounds at iterate {k}"
            break
        nominal.update(moved)
    best = max(
        range(len(iterates)),
        key=lambda i: (iterates[i].estimate.interval[0], iterates[i].estimate.fraction, -i),
    )
    confirmation = None
    if confirm_samples:
        used = int(seed) + (len(iterates) - 1 if fresh_draws else 0)
        fresh = used + 1 if confirm_seed is None else int(confirm_seed)
        at_best = {n: v.copy() for n, v in nominal.items()}
        at_best.update({n: iterates[best].nominal[n].copy() for n in names})
        confirmation = estimate_at(at_best, fresh, int(confirm_samples), "confirmation")
    return YieldAscent(
        parameters=names,
        iterates=tuple(iterates),
        best=best,
        confirmation=confirmation,
        stopped=stopped,
        common_random_numbers=not fresh_draws,
    )


def yield_ascent(
    pattern,
    parameters: str | Sequence[str],
    scatter: Scatter | Mapping[str, Any] | None = None,
    n_samples: int = 64,
    seed: int = 0,
    *,
    settings: AscentSettings | None = None,
    design=None,
    process: Mapping[str, Any] | None = None,
    release_times=None,
    first: YieldEstimate | None = None,
    run: RunOptions | None = None,
    **options: Any,
) -> YieldAscent:
    """Raise a net's Monte Carlo yield by moving the fabrication's nominal values of `parameters`
    (film misfit strain, i.e. stress; film and membrane thicknesses; hinge widths; release times)
    along the yield's score-function gradient (module docstring: the step rule, the stopping rule,
    common random numbers).

    Each iteration is one `yield_estimate(net, scatter, n_samples, seed, process=..., ...)` at the
    current nominal values (the hinge lengths stay the design's, as drawn), `yield_gradient` of it,
    and a step of at most `step` spread widths. The compiled kernel is shared: nominal values are
    data, so the ascent costs one compilation and ``(iterations + 1) · n_samples`` simulations (plus
    `confirm_samples`).

    ```python
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    film = ojy.Scatter.from_mapping({"defaults": False, "misfit_strain": {"width": 0.01}})
    ascent = ojy.yield_ascent(
        "corner_cube", "misfit_strain", film, n_samples=32, design=design,
        settings=ojy.AscentSettings(steps=4, step=1.0, confirm_samples=32),
        process={"misfit_strain": 0.97 * float(design.misfit_strain)},  # a film 3 % too relaxed
        tolerances=VerdictTolerances(seam=0.05),
    )
    print(ascent.summary())
    ```

    **Arguments** (µm, µs: the MICRO units):
    - `pattern` (a net: a tree of panels, or its name), `scatter`, `design` and `options`
      (`targets`, `solve`, `tolerances`): as `yield_estimate`.
    - `run`: as `yield_estimate`'s, its `out` holding one subfolder per iterate (`iterate-00`,
      ..., and `confirmation`); an ascent cannot `resume`.
    - `parameters`: the name(s) to move (`PARAMETERS`), each scattered by a normal or lognormal
      spread of non-zero width in `scatter`. `release` moves the nominal release times (per crease;
      an absolute normal spread, in µs).
    - `process`, `release_times`: the start (default the design's values, release at 0); the
      parameters not moved keep them throughout.
    - `n_samples`, `seed`, `settings` (an `AscentSettings`): as `ascend`.
    - `first`: an estimate already made at the start (same scatter, seed, number of samples and
      nominal values, e.g. the one that showed the yield is low), used as iterate 0 instead of
      estimating it again.

    **Returns:** a `YieldAscent` (`summary()`, `figure()`, `paired()`, `to_dict()`).

    **Raises:** `ValueError` before anything compiles: an unknown parameter, one with a uniform or
    zero-width spread, a non-positive `step`, bounds that do not contain the start, and what
    `yield_estimate` refuses.
    """
    if scatter is None:
        scatter = Scatter()
    elif isinstance(scatter, Mapping):
        scatter = Scatter.from_mapping(scatter)
    elif not isinstance(scatter, Scatter):
        raise ValueError(f"scatter must be a Scatter or a mapping, got {type(scatter).__name__}.")
    if design is not None and not isinstance(design, HingeDesign):
        raise ValueError(f"design must be a HingeDesign, got {type(design).__name__}.")
    for name in ("n_samples", "seed"):
        if name in options:
            raise ValueError(
                f"yield_ascent has no {name} option (every iterate is a new estimate)."
            )
    run = RunOptions() if run is None else run
    if run.resume:
        raise ValueError("yield_ascent cannot resume (every iterate is a new estimate).")
    pattern = as_pattern(pattern)
    if pattern.n_loops:
        raise ValueError(
            f"{pattern.name}: yield_ascent takes a net (a tree of panels), not a crease pattern "
            f"with {pattern.n_loops} closed loop(s)."
        )
    m = pattern.n_hinges
    if design is None:
        design = pattern.default_design(KOH_SOLUTION)  # as `yield_estimate`'s
    if release_times is not None:
        release_times = np.asarray(release_times, dtype=float)
        if release_times.shape != (m,) or not np.all(np.isfinite(release_times)):
            raise ValueError(f"release_times must be {m} finite times (µs, one per crease).")
    start = _nominal(design, release_times, m)
    start.update(_process(process, m))
    settings = AscentSettings() if settings is None else settings
    if not isinstance(settings, AscentSettings):
        raise ValueError(f"settings must be an AscentSettings, got {type(settings).__name__}.")
    names, _ = check_ascent(
        scatter,
        parameters,
        start,
        steps=settings.steps,
        step=settings.step,
        significance=settings.significance,
        bounds=settings.bounds,
    )
    if first is not None:
        same = (
            isinstance(first, YieldEstimate)
            and first.nominal is not None
            and (first.seed, first.n_samples, first.scatter) == (seed, n_samples, scatter)
            and all(np.array_equal(first.nominal[n], start[n]) for n in PARAMETERS)
        )
        if not same:
            raise ValueError(
                "first must be a yield estimate at the start: the same scatter, seed, n_samples, "
                "design, process and release times."
            )

    def estimate_at(nominal, draw_seed, count, label):
        if first is not None and label == "iterate-00":
            return first
        moved = {n: nominal[n] for n in names if n != "release"}
        moved = {n: float(v[0]) if n in _GLOBAL else v for n, v in moved.items()}
        out = None if run.out is None else os.path.join(os.fspath(run.out), label)
        return yield_estimate(
            pattern,
            scatter,
            count,
            draw_seed,
            design=design,
            process={**(process or {}), **moved},
            release_times=nominal["release"] if "release" in names else release_times,
            run=dataclasses.replace(run, out=out),
            **options,
        ).with_interval(settings.confidence, settings.interval)

    return ascend(
        estimate_at,
        start,
        scatter,
        names,
        n_samples,
        seed,
        settings=settings,
    )
