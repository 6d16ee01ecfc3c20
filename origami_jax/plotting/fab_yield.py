"""Figures of yield estimates (`origami_jax.fab_yield.yield_estimate`): the verdict counts and the
yield with its confidence interval (`yield_figure`), the yield against the scatter's width
(`width_figure`), the misfold modes as 3D snapshots (`misfold_figure`), and a family's yields
against the nets' compactness (`family_figure`).

Matplotlib only; imported explicitly (`from origami_jax.plotting import fab_yield`).
"""

from collections.abc import Mapping
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

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


def width_figure(factors, results, *, title: str | None = None):
    """Yield against scatter width: each estimate's yield with its interval, at the factor its
    scatter's widths were multiplied by (`Scatter.scaled`).

    **Arguments:** `factors`: the scale factors `(k,)`; `results`: the `YieldEstimate`s (or their
    `to_dict()`s) at those factors; `title`: figure title. **Returns:** the matplotlib `Figure`.
    """
    summaries = [r if isinstance(r, Mapping) else r.to_dict() for r in results]
    if len(summaries) != len(factors):
        raise ValueError("give one estimate per factor.")
    order = np.argsort(factors)
    x = np.asarray(factors, dtype=float)[order]
    y = np.array([summaries[i]["yield"] for i in order])
    low = np.array([summaries[i]["interval"][0] for i in order])
    high = np.array([summaries[i]["interval"][1] for i in order])
    fig, ax = plt.subplots(figsize=(5.0, 3.4), layout="constrained")
    ax.errorbar(x, y, yerr=[y - low, high - y], fmt="o-", capsize=5, color="k")
    for xi, s in zip(x, (summaries[i] for i in order), strict=True):
        ax.annotate(f"n={s['n_samples']}", (xi, 0.02), ha="center", fontsize=7, color="0.4")
    ax.set_xlabel("scatter width (× the given widths)")
    ax.set_ylabel("yield")
    ax.set_ylim(0, 1.02)
    if len(x) > 1 and x.min() > 0 and x.max() / x.min() >= 4:
        ax.set_xscale("log")
        ax.set_xticks(x, [f"{v:g}" for v in x])
    confidence = 100 * summaries[0].get("confidence", 0.95)
    ax.set_title(f"yield with its {confidence:g} % interval", fontsize=10)
    if title:
        fig.suptitle(title)
    return fig


def family_figure(result: Any, *, title: str | None = None):
    """A family's yields against its nets' compactness (`origami_jax.fab_yield.family_yield`): two
    panels, yield with its interval against the flat net's radius of gyration (µm) and against
    its number of vertex connections, each net's name beside its point and Spearman's ρ (with
    its p-value) in the panel's title.

    **Arguments:** `result`: a `FamilyYield` or its `to_dict()` (a CLI `family.json`); `title`.
    **Returns:** the matplotlib `Figure`.
    """
    summary: Mapping[str, Any] = result if isinstance(result, Mapping) else result.to_dict()
    nets = summary["nets"]
    fraction = np.array([n["yield"] for n in nets])
    low = np.array([n["interval"][0] for n in nets])
    high = np.array([n["interval"][1] for n in nets])
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.2), sharey=True, layout="constrained")
    panels = (
        ("radius_of_gyration", "radius_of_gyration_um", "radius of gyration of the flat net (µm)"),
        ("vertex_connections", "vertex_connections", "vertex connections"),
    )
    for ax, (measure, key, label) in zip(axes, panels, strict=True):
        x = np.array([n[key] for n in nets], dtype=float)
        ax.errorbar(
            x, fraction, yerr=[fraction - low, high - fraction], fmt="o", capsize=4, color="k"
        )
        placed: dict[tuple[float, float], int] = {}  # nets on one point: labels stacked
        for xi, yi, net in zip(x, fraction, nets, strict=True):
            k = placed[(xi, yi)] = placed.get((xi, yi), -1) + 1
            ax.annotate(
                net["name"], (xi, yi), xytext=(4, 3 + 9 * k), textcoords="offset points", fontsize=7
            )
        if measure == "vertex_connections":
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        rank = summary["spearman"][measure]
        rho, p = rank["rho"], rank["p_value"]
        if rho is None or not np.isfinite(rho):  # every yield (or measure) equal: no ranking
            ax.set_title("Spearman ρ undefined (all equal)")
        elif p is None or not np.isfinite(p):
            ax.set_title(f"Spearman ρ = {rho:.2f}")
        else:
            ax.set_title(f"Spearman ρ = {rho:.2f} (p = {p:.2g})")
        ax.set_xlabel(label)
        ax.set_ylim(-0.02, 1.05)
    axes[0].set_ylabel(f"yield ({100 * summary.get('confidence', 0.95):g} % interval)")
    if title:
        fig.suptitle(title)
    return fig


def tolerance_figure(sensitivity: Any, *, title: str | None = None):
    """Yield against the verdict's tolerances, from the samples' stored margins (a
    `origami_jax.fab_yield.ToleranceSensitivity`, `YieldEstimate.tolerance_sensitivity`): the
    yield as a curve of the factor on the angle tolerance, on the seam tolerances and on both
    (0.25 to 4, log scale), with the reported factors' intervals.

    **Returns:** the matplotlib `Figure`.
    """
    dense = np.geomspace(0.25, 4.0, 97)
    one = np.ones_like(dense)
    fig, ax = plt.subplots(figsize=(5.0, 3.4), layout="constrained")
    curves = (
        ("both", dense, dense, "k"),
        ("angle only", dense, one, "C0"),
        ("seams only", one, dense, "C1"),
    )
    factors = np.asarray(sensitivity.factors, dtype=float)
    ones = np.ones_like(factors)
    for (label, a, s, color), (pa, ps) in zip(
        curves, ((factors, factors), (factors, ones), (ones, factors)), strict=True
    ):
        ax.plot(dense, sensitivity.yield_at(a, s), color=color, label=label, lw=1.2)
        folded = np.sum(sensitivity.folded_at(pa, ps), axis=-1)
        y = folded / sensitivity.n_samples
        bounds = np.array([sensitivity.interval(k) for k in folded])
        ax.errorbar(
            factors, y, yerr=[y - bounds[:, 0], bounds[:, 1] - y], fmt="o", color=color,
            capsize=4, ms=4,
        )  # fmt: skip
    ax.set_xscale("log")
    ax.minorticks_off()
    ax.set_xticks([0.25, 0.5, 1, 2, 4], ["0.25", "0.5", "1", "2", "4"])
    ax.set_xlabel("tolerance (× the verdict's)")
    ax.set_ylabel("yield")
    ax.set_ylim(0, 1.02)
    ax.legend(fontsize=8, loc="upper left")
    tol = sensitivity.tolerances
    seam = tol.get("seam_fraction")
    seam_text = "seams derived" if seam == "derived" else f"seams {seam:g} of the panel"
    ax.set_title(
        f"{tol.get('angle_deg', 3.0):g}°, {seam_text}; n={sensitivity.n_samples}, "
        f"{100 * sensitivity.confidence:g} % intervals",
        fontsize=9,
    )
    if title:
        fig.suptitle(title)
    return fig


def representative_samples(estimate) -> dict[str, int]:
    """For each verdict other than folded that some sample got, the sample whose final crease
    angles are nearest (Euclidean, in rad) to that verdict's median final angles: one typical
    member of each misfold mode. Samples whose simulation failed (NaN angles) are skipped.

    **Returns:** verdict name → sample index (in the estimate's dataset order).
    """
    from ..simulation import FoldVerdict

    ds = estimate.dataset
    codes = np.asarray(ds["verdict"].values)
    angles = np.asarray(ds["final_angle"].values, dtype=float)
    out = {}
    for code, verdict in enumerate(FoldVerdict):
        if verdict == FoldVerdict.FOLDED:
            continue
        members = np.nonzero((codes == code) & np.all(np.isfinite(angles), axis=1))[0]
        if len(members):
            median = np.median(angles[members], axis=0)
            out[str(verdict)] = int(
                members[np.argmin(np.linalg.norm(angles[members] - median, axis=1))]
            )
    return out


def misfold_figure(net, estimate, *, title: str | None = None):
    """The misfold modes as 3D snapshots: for each verdict other than folded, the final state of one
    representative sample (`representative_samples`), the panels folded rigidly to its final crease
    angles (`NetGeometry.fold`; the base in grey), next to the intended shape.

    **Arguments:** `net`: the `origami_jax.net.Net` or closed-loop `CreasePattern` (or a catalogue
    name or `.fold` path; a pattern is folded along its spanning tree); `estimate`: its
    `YieldEstimate`. **Returns:** the matplotlib `Figure`.
    """
    from ..loops import load_pattern

    if not hasattr(net, "geometry"):
        net = load_pattern(net)
    g = net.geometry
    picks = representative_samples(estimate)
    counts = estimate.counts
    angles = np.asarray(estimate.dataset["final_angle"].values, dtype=float)
    panels = [("intended", np.asarray(net.intended_angles), "folded shape")]
    for verdict, index in picks.items():
        panels.append((verdict, angles[index], f"sample {index} of {counts[verdict]} {verdict}"))
    frames = [g.fold(a) for _, a, _ in panels]
    points = np.concatenate([f.reshape(-1, 3) for f in frames])
    points = points[np.all(np.isfinite(points), axis=1)]
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    half = 0.5 * float(np.max(points.max(axis=0) - points.min(axis=0))) or 1.0
    root = int(getattr(g, "tree", g).order[0])
    fig = plt.figure(figsize=(3.0 * len(panels), 3.3), layout="constrained")
    for k, ((verdict, a, caption), corners) in enumerate(zip(panels, frames, strict=True)):
        ax = fig.add_subplot(1, len(panels), k + 1, projection="3d")
        polygons = [c[np.all(np.isfinite(c), axis=1)] for c in corners]
        colour = VERDICT_COLOURS.get(verdict, "tab:green")
        colours = ["0.7" if f == root else colour for f in range(len(polygons))]
        ax.add_collection3d(
            Poly3DCollection(
                polygons, facecolors=colours, edgecolors="k", linewidths=0.5, alpha=0.7
            )
        )
        for axis, c in zip("xyz", centre, strict=True):
            getattr(ax, f"set_{axis}lim")(c - half, c + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=25, azim=-60)
        ax.set_axis_off()
        degrees = ", ".join(f"{v:.1f}" for v in np.degrees(a))
        ax.set_title(f"{verdict}\n{caption}\nangles {degrees}°", fontsize=8)
    if not picks:
        fig.text(0.7, 0.5, "every sample folded", ha="center", va="center")
    if title:
        fig.suptitle(title)
    return fig


def ascent_figure(result: Any, *, title: str | None = None):
    """The iterations of a yield ascent (`origami_jax.fab_yield.yield_ascent`): the yield with its
    interval per iterate (the best ringed, its re-estimate on fresh draws to the right if there is
    one), then one panel per moved parameter: its nominal value per crease along the ascent (one
    line when every crease has the same).

    **Arguments:** `result`: a `YieldAscent`; `title`: figure title. **Returns:** the matplotlib
    `Figure`.
    """
    from ..fab_yield import PARAMETERS

    k = np.arange(len(result.iterates))
    y = result.yields
    low, high = result.intervals.T
    names = list(result.parameters)
    fig, axes = plt.subplots(
        1 + len(names), 1, figsize=(5.5, 2.6 + 1.8 * len(names)), sharex=True, layout="constrained"
    )
    ax = axes[0]
    ax.errorbar(k, y, yerr=[y - low, high - y], fmt="o-", capsize=4, color="k", label="iterate")
    ax.plot(
        [k[result.best]], [y[result.best]], "o", ms=12, mfc="none", color="tab:green", label="best"
    )
    confirmation = result.confirmation
    if confirmation is not None:
        c, (c_low, c_high) = confirmation.fraction, confirmation.interval
        ax.errorbar(
            [k[-1] + 0.6], [c], yerr=[[c - c_low], [c_high - c]], fmt="s", capsize=4,
            color="tab:green", label=f"best, fresh draws (n={confirmation.n_samples})",
        )  # fmt: skip
    ax.set_ylim(0, 1.02)
    ax.set_ylabel("yield")
    confidence = 100 * result.iterates[0].estimate.confidence
    draws = "same draws" if result.common_random_numbers else "fresh draws each"
    ax.set_title(f"yield with its {confidence:g} % interval ({draws})", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    for ax, name in zip(axes[1:], names, strict=True):
        path = result.path(name)
        if np.all(path == path[:, :1]):
            ax.plot(k, path[:, 0], "o-", color="C0", label="every crease")
        else:
            for j in range(path.shape[1]):
                ax.plot(k, path[:, j], "o-", color=f"C{j % 10}", label=f"crease {j}")
        unit = {"1": "", "um": " (µm)", "us": " (µs)"}[PARAMETERS[name][0]]
        ax.set_ylabel(f"{name}{unit}")
        ax.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("iterate")
    axes[-1].set_xticks(k)
    if title:
        fig.suptitle(title)
    return fig
