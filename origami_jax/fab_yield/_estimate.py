"""`yield_estimate`: Monte Carlo over fabrication scatter, one folding simulation per sample, run
through the sweep engine (chunked, sharded over devices, resumable)."""

import dataclasses
import json
import os
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, NamedTuple

import equinox as eqx
import jax
import numpy as np

from .._limits import FOLD_SEGMENT, MAX_FOLD_SEGMENTS, MAX_SAMPLES
from ..fold import FoldFormatError
from ..loops import load_pattern
from ..net import FOLD_KERNEL_SOLVE, default_t_end, stored_tolerances
from ..simulation import (
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    RESULTS,
    VERDICT_CODES,
    FoldVerdict,
    SaveAt,
    SolveOptions,
    VerdictTolerances,
)
from ..sweep import AXIS, Table, store_result, sweep
from ..system import KOH_SOLUTION, AbstractPattern, HingeDesign
from ._scatter import PARAMETERS, Scatter, noise_seeds, sample_values, standard_draws
from ._stats import INTERVAL_METHODS, binomial_interval
from ._tolerance import ToleranceSensitivity, tolerance_sensitivity
from ._until import SampleUntil, check_sample_count

_GLOBAL = ("t_structural", "drag_coefficient")


@dataclasses.dataclass(frozen=True)
class YieldEstimate:
    """The yield of a net under fabrication scatter.

    **Fields:**
    - `fraction`: the yield, folded samples / samples (every other verdict, `invalid` included, is
      a failure).
    - `interval`: `(low, high)`, the `confidence` interval of the yield (`method`: `"wilson"` or
      `"clopper-pearson"`, see `wilson_interval`).
    - `counts`: verdict → number of samples (`"folded"`, `"jammed"`, `"misfolded"`, `"unfinished"`,
      `"invalid"`; `origami_jax.simulation.FoldVerdict`).
    - `n_samples`, `seed`, `scatter`.
    - `dataset`: the samples as an `xarray.Dataset` along dimension `design` (one per sample): the
      drawn parameters as coordinates (`misfit_strain[j]`, `t_hinge[j]`, `hinge_width[j]`,
      `release[j]`, `target[j]` per crease, `t_structural`, `drag_coefficient`; µm, µs, rad) and
      the net kernel's
      outputs (`verdict`, `folded`, `time_to_fold`, `final_angle`, `max_seam_gap`, ...; see
      `origami_jax.sweep.get_model("net-fold")`). Attributes: the sweep's, plus `scatter` (JSON),
      `seed`, `yield`.
    - `seconds_per_sample`: this call's computing time per sample it computed, compilation
      excluded (0 when every sample was already stored).
    - `tolerances`: the verdict's, `{"angle_deg", "seam_fraction"}`
      (`origami_jax.simulation.VerdictTolerances.to_dict`; `"derived"` for the default seam
      tolerance).
    - `nominal`: each parameter's nominal value per crease, `{name: (m,)}` (µm, µs), the values the
      scatter is drawn around (`yield_gradient` differentiates the yield with respect to them).
    - `tolerance_sensitivity`: the yield at the tolerances × 0.5, 1 and 2 (angle and seams, each
      and together) from the samples' stored margins, nothing simulated again
      (`ToleranceSensitivity`; only folded against not folded moves); `None` for a resumed run
      whose older samples were stored without margins.
    - `replay`: what `sample_fold` folds a sample again with (the pattern and the estimate's
      options); `None` for an estimate assembled otherwise.
    """

    fraction: float
    interval: tuple[float, float]
    confidence: float
    method: str
    counts: dict[str, int]
    n_samples: int
    seed: int
    scatter: Scatter
    dataset: Any
    seconds_per_sample: float
    tolerances: dict[str, float | str] = dataclasses.field(
        default_factory=lambda: {"angle_deg": 3.0, "seam_fraction": "derived"}
    )
    nominal: dict[str, np.ndarray] | None = None
    tolerance_sensitivity: ToleranceSensitivity | None = None
    replay: "SampleReplay | None" = dataclasses.field(default=None, repr=False, compare=False)

    def samples(self, name: str) -> np.ndarray:
        """The drawn values of a parameter of `PARAMETERS`: `(n_samples, n_creases)` for a per-crease
        one, `(n_samples,)` for `t_structural` and `drag_coefficient`."""
        if name in _GLOBAL:
            return np.asarray(self.dataset[name].values)
        if name not in PARAMETERS:
            raise ValueError(f"unknown parameter {name!r}; the known ones are {list(PARAMETERS)}.")
        columns = sorted(
            (int(c[len(name) + 1 : -1]), c)
            for c in self.dataset.coords
            if str(c).startswith(f"{name}[")
        )
        return np.stack([self.dataset[c].values for _, c in columns], axis=1)

    def sample_fold(self, index: int) -> "SampleFold":
        """Sample `index` (0-based, a row of `dataset`) folded again on its own, its whole trajectory
        kept: why it jammed or misfolded, to plot (`origami_jax.plotting`), view or export
        (`Net.to_fold`). The same drawn parameters, model, solve and tolerances as the estimate; a
        sample the estimate ran on to `RunOptions.t_settle` is run on here too. Compiles the one
        sample's simulation (seconds to a minute; a second sample compiles nothing again).

        Alone, not in a vmapped chunk, the simulation's last bits may differ from the stored
        sample's, and the verdict with them where a crease or seam lies at its tolerance:
        `SampleFold.verdict` is the stored one, `report.verdict` the new run's.

        **Raises:** `ValueError` for an index outside the samples, or an estimate without a
        `replay` (assembled otherwise than by `yield_estimate`)."""
        if self.replay is None:
            raise ValueError(
                "this estimate cannot fold its samples again (no replay: it was not made by "
                "yield_estimate); run yield_estimate with the same pattern and options."
            )
        n = int(self.dataset.sizes[AXIS])
        if (
            isinstance(index, bool)
            or not isinstance(index, int | np.integer)
            or not (-n <= index < n)
        ):
            raise ValueError(f"index must be a sample number in [0, {n}), got {index!r}.")
        return self.replay(self.dataset, int(index) % n)

    def with_interval(self, confidence: float = 0.95, method: str = "wilson") -> "YieldEstimate":
        """This estimate with its interval at another `confidence` or by another `method`
        (`"wilson"`, `"clopper-pearson"`; `binomial_interval`): statistics of the same counts,
        nothing simulated again.

        **Raises:** `ValueError` for a confidence outside ``(0, 1)`` or an unknown method."""
        if method not in INTERVAL_METHODS:
            raise ValueError(f"interval must be one of {INTERVAL_METHODS}, got {method!r}.")
        if not (isinstance(confidence, int | float) and 0 < confidence < 1):
            raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence!r}.")
        folded = self.counts[str(FoldVerdict.FOLDED)]
        interval = binomial_interval(folded, self.n_samples, float(confidence), method)
        sensitivity = self.tolerance_sensitivity
        if sensitivity is not None:
            sensitivity = sensitivity.with_interval(float(confidence), method)
        return dataclasses.replace(
            self,
            interval=interval,
            confidence=float(confidence),
            method=method,
            tolerance_sensitivity=sensitivity,
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no samples)."""
        return {
            "yield": self.fraction,
            "interval": list(self.interval),
            "confidence": self.confidence,
            "interval_method": self.method,
            "counts": dict(self.counts),
            "n_samples": self.n_samples,
            "seed": self.seed,
            "scatter": self.scatter.to_dict(),
            "seconds_per_sample": self.seconds_per_sample,
            "tolerances": dict(self.tolerances),
            "tolerance_sensitivity": (
                None if self.tolerance_sensitivity is None else self.tolerance_sensitivity.to_dict()
            ),
            # The samples still moving at the solve's end and run on to `t_settle` (µs; None: not
            # settled).
            "t_settle_us": self._attrs.get("t_settle_us"),
            "continued": int(self._attrs.get("continued", 0)),
            **(
                {}
                if self.contacts_left_out is None
                else {"samples_with_contacts_left_out": self.contacts_left_out}
            ),
        }

    @property
    def contacts_left_out(self) -> int | None:
        """With the fixed-step engine, how many samples had a step whose working set of contact
        pairs missed one within reach (its force was missed: 0 expected; raise
        `ImplicitStep.active_pairs` otherwise); `None` with the adaptive solvers."""
        dataset = self.dataset
        if dataset is None or "contacts_left_out" not in getattr(dataset, "data_vars", {}):
            return None
        return int(np.sum(np.asarray(dataset["contacts_left_out"].values) > 0))

    @property
    def _attrs(self) -> Mapping[str, Any]:
        return getattr(self.dataset, "attrs", {})

    def summary(self) -> str:
        """One line for people."""
        low, high = self.interval
        counts = ", ".join(f"{k} {v}" for k, v in self.counts.items() if v)
        continued = int(self._attrs.get("continued", 0))
        settled = (
            f" ({continued} still moving at the end, run on to {self._attrs['t_settle_us']:g} µs)"
            if continued
            else ""
        )
        missed = self.contacts_left_out
        missed = (
            f"; {missed} sample(s) had a contact outside the fixed-step engine's working set "
            "(its force missed: raise ImplicitStep.active_pairs)"
            if missed
            else ""
        )
        return (
            f"yield {self.fraction:.3f} ({100 * self.confidence:g} % interval {low:.3f}-{high:.3f},"
            f" {self.method}) over {self.n_samples} samples: {counts}{settled}{missed}"
        )


SETTLE_TIME = MAX_FOLD_SEGMENTS * FOLD_SEGMENT
"""`RunOptions.t_settle`'s default: a sample still moving at the end of its run is run
again up to this time (µs in the MICRO units), the longest folding `fold` continues to."""


YIELD_RTOL = 1e-6
"""A yield's relative tolerance unless given one (its absolute tolerance in the simulation's ratio,
`DEFAULT_ATOL / DEFAULT_RTOL`): looser than a single folding's 1e-7, since a yield asks only which
verdict each sample gets. Against rtol 1e-8 in the bath's default dynamics, it judged 199 of 200
scattered `cube_net_01` samples (seed 5) alike, as 1e-7 did (each difference a crease within 0.1°
of the angle tolerance, a different one for each), and 100 of 100 `octahedron_net_05` samples, in
75 % of 1e-7's steps (54 % of 1e-8's)."""

YIELD_SOLVE = FOLD_KERNEL_SOLVE.replace(
    rtol=YIELD_RTOL, atol=DEFAULT_ATOL / DEFAULT_RTOL * YIELD_RTOL
)
"""A yield's solve unless given one: `origami_jax.net.FOLD_KERNEL_SOLVE` at `YIELD_RTOL`."""


@dataclasses.dataclass(frozen=True)
class RunOptions:
    """How a yield estimate runs and where it keeps its samples: nothing here changes a sample's
    simulation (`t_settle` decides how long one still moving at the end is followed).

    **Fields:**
    - `out`: a folder to store the samples in as they finish (`origami_jax.sweep.sweep`'s), or
      `None` (in memory).
    - `resume`: continue the interrupted estimate stored in `out` (it must have the same pattern,
      settings, scatter, seed and number of samples).
    - `chunk_size`, `workers`, `progress`, `on_chunk`: as `origami_jax.sweep.sweep` (on a CPU the
      default runs one sample per compiled call, as many at once as there are cores).
    - `step_budget`: solver steps per sample in a first pass (default `None`: one pass of the
      solve's `max_steps`). A vmapped chunk steps until its slowest member is done, and under
      scatter a few samples take ten times the median's steps: with a budget, the samples that
      reach it are run again, all together, in a second pass with `max_steps` (stored in
      `out/stragglers`). The samples' results are the same either way; it pays where chunks are
      wide (accelerators, or a `chunk_size` on a CPU) at the price of one more compilation. A
      budget of a few times the median sample's steps (the dataset's `num_steps`) keeps the
      second pass small.
    - `t_settle`: µs (default `SETTLE_TIME`, 8,000 µs: the longest folding `fold` continues to).
      A sample whose panels still move at the end of the solve's `t1` (verdict `unfinished`, the
      solve successful) is run again from the start to `t_settle`, with the same spacing of saved
      samples, and judged there: the estimate then judges where the nets come to rest, as `fold`
      does, rather than how far they got by `t1` (in the etch bath a scattered cube net can creep
      or ring for milliseconds after the nominal one has closed). The samples continued run in
      one more sweep (one more compilation; `out/settled` when stored); the dataset's attributes
      `continued` and `t_settle_us` say how many and to when. `None`, or a time not past `t1`,
      keeps the verdicts at `t1` (`unfinished`).

    Change one with `dataclasses.replace(run, out=...)`.
    """

    out: str | os.PathLike | None = None
    resume: bool = False
    chunk_size: int | None = None
    workers: int | None = None
    progress: bool = True
    on_chunk: Callable[[int, int], None] | None = None
    step_budget: int | None = None
    t_settle: float | None = SETTLE_TIME

    def sweep_options(self) -> dict[str, Any]:
        """The keyword arguments of `origami_jax.sweep.sweep` these options set."""
        return {
            "out": self.out,
            "resume": self.resume,
            "chunk_size": self.chunk_size,
            "workers": self.workers,
            "progress": self.progress,
            "on_chunk": self.on_chunk,
        }


def as_pattern(pattern):
    """A pattern object from `pattern`: itself, or the pattern a catalogue name or `.fold` path
    names (`origami_jax.loops.load_pattern`; the one place a yield function reads a name).

    **Raises:** `ValueError` for a file that is not a pattern."""
    if isinstance(pattern, AbstractPattern):
        return pattern
    try:
        return load_pattern(pattern)
    except FoldFormatError as error:
        raise ValueError(f"{pattern}: {error}") from None


def _nominal(design, release_times, m: int) -> dict[str, np.ndarray]:
    """Nominal value of every scattered parameter, `(m,)` each (global ones repeated)."""
    nominal = {}
    for name in PARAMETERS:
        if name == "release":
            value = np.zeros(m) if release_times is None else release_times
        else:
            value = np.asarray(getattr(design, name), dtype=float)
            if name in _GLOBAL and value.ndim:
                raise ValueError(
                    f"the design's {name} must be one number for the whole net, got shape "
                    f"{value.shape}."
                )
            if value.ndim and value.shape != (m,):
                raise ValueError(
                    f"the design's {name} must be a number or one per crease ({m}), got shape "
                    f"{value.shape}."
                )
        nominal[name] = np.broadcast_to(value, (m,)).astype(float)
    return nominal


def _process(process: Mapping[str, Any] | None, m: int) -> dict[str, np.ndarray]:
    """The checked `process` nominal values of `yield_estimate`, `(m,)` each."""
    if process is None:
        return {}
    if not isinstance(process, Mapping):
        raise ValueError(
            f"process must be a mapping of nominal values, got {type(process).__name__}."
        )
    out = {}
    for name, value in process.items():
        if name not in PARAMETERS or name == "release":
            known = [n for n in PARAMETERS if n != "release"]
            raise ValueError(
                f"process: unknown parameter {name!r}; use {known} (release times: release_times)."
            )
        value = np.asarray(value, dtype=float)
        if value.ndim and (name in _GLOBAL or value.shape != (m,)):
            raise ValueError(
                f"process: {name} must be a number"
                + ("" if name in _GLOBAL else f" or one per crease ({m})")
                + f", got shape {value.shape}."
            )
        if not (np.all(np.isfinite(value)) and np.all(value > 0)):
            raise ValueError(f"process: {name} must be finite and positive, got {value.tolist()}.")
        out[name] = np.broadcast_to(value, (m,)).astype(float)
    return out


def _columns(values: Mapping[str, np.ndarray]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The sweep's columns and their units (`PARAMETERS`: the net kernel's MICRO units, µm, µs)."""
    columns, units = {}, {}
    for name, x in values.items():
        unit = PARAMETERS[name][0]
        if name in _GLOBAL:
            columns[name] = x[:, 0]
            units[name] = unit
            continue
        for j in range(x.shape[1]):
            columns[f"{name}[{j}]"] = x[:, j]
            units[f"{name}[{j}]"] = unit
    return columns, units


def _stragglers_finished(dataset, kernel, columns, units, **sweep_options):
    """`dataset` (a first pass under a step budget) with its samples that reached the budget run
    again by `kernel` (the full `max_steps`), all in one sweep; its `run_s` and `compile_s` then
    include that pass, and its attributes say how many there were (`stragglers`)."""
    over = np.flatnonzero(
        np.asarray(dataset["result"].values) == int(RESULTS.max_steps_reached._value)
    )
    dataset = dataset.copy(deep=True)
    dataset.attrs["stragglers"] = int(over.size)
    if over.size:
        _run_again(dataset, over, kernel, columns, units, **sweep_options)
    return dataset


def _run_again(dataset, rows, kernel, columns, units, **sweep_options) -> None:
    """The samples `rows` of `dataset` run again by `kernel` in one sweep, their outputs written
    over theirs (in place); `run_s` and `compile_s` then include that pass."""
    table = Table({name: np.asarray(c)[rows] for name, c in columns.items()}, units=units)
    rest = sweep(kernel, table, **sweep_options)
    for name in dataset.data_vars:
        dataset[name].values[rows] = rest[name].values
    for key in ("run_s", "compile_s"):
        dataset.attrs[key] = float(dataset.attrs.get(key, 0.0)) + float(rest.attrs.get(key, 0.0))
    dataset.attrs["n_failed"] = int(np.sum(np.asarray(dataset["result"].values) != 0))


def _unfinished_settled(dataset, pattern, options, columns, units, t_settle, **sweep_options):
    """`dataset` with its samples judged `unfinished` because their panels still moved at the end
    (a successful solve whose time ran out) run again from the start to `t_settle`, all in one
    sweep (`_settling`). Its attributes say how many there were (`continued`) and to when
    (`t_settle_us`); `run_s` and `compile_s` include that pass."""
    solve = options["solve"]
    dataset = dataset.copy(deep=True)
    dataset.attrs["t_settle_us"] = float(t_settle)
    moving = (np.asarray(dataset["verdict"].values) == VERDICT_CODES[FoldVerdict.UNFINISHED]) & (
        np.asarray(dataset["result"].values) == int(RESULTS.successful._value)
    )
    rows = np.flatnonzero(moving)
    dataset.attrs["continued"] = int(rows.size)
    if rows.size:
        kernel = pattern.kernel(**{**options, "solve": _settling(solve, t_settle)})
        _run_again(dataset, rows, kernel, columns, units, **sweep_options)
    return dataset


def _settling(solve: SolveOptions, t_settle: float) -> SolveOptions:
    """`solve` run on to `t_settle`, with the same spacing of saved samples (so the verdict's tail
    and drift judge the same time resolution)."""
    t_end, n_save = solve.number("t1"), solve.saveat.n
    n_long = min(int(round((n_save - 1) * t_settle / t_end)) + 1, MAX_SAMPLES)
    return solve.replace(t1=float(t_settle), saveat=SaveAt(n=n_long))


class SampleFold(NamedTuple):
    """One sample of a yield estimate folded again (`YieldEstimate.sample_fold`): its `system` (a
    `FoldingSystem` with the sample's drawn hinges), its `trajectory` (the whole run, to the
    estimate's end or, where it was run on, to `t_settle`), the `report` on it (the verdict and its
    reasons, `origami_jax.simulation.FoldReport`) and the `verdict` the estimate stored."""

    system: Any
    trajectory: Any
    report: Any
    verdict: str


class SampleReplay:
    """What `YieldEstimate.sample_fold` folds a sample with: the `pattern`, the estimate's kernel
    `options` (`origami_jax.net.fold_kernel`'s) and `t_settle` (µs, `None`: not run on). Keeps the
    compiled simulation of each of its kernels (the run to the end, and on to `t_settle`)."""

    def __init__(self, pattern, options: Mapping[str, Any], t_settle: float | None):
        self.pattern, self.options, self.t_settle = pattern, dict(options), t_settle
        self._compiled: dict[float, Callable] = {}

    def __call__(self, dataset, index: int) -> SampleFold:
        codes = list(FoldVerdict)
        stored = str(codes[int(dataset["verdict"].values[index])])
        solve = self.options["solve"]
        system, trajectory = self._run(solve, dataset, index)
        report = self._report(system, trajectory)
        t_end = solve.number("t1")
        if (
            report.verdict == FoldVerdict.UNFINISHED
            and bool(trajectory.succeeded)
            and self.t_settle is not None
            and self.t_settle > t_end
        ):
            longer = _settling(solve, self.t_settle)
            system, trajectory = self._run(longer, dataset, index)
            report = self._report(system, trajectory)
        return SampleFold(system, trajectory, report, stored)

    def _run(self, solve: SolveOptions, dataset, index: int):
        kernel = self.pattern.kernel(**{**self.options, "solve": solve})
        params = {
            name: jax.numpy.asarray(float(dataset[name].values[index]))
            for name in kernel.parameters
            if name in dataset.coords
        }
        t1 = solve.number("t1")
        if t1 not in self._compiled:
            self._compiled[t1] = eqx.filter_jit(kernel.replay)
        return self._compiled[t1](params)

    def _report(self, system, trajectory):
        return self.pattern.assess(
            system, trajectory, tolerances=self.options["tolerances"], bias=self.options["bias"]
        )


def stored_run_tolerances(out) -> VerdictTolerances | None:
    """The verdict's tolerances of the yield estimate stored in the folder `out` (its sweep's
    settings, `origami_jax.net.stored_tolerances`: a run stored when the fixed 0.01 was the
    default names none and gets 0.01), or `None` where nothing readable is stored (the sweep then
    says what is wrong). What `yield_estimate` resumes with when given no `tolerances`."""
    try:
        manifest = json.loads((Path(out) / "sweep.json").read_text())
        return stored_tolerances(manifest["settings"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _stored_samples(out) -> int:
    """Samples a resumed estimate finds stored (the sweep's chunk files name their counts)."""
    if out is None:
        return 0
    total = 0
    for path in (Path(out) / "chunks").glob("part-*-*.nc"):
        try:
            total += int(path.stem.rsplit("-", 1)[1])
        except ValueError:
            continue
    return total


def yield_estimate(
    pattern,
    scatter: Scatter | Mapping[str, Any] | None = None,
    n_samples: int | SampleUntil = 100,
    seed: int = 0,
    *,
    design=None,
    targets=None,
    release_times=None,
    process: Mapping[str, Any] | None = None,
    solve=None,
    tolerances=None,
    bias: float = 0.0,
    run: RunOptions | None = None,
) -> YieldEstimate:
    """The fraction of fabricated nets that fold into the intended shape, with its confidence
    interval (module docstring).

    Every sample is the pattern with its hinges' films, widths and release times drawn from
    `scatter` (`standard_draws` from `seed`), simulated from flat for the solve's `t1` and judged
    by `origami_jax.simulation.fold_outcome` against the pattern's fold angles and seams. The
    hinge lengths are the nominal design's (``l = ρ₀ |θ_target|``, drawn by lithography), so a
    sample whose film bends more or less than nominal folds its crease past or short of the target
    (`hinge_lengths="designed"` of `origami_jax.net.fold_kernel`). The samples run through
    `origami_jax.sweep.sweep`: in chunks, vmapped, sharded over `jax.local_devices()`, stored in
    `run.out` as they finish.

    ```python
    pattern = load_pattern("corner_cube").with_model(contact="plate")
    estimate = yield_estimate(
        pattern, Scatter(), 32, seed=1, run=RunOptions(out="yield-out", chunk_size=4)
    )  # in the KOH bath: the fluid's inertia, released over the quasi-static ramp
    ```

    **Arguments** (lengths µm, times µs: the MICRO units):
    - `pattern`: a `Net` (a tree of panels) or a `CreasePattern` (closed loops: a waterbomb, a
      Miura sheet, whose samples start flat or pre-folded by `bias` and are `misfolded` when they
      take another branch), with the physics model its samples fold with (`contact`, `drag`,
      `contact_sampling`: `Net.with_model`). For convenience a catalogue name
      (`origami_jax.fold.catalogue_names()`, e.g. `"cube_net_01"`) or a `.fold` path, read once
      here (`load_pattern`, its default model).
    - `scatter`: a `Scatter` (default `Scatter()`, the documented defaults) or a mapping of one.
    - `n_samples`, `seed`: how many nets to draw, and from which seed; or, for `n_samples`, a
      `SampleUntil` (e.g. `SampleUntil(half_width=0.1)`): draw in rounds until the interval is
      that narrow (each further round in `run.out/samples-<from>-<to>/`; the samples are the same
      sequence of draws whatever the count, so the first `n` of a larger estimate are the `n` of
      a smaller one). The dataset's attributes `rounds` and `sample_until` record it.
    - `design`: the nominal `HingeDesign` (default `HingeDesign.literature(fluid=KOH_SOLUTION)`,
      each hinge no wider than its crease: the fold happens in the etch bath); its `theta_final`
      is not used.
    - `targets`: the angles the hinges are drawn to fold to (rad, one per crease; default the
      pattern's); `release_times`: nominal release time per crease (µs, default all 0).
    - `process`: the fabrication's nominal values where they differ from the design's, e.g.
      `{"misfit_strain": 1.03 * design.misfit_strain}` for a film deposited 3 % more stressed than
      the hinges were drawn for: the scatter is drawn around these while the hinge lengths stay the
      design's. Keys: `misfit_strain`, `t_hinge`, `hinge_width` (a number or one per crease),
      `t_structural`, `drag_coefficient` (a number); default none (the process hits the design).
    - `solve`: a `SolveOptions`, each sample's simulated time `t1`, saved samples `saveat.n`,
      step budget `max_steps` and tolerances `rtol`, `atol` (default
      `YIELD_SOLVE`: 1500 µs, or a fifth of the release ramp past it — in the etch bath, by
      default, the quasi-static ramp of the nominal design, `Net.nominal_release_ramp` —, 301
      samples, 200,000 steps, rtol `YIELD_RTOL` = 1e-6, where a single folding's is 1e-7).
      Looser tolerances are faster and move contact events in time: on 16
      scattered cube nets every verdict was the same from rtol 1e-4 to 1e-10 (atol 1e-2 rtol,
      the defaults' ratio), with 40 % fewer steps at 1e-5 than at 1e-7; check on a few
      samples of your own net before relying on it.
    - `tolerances`: the verdict's (`origami_jax.simulation.VerdictTolerances`; default 3° and each
      seam's tolerance derived from it and the geometry: the gap creases each within 3° would
      leave). `VerdictTolerances(seam=0.01)` is the fixed 1 % of the largest panel's size that
      was the default before (2 µm on 200 µm panels, about 0.6° of crease error: it decided most
      verdicts). Resuming (`run.resume`) without `tolerances` keeps the stored run's (a run
      stored without a seam tolerance in its settings: the fixed 0.01; `stored_tolerances`).
      The estimate also reports the yield at the tolerances × 0.5, 1 and 2
      (`YieldEstimate.tolerance_sensitivity`).
    - `bias`: a closed-loop pattern's pre-fold (rad, `CreasePattern.start_state`): 0 (default)
      starts every sample flat, a bifurcation where the inputs pick the branch; a membrane is
      never quite flat, and a small bias along the pattern's own angles (0.05) is what most
      devices start from. Nets take 0.
    - `run`: a `RunOptions`: where the samples are kept (`out`, `resume`), how they are computed
      (`chunk_size`, `workers`, `step_budget`) and reported (`progress`, `on_chunk`), and how
      long a sample still moving at `t1` is followed (`t_settle`, default 8,000 µs after the
      release ramp).

    The interval is the 95 % Wilson interval; `YieldEstimate.with_interval` gives another.

    **Returns:** a `YieldEstimate`.

    **Raises:** `ValueError` (before anything compiles) for a bad scatter, a pattern that cannot
    be read, bad counts or settings; `RuntimeError` without float64
    (`jax.config.update("jax_enable_x64", True)`); the sweep's errors for a folder that holds
    another estimate.
    """
    if not jax.config.jax_enable_x64:  # pyright: ignore[reportAttributeAccessIssue] (a flag)
        # In float32 a net's contact solve runs out of steps: every sample would come back
        # unfinished after the whole step budget (minutes per sample).
        raise RuntimeError(
            'yield_estimate needs float64: call jax.config.update("jax_enable_x64", True) first'
        )
    check_sample_count(n_samples)
    if tolerances is None:
        resumed = isinstance(run, RunOptions) and run.resume and run.out is not None
        tolerances = (resumed and stored_run_tolerances(run.out)) or VerdictTolerances()
    if not isinstance(tolerances, VerdictTolerances):
        raise ValueError(f"tolerances must be a VerdictTolerances, got {tolerances!r}.")
    solve = YIELD_SOLVE if solve is None else solve
    if not isinstance(solve, SolveOptions):
        raise ValueError(f"solve must be a SolveOptions, got {type(solve).__name__}.")
    rtol = solve.number("rtol")
    if not (isinstance(rtol, float) and 0 < rtol < 1):
        raise ValueError(f"rtol must be a number strictly between 0 and 1, got {rtol!r}.")
    run = RunOptions() if run is None else run
    if not isinstance(run, RunOptions):
        raise ValueError(f"run must be a RunOptions, got {type(run).__name__}.")
    t_settle = run.t_settle
    if t_settle is not None and not (
        isinstance(t_settle, int | float)
        and not isinstance(t_settle, bool)
        and np.isfinite(t_settle)
        and t_settle > 0
    ):
        raise ValueError(
            f"t_settle must be a positive end time (µs) or None (no settling run), got "
            f"{t_settle!r}."
        )
    if scatter is None:
        scatter = Scatter()
    elif isinstance(scatter, Mapping):
        scatter = Scatter.from_mapping(scatter)
    elif not isinstance(scatter, Scatter):
        raise ValueError(f"scatter must be a Scatter or a mapping, got {type(scatter).__name__}.")
    if design is not None and not isinstance(design, HingeDesign):
        raise ValueError(f"design must be a HingeDesign, got {type(design).__name__}.")
    out = run.out
    if out is not None and not run.resume and (Path(out) / "sweep.json").exists():
        raise FileExistsError(
            f"{out} already holds a yield estimate. Pass resume=True (CLI: --resume) to continue "
            "it, or choose another output folder."
        )
    pattern = as_pattern(pattern)
    if not (isinstance(bias, int | float) and not isinstance(bias, bool) and 0 <= bias < 1):
        raise ValueError(f"bias must be a pre-fold angle in [0, 1) rad, got {bias!r}.")
    if bias:
        pattern.start_state(bias=bias)  # a net refuses one: it starts flat
    max_steps = solve.max_steps
    step_budget = run.step_budget
    if step_budget is not None and not (
        isinstance(step_budget, int | np.integer)
        and not isinstance(step_budget, bool)
        and 1 <= step_budget < max_steps
    ):
        raise ValueError(
            f"step_budget must be a whole number of solver steps from 1 to max_steps - 1 "
            f"({max_steps - 1}), got {step_budget!r}."
        )
    if design is None:
        design = pattern.default_design(KOH_SOLUTION)
    m = pattern.n_hinges
    # Every sample is released over the nominal design's ramp (`nominal_release_ramp`).
    ramp = pattern.nominal_release_ramp(design)
    t_end = solve.number("t1") if solve.t1 is not None else default_t_end(ramp)
    if t_settle is not None:
        t_settle = t_settle + (0.0 if ramp is None else ramp)
    if release_times is not None:
        release_times = np.asarray(release_times, dtype=float)
        if release_times.shape != (m,):
            raise ValueError(
                f"release_times must be {m} times (µs, one per crease), got shape "
                f"{release_times.shape}."
            )
        if not np.all(np.isfinite(release_times)):
            raise ValueError(f"release_times must be finite (µs), got {release_times.tolist()}.")
        if np.any(release_times < 0):
            raise ValueError(f"release_times must be >= 0 µs, got {release_times.tolist()}.")
        late = np.flatnonzero(release_times >= t_end) if isinstance(t_end, int | float) else []
        if len(late):
            # Every sample would be unfinished (the crease never moves): a yield of 0 that says
            # nothing about the net.
            raise ValueError(
                f"release_times: crease {int(late[0])} is released at "
                f"{release_times[late[0]]:g} µs, at or after t_end {t_end:g} µs, so no sample "
                "could fold; give a longer t_end (CLI: --t-end) or earlier release times."
            )
    nominal = _nominal(design, release_times, m)
    nominal.update(_process(process, m))
    release = scatter.release
    if release.width > 0 and release.relative and not np.any(nominal["release"] > 0):
        raise ValueError(
            "scatter of release: a relative width of nominal release times that are all 0 is no "
            "scatter; give relative = false (a width in µs) or nominal release_times."
        )
    aims = pattern.intended_angles if targets is None else np.asarray(targets, dtype=float)
    if aims.shape != (m,) or not np.all(np.isfinite(aims)):
        raise ValueError(f"targets must be {m} finite angles (rad, one per crease).")
    options = dict(
        design=design,
        hinge_lengths="designed",
        solve=solve.replace(t1=t_end),
        tolerances=tolerances,
        bias=float(bias),
    )
    first_pass = max_steps if step_budget is None else int(step_budget)
    # The same kernel program for the same pattern contents and options (`fold_kernel`): a second
    # estimate of the net, loaded again or not, at other tolerances or another nominal design,
    # compiles nothing again.
    kernel = pattern.kernel(**{**options, "solve": options["solve"].replace(max_steps=first_pass)})

    def samples(start: int, end: int, folder, chunk_size) -> tuple[Any, int]:
        """Samples `start` to `end` (of the one sequence of draws) simulated and judged, stored in
        `folder`; and how many of them a resumed estimate found stored."""
        values = sample_values(scatter, nominal, standard_draws(seed, end, m))
        values = {name: v[start:end] for name, v in values.items()}
        _warn_non_positive(values)
        columns, units = _columns(values)
        # The hinges' drawn angles are data, not settings: nets aimed elsewhere share the
        # compiled call.
        for j in range(m):
            columns[f"target[{j}]"] = np.full(end - start, aims[j])
            units[f"target[{j}]"] = "rad"
        if getattr(pattern, "agitation", None) is not None:
            # Each sample's own noise (`Net.with_model(agitation=...)`), from the seed.
            columns["noise_seed"] = noise_seeds(seed, end)[start:end]
            units["noise_seed"] = "1"
        part_run = dataclasses.replace(run, out=folder, chunk_size=chunk_size)
        stored = _stored_samples(folder) if run.resume else 0
        dataset = sweep(kernel, Table(columns, units=units), **part_run.sweep_options())

        def later_pass(name: str) -> dict[str, Any]:
            """The sweep options of a pass that runs some samples again (stored in
            `folder/name`; `on_chunk` counts the estimate's samples, so not these)."""
            where = None if folder is None else Path(folder) / name
            return {**part_run.sweep_options(), "out": where, "on_chunk": None}

        if step_budget is not None:
            dataset = _stragglers_finished(
                dataset, pattern.kernel(**options), columns, units, **later_pass("stragglers")
            )
            # The first pass's kernel settings say max_steps = the budget; the second's did not.
            dataset.attrs.update({"step_budget": int(step_budget), "max_steps": int(max_steps)})
        if t_settle is not None and isinstance(t_end, int | float) and t_settle > t_end:
            dataset = _unfinished_settled(
                dataset, pattern, options, columns, units, t_settle, **later_pass("settled")
            )
        if folder is not None and (
            dataset.attrs.get("stragglers") or dataset.attrs.get("continued")
        ):
            # The store's sweep.nc gathers the first pass; the samples as judged (the later
            # passes' rows merged in) replace it. A resume gathers the chunks again.
            store_result(folder, dataset)
        return dataset, stored

    until = n_samples if isinstance(n_samples, SampleUntil) else None
    n = until.first if until is not None else int(n_samples)
    dataset, stored = samples(0, n, out, run.chunk_size)
    parts = [dataset]
    chunk_size = run.chunk_size or dataset.attrs.get("chunk_size")
    folded = _folded(dataset)
    while until is not None:
        more = until.next_count(folded, n)
        if more is None:
            break
        # Each further round in a folder of its own (a sweep of its own rows), named by its
        # rows, so that a resumed estimate finds it again.
        folder = None if out is None else Path(out) / f"samples-{n}-{more}"
        part, stored_part = samples(n, more, folder, chunk_size)
        parts.append(part)
        stored += stored_part
        folded, n = folded + _folded(part), more
    if len(parts) > 1:
        dataset = _joined(parts)
    if until is not None:
        dataset.attrs["rounds"] = len(parts)
        dataset.attrs["sample_until"] = json.dumps(until.to_dict(), sort_keys=True)
        if out is not None and len(parts) > 1:
            store_result(out, dataset)  # every round's samples, as reported
    codes = np.asarray(dataset["verdict"].values)
    counts = {str(v): int(np.sum(codes == i)) for i, v in enumerate(FoldVerdict)}
    folded = counts[str(FoldVerdict.FOLDED)]
    low, high = binomial_interval(folded, n, 0.95, "wilson")
    dataset.attrs.update(
        {
            "scatter": json.dumps(scatter.to_dict(), sort_keys=True),
            "seed": int(seed),
            "yield": folded / n,
        }
    )
    n_run = n - min(stored, n)
    seconds = float(dataset.attrs.get("run_s", 0.0))
    sensitivity = tolerance_sensitivity(dataset, tolerances.to_dict())
    return YieldEstimate(
        fraction=folded / n,
        interval=(low, high),
        confidence=0.95,
        method="wilson",
        counts=counts,
        n_samples=n,
        seed=int(seed),
        scatter=scatter,
        dataset=dataset,
        seconds_per_sample=seconds / n_run if n_run else 0.0,
        tolerances=tolerances.to_dict(),
        nominal={k: np.array(v) for k, v in nominal.items()},
        tolerance_sensitivity=sensitivity,
        replay=SampleReplay(pattern, options, t_settle),
    )


def _folded(dataset) -> int:
    """How many of `dataset`'s samples are `folded`."""
    code = VERDICT_CODES[FoldVerdict.FOLDED]
    return int(np.sum(np.asarray(dataset["verdict"].values) == code))


# Attributes of a round's dataset that count its work: a joined estimate's are their sums.
_SUMMED_ATTRS = ("run_s", "compile_s", "stragglers", "continued", "n_failed")


def _warn_non_positive(values: Mapping[str, np.ndarray]) -> None:
    bad = {n: int(np.sum(np.any(v <= 0, axis=1))) for n, v in values.items() if n != "release"}
    bad = {n: c for n, c in bad.items() if c}
    if bad:
        warnings.warn(
            f"the scatter draws non-positive values for {bad} sample(s); they count as invalid "
            "(not folded): narrow the spread or use a lognormal one.",
            stacklevel=4,
        )


def _joined(parts):
    """The rounds' datasets as one, the samples numbered on from round to round along the sweep's
    axis; the work attributes (`_SUMMED_ATTRS`) summed."""
    import xarray as xr

    offset, shifted = 0, []
    for part in parts:
        size = part.sizes[AXIS]
        shifted.append(part.assign_coords({AXIS: np.arange(offset, offset + size)}))
        offset += size
    joined = xr.concat(shifted, dim=AXIS, combine_attrs="override")
    for key in _SUMMED_ATTRS:
        present = [p.attrs[key] for p in parts if key in p.attrs]
        if present:
            joined.attrs[key] = type(present[0])(sum(present))
    return joined
