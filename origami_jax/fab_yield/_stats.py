"""Confidence intervals for a yield: a binomial proportion from `k` successes in `n` trials."""

import math

INTERVAL_METHODS = ("wilson", "clopper-pearson")


def _check(k: int, n: int, confidence: float) -> tuple[int, int, float]:
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n (the number of samples) must be an integer >= 1, got {n!r}.")
    if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k <= n:
        raise ValueError(f"k (the successes) must be an integer from 0 to n = {n}, got {k!r}.")
    if not (isinstance(confidence, int | float) and 0.0 < confidence < 1.0):
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}.")
    return k, n, float(confidence)


def _normal_quantile(p: float) -> float:
    from scipy.special import ndtri

    return float(ndtri(p))


def wilson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (Wilson, JASA 22, 1927):

    ``(p̂ + z²/2n ± z √(p̂(1−p̂)/n + z²/4n²)) / (1 + z²/n)``, ``p̂ = k/n``, ``z`` the normal quantile
    of ``(1 + confidence)/2``. Its coverage stays close to `confidence` on average over the true
    proportion, also near 0 and 1 where the normal ("Wald") interval fails (Brown, Cai & DasGupta,
    Statistical Science 16, 2001); at a given proportion it may fall a little below.

    **Returns:** `(low, high)` in ``[0, 1]``. **Raises:** `ValueError` for `k` outside ``[0, n]``,
    `n < 1`, or a confidence outside ``(0, 1)``.
    """
    k, n, confidence = _check(k, n, confidence)
    z = _normal_quantile(0.5 + confidence / 2)
    p = k / n
    denominator = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    # At k = 0 (k = n) the low (high) end is exactly 0 (1); round-off would leave ~1e-17.
    low = 0.0 if k == 0 else max(0.0, centre - half)
    high = 1.0 if k == n else min(1.0, centre + half)
    return low, high


def clopper_pearson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Clopper–Pearson ("exact") interval of a binomial proportion (Biometrika 26, 1934): the beta
    quantiles ``B(α/2; k, n−k+1)`` and ``B(1−α/2; k+1, n−k)``, ``α = 1 − confidence``. Its coverage is
    at least `confidence` at every true proportion (conservative).

    **Returns:** `(low, high)` in ``[0, 1]``. **Raises:** as `wilson_interval`.
    """
    from scipy.special import betaincinv

    k, n, confidence = _check(k, n, confidence)
    alpha = 1 - confidence
    low = 0.0 if k == 0 else float(betaincinv(k, n - k + 1, alpha / 2))
    high = 1.0 if k == n else float(betaincinv(k + 1, n - k, 1 - alpha / 2))
    return low, high


def binomial_interval(
    k: int, n: int, confidence: float = 0.95, method: str = "wilson"
) -> tuple[float, float]:
    """`wilson_interval` or `clopper_pearson_interval`, by `method` (`INTERVAL_METHODS`)."""
    if method == "wilson":
        return wilson_interval(k, n, confidence)
    if method == "clopper-pearson":
        return clopper_pearson_interval(k, n, confidence)
    raise ValueError(f"method must be one of {INTERVAL_METHODS}, got {method!r}.")


def average_ranks(values) -> list[float]:
    """Ranks 1 … n of `values`, ties given the mean of the ranks they span (``[10, 20, 20, 30]``
    → ``[1, 2.5, 2.5, 4]``)."""
    values = [float(v) for v in values]
    order = sorted(range(len(values)), key=values.__getitem__)
    ranks = [0.0] * len(values)
    start = 0
    while start < len(order):
        end = start
        while end + 1 < len(order) and values[order[end + 1]] == values[order[start]]:
            end += 1
        for i in order[start : end + 1]:
            ranks[i] = (start + end) / 2 + 1
        start = end + 1
    return ranks


def spearman(x, y) -> tuple[float, float]:
    """Spearman's rank correlation of `x` and `y` (equal lengths) and its two-sided p-value.

    ρ is Pearson's correlation of the average ranks (`average_ranks`: ties share their mean
    rank). The p-value of no correlation uses ``t = ρ √((n − 2)/(1 − ρ²))`` with Student's t of
    ``n − 2`` degrees of freedom (as `scipy.stats.spearmanr`; an approximation, fair from about
    ten points).

    **Returns:** `(rho, p)`; `rho` NaN when either sequence is constant (no ranking), `p` NaN then
    or below 3 points. **Raises:** `ValueError` for lengths that differ, fewer than 2 points or
    values that are not finite.
    """
    from scipy.special import stdtr

    x = [float(v) for v in x]
    y = [float(v) for v in y]
    if len(x) != len(y) or len(x) < 2:
        raise ValueError(
            f"spearman needs two sequences of equal length >= 2, got {len(x)} and {len(y)}."
        )
    if not all(math.isfinite(v) for v in x + y):
        raise ValueError("spearman needs finite values.")
    rx, ry = average_ranks(x), average_ranks(y)
    n = len(x)
    mx, my = sum(rx) / n, sum(ry) / n
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry, strict=True))
    sxx = sum((a - mx) ** 2 for a in rx)
    syy = sum((b - my) ** 2 for b in ry)
    if sxx == 0 or syy == 0:
        return math.nan, math.nan
    rho = max(-1.0, min(1.0, sxy / math.sqrt(sxx * syy)))
    if n < 3:
        return rho, math.nan
    if abs(rho) == 1.0:
        return rho, 0.0
    t = rho * math.sqrt((n - 2) / (1 - rho * rho))
    return rho, float(2 * stdtr(n - 2, -abs(t)))
