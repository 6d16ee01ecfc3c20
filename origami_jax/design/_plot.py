"""Before/after response figure of a design (matplotlib is imported only when a figure is drawn)."""

import numpy as np

from ._design import evaluate
from ._report import DesignResult


def plot_response(
    result: DesignResult, *, path=None, time_unit: str = "µs", time_scale: float = 1.0
):
    """Plot θ(t)/θ_target of every joint at the start (dashed) and at the solution (solid), with the
    rise-time targets marked, and save to `path` if given.

    **Arguments:**
    - `result`: a [`origami_jax.design.DesignResult`][].
    - `path`: where to save the figure (PNG, PDF, …), or `None`.
    - `time_unit`, `time_scale`: axis label and factor applied to the design's times (MICRO: µs).

    **Returns:** the matplotlib `Figure`.
    """
    import matplotlib.pyplot as plt

    before, _ = evaluate(result, "before")
    after, _ = evaluate(result, "after")
    fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j in range(after.theta.shape[1]):
        c = colours[j % len(colours)]
        target = float(after.target[j])
        ax.plot(
            np.asarray(before.times) * time_scale,
            np.asarray(before.theta[:, j]) / target,
            "--",
            color=c,
            alpha=0.6,
            label=f"joint {j + 1} before",
        )
        ax.plot(
            np.asarray(after.times) * time_scale,
            np.asarray(after.theta[:, j]) / target,
            color=c,
            label=f"joint {j + 1} after",
        )
    for row in result.targets:
        if row.kind == "overshoot":
            ax.axhline(1 + row.target, color="grey", lw=0.6, ls=":")
    for level in (0.1, 0.9, 1.0):
        ax.axhline(level, color="k", lw=0.5, alpha=0.4)
    curve = result._problem.targets.curve if result._problem is not None else None
    if curve is not None:
        for j in range(curve.theta.shape[1]):
            ax.plot(
                np.asarray(curve.times) * time_scale,
                np.asarray(curve.theta[:, j]) / float(after.target[j]),
                ".",
                ms=3,
                color=colours[j % len(colours)],
            )
    ax.set_xlabel(f"time ({time_unit})")
    ax.set_ylabel("θ / θ_target")
    params = ", ".join(f"{k} = {v:.4g}" for k, v in result.parameters.items())
    ax.set_title(f"Design: {params}", fontsize=9)
    ax.legend(fontsize=7, ncols=2)
    if path is not None:
        fig.savefig(path, dpi=130)
    return fig
