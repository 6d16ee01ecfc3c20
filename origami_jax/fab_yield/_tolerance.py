"""How much a yield depends on the verdict's tolerances, from the samples' stored margins: nothing
is simulated again.

Each sample of a yield estimate stores two margins (the fold kernel's `angle_margin` and
`seam_margin`, `origami_jax.simulation.FoldOutcome`): its largest crease error at the end over the
angle tolerance, and its largest open seam's gap over that seam's tolerance. A sample whose
simulation succeeded is *folded* at the angle tolerance × ``a`` and every seam tolerance × ``s``
iff ``angle_margin < a`` and ``seam_margin < s``; at ``a = s = 1`` this is its stored verdict.
The yield at any tolerance is then a count, and a curve of it is free.

Which verdicts can move: only *folded* against the others. The folded test looks at the last
state alone (every crease within the angle tolerance, every seam closed), and it comes first: a
sample that passes it is folded whatever else. A sample that fails it is unfinished (not at
rest), jammed (a crease short of its angle, held there by contact) or misfolded, and since the
tests for rest, for "short" and for "held" also use the angle tolerance, which of the three it
is can change with the tolerance too; that split needs the run's last tenth, which is not
stored, and is not recomputed here. A sample whose simulation failed (`invalid`, or
`unfinished` because it ran out of solver steps) never folds at any tolerance.

A seam tolerance scaled by ``s``: each seam's tolerance (a length) times ``s``. For the fixed
fraction of the panel size that is the fraction × ``s``; for the derived one (the default) it is,
to first order in the angle tolerance, the tolerance derived from the angle tolerance × ``s``
(the seam's own gap in the intended shape, zero for a seam that closes exactly, scaled too).
"""

import dataclasses
from typing import Any

import numpy as np

from ._stats import INTERVAL_METHODS, binomial_interval

TOLERANCE_FACTORS = (0.5, 1.0, 2.0)
"""The multiples of the tolerances a yield estimate reports its yield at (`ToleranceSensitivity`)."""


@dataclasses.dataclass(frozen=True)
class ToleranceSensitivity:
    """The yield of one set of samples at multiples of the verdict's tolerances (module
    docstring).

    **Fields:**
    - `factors`: the multiples `(k,)`; `tolerances`: the verdict's at factor 1
      (`VerdictTolerances.to_dict`).
    - `folded`: `(k, k)` int, the folded samples with the angle tolerance × ``factors[i]`` and
      every seam tolerance × ``factors[j]``; the diagonal scales both together.
    - `n_samples`, `confidence`, `method`: the intervals' (`binomial_interval`).
    - `angle_margin`, `seam_margin` `(n,)`: every sample's margins (`inf` where its simulation
      failed: it folds at no tolerance); `yield_at(a, s)` counts them.
    """

    factors: tuple[float, ...]
    tolerances: dict[str, Any]
    folded: np.ndarray
    n_samples: int
    confidence: float
    method: str
    angle_margin: np.ndarray
    seam_margin: np.ndarray

    def folded_at(self, angle_factor, seam_factor) -> np.ndarray:
        """Which samples are folded at the angle tolerance × `angle_factor` and the seam
        tolerances × `seam_factor`, `(n,)` bool (broadcasts over arrays of factors, `(..., n)`)."""
        a = np.asarray(angle_factor, dtype=float)[..., None]
        s = np.asarray(seam_factor, dtype=float)[..., None]
        return (self.angle_margin < a) & (self.seam_margin < s)

    def yield_at(self, angle_factor, seam_factor) -> np.ndarray:
        """The yield at those multiples of the tolerances (a fraction; broadcasts)."""
        return np.mean(self.folded_at(angle_factor, seam_factor), axis=-1)

    def interval(self, folded: int | np.integer) -> tuple[float, float]:
        return binomial_interval(int(folded), self.n_samples, self.confidence, self.method)

    def with_interval(self, confidence: float, method: str) -> "ToleranceSensitivity":
        return dataclasses.replace(self, confidence=float(confidence), method=method)

    def rows(self) -> list[dict[str, Any]]:
        """One row per pair of factors: `angle_factor`, `seam_factor`, `folded`, `yield`,
        `interval`."""
        out = []
        for i, a in enumerate(self.factors):
            for j, s in enumerate(self.factors):
                k = int(self.folded[i, j])
                out.append(
                    {
                        "angle_factor": a,
                        "seam_factor": s,
                        "folded": k,
                        "yield": k / self.n_samples,
                        "interval": list(self.interval(k)),
                    }
                )
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (no per-sample margins)."""
        return {
            "factors": list(self.factors),
            "tolerances": dict(self.tolerances),
            "confidence": self.confidence,
            "interval_method": self.method,
            "rows": self.rows(),
        }

    def summary(self) -> str:
        """One line for people: the yield with both tolerances scaled by each factor."""
        parts = []
        for i, f in enumerate(self.factors):
            k = int(self.folded[i, i])
            low, high = self.interval(k)
            parts.append(f"x{f:g} {k / self.n_samples:.3f} ({low:.3f}-{high:.3f})")
        return "yield at the tolerances " + ", ".join(parts) + " (angle and seams scaled together)"


def tolerance_sensitivity(
    dataset,
    tolerances: dict[str, Any],
    factors=TOLERANCE_FACTORS,
    *,
    confidence: float = 0.95,
    method: str = "wilson",
) -> ToleranceSensitivity | None:
    """The yield of a yield estimate's samples (`dataset`, `YieldEstimate.dataset`) at multiples of
    its verdict's `tolerances` (`VerdictTolerances.to_dict`), from the stored margins (module
    docstring).

    **Returns:** a `ToleranceSensitivity`, or `None` where samples that succeeded have no margins
    (stored before margins were recorded: a resumed old run).

    **Raises:** `ValueError` for factors that are not positive finite numbers, or a bad interval.
    """
    factors = tuple(float(f) for f in np.atleast_1d(np.asarray(factors, dtype=float)))
    if not factors or not all(np.isfinite(f) and f > 0 for f in factors):
        raise ValueError(f"factors must be positive finite numbers, got {factors!r}.")
    if method not in INTERVAL_METHODS:
        raise ValueError(f"interval must be one of {INTERVAL_METHODS}, got {method!r}.")
    if not (0 < confidence < 1):
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}.")
    if "angle_margin" not in dataset or "seam_margin" not in dataset:
        return None
    ok = np.asarray(dataset["result"].values) == 0
    angle = np.asarray(dataset["angle_margin"].values, dtype=float)
    seam = np.asarray(dataset["seam_margin"].values, dtype=float)
    if np.any(ok & ~(np.isfinite(angle) & np.isfinite(seam))):
        # A sample stored without margins (NaN where it succeeded); an infinite angle margin is a
        # non-finite state, which no succeeded run has.
        return None
    angle = np.where(ok, angle, np.inf)
    seam = np.where(ok, seam, np.inf)
    f = np.asarray(factors)
    folded = np.sum((angle < f[:, None, None]) & (seam < f[None, :, None]), axis=-1).astype(
        np.int64
    )
    return ToleranceSensitivity(
        factors=factors,
        tolerances=dict(tolerances),
        folded=folded,
        n_samples=int(angle.size),
        confidence=float(confidence),
        method=method,
        angle_margin=angle,
        seam_margin=seam,
    )
