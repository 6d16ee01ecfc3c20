"""Summary figures of a sweep dataset (`origami_jax.sweep.sweep`): a metric against a parameter, and a
heat map of a metric over two parameters.

Matplotlib only; imported explicitly (`from origami_jax.plotting import sweep as sweep_plots`).
Failed designs (`result != 0`) are drawn as red crosses on the parameter axis, never as values.
"""

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

_FAILED: dict[str, Any] = {"marker": "x", "color": "tab:red", "linestyle": "none"}


def _label(ds: xr.Dataset, name: str) -> str:
    unit = ds[name].attrs.get("units", "")
    return f"{name} [{unit}]" if unit and unit != "1" else name


def _is_log(values: np.ndarray) -> bool:
    values = values[np.isfinite(values)]
    return bool(values.size > 2 and np.all(values > 0) and values.max() / values.min() > 50)


def _components(ds: xr.Dataset, metric: str) -> list[tuple[str, np.ndarray]]:
    """The metric as one or more series along `design` (one per index of its trailing axes)."""
    data = ds[metric]
    extra = [d for d in data.dims if d != "design"]
    if not extra:
        return [("", data.values.astype(float))]
    stacked = data.stack(component=extra).transpose("design", "component")
    labels = [
        ", ".join(f"{d} {v}" for d, v in zip(extra, np.atleast_1d(c), strict=True))
        for c in stacked["component"].values
    ]
    values = stacked.values.astype(float)
    return [(label, values[:, j]) for j, label in enumerate(labels)]


def numeric_parameters(ds: xr.Dataset) -> list[str]:
    """Parameter coordinates along `design` that vary (numbers, or categories)."""
    names = []
    for name, coord in ds.coords.items():
        if name == "design" or coord.dims != ("design",):
            continue
        if np.unique(coord.values).size > 1:
            names.append(str(name))
    return names


def plot_metric(ds: xr.Dataset, metric: str, parameter: str, *, ax=None):
    """`metric` against `parameter`, one point per design (per component for per-joint metrics).

    Categorical parameters are placed at their category index. Failed designs appear as red crosses
    at the bottom of the axes. **Returns:** the matplotlib `Axes`.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    x_raw = ds[parameter].values
    categorical = x_raw.dtype.kind in "UO"
    if categorical:
        labels = sorted(set(x_raw.tolist()))
        x = np.array([labels.index(v) for v in x_raw], dtype=float)
        ax.set_xticks(range(len(labels)), labels)
    else:
        x = x_raw.astype(float)
    ok = ds["result"].values == 0
    for label, y in _components(ds, metric):
        ax.plot(x[ok], y[ok], "o", markersize=3, alpha=0.7, label=label or None)
    if (~ok).any():
        ax.plot(
            x[~ok],
            np.zeros((~ok).sum()),
            transform=ax.get_xaxis_transform(),
            **_FAILED,
            label=f"failed ({int((~ok).sum())})",
        )
    if not categorical and _is_log(x):
        ax.set_xscale("log")
    ax.set_xlabel(_label(ds, parameter))
    ax.set_ylabel(_label(ds, metric))
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small")
    return ax


def plot_heatmap(
    ds: xr.Dataset,
    metric: str,
    x: str,
    y: str,
    *,
    component: int = 0,
    reduce: str = "median",
    ax=None,
):
    """Heat map of `metric` over parameters `x` and `y`.

    On a grid each cell is one `(x, y)` pair; designs sharing it (other parameters varying) are
    combined by `reduce` (`"median"`, `"mean"`, `"min"` or `"max"`) and the title says so. Scattered
    designs (random samples) are drawn as coloured points instead. Per-joint metrics show one
    `component` (index along their trailing axes). **Returns:** the matplotlib `Axes`.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4.5))
    label, values = _components(ds, metric)[component]
    ok = ds["result"].values == 0
    values = np.where(ok, values, np.nan)
    xs, ys = ds[x].values, ds[y].values
    ux, uy = np.unique(xs), np.unique(ys)
    title = f"{metric}{f' ({label})' if label else ''}"
    if ux.size * uy.size <= len(xs) and ux.size > 1 and uy.size > 1:
        grid = np.full((uy.size, ux.size), np.nan)
        for j, vy in enumerate(uy):
            for i, vx in enumerate(ux):
                cell = values[(xs == vx) & (ys == vy)]
                cell = cell[np.isfinite(cell)]
                if cell.size:
                    grid[j, i] = getattr(np, reduce)(cell)
        mesh = ax.pcolormesh(np.arange(ux.size + 1), np.arange(uy.size + 1), grid, shading="flat")
        ax.set_xticks(np.arange(ux.size) + 0.5, [_tick(v) for v in ux], rotation=45, ha="right")
        ax.set_yticks(np.arange(uy.size) + 0.5, [_tick(v) for v in uy])
        if len(xs) > ux.size * uy.size:
            title += f", {reduce} over other parameters"
        if np.isnan(grid).any():
            title += " (blank: failed)"
    else:
        mesh = ax.scatter(xs, ys, c=values, s=12)
        if xs.dtype.kind == "f" and _is_log(xs):
            ax.set_xscale("log")
        if ys.dtype.kind == "f" and _is_log(ys):
            ax.set_yscale("log")
    plt.colorbar(mesh, ax=ax, label=_label(ds, metric))
    ax.set_xlabel(_label(ds, x))
    ax.set_ylabel(_label(ds, y))
    ax.set_title(title, fontsize="medium")
    return ax


def _tick(value) -> str:
    return f"{value:.3g}" if isinstance(value, float | np.floating) else str(value)


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def summary_plots(
    ds: xr.Dataset, out: str | Path, *, metrics: Sequence[str] | None = None
) -> list[Path]:
    """Write the summary figures of a sweep to `out` (created if missing); return their paths.

    For every metric (default: every float output) and every varying parameter, `metric vs
    parameter`; for the first two varying parameters, a heat map per metric.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if metrics is None:
        metrics = [str(n) for n, v in ds.data_vars.items() if v.dtype.kind == "f"]
    parameters = numeric_parameters(ds)
    paths = []
    for metric in metrics:
        for parameter in parameters:
            fig, ax = plt.subplots(figsize=(6, 4))
            plot_metric(ds, metric, parameter, ax=ax)
            fig.tight_layout()
            path = out / f"{_safe(metric)}_vs_{_safe(parameter)}.png"
            fig.savefig(path, dpi=110)
            plt.close(fig)
            paths.append(path)
        if len(parameters) >= 2:
            fig, ax = plt.subplots(figsize=(6, 4.5))
            plot_heatmap(ds, metric, parameters[0], parameters[1], ax=ax)
            fig.tight_layout()
            path = out / f"{_safe(metric)}_map_{_safe(parameters[0])}_{_safe(parameters[1])}.png"
            fig.savefig(path, dpi=110)
            plt.close(fig)
            paths.append(path)
    return paths
