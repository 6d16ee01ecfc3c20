"""`unfold`: decide whether a folded single vertex unfolds flat without collisions, and show how.

The descent itself is `_descent.descend`, one jitted `lax.while_loop`; this module validates the
input, compiles and caches the kernel per (size, kind, energy), tries the documented escapes when a
run stalls, re-checks the certificate on the returned path, and packages an `UnfoldResult`.

**Escapes** (tried in this order after a stall, each from the stalled state; the first that reaches
flat wins, and every attempt is listed in `UnfoldResult.escapes`):
1. `"perturbation"`: a small random move in the tangent space of the constraints (certified like a
   step), then the same descent again: leaves a saddle or a flat stretch of the energy.
2. `"switch-energy"`: descend with the other energy (Eq. 1 ↔ Eq. 2) at its default `p`.
3. `"continuation-p"`: descend with the same energy at a sequence of other exponents `p`
   (separable: 1, 4, 8; non-separable: 2, 8), each from where the previous one stopped.
"""

import dataclasses
import enum
import functools
import time
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, PRNGKeyArray

from .._result_codes import message
from ._descent import (
    CERT_MARGIN,
    RESULTS,
    DescentOutput,
    DescentSettings,
    descend,
    multipliers,
    project,
    restore,
)
from ._energy import DEFAULT_P, check_energy
from ._geometry import arc_pair_clearances, constraints, fold_angles_of, topology
from ._model import CONTACT_TOL, InvalidVertexError, SingleVertex, validate_vertex


class Verdict(enum.StrEnum):
    """Outcome of `unfold` (a `str`, so `result.verdict == "flat-unfolded"` works)."""

    FLAT_UNFOLDED = "flat-unfolded"
    """All nodes on one great circle and every |fold angle| below tolerance, via a certified path."""
    FLAT_FOLDED = "flat-folded"
    """Nodes planar but some flaps lie on each other: flat, but not unfolded."""
    STALLED = "stalled"
    """The energy stopped decreasing away from flat (or the step budget ran out); escapes failed."""
    INVALID = "invalid"
    """The input failed validation (see `UnfoldResult.reason`)."""


def _code(item: RESULTS) -> np.ndarray:
    # The integer code(s) of a concrete result (host-side lookups, also over whole batches).
    return np.asarray(item._value)


def _is(status: RESULTS, items: tuple[RESULTS, ...]) -> bool:
    """Whether a concrete scalar descent result is one of `items`."""
    return int(_code(status)) in {int(_code(item)) for item in items}


_VERDICT_OF_CODE = {
    int(_code(RESULTS.flat_unfolded)): Verdict.FLAT_UNFOLDED,
    int(_code(RESULTS.flat_folded)): Verdict.FLAT_FOLDED,
    int(_code(RESULTS.stalled)): Verdict.STALLED,
    int(_code(RESULTS.max_steps_reached)): Verdict.STALLED,
    int(_code(RESULTS.invalid)): Verdict.INVALID,
    int(_code(RESULTS.contact)): Verdict.STALLED,
}
# The stalls the escapes try to get out of.
_STALLS = (RESULTS.stalled, RESULTS.max_steps_reached, RESULTS.contact)
# The results that end an escape's sequence of runs.
_FINAL = (RESULTS.flat_unfolded, RESULTS.flat_folded, RESULTS.invalid)


@dataclasses.dataclass(frozen=True)
class Certificate:
    """Collision-free check of a path, re-done on the returned states (`certify_path`).

    - `ok`: no state has crossing non-adjacent arcs, no fold angle reaches ±π, constraints hold to
      `1e-9`, and every step satisfies the step bound `CERT_MARGIN · δ / cos(α_max/2) < clearance`
      (see `_descent`), so no crossing can happen between two checked states.
    - `n_states`, `n_steps`: how many states and steps were checked.
    - `min_clearance`: smallest clearance between non-adjacent arcs over the path (radians; pairs
      touching in the input excluded).
    - `max_abs_fold_angle`: radians, over the path (after the first state).
    - `max_constraint_residual`: largest `|G(x)|` over the path.
    - `max_step_ratio`: largest `CERT_MARGIN · δ / cos(α_max/2) / clearance` over the steps (< 1).
    - `crossing_states`: indices of states with a crossing (empty when ok).
    - `warnings`: contacts of the input that only the discrete test covers.
    """

    ok: bool
    n_states: int
    n_steps: int
    min_clearance: float
    max_abs_fold_angle: float
    max_constraint_residual: float
    max_step_ratio: float
    crossing_states: tuple[int, ...]
    warnings: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class CreaseReport:
    """How each crease's fold angle behaved along the path (the paper's "consistent with the
    direction of rotation" claim, measured rather than assumed).

    - `creases`: node indices of the creases, `(m,)`.
    - `sign_changes`: times the fold angle went from clearly valley to clearly mountain or back
      (|ρ| > 1° on both sides).
    - `reversals`: times the fold angle's rate changed sign (not monotone in time).
    - `opening_steps`: steps on which |ρ| grew (the crease folded further instead of unfolding).
    - `monotone`: `reversals == 0` per crease.
    """

    creases: np.ndarray
    sign_changes: np.ndarray
    reversals: np.ndarray
    opening_steps: np.ndarray

    @property
    def monotone(self) -> np.ndarray:
        return self.reversals == 0

    def summary(self) -> str:
        return (
            f"{int(np.sum(self.sign_changes > 0))}/{len(self.creases)} creases change sign, "
            f"{int(np.sum(~self.monotone))}/{len(self.creases)} are not monotone"
        )


@dataclasses.dataclass(frozen=True)
class UnfoldResult:
    """Everything `unfold` found. Arrays are NumPy, angles in radians.

    - `verdict`: a `Verdict`; `reason`: one line why.
    - `vertex`: the input; `energy_kind`, `p`: the energy of the main run.
    - `path`: `(k, n, 3)` states, the input first; `fold_angles`: `(k, m)`; `energy`: `(k,)`
      (each segment's own energy: an escape that switches energy or `p` starts a new scale);
      `path_length`: `(k,)` cumulative largest node displacement (radians), the path parameter.
    - `multipliers`: KKT multipliers `λ` of `∇U + Σ λ_i ∇G_i = 0` at the end state, `(c,)`
      (free in sign: equality constraints), and `kkt_residual` the norm of that sum.
    - `certificate`: `Certificate` of the whole path; `crease_report`: `CreaseReport`.
    - `iterations`: descent iterations (including rejected trial steps); `accepted_steps`.
    - `timings`: seconds, `{"compile": ..., "run": ..., "total": ...}`.
    - `escapes`: `((name, verdict), ...)` tried after a stall; `escape_used`: the one that
      reached flat, or `None`.
    - `warnings`: contacts in the input and other remarks.
    """

    verdict: Verdict
    reason: str
    vertex: SingleVertex
    energy_kind: str
    p: float
    path: np.ndarray
    fold_angles: np.ndarray
    energy: np.ndarray
    path_length: np.ndarray
    multipliers: np.ndarray
    kkt_residual: float
    certificate: Certificate | None
    crease_report: CreaseReport
    iterations: int
    accepted_steps: int
    timings: dict[str, float]
    escapes: tuple[tuple[str, str], ...] = ()
    escape_used: str | None = None
    warnings: tuple[str, ...] = ()

    @property
    def final(self) -> np.ndarray:
        """The end state, `(n, 3)`."""
        return self.path[-1]

    def summary(self) -> str:
        """A few lines for people."""
        lines = [
            f"verdict: {self.verdict.value} ({self.reason})",
            f"energy: {self.energy_kind}, p = {self.p:g}; {self.accepted_steps} steps, "
            f"{self.iterations} iterations, {self.timings.get('run', float('nan')):.3g} s run",
        ]
        if self.certificate is not None:
            cert = self.certificate
            lines.append(
                f"certificate: {'OK' if cert.ok else 'FAILED'} over {cert.n_states} states; "
                f"min clearance {np.rad2deg(cert.min_clearance):.3g}°, max |fold| "
                f"{np.rad2deg(cert.max_abs_fold_angle):.4g}°, max |G| {cert.max_constraint_residual:.1e}"
            )
        lines.append(f"creases: {self.crease_report.summary()}")
        if self.escapes:
            lines.append(
                "escapes: " + ", ".join(f"{name} -> {verdict}" for name, verdict in self.escapes)
            )
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


def unfold_kernel(x0, sectors, p, settings, *, closed, kind, max_steps, record=False):
    """The traceable per-vertex descent behind `unfold` and `unfold_batch`, for your own `jit`/`vmap`
    batch code (the sweep engine uses it). No validation, no escapes, no certificate re-check: give it
    states that `SingleVertex` accepted.

    **Arguments:**
    - `x0`: `(n, 3)` unit crease directions of a valid folded state; `sectors`: `(a,)` sector angles
      (rad; `a = n` closed, `n − 1` open).
    - `p`: energy exponent; `settings`: a `DescentSettings` (its fields may be arrays).
    - `closed`, `kind` (`"separable"` / `"nonseparable"`), `max_steps`, `record` (keep the path):
      static.

    **Returns:** the descent's `DescentOutput`: `status` (a `RESULTS` item: `flat_unfolded`,
    `flat_folded`, `stalled`, `max_steps_reached`, `invalid` or `contact`), the final state, fold
    angles, energy, clearances, and the path when `record`.
    """
    clearance, _ = arc_pair_clearances(x0, closed)
    # Pairs touching in the input cannot bound the step (clearance 0); see `_descent`.
    mask = clearance > CONTACT_TOL
    return descend(
        x0, sectors, p, mask, settings, closed=closed, kind=kind, max_steps=max_steps, record=record
    )


@functools.lru_cache(maxsize=64)
def _compiled(n: int, closed: bool, kind: str, max_steps: int, record: bool, batch: int | None):
    """AOT-compiled kernel for one problem size; returns `(compiled, compile_seconds)`."""
    fn = functools.partial(
        unfold_kernel, closed=closed, kind=kind, max_steps=max_steps, record=record
    )
    if batch is not None:
        fn = jax.vmap(fn, in_axes=(0, 0, None, None))
    n_arcs = n if closed else n - 1
    lead = () if batch is None else (batch,)
    args = (
        jax.ShapeDtypeStruct(lead + (n, 3), jnp.float64),
        jax.ShapeDtypeStruct(lead + (n_arcs,), jnp.float64),
        jax.ShapeDtypeStruct((), jnp.float64),
        jax.tree.map(lambda _: jax.ShapeDtypeStruct((), jnp.float64), DescentSettings()),
    )
    start = time.perf_counter()
    compiled = jax.jit(fn).lower(*args).compile()
    return compiled, time.perf_counter() - start


def _settings_arrays(settings: DescentSettings) -> DescentSettings:
    return jax.tree.map(lambda v: jnp.asarray(v, jnp.float64), settings)


def _run(x0, sectors, closed, kind, p, settings, max_steps, record=True):
    hit = _compiled.cache_info().hits
    compiled, compile_s = _compiled(x0.shape[0], closed, kind, max_steps, record, None)
    fresh = _compiled.cache_info().hits == hit
    start = time.perf_counter()
    out = compiled(
        jnp.asarray(x0, jnp.float64),
        jnp.asarray(sectors, jnp.float64),
        jnp.asarray(p, jnp.float64),
        _settings_arrays(settings),
    )
    out = jax.block_until_ready(out)
    return out, (compile_s if fresh else 0.0), time.perf_counter() - start


@dataclasses.dataclass(frozen=True)
class _Segment:
    """Consecutive states of a path (host arrays): `(k, n, 3)`, fold angles `(k, m)`, energy `(k,)`."""

    path: np.ndarray
    folds: np.ndarray
    energy: np.ndarray

    @classmethod
    def of(cls, out: DescentOutput) -> "_Segment":
        k = int(out.n_accepted) + 1
        return cls(
            np.asarray(out.path[:k]),
            np.asarray(out.path_folds[:k]),
            np.asarray(out.path_energy[:k]),
        )

    @property
    def end(self) -> np.ndarray:
        return self.path[-1]


@dataclasses.dataclass
class _Runner:
    """Runs recorded descents of one vertex from host states, adding up what `UnfoldResult`
    reports over all of them: compile and run seconds, iterations, accepted steps and the crease
    counts (escape attempts that fail included)."""

    sectors: np.ndarray
    closed: bool
    settings: DescentSettings
    max_steps: int
    compile_s: float = 0.0
    run_s: float = 0.0
    iterations: int = 0
    accepted: int = 0
    counts: tuple[np.ndarray, ...] = ()

    def __call__(
        self, x0: Float[ArrayLike, "n 3"], kind: str, p: float
    ) -> tuple[_Segment, RESULTS]:
        out, compile_s, run_s = _run(
            x0, self.sectors, self.closed, kind, p, self.settings, self.max_steps
        )
        self.compile_s += compile_s
        self.run_s += run_s
        self.iterations += int(out.n_iterations)
        self.accepted += int(out.n_accepted)
        counts = tuple(np.asarray(a) for a in (out.sign_changes, out.reversals, out.opening_steps))
        self.counts = (
            counts
            if not self.counts
            else tuple(a + b for a, b in zip(self.counts, counts, strict=True))
        )
        return _Segment.of(out), out.status


@dataclasses.dataclass(frozen=True)
class _Attempt:
    """What one escape did: its segments (from the stalled state on), how its last run ended,
    and the energy of that run."""

    name: str
    segments: tuple[_Segment, ...]
    status: RESULTS
    kind: str
    p: float


def _run_sequence(runner: _Runner, name: str, x: np.ndarray, runs) -> _Attempt:
    """Descend with each `(kind, p)` of `runs` in turn, each from where the previous one stopped,
    until one ends flat or invalid."""
    segments = []
    status, kind, p = RESULTS.stalled, "", float("nan")
    for kind, p in runs:
        segment, status = runner(x, kind, p)
        segments.append(segment)
        x = segment.end
        if _is(status, _FINAL):
            break
    return _Attempt(name, tuple(segments), status, kind, p)


def _switch_energy_runs(kind: str) -> tuple[tuple[str, float], ...]:
    other = "nonseparable" if kind == "separable" else "separable"
    return ((other, DEFAULT_P[other]),)


def _continuation_runs(kind: str, p: float) -> tuple[tuple[str, float], ...]:
    ladder = (1.0, 4.0, 8.0) if kind == "separable" else (2.0, 8.0)
    return tuple((kind, q) for q in ladder if q != p)


def _escape_perturbation(runner: _Runner, x: np.ndarray, kind: str, p: float, key) -> _Attempt:
    """Escape 1: a small random certified move in the tangent space of the constraints (a fifth
    of the clearance bound, at most 0.02), then the same descent again."""
    clear, _ = arc_pair_clearances(jnp.asarray(x), runner.closed)
    size = min(
        0.02, 0.2 * float(jnp.min(clear, initial=np.pi)) * np.cos(np.max(runner.sectors) / 2)
    )
    _, sub = jax.random.split(key)
    moved = np.asarray(
        _perturb(
            jnp.asarray(x), jnp.asarray(runner.sectors), closed=runner.closed, key=sub, size=size
        )
    )
    folds = np.asarray(fold_angles_of(jnp.asarray(moved), runner.closed))
    start = _Segment(moved[None], folds[None], np.full(1, np.nan))
    attempt = _run_sequence(runner, "perturbation", moved, ((kind, p),))
    return dataclasses.replace(attempt, segments=(start, *attempt.segments))


def _escape_switch_energy(runner: _Runner, x: np.ndarray, kind: str, p: float, key) -> _Attempt:
    """Escape 2: descend with the other energy (Eq. 1 ↔ Eq. 2) at its default `p`."""
    del p, key
    return _run_sequence(runner, "switch-energy", x, _switch_energy_runs(kind))


def _escape_continuation_p(runner: _Runner, x: np.ndarray, kind: str, p: float, key) -> _Attempt:
    """Escape 3: the same energy at a ladder of other exponents, each from where the previous one
    stopped."""
    del key
    return _run_sequence(runner, "continuation-p", x, _continuation_runs(kind, p))


_ESCAPES = (_escape_perturbation, _escape_switch_energy, _escape_continuation_p)
"""Tried in this order after a stall (see the module docstring)."""


def _try_escapes(
    runner: _Runner, x: np.ndarray, kind: str, p: float, key
) -> tuple[tuple[tuple[str, str], ...], _Attempt | None]:
    """Each escape from the stalled state `x` until one reaches flat-unfolded.

    **Returns:** `((name, verdict), ...)` of the escapes tried, and the one that reached flat
    (or `None`).
    """
    tried = []
    for escape in _ESCAPES:
        attempt = escape(runner, x, kind, p, key)
        tried.append((attempt.name, _VERDICT_OF_CODE[int(_code(attempt.status))].value))
        if _is(attempt.status, (RESULTS.flat_unfolded,)):
            return tuple(tried), attempt
    return tuple(tried), None


@functools.partial(jax.jit, static_argnames="closed")
def _perturb(x, sectors, closed, key, size):
    """A small random certified move in the constraints' tangent space (escape 1)."""
    direction = project(x, jax.random.normal(key, x.shape, x.dtype), sectors, closed)
    direction = direction / jnp.max(jnp.linalg.norm(direction, axis=-1))
    return restore(x + size * direction, sectors, closed)


@functools.partial(jax.jit, static_argnames="closed")
def _measure_path(path, sectors, closed):
    def one(y):
        clear, cross = arc_pair_clearances(y, closed)
        residual = jnp.max(jnp.abs(constraints(y, sectors, closed)))
        return clear, cross, fold_angles_of(y, closed), residual

    return jax.vmap(one)(path)


_multipliers = jax.jit(multipliers, static_argnums=(2, 3))


def _padded(count: int) -> int:
    """The smallest power of two at least `count` (and 16)."""
    return max(16, 1 << max(count - 1, 0).bit_length())


def certify_path(
    path: Float[Array, "k n 3"] | np.ndarray,
    sector_angles: Float[Array, " a"] | np.ndarray,
    *,
    closed: bool,
    contact_pairs: np.ndarray | None = None,
) -> Certificate:
    """Check a path of states for collisions (see `Certificate`); independent of the descent's own
    bookkeeping, so it also certifies paths from elsewhere (e.g. the SLSQP benchmark peer).

    **Arguments:**
    - `path`: `(k, n, 3)` states in order; `sector_angles`: radians.
    - `contact_pairs`: `(r,)` boolean mask over `Topology.arc_pairs` of pairs touching in the
      input, excluded from the clearance bound (default: those with clearance < `CONTACT_TOL` in
      the first state).
    """
    path = jnp.asarray(path, jnp.float64)
    sectors = jnp.asarray(sector_angles, jnp.float64)
    # Measured on the path padded to a power of two of states (its last repeated), so that paths
    # of other lengths (every run's own count of steps) share one compiled program.
    count = path.shape[0]
    padded = np.concatenate(
        [np.asarray(path), np.repeat(np.asarray(path)[-1:], _padded(count) - count, axis=0)]
    )
    measured = _measure_path(jnp.asarray(padded), sectors, closed)
    clear, cross, folds, residual = (np.asarray(a)[:count] for a in measured)
    top = topology(path.shape[1], closed)
    if contact_pairs is None:
        contact_pairs = clear[0] < CONTACT_TOL if clear.shape[1] else np.zeros(0, bool)
    bound_mask = ~np.asarray(contact_pairs, bool)
    clear_b = np.where(bound_mask[None, :], clear, np.pi)
    clear_min = clear_b.min(axis=1) if clear.shape[1] else np.full(len(path), np.pi)
    arc_factor = 1.0 / np.cos(float(np.max(sectors)) / 2)
    disp = np.max(np.linalg.norm(np.diff(np.asarray(path), axis=0), axis=-1), axis=-1)
    both = np.minimum(clear_min[:-1], clear_min[1:])
    ratio = CERT_MARGIN * disp * arc_factor / np.maximum(both, 1e-300)
    dfold = np.angle(np.exp(1j * (folds[1:] - folds[:-1])))
    start_contact = np.abs(folds[:-1]) > np.pi - 1e-7
    folds_ok = np.all((np.abs(folds[:-1]) + np.abs(dfold) < np.pi) | start_contact) and np.all(
        np.abs(folds[1:]) < np.pi
    )
    crossing_states = tuple(int(i) for i in np.flatnonzero(np.any(cross, axis=1)))
    ok = (
        not crossing_states
        and bool(folds_ok)
        and float(np.max(residual)) <= 1e-9
        and (len(ratio) == 0 or float(np.max(ratio)) < 1.0)
    )
    warnings = tuple(
        f"arcs {e} and {f} touch in the input: checked for crossing state by state only"
        for e, f in top.arc_pairs[~bound_mask].tolist()
    )
    return Certificate(
        ok=bool(ok),
        n_states=len(path),
        n_steps=len(path) - 1,
        min_clearance=float(np.min(clear_min[1:])) if len(path) > 1 else float(clear_min[0]),
        max_abs_fold_angle=float(np.max(np.abs(folds[1:])))
        if len(path) > 1 and folds.shape[1]
        else 0.0,
        max_constraint_residual=float(np.max(residual)),
        max_step_ratio=float(np.max(ratio)) if len(ratio) else 0.0,
        crossing_states=crossing_states,
        warnings=warnings,
    )


def _invalid_result(vertex, kind, p, reason) -> UnfoldResult:
    x = np.asarray(vertex.directions)[None]
    m = vertex.n_fold_angles
    return UnfoldResult(
        verdict=Verdict.INVALID,
        reason=reason,
        vertex=vertex,
        energy_kind=kind,
        p=float(p),
        path=x,
        fold_angles=np.full((1, m), np.nan),
        energy=np.full(1, np.nan),
        path_length=np.zeros(1),
        multipliers=np.zeros(0),
        kkt_residual=float("nan"),
        certificate=None,
        crease_report=CreaseReport(*(np.zeros(m, int) for _ in range(4))),
        iterations=0,
        accepted_steps=0,
        timings={"compile": 0.0, "run": 0.0, "total": 0.0},
    )


def _checked_p(energy: str, p: Any) -> float:
    """The energy exponent: `DEFAULT_P[energy]` when `None`, else a positive finite number."""
    if p is None:
        return float(DEFAULT_P[energy])
    if (
        isinstance(p, bool)
        or not isinstance(p, int | float | np.number)
        or not (np.isfinite(p) and p > 0)
    ):
        raise ValueError(
            f"p, the exponent of the charge energy 1/d^p, must be a positive finite number (the "
            f"paper uses {DEFAULT_P['separable']:g} and {DEFAULT_P['nonseparable']:g}), got {p!r}."
        )
    return float(p)


def _check_max_steps(max_steps: Any) -> None:
    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) or max_steps < 1:
        raise ValueError(f"max_steps must be a positive integer, got {max_steps!r}.")


def unfold(
    vertex: SingleVertex,
    *,
    energy: str = "separable",
    p: float | None = None,
    max_steps: int = 2000,
    escapes: bool = True,
    key: PRNGKeyArray | None = None,
    settings: DescentSettings | None = None,
) -> UnfoldResult:
    """Unfold a folded single vertex by steepest descent of a charge energy on the constraint
    manifold, with a collision-free certificate and a verdict (paper Eqs. 1–6).

    **Arguments:**
    - `vertex`: a `SingleVertex` (validated here again).
    - `energy`: `"separable"` (Eq. 1) or `"nonseparable"` (Eq. 2).
    - `p`: the exponent (default 2 for Eq. 1, 4 for Eq. 2).
    - `max_steps`: accepted steps per descent run (static: each value compiles once per size).
    - `escapes`: try the escapes in the module docstring after a stall.
    - `key`: PRNG key for the perturbation escape (default: a fixed seed, reproducible).
    - `settings`: `DescentSettings` (step bounds and verdict tolerances).

    **Returns:** an `UnfoldResult`. Invalid inputs give `Verdict.INVALID` with the validation
    message in `reason` instead of raising, so that sweeps can carry on; use
    `validate_vertex` to get the exception.

    **Raises:** `ValueError` for an unknown `energy`, a `p` that is not a positive finite number or a
    `max_steps` below 1 (checked before anything compiles).

    Requires float64 (`jax.config.update("jax_enable_x64", True)`): the constraints are held to
    1e-10 and the verdict thresholds are 1e-4.
    """
    check_energy(energy)
    if not jax.config.jax_enable_x64:  # pyright: ignore[reportAttributeAccessIssue] (a flag)
        raise RuntimeError(
            'unfold needs float64: call jax.config.update("jax_enable_x64", True) first'
        )
    p = _checked_p(energy, p)
    _check_max_steps(max_steps)
    settings = DescentSettings() if settings is None else settings
    key = jax.random.key(0) if key is None else key
    t_start = time.perf_counter()
    try:
        report = validate_vertex(vertex)
    except InvalidVertexError as error:
        return _invalid_result(vertex, energy, p, str(error))
    closed = vertex.closed
    sectors = np.asarray(vertex.sector_angles)
    runner = _Runner(sectors, closed, settings, max_steps)
    main, status = runner(vertex.directions, energy, p)
    segments = [main]
    end_kind, end_p = energy, p
    tried: tuple[tuple[str, str], ...] = ()
    used = None
    if escapes and _is(status, _STALLS):
        tried, attempt = _try_escapes(runner, main.end, energy, p, key)
        if attempt is not None:
            segments += attempt.segments
            status, end_kind, end_p, used = attempt.status, attempt.kind, attempt.p, attempt.name
    path, folds, energies = _join(segments)
    steps = (
        np.max(np.linalg.norm(np.diff(path, axis=0), axis=-1), axis=-1)
        if len(path) > 1
        else np.zeros(0)
    )
    path_length = np.concatenate([[0.0], np.cumsum(steps)])
    # KKT multipliers of the energy whose descent produced the end state.
    lam, kkt = _multipliers(jnp.asarray(path[-1]), jnp.asarray(sectors), closed, end_kind, end_p)
    certificate = certify_path(path, sectors, closed=closed, contact_pairs=report.contact_mask)
    verdict = _VERDICT_OF_CODE[int(_code(status))]
    reason = message(status, RESULTS)
    if used is not None:
        reason += f" (after escape '{used}')"
    if verdict == Verdict.FLAT_UNFOLDED and not certificate.ok:
        # Never report flat without a certificate.
        verdict = Verdict.STALLED
        reason = "reached flat but the path failed the collision-free re-check"
    top = topology(vertex.n, closed)
    return UnfoldResult(
        verdict=verdict,
        reason=reason,
        vertex=vertex,
        energy_kind=energy,
        p=p,
        path=path,
        fold_angles=folds,
        energy=energies,
        path_length=path_length,
        multipliers=np.asarray(lam),
        kkt_residual=float(kkt),
        certificate=certificate,
        crease_report=CreaseReport(top.creases.copy(), *runner.counts),
        iterations=runner.iterations,
        accepted_steps=runner.accepted,
        timings={
            "compile": runner.compile_s,
            "run": runner.run_s,
            "total": time.perf_counter() - t_start,
        },
        escapes=tried,
        escape_used=used,
        warnings=report.contacts + certificate.warnings,
    )


def _join(segments: list[_Segment]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One path from consecutive segments; each starts where the previous one ended, so repeated
    states are dropped."""
    path = np.concatenate([s.path for s in segments])
    folds = np.concatenate([s.folds for s in segments])
    energies = np.concatenate([s.energy for s in segments])
    return _dedupe(path, folds, energies)


def _dedupe(path, folds, energies):
    keep = np.ones(len(path), bool)
    keep[1:] = np.any(np.abs(np.diff(path, axis=0)) > 0, axis=(1, 2))
    return path[keep], folds[keep], energies[keep]


class BatchResult(eqx.Module):
    """Results of `unfold_batch` for `b` vertices (arrays with a leading batch axis).

    - `status`: the descent's `RESULTS`, batched; `verdicts()` turns them into `Verdict`s.
    - `final`: `(b, n, 3)` end states; `fold_angles`: `(b, m)` at the end.
    - `certified`: the online certificate (every accepted step passed the bound and the crossing
      test; the path itself is not stored).
    - `accepted_steps`, `iterations`, `min_clearance`, `max_abs_fold`, `max_residual`,
      `sign_changes` `(b, m)`, `reversals` `(b, m)`.
    - `escape`: per member, 0 none, 1 switch-energy, 2 continuation-p (which reached flat).
    """

    status: RESULTS
    final: Array
    fold_angles: Array
    certified: Array
    accepted_steps: Array
    iterations: Array
    min_clearance: Array
    max_abs_fold: Array
    max_residual: Array
    sign_changes: Array
    reversals: Array
    escape: Array

    def verdicts(self) -> list[Verdict]:
        return [_VERDICT_OF_CODE[int(code)] for code in _code(self.status)]


def unfold_batch(
    vertices: SingleVertex,
    *,
    energy: str = "separable",
    p: float | None = None,
    max_steps: int = 500,
    escapes: bool = True,
    settings: DescentSettings | None = None,
) -> BatchResult:
    """Unfold a batch of same-size vertices through one vmapped, compiled call.

    **Arguments:** `vertices` a batched `SingleVertex` (see `stack_vertices`, `random_vertices`);
    the rest as in `unfold`. Inputs are not re-validated member by member here (a crossing or
    constraint-violating member comes out `INVALID`); paths are not stored (memory), only the
    online certificate and statistics. The `switch-energy` and `continuation-p` escapes run as
    further vmapped calls on the stalled members only; `perturbation` is left to `unfold`.
    """
    check_energy(energy)
    p = _checked_p(energy, p)
    _check_max_steps(max_steps)
    settings = _settings_arrays(DescentSettings() if settings is None else settings)
    x = jnp.asarray(vertices.directions, jnp.float64)
    sectors = jnp.asarray(vertices.sector_angles, jnp.float64)
    if x.ndim != 3:
        raise ValueError("unfold_batch expects a batched SingleVertex (leading batch axis)")
    closed = vertices.closed

    def run(xb, sb, kind, p_value):
        compiled, _ = _compiled(xb.shape[1], closed, kind, max_steps, False, xb.shape[0])
        return compiled(xb, sb, jnp.asarray(p_value, jnp.float64), settings)

    out = run(x, sectors, energy, p)
    status = out.status
    fields = {
        "final": np.array(out.x),
        "certified": np.array(out.certified),
        "accepted_steps": np.array(out.n_accepted),
        "iterations": np.array(out.n_iterations),
        "min_clearance": np.array(out.min_clearance),
        "max_abs_fold": np.array(out.max_abs_fold),
        "max_residual": np.array(out.max_residual),
        "sign_changes": np.array(out.sign_changes),
        "reversals": np.array(out.reversals),
    }
    escape = np.zeros(len(fields["final"]), np.int32)
    batch_escapes = (_switch_energy_runs(energy), _continuation_runs(energy, p))
    stall_codes = [int(_code(item)) for item in _STALLS]
    if escapes:
        for number, runs in enumerate(batch_escapes, start=1):
            stalled = np.flatnonzero(np.isin(_code(status), stall_codes))
            if len(stalled) == 0:
                break
            # Pad the stalled subset to a power of two (repeating its first member) so that the
            # escape kernels compile for a few batch sizes only, not for every stalled count.
            size = 1 << int(np.ceil(np.log2(len(stalled))))
            padded = np.concatenate([stalled, np.full(size - len(stalled), stalled[0])])
            xs = jnp.asarray(fields["final"][padded])
            for kind_i, p_i in runs:
                o = run(xs, sectors[padded], kind_i, p_i)
                xs = o.x
            count = len(stalled)
            o = jax.tree.map(lambda leaf, k=count: leaf[:k], o)
            ok = _code(o.status) == int(_code(RESULTS.flat_unfolded))
            idx = stalled[ok]
            reached = np.zeros(len(escape), bool)
            reached[idx] = True
            status = jax.vmap(lambda r, s: RESULTS.where(r, RESULTS.flat_unfolded, s))(
                jnp.asarray(reached), status
            )
            fields["final"][idx] = np.asarray(o.x)[ok]
            fields["certified"][idx] = np.asarray(o.certified)[ok] & fields["certified"][idx]
            for name, value, combine in (
                ("min_clearance", o.min_clearance, np.minimum),
                ("max_abs_fold", o.max_abs_fold, np.maximum),
                ("max_residual", o.max_residual, np.maximum),
            ):
                fields[name][idx] = combine(np.asarray(value)[ok], fields[name][idx])
            escape[idx] = number
    folds = jax.vmap(lambda y: fold_angles_of(y, closed))(jnp.asarray(fields["final"]))
    return BatchResult(
        status=status,
        fold_angles=folds,
        escape=jnp.asarray(escape),
        **{k: jnp.asarray(v) for k, v in fields.items()},
    )
