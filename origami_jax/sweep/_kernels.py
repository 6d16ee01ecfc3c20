"""Model adapters: the sweep's registry of named models, each the `Kernel` of a physics package.

`available_models()` lists them with a description; `get_model(name, **settings)` builds one, and
a name becomes an object here (a pattern's catalogue name or file, `"net-fold"`'s `net=`), once.

- `"accordion-step"`: step response of the `n`-flap accordion, the accordion's own kernel
  (`origami_jax.chain.accordion_step`, `Accordion.kernel`): per-joint rise time, overshoot, peak
  and settling time, with the simulation's result code; the flap count is a *static* parameter.
- `"vertex-unfold"`: random single vertices unfolded by charge-energy descent (`origami_jax.vertex`);
  the vertices are drawn on the host (`Kernel.prepare`), the descent is batched. It calls the vertex
  package's traceable per-vertex descent, `origami_jax.vertex.unfold_kernel` (`unfold_batch` is
  itself a batch driver with host-side escapes, so it cannot be vmapped again).
- `"net-fold"`: fold verdicts of a net or closed-loop crease pattern; the kernel lives beside the
  patterns (`origami_jax.net.fold_kernel`, built from a pattern object), the model names the
  pattern (`net=`) as a sweep's config does.
"""

import dataclasses
import inspect
import json
from collections.abc import Callable, Mapping
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from .._kernel import INVALID_INPUT, KeptKernels, Kernel, check_setting
from .._limits import AFTER_RELEASE_US, CONTACT_SAMPLING, MAX_SAMPLES
from .._names import did_you_mean
from ..chain import accordion_step
from ..loops import load_pattern
from ..net import FOLD_KERNEL_SOLVE, check_kernel_sampling, fold_kernel
from ..simulation import (
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    ImplicitStep,
    SaveAt,
    VerdictTolerances,
    named_solver,
)
from ..vertex import DEFAULT_P, RESULTS, DescentSettings, random_vertex
from ..vertex import unfold_kernel as descend


@dataclasses.dataclass(frozen=True)
class _Model:
    description: str
    build: Callable[..., Kernel]
    # Whether `get_model` keeps the kernel per settings (plain values): not for a model that reads
    # a file (a FOLD file may change between calls; `fold_kernel` keeps its own by the contents).
    kept: bool = True


VERTEX_PARAMETERS = {"n_creases": "", "closed": "", "seed": "", "p": ""}


def vertex_unfold(
    *,
    n_creases: int = 5,
    closed: bool = True,
    energy: str = "separable",
    p: float | None = None,
    max_steps: int = 1000,
    max_fold_deg: float = 150.0,
) -> Kernel:
    """Sweep kernel: unfolding verdicts of random single vertices (paper Eqs. 1–6).

    Each design is one random valid folded vertex, `origami_jax.vertex.random_vertex(key(seed),
    n_creases, closed=closed, max_fold=max_fold_deg°)`, drawn on the host (rejection sampling, so it
    runs in `Kernel.prepare`, chunk by chunk), then one charge-energy descent, vmapped and compiled
    once per `(n_creases, closed)` group (both static). Swept parameters: `seed`, `n_creases`,
    `closed`, and the energy exponent `p`.

    Differences from `origami_jax.vertex.unfold` (say so when quoting numbers): no stall escapes
    (perturbation, energy switch, continuation in `p`) are tried, and the path is not stored, only
    the online certificate (every accepted step passed the clearance bound and the crossing test).

    **Outputs:** `verdict` (the code of `origami_jax.vertex.RESULTS`: 1 flat-unfolded, 2 flat-folded,
    3 stalled, 4 step budget exhausted, 5 invalid, 6 stalled at a contact), `flat_unfolded`,
    `certified`, `accepted_steps`, `energy`, `min_clearance` (rad), `max_abs_fold` (rad), `max_residual`, per crease (dim `crease`) `sign_changes`, and `result`
    (0 = a verdict was reached, 1 = step budget exhausted, −1 = invalid input).
    """
    if energy not in DEFAULT_P:
        raise ValueError(f"energy must be one of {sorted(DEFAULT_P)}, got {energy!r}.")
    p_default = float(DEFAULT_P[energy] if p is None else check_setting(p, "p", low=0.0))
    n_creases = check_setting(n_creases, "n_creases", low=3, integer=True)
    max_steps = check_setting(max_steps, "max_steps", low=1, integer=True)
    max_fold_deg = check_setting(max_fold_deg, "max_fold_deg", low=0.0, high=180.0)
    if not isinstance(closed, bool):
        raise ValueError(f"setting closed must be true or false, got {closed!r}.")
    settings = jax.tree.map(lambda v: float(v), DescentSettings())

    def prepare(columns: Mapping[str, Any], static: Mapping[str, Any]) -> dict[str, Any]:
        n = int(static.get("n_creases", n_creases))
        is_closed = bool(static.get("closed", closed))
        directions, sectors = [], []
        for seed in np.asarray(columns["seed"]).astype(np.int64).tolist():
            vertex = random_vertex(
                jax.random.key(seed), n, closed=is_closed, max_fold=np.radians(max_fold_deg)
            )
            directions.append(np.asarray(vertex.directions, dtype=np.float64))
            sectors.append(np.asarray(vertex.sector_angles, dtype=np.float64))
        return {"directions": np.stack(directions), "sectors": np.stack(sectors)}

    def fn(params: Mapping[str, Any]) -> dict[str, Any]:
        is_closed = bool(params.get("closed", closed))
        exponent = jnp.asarray(params.get("p", p_default), dtype=float)
        out = descend(
            params["directions"],
            params["sectors"],
            exponent,
            jax.tree.map(lambda v: jnp.asarray(v, dtype=float), settings),
            closed=is_closed,
            kind=energy,
            max_steps=max_steps,
            record=False,
        )
        status = out.status
        result = jnp.where(
            status == RESULTS.invalid,
            INVALID_INPUT,
            jnp.where(status == RESULTS.max_steps_reached, 1, 0),
        )
        return {
            "verdict": status._value.astype(jnp.int32),
            "flat_unfolded": status == RESULTS.flat_unfolded,
            "certified": out.certified,
            "accepted_steps": out.n_accepted.astype(jnp.int32),
            "energy": out.energy,
            "min_clearance": out.min_clearance,
            "max_abs_fold": out.max_abs_fold,
            "max_residual": out.max_residual,
            "sign_changes": out.sign_changes.astype(jnp.int32),
            "result": result.astype(jnp.int32),
        }

    # Every value `fn` closes over, by value (the rest is this package's source).
    recorded = {
        "n_creases": n_creases,
        "closed": closed,
        "energy": energy,
        "p": p_default,
        "max_steps": max_steps,
        "max_fold_deg": max_fold_deg,
        "descent": {f: getattr(settings, f) for f in settings.__dataclass_fields__},
        "generator": "origami_jax.vertex.random_vertex(jax.random.key(seed), ...)",
    }
    return Kernel(
        fn=fn,
        never_raises=True,  # bad values come back as INVALID_INPUT
        name="vertex-unfold",
        settings=recorded,
        program_key=("vertex-unfold", recorded),
        # Two chunks of this program computed at once on one CPU hung in XLA (jaxlib 0.10.2:
        # both threads waiting for their results, no thread computing; 250 vertices of one size in
        # chunks of 8 or 32, every time; 120 in chunks of 15 finished): one at a time.
        cpu_workers=1,
        parameters=VERTEX_PARAMETERS,
        static=("n_creases", "closed"),
        output_units={"min_clearance": "rad", "max_abs_fold": "rad"},
        output_dims={"sign_changes": ("crease",)},
        result_messages={INVALID_INPUT: "invalid input", 0: "verdict reached", 1: "max steps"},
        prepare=prepare,
    )


def net_fold(*, net: str = "cube_net_01", **settings: Any) -> Kernel:
    """Sweep kernel `"net-fold"`: does a net, or a crease pattern with closed loops, fold? The fold
    kernel that lives beside the patterns (`origami_jax.net.fold_kernel`, `Net.kernel`) of the
    pattern `net` names (a catalogue name or a `.fold` path, `origami_jax.loops.load_pattern`;
    default `"cube_net_01"`), with flat settings as a sweep's config gives them (every one checked
    before the pattern is read):

    - the pattern's physics (`Net.with_model`): `contact` (default `True`), `drag` (`"panel"`),
      `hinges` (`"point"`), `contact_sampling` (`(4, 2)`), `added_mass` and `viscous` (the
      fluid's inertia and viscosity, default on in the etch bath, off in air),
      `release_ramp` (µs: each hinge released over that time; 0 at once, the paper's step;
      default `"auto"`: quasi-static where the fluid's inertia is on, at once otherwise);
    - the solve's: `t_end` (µs, default 1500, or a fifth of the release ramp past it:
      `default_t_end`), `n_save` (301), `rtol`, `atol` (`None`: the
      simulation's), `max_steps` (200,000); `solver` (`"tsit5"`, the default, `"kvaerno5"` or
      `"implicit-step"`, `"implicit-bdf2"`: `origami_jax.simulation.named_solver`) with, for the
      last two, `dt` (µs, its fixed step; required, at most `t_end`) and `newton_iterations`
      (default 10);
    - the verdict's: `angle_tolerance_deg` (3) and `seam_tolerance` (default `"derived"`: each
      seam's from the angle tolerance and the geometry, `origami_jax.simulation.VerdictTolerances`;
      or a fraction of the largest panel's size, e.g. 0.01, the default before). Resuming a store
      written when 0.01 was the default, with a config that names no `seam_tolerance`, keeps its
      0.01 (`origami-jax sweep --resume`);
    - `fold_kernel`'s others: `fluid`, `design`, `bias`, `targets`, `hinge_lengths`.

    **Raises:** `TypeError` for an unknown setting (`get_model` says which), `ValueError` for a bad
    one.
    """
    model = {
        k: settings.pop(k)
        for k in ("contact", "drag", "hinges", "added_mass", "viscous", "release_ramp")
        if k in settings
    }
    sampling = settings.pop("contact_sampling", CONTACT_SAMPLING)
    solve = {
        k: settings.pop(k)
        for k in ("t_end", "n_save", "rtol", "atol", "max_steps")
        if k in settings
    }
    engine = {k: settings.pop(k) for k in ("solver", "dt", "newton_iterations") if k in settings}
    angle = settings.pop("angle_tolerance_deg", 3.0)
    seam = settings.pop("seam_tolerance", None)
    if isinstance(seam, str) and seam.strip().lower() == "derived":
        seam = None  # TOML has no null
    unknown = sorted(set(settings) - {"fluid", "design", "bias", "targets", "hinge_lengths"})
    if unknown:
        raise TypeError(f"net-fold has no setting(s) {unknown}")
    t_end = solve.get("t_end")
    t_end = None if t_end is None else check_setting(t_end, "t_end", low=0.0)
    if model.get("release_ramp") == 0:
        model["release_ramp"] = None  # TOML has no null: 0 is the step
    n_save = check_setting(
        solve.get("n_save", 301), "n_save", low=2, integer=True, high=MAX_SAMPLES
    )
    max_steps = check_setting(solve.get("max_steps", 200_000), "max_steps", low=1, integer=True)
    rtol = solve.get("rtol")
    atol = solve.get("atol")
    rtol = DEFAULT_RTOL if rtol is None else check_setting(rtol, "rtol", low=0.0)
    atol = DEFAULT_ATOL if atol is None else check_setting(atol, "atol", low=0.0)
    # Tsit5, the kernel's own default, unnamed: a store written without `solver` resumes with it.
    name = engine.pop("solver", "tsit5")
    solver = None if name == "tsit5" and not engine else named_solver(name, **engine)
    shortest = AFTER_RELEASE_US if t_end is None else t_end
    if isinstance(solver, ImplicitStep) and solver.dt > shortest:
        raise ValueError(f"dt {solver.dt:g} µs is longer than the run (t_end {shortest:g} µs).")
    tolerances = VerdictTolerances.from_degrees(angle, seam)
    sampling = check_kernel_sampling(model.get("contact", True), sampling)
    pattern = load_pattern(net).with_model(**model, contact_sampling=sampling)
    return fold_kernel(
        pattern,
        solve=FOLD_KERNEL_SOLVE.replace(
            t1=t_end,
            saveat=SaveAt(n=n_save),
            rtol=rtol,
            atol=atol,
            max_steps=max_steps,
            solver=solver,
        ),
        tolerances=tolerances,
        **settings,
    )


MODELS: dict[str, _Model] = {
    "accordion-step": _Model(
        "step response metrics of the n-flap accordion over hinge and fluid parameters",
        accordion_step,
    ),
    "vertex-unfold": _Model(
        "unfolding verdicts of random single-vertex origami",
        vertex_unfold,
    ),
    "net-fold": _Model(
        "fold verdicts of a net or closed-loop crease pattern (FOLD) over hinge parameters and "
        "release times",
        net_fold,
        kept=False,
    ),
}


def available_models() -> dict[str, str]:
    """Every model the sweep knows → its description."""
    return {name: model.description for name, model in MODELS.items()}


def get_model(name: str, **options: Any) -> Kernel:
    """Build the sweep `Kernel` of a named model with its `options` (settings): the same object
    for the same settings (the last four kept; `net-fold` through `origami_jax.net.fold_kernel`,
    which keeps its kernels by the pattern's contents), so that sweeping the model again in one
    process compiles nothing again.

    **Raises:** `ValueError` for an unknown model or option.
    """
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}; the sweep knows {sorted(MODELS)}.")
    build = MODELS[name].build
    accepted = inspect.signature(build).parameters
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in accepted.values()):
        known = [p for p in accepted if accepted[p].kind is not inspect.Parameter.VAR_POSITIONAL]
        for key in options:
            if key not in known:
                raise ValueError(
                    f"model {name!r}: unknown setting {key!r}{did_you_mean(key, known)}; its "
                    f"settings are {', '.join(known)}."
                )

    def built() -> Kernel:
        try:
            return build(**options)
        except TypeError as error:
            raise ValueError(f"model {name!r}: bad settings {sorted(options)}: {error}") from error

    if not MODELS[name].kept:
        return built()
    try:
        settings = json.dumps(options, sort_keys=True)
    except TypeError:  # settings that are not plain values: a kernel of their own
        return built()
    # The same object for the same settings (a new object compiled again: 6 s for the accordion).
    return _KEPT.get((name, settings), built)


_KEPT = KeptKernels()
