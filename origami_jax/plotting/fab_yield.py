"""Figure of a yield estimate (`origami_jax.fab_yield.yield_estimate`): the verdict counts and the
yield with its confidence interval.

Matplotlib only; imported explicitly (`from origami_jax.plotting import fab_yield`).
"""

from collections.abc import Mapping
from typing import Any

import matplotlib.pyplot as plt

VERDICT_COLOURS = {
    "folded": "tab:green",
    "jammed": "tab:orange",
    "misfolded": "tab:red",
    "unfinished": "tab:gray",
    "invalid": "black",
}


def yield_figure(result: Any, *, title: str | None = None):
    """Two panels: samples per verdict (bars) and the yield with its interval (a point with an
    error bar on ``[0, 1]``).

    **Arguments:** `result`: a `YieldEstimate` or its `to_dict()` (e.g. a CLI `result.json`);
    `title`: figure title. **Returns:** the matplotlib `Figure`.
    """
    summary: Mapping[str, Any] = result if isinstance(result, Mapping) else result.to_dict()
    counts = summary["counts"]
    fraction = summary["yield"]
    low, high = summary["interval"]
    fig, (bars, point) = plt.subplots(
        1, 2, figsize=(8.0, 3.4), gridspec_kw={"width_ratios": [3, 1]}, layout="constrained"
    )
    names = list(counts)
    bars.bar(names, [counts[n] for n in names], color=[VERDICT_COLOURS.get(n, "C0") for n in names])
    bars.set_ylim(0, 1.15 * max(max(counts.values()), 1))  # room for the labels
    bars.set_ylabel("samples")
    bars.set_title(f"verdicts of {summary['n_samples']} samples")
    for i, name in enumerate(names):
        bars.annotate(str(counts[name]), (i, counts[name]), ha="center", va="bottom")
    point.errorbar(
        [0], [fraction], yerr=[[fraction - low], [high - fraction]], fmt="o", capsize=6, color="k"
    )
    point.set_xlim(-1, 1)
    point.set_xticks([])
    point.set_ylim(0, 1.02)
    point.set_ylabel("yield")
    confidence = 100 * summary.get("confidence", 0.95)
    point.set_title(f"{fraction:.2f} [{low:.2f}, {high:.2f}]\n{confidence:g} % interval")
    if title:
        fig.suptitle(title)
    return fig
