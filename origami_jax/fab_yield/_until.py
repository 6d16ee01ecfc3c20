"""`SampleUntil`: draw a yield's samples in rounds until its confidence interval is narrow enough.

How many samples a yield needs depends on the yield itself: the 95 % Wilson interval is ±0.1 wide
after ~35 samples at a yield near 0.1 or 0.9, ~96 near 0.5, and 17 when nothing folds. A study of
many nets asked for "intervals of ±0.1" therefore spends its samples where they are needed when
each net samples until its own interval is that narrow, rather than every net drawing the count
the worst one needs.

The rounds are prefixes of one sequence of draws (`standard_draws` of the seed: row `k` is sample
`k` whatever the count), so an estimate that stopped after `n` samples holds exactly the first `n`
samples of a longer one, and a resumed estimate takes the same rounds again.

Stopping on the interval's width uses the data, so the final interval's coverage is not exactly
its nominal level; the rule looks at the width only (not at whether the yield crossed some value),
which moves the coverage little (the width varies slowly with the yield), and `first` keeps the
earliest, noisiest rounds out of the decision.
"""

import dataclasses
import math

import numpy as np

from ._stats import INTERVAL_METHODS, binomial_interval

# Each round adds at least this fraction of the samples so far: a yield estimated a little too
# wide does not take a string of small rounds (each one a sweep of its own).
_GROWTH = 0.25


@dataclasses.dataclass(frozen=True)
class SampleUntil:
    """A yield estimate's sample count given as a precision (`yield_estimate`'s `n_samples`): draw
    `first` samples, then more in rounds until the interval's half-width (half its length) is at
    most `half_width`, never more than `most` samples in all.

    **Fields:**
    - `half_width`: the interval's half-length to reach, in ``(0, 0.5)`` (0.1: "±0.1").
    - `first`: the first round's samples (≥ 1; default 20).
    - `most`: the cap on the samples in all (≥ `first`; default 1000).
    - `confidence`, `method`: the interval judged (default the estimate's: 95 %, Wilson).

    Each further round is sized to reach `half_width` if the yield stays what it is so far, and
    adds at least a quarter of the samples already drawn.
    """

    half_width: float = 0.1
    first: int = 20
    most: int = 1000
    confidence: float = 0.95
    method: str = "wilson"

    def __post_init__(self):
        width = self.half_width
        if isinstance(width, bool) or not isinstance(width, int | float) or not 0 < width < 0.5:
            raise ValueError(
                f"SampleUntil.half_width must be a number in (0, 0.5) (0.1 for ±0.1), got "
                f"{width!r}."
            )
        for name in ("first", "most"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"SampleUntil.{name} must be an integer >= 1, got {value!r}.")
        if self.most < self.first:
            raise ValueError(
                f"SampleUntil.most ({self.most}) must be at least first ({self.first})."
            )
        if not (isinstance(self.confidence, int | float) and 0 < self.confidence < 1):
            raise ValueError(
                f"SampleUntil.confidence must lie strictly between 0 and 1, got "
                f"{self.confidence!r}."
            )
        if self.method not in INTERVAL_METHODS:
            raise ValueError(
                f"SampleUntil.method must be one of {INTERVAL_METHODS}, got {self.method!r}."
            )

    def reached(self, folded: int, n: int) -> bool:
        """Whether `folded` of `n` samples give an interval no wider than ``±half_width``."""
        low, high = binomial_interval(int(folded), int(n), self.confidence, self.method)
        return (high - low) / 2 <= self.half_width

    def next_count(self, folded: int, n: int) -> int | None:
        """The samples in all after the next round, given `folded` of `n` so far; `None` when
        the interval is narrow enough or `n` has reached `most`."""
        if n >= self.most or self.reached(folded, n):
            return None
        fraction = folded / n
        floor = min(self.most, n + max(1, math.ceil(_GROWTH * n)))
        for count in range(floor, self.most + 1):
            # The count at which the same yield would give the interval asked for.
            if self.reached(round(fraction * count), count):
                return count
        return self.most

    def to_dict(self) -> dict[str, object]:
        """The settings, for a record (`result.json`, a family's settings)."""
        return dataclasses.asdict(self)


def check_sample_count(n_samples) -> None:
    """Refuse an `n_samples` that is neither a whole number ≥ 1 nor a `SampleUntil` (one line)."""
    if not isinstance(n_samples, SampleUntil) and (
        isinstance(n_samples, bool) or not isinstance(n_samples, int | np.integer) or n_samples < 1
    ):
        raise ValueError(
            f"n_samples must be an integer >= 1 or a SampleUntil (a precision), got {n_samples!r}."
        )
