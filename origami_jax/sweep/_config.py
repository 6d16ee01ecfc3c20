"""Sweep configuration files (TOML) for `origami-jax sweep CONFIG.toml`.

```toml
[model]
name = "accordion"        # a model of `available_models()`, or its prefix with `input`
input = "step"            # -> "accordion-step"
t_end = 2000.0            # any other key: a model setting (see the model's builder)

[sweep]
kind = "grid"             # "grid" (full factorial), "lhs", "uniform" (seeded samples) or "table"
n = 200                   # lhs / uniform: number of samples
seed = 0                  # lhs / uniform
chunk_size = 64           # optional; default: chosen to fit memory

[parameters]              # grid / lhs / uniform
hinge_width = { min = 20.0, max = 200.0, num = 6, scale = "log" }   # num: grid points
misfit_strain = { values = [2.0e-3, 2.5e-3, 3.0e-3] }
fluid = { values = ["air", "koh"] }

[[designs]]               # kind = "table": one table per design
hinge_width = 50.0
misfit_strain = 2.0e-3

[plots]
metrics = ["rise_time", "overshoot"]   # optional; default: every float output
```

In `grid`, a `{min, max, num, scale}` parameter becomes `num` linearly or logarithmically spaced
points. In `lhs` / `uniform`, it is sampled in `[min, max)`; parameters given by `values` are
crossed with the samples (every sample with every value). Units default to the model's.
"""

import json
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._kernel import Kernel
from ..simulation import LEGACY_SEAM_FRACTION
from ._kernels import MODELS, get_model
from ._space import AbstractDesignSpace, Grid, Product, Range, Samples, Table
from ._store import MANIFEST

KINDS = ("grid", "lhs", "uniform", "table")


@dataclass
class SweepConfig:
    """A parsed configuration: the kernel, the design space, and the run options."""

    kernel: Kernel
    space: AbstractDesignSpace
    chunk_size: int | None = None
    plot_metrics: list[str] | None = None
    raw: dict[str, Any] = field(default_factory=dict)


def _model_name(model: Mapping[str, Any]) -> str:
    name = model.get("name")
    if not isinstance(name, str):
        raise ValueError(f"[model] needs a name, one of {sorted(MODELS)}.")
    given = model.get("input")
    if given is not None:
        full = name if name.endswith(f"-{given}") else f"{name}-{given}"
        if full not in MODELS:
            inputs = sorted(m.split("-", 1)[1] for m in MODELS if m.startswith(f"{name}-"))
            raise ValueError(
                f"model {name!r} has no input {given!r}"
                + (f"; it has {inputs}." if inputs else f"; the models are {sorted(MODELS)}.")
            )
        return full
    return name


# Most designs a configuration may describe (a grid's `num` multiplies up quickly).
MAX_DESIGNS = 10_000_000


def _number(spec: Mapping[str, Any], key: str, name: str, *, integer: bool = False) -> Any:
    value = spec[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"parameter {name!r}: {key} must be a number, got {value!r}.")
    if integer and not float(value).is_integer():
        raise ValueError(f"parameter {name!r}: {key} must be an integer, got {value!r}.")
    return int(value) if integer else float(value)


def _grid_axis(name: str, spec: Mapping[str, Any]) -> np.ndarray | list:
    if "values" in spec:
        values = spec["values"]
        if not isinstance(values, list):
            raise ValueError(f"parameter {name!r}: values must be a list, got {values!r}.")
        return list(values)
    try:
        low, high = _number(spec, "min", name), _number(spec, "max", name)
        num = _number(spec, "num", name, integer=True)
    except KeyError as error:
        raise ValueError(
            f"parameter {name!r}: give `values = [...]` or `min`, `max` and `num` for a grid."
        ) from error
    if not 1 <= num <= MAX_DESIGNS:
        raise ValueError(f"parameter {name!r}: num must be from 1 to {MAX_DESIGNS}, got {num}.")
    if spec.get("scale", "linear") == "log":
        Range(low, high, "log")  # checks low > 0
        return np.geomspace(low, high, num)
    return np.linspace(low, high, num)


def _stored_manifest(folder: str | Path) -> dict[str, Any]:
    """The manifest of the sweep stored in `folder` (`{}` if none is readable: the sweep itself
    then says what is wrong)."""
    try:
        stored = json.loads((Path(folder) / MANIFEST).read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(stored, dict) or not isinstance(stored.get("settings"), dict):
        return {}
    return stored


def load_config(path: str | Path, *, resume_from: str | Path | None = None) -> SweepConfig:
    """Read a sweep TOML file (format: see the module docstring).

    `resume_from`: the folder of a stored sweep this config resumes (`origami-jax sweep
    --resume`): a `"net-fold"` sweep stored when the fixed seam tolerance 0.01 was the default
    (its settings name no `seam_tolerance`) keeps it where the config names none (the default is
    derived now), so the stored sweep resumes with its verdicts judged as before.

    **Raises:** `ValueError` for an unknown model, kind or key, or a malformed parameter.
    """
    path = Path(path)
    with path.open("rb") as file:
        raw = tomllib.load(file)
    unknown = set(raw) - {"model", "sweep", "parameters", "designs", "plots"}
    if unknown:
        raise ValueError(f"{path}: unknown section(s) {sorted(unknown)}.")
    for section in ("model", "sweep", "parameters", "plots"):
        if section in raw and not isinstance(raw[section], Mapping):
            raise ValueError(
                f"[{section}] must be a table (a [{section}] header and its keys), got "
                f"{section} = {raw[section]!r}."
            )
    if "designs" in raw and not (
        isinstance(raw["designs"], list) and all(isinstance(d, Mapping) for d in raw["designs"])
    ):
        raise ValueError("designs must be [[designs]] tables, one per design.")
    model = dict(raw.get("model", {}))
    name = _model_name(model)
    settings = {k: v for k, v in model.items() if k not in ("name", "input")}
    if resume_from is not None and name == "net-fold" and "seam_tolerance" not in settings:
        stored = _stored_manifest(resume_from)
        if stored.get("model") == "net-fold" and "seam_tolerance" not in stored.get("settings", {}):
            settings["seam_tolerance"] = LEGACY_SEAM_FRACTION
    kernel = get_model(name, **settings)
    units = dict(kernel.parameters or {})

    run = dict(raw.get("sweep", {}))
    kind = run.pop("kind", "grid")
    if kind not in KINDS:
        raise ValueError(f"[sweep] kind must be one of {KINDS}, got {kind!r}.")
    chunk_size = run.pop("chunk_size", None)
    n = run.pop("n", None)
    seed = run.pop("seed", 0)
    if run:
        raise ValueError(f"[sweep]: unknown key(s) {sorted(run)}.")
    for key, value, low in (("chunk_size", chunk_size, 1), ("n", n, 1), ("seed", seed, 0)):
        if value is not None and (
            isinstance(value, bool) or not isinstance(value, int) or not low <= value
        ):
            raise ValueError(f"[sweep] {key} must be an integer >= {low}, got {value!r}.")
    if n is not None and n > MAX_DESIGNS:
        raise ValueError(f"[sweep] n must be at most {MAX_DESIGNS}, got {n}.")

    parameters = dict(raw.get("parameters", {}))
    space: AbstractDesignSpace
    if kind == "table":
        designs = raw.get("designs")
        if not designs or parameters:
            raise ValueError("kind = 'table' needs [[designs]] entries and no [parameters].")
        names = list(designs[0])
        space = Table.from_records(designs, units={k: units.get(k, "") for k in names})
    else:
        if not parameters:
            raise ValueError(f"kind = {kind!r} needs a [parameters] section.")
        for pname, spec in parameters.items():
            if not isinstance(spec, Mapping):
                raise ValueError(
                    f"parameter {pname!r}: give a table such as {{ values = [...] }} or "
                    "{ min = ..., max = ..., num = ... }."
                )
        unit_of = {p: parameters[p].get("unit", units.get(p, "")) for p in parameters}
        if kind == "grid":
            axes = {p: _grid_axis(p, spec) for p, spec in parameters.items()}
            space = Grid(axes, units=unit_of)
        else:
            if n is None:
                raise ValueError(f"kind = {kind!r} needs [sweep] n = <number of samples>.")
            fixed = {p: s for p, s in parameters.items() if "values" in s}
            try:
                ranges = {
                    p: Range(_number(s, "min", p), _number(s, "max", p), s.get("scale", "linear"))
                    for p, s in parameters.items()
                    if "values" not in s
                }
            except KeyError as error:
                raise ValueError(
                    f"kind = {kind!r}: give every sampled parameter `min` and `max` (missing "
                    f"{error})."
                ) from None
            if not ranges:
                raise ValueError(f"kind = {kind!r} needs at least one {{min, max}} parameter.")
            sampled = Samples(
                ranges, n=int(n), seed=seed, method=kind, units={p: unit_of[p] for p in ranges}
            )
            space = sampled
            if fixed:
                grid = Grid(
                    {p: list(s["values"]) for p, s in fixed.items()},
                    units={p: unit_of[p] for p in fixed},
                )
                space = Product((grid, sampled))
    if space.size > MAX_DESIGNS:
        raise ValueError(
            f"the design space has {space.size} designs, more than {MAX_DESIGNS}; split the sweep."
        )
    plots = dict(raw.get("plots", {}))
    metrics = plots.get("metrics")
    return SweepConfig(
        kernel=kernel,
        space=space,
        chunk_size=None if chunk_size is None else int(chunk_size),
        plot_metrics=None if metrics is None else list(metrics),
        raw=raw,
    )
