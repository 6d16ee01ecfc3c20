"""`family_yield`: the yields of a family of nets (the eleven cube nets, the eleven octahedron
nets, or any list) and their rank correlation with the nets' compactness, as in the
self-folding experiments of Azam, Leong, Zarafshar & Gracias (PLoS ONE 4, e4451, 2009), who
found that compact nets (small radius of gyration, many vertex connections) fold with higher
yield."""

import csv
import dataclasses
import io
import json
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._kernel import design_settings
from ..fold import catalogue_families, catalogue_family
from ..net import Net, model_settings
from ..simulation import FoldVerdict, VerdictTolerances
from ..system import KOH_SOLUTION
from ._estimate import YIELD_RTOL, RunOptions, as_pattern, yield_estimate
from ._scatter import Scatter
from ._stats import INTERVAL_METHODS, binomial_interval, spearman
from ._until import SampleUntil, check_sample_count

# The compactness measures the yields are ranked against: the flat net's radius of gyration
# (µm; small is compact) and its number of vertex connections (many is compact).
MEASURES = ("radius_of_gyration", "vertex_connections")
# Each net's summary in its folder: a net with one is finished (a resumed family skips it).
ESTIMATE_FILE = "estimate.json"
_SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclasses.dataclass(frozen=True)
class RankCorrelation:
    """Spearman's rank correlation of the yields with one compactness measure.

    **Fields:** `measure` (one of `MEASURES`), `rho` (in ``[−1, 1]``; NaN when the yields or the
    measure are all equal, e.g. every net folded), `p_value` (two-sided, of no correlation: the
    t approximation ``t = ρ √((n − 2)/(1 − ρ²))`` with `n − 2` degrees of freedom, as
    `scipy.stats.spearmanr`'s default; NaN below 3 nets), `n` (nets).

    A compact net has a *small* radius of gyration and *many* vertex connections: the
    experimental trend is ``ρ < 0`` against the radius and ``ρ > 0`` against the connections.
    """

    measure: str
    rho: float
    p_value: float
    n: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (NaN stays NaN: the CLI writes it as `null`)."""
        return {"measure": self.measure, "rho": self.rho, "p_value": self.p_value, "n": self.n}


@dataclasses.dataclass(frozen=True)
class NetYield:
    """One net's row of a `FamilyYield`: `name`, `fraction` (the yield), `interval`
    (`(low, high)`), `counts` (verdict → samples), `n_samples`, `radius_of_gyration` (µm, of the
    flat net's face centres, `origami_jax.fold.NetGeometry.radius_of_gyration`),
    `vertex_connections` (`NetGeometry.vertex_connections`, a count), `seconds_per_sample`
    (compilation excluded; 0 for a net read back from its folder)."""

    name: str
    fraction: float
    interval: tuple[float, float]
    counts: dict[str, int]
    n_samples: int
    radius_of_gyration: float
    vertex_connections: int
    seconds_per_sample: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (the radius of gyration as `radius_of_gyration_um`)."""
        return {
            "name": self.name,
            "yield": self.fraction,
            "interval": list(self.interval),
            "counts": dict(self.counts),
            "n_samples": self.n_samples,
            "radius_of_gyration_um": self.radius_of_gyration,
            "vertex_connections": self.vertex_connections,
            "seconds_per_sample": self.seconds_per_sample,
        }


@dataclasses.dataclass(frozen=True)
class FamilyYield:
    """The yields of a family of nets against their compactness (`family_yield`).

    **Fields:** `rows` (one `NetYield` per net, in the order given), `correlations`
    (`measure` → `RankCorrelation`, one per `MEASURES`), `seed`, `n_samples` (samples per net:
    the most of any net where a `SampleUntil` gave each its own; each row has its count),
    `confidence` and `method` (of every net's interval), `settings` (what the estimates shared,
    JSON-ready).
    """

    rows: tuple[NetYield, ...]
    correlations: dict[str, RankCorrelation]
    seed: int
    n_samples: int
    confidence: float
    method: str
    settings: dict[str, Any]

    @property
    def names(self) -> tuple[str, ...]:
        """The nets' names, in the order of `rows`."""
        return tuple(r.name for r in self.rows)

    def table(self) -> list[dict[str, Any]]:
        """One flat row per net (the CSV's): name, yield, interval low and high, one count per
        verdict, radius of gyration (µm), vertex connections, samples."""
        out = []
        for r in self.rows:
            row: dict[str, Any] = {
                "name": r.name,
                "yield": r.fraction,
                "interval_low": r.interval[0],
                "interval_high": r.interval[1],
            }
            row.update({str(v): r.counts.get(str(v), 0) for v in FoldVerdict})
            row.update(
                {
                    "radius_of_gyration_um": r.radius_of_gyration,
                    "vertex_connections": r.vertex_connections,
                    "n_samples": r.n_samples,
                }
            )
            out.append(row)
        return out

    def to_csv(self) -> str:
        """`table()` as CSV text (a header line, then one line per net)."""
        rows = self.table()
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        return buffer.getvalue()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the nets' rows, the correlations and the settings."""
        return {
            "nets": [r.to_dict() for r in self.rows],
            "spearman": {m: c.to_dict() for m, c in self.correlations.items()},
            "seed": self.seed,
            "n_samples": self.n_samples,
            "confidence": self.confidence,
            "interval_method": self.method,
            "settings": self.settings,
        }

    def summary(self) -> str:
        """A few lines for people: one per net, then the correlations."""
        lines = [
            f"{r.name}: yield {r.fraction:.3f} ({r.interval[0]:.3f}-{r.interval[1]:.3f}, "
            f"{r.n_samples} samples), Rg {r.radius_of_gyration:.1f} µm, "
            f"{r.vertex_connections} vertex connections"
            for r in self.rows
        ]
        for c in self.correlations.values():
            lines.append(
                f"Spearman rho vs {c.measure}: {c.rho:.3f} (p = {c.p_value:.3g}, n = {c.n})"
            )
        return "\n".join(lines)


def family_names(patterns) -> list[str] | None:
    """The names of a family given by name (`origami_jax.fold.catalogue_family`: `"cube_nets"`,
    `"octahedron_nets"`) or as a comma-separated list of names; `None` for one name that is
    neither (a single net)."""
    if not isinstance(patterns, str):
        return None
    if patterns in catalogue_families():
        return list(catalogue_family(patterns))
    if "," in patterns:
        return [p.strip() for p in patterns.split(",") if p.strip()]
    return None


def compactness(pattern: Net) -> tuple[float, int]:
    """A net's radius of gyration (design length units, µm for the catalogue) and number of
    vertex connections (`origami_jax.fold.NetGeometry`)."""
    geometry = pattern.geometry
    rg = geometry.radius_of_gyration() * pattern.length_scale
    return float(rg), int(len(geometry.vertex_connections()))


def _settings(
    n_samples, seed, scatter, fluid, process, solve, tolerances, t_settle
) -> dict[str, Any]:
    """What every net's estimate shares, JSON-ready: a resumed family must match it."""
    described = {
        "n_samples": n_samples.to_dict() if isinstance(n_samples, SampleUntil) else int(n_samples),
        "seed": int(seed),
        "scatter": scatter.to_dict(),
        "fluid": design_settings(fluid) if fluid is not None else None,
        "process": None
        if process is None
        else {k: np.asarray(v).tolist() for k, v in process.items()},
        "solve": None
        if solve is None
        else [solve.number("t1"), solve.saveat.n, float(solve.number("rtol"))]
        + [float(solve.number("atol")), solve.max_steps],
        # The tolerance the default solve stands for: a net finished under another default (1e-7
        # before 2026-12-05) is not read back into this family.
        "default_rtol": YIELD_RTOL if solve is None else None,
        "tolerances": tolerances.to_dict(),
        # Always named: a family stored before samples were settled judged them at t1, and is
        # not mixed with nets judged where they come to rest.
        "t_settle_us": t_settle,
    }
    return json.loads(json.dumps(described, default=str))


def family_yield(
    patterns,
    scatter: Scatter | Mapping[str, Any] | None = None,
    n_samples: "int | SampleUntil" = 100,
    seed: int = 0,
    *,
    fluid=KOH_SOLUTION,
    process: Mapping[str, Any] | None = None,
    solve=None,
    tolerances=None,
    confidence: float = 0.95,
    interval: str = "wilson",
    run: RunOptions | None = None,
    on_net: Callable[[str, int, int], None] | None = None,
) -> FamilyYield:
    """The yield of every net of a family (`yield_estimate`, one after the other) and Spearman's
    rank correlation of the yields with the nets' compactness.

    ```python
    family = family_yield("cube_nets", Scatter(), 100, seed=0, run=RunOptions(out="cubes"))
    print(family.summary())   # one line per net, then rho against each measure
    ```

    **Arguments:**
    - `patterns`: a family's name (`"cube_nets"`, `"octahedron_nets"`:
      `origami_jax.fold.catalogue_family`), a comma-separated string of names, or a sequence of
      catalogue names, `.fold` paths or `Net` objects (with the physics model their samples fold
      with: `Net.with_model`). Nets only (trees of panels): compactness is a net's. At least two,
      with distinct names.
    - `scatter`, `n_samples`, `seed`: as `yield_estimate`, the same for every net (a
      `SampleUntil` samples each net until its own interval is as narrow as asked): every net is
      estimated from the same `seed` (common random numbers: sample `k` of every net draws its
      films from the same standard normals, crease `j` of one net the same as crease `j` of
      another), so differences between nets are not differences between independent draws.
    - `fluid`: each net's nominal design is its `default_design(fluid)` (default the KOH bath).
    - `process`, `solve`, `tolerances`: as `yield_estimate` (`process` values one number each:
      the nets have different numbers of creases).
    - `confidence`, `interval`: every net's interval (`YieldEstimate.with_interval`).
    - `run`: a `RunOptions`; with `out`, net `name` keeps its samples in `out/name/` and, once
      finished, its summary in `out/name/estimate.json`; with `resume`, nets whose summary is
      there (and whose settings match) are read back, not run again, and an interrupted net
      continues from its stored samples.
    - `on_net(name, index, total)`: called before each net starts (or is read back).

    **Returns:** a `FamilyYield`.

    **Raises:** `ValueError` (before anything runs) for fewer than two nets, a pattern that is not
    a net, duplicate or unsafe names, bad settings; a resumed net whose stored summary has other
    settings.
    """
    names = family_names(patterns)
    items = names if names is not None else patterns
    if isinstance(items, str) or not isinstance(items, Sequence):
        raise ValueError(
            f"patterns must be a family's name ({', '.join(catalogue_families())}), a "
            f"comma-separated list or a sequence of nets, got {patterns!r}."
        )
    nets = [as_pattern(p) for p in items]
    if len(nets) < 2:
        raise ValueError(f"a family needs at least two nets, got {len(nets)}.")
    for net in nets:
        if not isinstance(net, Net):
            raise ValueError(
                f"{getattr(net, 'name', net)!r} is not a net (a tree of panels): a family's yield "
                "is ranked against the nets' compactness."
            )
        if not _SAFE_NAME.match(net.name):
            raise ValueError(
                f"net name {net.name!r} cannot name a folder: use letters, digits, '.', '_', '-'."
            )
    seen = [n.name for n in nets]
    duplicates = sorted({n for n in seen if seen.count(n) > 1})
    if duplicates:
        raise ValueError(f"nets named twice in the family: {duplicates}; give each once.")
    if interval not in INTERVAL_METHODS:
        raise ValueError(f"interval must be one of {INTERVAL_METHODS}, got {interval!r}.")
    if not (isinstance(confidence, int | float) and 0 < confidence < 1):
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}.")
    check_sample_count(n_samples)
    if scatter is None:
        scatter = Scatter()
    elif isinstance(scatter, Mapping):
        scatter = Scatter.from_mapping(scatter)
    tolerances = VerdictTolerances() if tolerances is None else tolerances
    if not isinstance(tolerances, VerdictTolerances):
        raise ValueError(f"tolerances must be a VerdictTolerances, got {tolerances!r}.")
    run = RunOptions() if run is None else run
    settings = _settings(n_samples, seed, scatter, fluid, process, solve, tolerances, run.t_settle)
    rows = []
    for index, net in enumerate(nets):
        if on_net is not None:
            on_net(net.name, index, len(nets))
        rg, connections = compactness(net)
        folder = None if run.out is None else Path(run.out) / net.name
        design = net.default_design(fluid)
        # The net's own physics (its fluid's inertia, its release ramp) belongs to its record.
        net_settings = {**settings, "model": model_settings(net, design)}
        stored = _stored(folder, net_settings) if run.resume else None
        if stored is not None:
            counts = {str(k): int(v) for k, v in stored["counts"].items()}
            seconds, count = 0.0, int(stored["n_samples"])
        else:
            estimate = yield_estimate(
                net,
                scatter,
                n_samples if isinstance(n_samples, SampleUntil) else int(n_samples),
                int(seed),
                design=design,
                process=process,
                solve=solve,
                tolerances=tolerances,
                run=dataclasses.replace(run, out=folder),
            )
            counts, seconds = dict(estimate.counts), estimate.seconds_per_sample
            count = estimate.n_samples
            if folder is not None:
                record = {"settings": net_settings, "net": net.name, **estimate.to_dict()}
                (folder / ESTIMATE_FILE).write_text(json.dumps(record, indent=1, default=str))
        folded = counts[str(FoldVerdict.FOLDED)]
        rows.append(
            NetYield(
                name=net.name,
                fraction=folded / count,
                interval=binomial_interval(folded, count, float(confidence), interval),
                counts=counts,
                n_samples=count,
                radius_of_gyration=rg,
                vertex_connections=connections,
                seconds_per_sample=float(seconds),
            )
        )
    yields = np.array([r.fraction for r in rows])
    measures = {
        "radius_of_gyration": np.array([r.radius_of_gyration for r in rows]),
        "vertex_connections": np.array([r.vertex_connections for r in rows], dtype=float),
    }
    correlations = {}
    for name, values in measures.items():
        rho, p = spearman(yields, values)
        correlations[name] = RankCorrelation(measure=name, rho=rho, p_value=p, n=len(rows))
    return FamilyYield(
        rows=tuple(rows),
        correlations=correlations,
        seed=int(seed),
        n_samples=max(r.n_samples for r in rows),
        confidence=float(confidence),
        method=interval,
        settings=settings,
    )


def _stored(folder: Path | None, settings: dict[str, Any]) -> dict[str, Any] | None:
    """A finished net's summary in `folder` (its `estimate.json`), or None where there is none.

    **Raises:** `ValueError` when the summary was made with other settings."""
    if folder is None or not (folder / ESTIMATE_FILE).is_file():
        return None
    try:
        record = json.loads((folder / ESTIMATE_FILE).read_text())
    except (OSError, ValueError):
        return None  # unreadable: the net runs again (its samples resume from the store)
    if record.get("settings") != settings:
        raise ValueError(
            f"{folder} holds an estimate made with other settings (samples, seed, scatter, fluid, "
            "process, solve, tolerances or the net's physics model); resume with the settings it "
            "was made with, or choose another output folder."
        )
    return record
