"""Model adapters: the physics of the other sub-packages as sweep `Kernel`s.

Each adapter imports its physics inside the builder, so that `import origami_jax.sweep` and
`origami-jax sweep --help` stay fast. `available_models()` lists them with a description.

- `"accordion-step"`: step response of the `n`-flap accordion (`origami_jax.chain` +
  `origami_jax.simulation`): per-joint rise time, overshoot, peak and settling time, with the
  simulation's result code. The flap count fixes array shapes, so it is a *static* parameter: the
  engine runs one compiled call per flap count (an outer loop over separately compiled groups),
  every other parameter is batched.
- `"vertex-unfold"`: random single vertices unfolded by charge-energy descent (`origami_jax.vertex`);
  the vertices are drawn on the host (`Kernel.prepare`), the descent is batched. It calls the vertex
  package's traceable per-vertex descent, `origami_jax.vertex.unfold_kernel` (`unfold_batch` is
  itself a batch driver with host-side escapes, so it cannot be vmapped again).
"""

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

from .._limits import CONTACT_SAMPLING, MAX_CONTACT_SAMPLING, MAX_FLAPS, MAX_SAMPLES
from ._kernel import Kernel

# Result code for a design whose parameters are outside the model's domain (non-positive or
# non-finite lengths, strains...). The kernel then computes a harmless stand-in design and marks it.
INVALID_INPUT = -1

# Parameters of "accordion-step" and their units: lengths in µm, the package's MICRO unit system.
ACCORDION_PARAMETERS = {
    "n_flaps": "",
    "hinge_width": "um",
    "flap_length": "um",
    "flap_width": "um",
    "t_structural": "um",
    "t_hinge": "um",
    "misfit_strain": "1",
    "theta_final": "rad",
    "drag_coefficient": "1",
    "k_scale": "1",
    "b_scale": "1",
    "fluid": "",
}
FLUIDS = ("air", "koh")


def _setting(
    value: Any,
    name: str,
    *,
    low: float | int,
    integer: bool = False,
    high: float | int | None = None,
) -> Any:
    """A numeric model setting, checked before anything compiles: a number (not a string or a
    boolean), finite, `> low` (or `>= low` for integers) and at most `high`."""
    import math

    kind = "an integer" if integer else "a number"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"setting {name} must be {kind}, got {value!r}.")
    if integer and not float(value).is_integer():
        raise ValueError(f"setting {name} must be an integer, got {value!r}.")
    ok = math.isfinite(value) and (value >= low if integer else value > low)
    if high is not None:
        ok = ok and value <= high
    if not ok:
        span = f">= {low}" if integer else f"> {low:g}"
        span += "" if high is None else f" and <= {high}"
        raise ValueError(f"setting {name} must be finite and {span}, got {value!r}.")
    return int(value) if integer else float(value)


@dataclasses.dataclass(frozen=True)
class _Model:
    description: str
    build: Callable[..., Kernel]


def accordion_step(
    *,
    n_flaps: int = 3,
    fluid: str = "air",
    t_end: float = 2000.0,
    n_save: int = 2001,
    rtol: float | None = None,
    atol: float | None = None,
    max_steps: int = 16_384,
    stiffness_model: str = "paper",
    drag_model: str = "paper",
    solver: str = "kvaerno5",
) -> Kernel:
    """Sweep kernel: step response metrics of the accordion (paper Fig. 7).

    Parameters not swept take `HingeDesign.literature()` values (200 nm SiNx, 100 nm Cr at 1 GPa,
    200 µm square flaps, hinge as wide as the flap, `C_D = 1.17`, `θ_final = π`); lengths are in µm.
    The system is `origami_jax.chain.accordion_system(design, n_flaps)`, stepped to its hinge targets
    `(θ_final, −θ_final, θ_final, ...)`. Swept parameters: see
    `ACCORDION_PARAMETERS`; `fluid` is `"air"` or `"koh"` (30 wt% KOH solution); `n_flaps` is static.

    **Arguments (settings, fixed for the whole sweep and checked on resume):** constants of the
    compiled sweep (folded in by XLA), so a new value, `n_save` included, compiles a new sweep: once
    per sweep, not per design (the sample count is not padded as in a top-level `simulate`).
    - `n_flaps`, `fluid`: values used when they are not swept.
    - `t_end`: simulated time, µs; `n_save`: samples over `[0, t_end]` the metrics are measured on.
    - `rtol`, `atol`, `max_steps`, `stiffness_model`, `drag_model`: passed to `simulate` /
      `HingeDesign` (`None` tolerances: the simulation's defaults).
    - `solver`: `"kvaerno5"` (implicit, safe for stiff hinges: `simulation.implicit_solver()`) or
      `"tsit5"` (explicit; much cheaper per step on non-stiff designs, e.g. in air, but see docs/physics.md,
      "Numerics", on gradients at loose tolerances).

    **Outputs** per design: per joint (dim `joint`) `rise_time`, `t10`, `t90`, `overshoot` (%),
    `peak_time`, `settling_time` (µs), `final_error` (rad), flags `rise_ill_conditioned`,
    `settling_ill_posed`; per design `stiffness`, `drag`, `hinge_length`, `num_steps`, and `result`
    (`origami_jax.simulation.RESULTS` codes; −1 = invalid input). Floats are NaN where `result != 0`.
    """
    import diffrax
    import jax.numpy as jnp

    from ..chain import accordion_system
    from ..simulation import (
        DEFAULT_ATOL,
        DEFAULT_RTOL,
        RESULTS,
        Step,
        implicit_solver,
        response_metrics,
        simulate,
    )
    from ..system import AIR, KOH_SOLUTION, MICRO, Fluid, HingeDesign

    # Not the simulation's default (`StiffnessSwitching`): under `vmap` its switch would run both the
    # explicit and the implicit step for every member; a sweep picks one.
    solvers = {"kvaerno5": implicit_solver(), "tsit5": diffrax.Tsit5()}
    if solver not in solvers:
        raise ValueError(f"solver must be one of {sorted(solvers)}, got {solver!r}.")
    if fluid not in FLUIDS:
        raise ValueError(f"fluid must be one of {FLUIDS}, got {fluid!r}.")
    n_flaps = _setting(n_flaps, "n_flaps", low=1, integer=True, high=MAX_FLAPS)
    t_end = _setting(t_end, "t_end", low=0.0)
    n_save = _setting(n_save, "n_save", low=2, integer=True, high=MAX_SAMPLES)
    max_steps = _setting(max_steps, "max_steps", low=1, integer=True)
    rtol = DEFAULT_RTOL if rtol is None else _setting(rtol, "rtol", low=0.0)
    atol = DEFAULT_ATOL if atol is None else _setting(atol, "atol", low=0.0)
    literature = HingeDesign.literature(MICRO)
    floats = [n for n, u in ACCORDION_PARAMETERS.items() if n not in ("n_flaps", "fluid")]
    defaults = {n: float(getattr(literature, n)) for n in floats if n not in ("k_scale", "b_scale")}
    defaults.update(k_scale=1.0, b_scale=1.0)
    densities = [float(f.to(MICRO).density) for f in (AIR, KOH_SOLUTION)]

    def design_of(params: Mapping[str, Any]):
        n = params.get("n_flaps", n_flaps)
        if not isinstance(n, int) or not 1 <= n <= MAX_FLAPS:
            raise ValueError(f"n_flaps must be an integer from 1 to {MAX_FLAPS}, got {n!r}.")
        swept = {k: jnp.asarray(params[k], dtype=float) for k in defaults if k in params}
        invalid = jnp.zeros((), dtype=bool)
        for value in swept.values():
            invalid = invalid | ~(jnp.isfinite(value) & (value > 0))
        if "theta_final" in swept:  # a fold angle: at most π (see HingeDesign)
            invalid = invalid | (swept["theta_final"] > jnp.pi)
        # Parameters not swept stay Python constants: XLA folds them into the compiled kernel (a
        # chain whose geometry is not swept has constant masses and inertias, which made the
        # width x strain benchmark sweep 2.2x faster than with every default traced per design).
        safe: dict[str, Any] = dict(defaults)
        safe.update({k: jnp.where(invalid, defaults[k], v) for k, v in swept.items()})
        density = jnp.asarray(densities)[params.get("fluid", FLUIDS.index(fluid))]
        design = HingeDesign(
            **safe,
            fluid=Fluid(density, MICRO, "swept"),
            stiffness_model=stiffness_model,
            drag_model=drag_model,
            units=MICRO,
        )
        return design, n, invalid, safe

    def cost(params: Mapping[str, Any]):
        # Steps of an adaptive solve scale with the fastest natural frequency times the run length:
        # ω_max² = λ_max(M(0)⁻¹ K), from the symmetric K^½ M⁻¹ K^½ (eigvalsh runs on every backend).
        design, n, invalid, _ = design_of(params)
        system = accordion_system(design, n)
        root_k = jnp.sqrt(system.hinges.stiffness)
        m_inverse = jnp.linalg.inv(system.mechanism.mass_matrix(jnp.zeros(n)))
        omega_max = jnp.sqrt(jnp.max(jnp.linalg.eigvalsh(root_k[:, None] * m_inverse * root_k)))
        return jnp.where(invalid, jnp.inf, omega_max * t_end)

    def fn(params: Mapping[str, Any]) -> dict[str, Any]:
        design, n, invalid, _ = design_of(params)
        system = accordion_system(design, n)
        stiffness, drag = system.hinges.stiffness, system.drag.coefficient
        trajectory = simulate(
            system,
            Step(),
            t1=t_end,
            n_save=n_save,
            rtol=rtol,
            atol=atol,
            max_steps=max_steps,
            solver=solvers[solver],
            throw=False,
        )
        metrics = response_metrics(trajectory)
        result = jnp.where(invalid, INVALID_INPUT, trajectory.result._value).astype(jnp.int32)
        failed = result != 0

        def masked(x):
            return jnp.where(failed, jnp.nan, x)

        return {
            "rise_time": masked(metrics.rise_time),
            "t10": masked(metrics.t10),
            "t90": masked(metrics.t90),
            "overshoot": masked(metrics.overshoot),
            "peak_time": masked(metrics.peak_time),
            "settling_time": masked(metrics.settling_time),
            "final_error": masked(metrics.final_error),
            "rise_ill_conditioned": metrics.rise_ill_conditioned,
            "settling_ill_posed": metrics.settling_ill_posed,
            "stiffness": masked(stiffness[0]),
            "drag": masked(drag[0]),
            "hinge_length": masked(design.hinge_length()),
            "num_steps": jnp.asarray(trajectory.stats["num_steps"], dtype=jnp.int32),
            "result": result,
        }

    joint = ("joint",)
    messages = {INVALID_INPUT: "invalid input"}
    messages.update({int(item._value): name for name, item in RESULTS._name_to_item.items()})
    return Kernel(
        fn=fn,
        never_raises=True,  # bad values come back as INVALID_INPUT
        name="accordion-step",
        settings={
            "n_flaps": n_flaps,
            "fluid": fluid,
            "t_end_us": t_end,
            "n_save": n_save,
            "rtol": rtol,
            "atol": atol,
            "max_steps": max_steps,
            "stiffness_model": stiffness_model,
            "drag_model": drag_model,
            "solver": solver,
            "defaults": defaults,
        },
        parameters=ACCORDION_PARAMETERS,
        static=("n_flaps",),
        output_units={
            "rise_time": "us",
            "t10": "us",
            "t90": "us",
            "overshoot": "%",
            "peak_time": "us",
            "settling_time": "us",
            "final_error": "rad",
            "stiffness": "pN m/rad",
            "drag": "pN m us2/rad2",
            "hinge_length": "um",
        },
        output_dims={
            n: joint
            for n in (
                "rise_time",
                "t10",
                "t90",
                "overshoot",
                "peak_time",
                "settling_time",
                "final_error",
                "rise_ill_conditioned",
                "settling_ill_posed",
            )
        },
        result_messages=messages,
        cost=cost,
        categories={"fluid": FLUIDS},
    )


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
    import jax
    import jax.numpy as jnp
    import numpy as np

    from ..vertex import DEFAULT_P, RESULTS, DescentSettings, random_vertex
    from ..vertex import unfold_kernel as descend

    if energy not in DEFAULT_P:
        raise ValueError(f"energy must be one of {sorted(DEFAULT_P)}, got {energy!r}.")
    p_default = float(DEFAULT_P[energy] if p is None else _setting(p, "p", low=0.0))
    n_creases = _setting(n_creases, "n_creases", low=3, integer=True)
    max_steps = _setting(max_steps, "max_steps", low=1, integer=True)
    max_fold_deg = _setting(max_fold_deg, "max_fold_deg", low=0.0, high=180.0)
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

    return Kernel(
        fn=fn,
        never_raises=True,  # bad values come back as INVALID_INPUT
        name="vertex-unfold",
        settings={
            "n_creases": n_creases,
            "closed": closed,
            "energy": energy,
            "p": p_default,
            "max_steps": max_steps,
            "max_fold_deg": max_fold_deg,
            "descent": {f: getattr(settings, f) for f in settings.__dataclass_fields__},
            "generator": "origami_jax.vertex.random_vertex(jax.random.key(seed), ...)",
        },
        parameters=VERTEX_PARAMETERS,
        static=("n_creases", "closed"),
        output_units={"min_clearance": "rad", "max_abs_fold": "rad"},
        output_dims={"sign_changes": ("crease",)},
        result_messages={INVALID_INPUT: "invalid input", 0: "verdict reached", 1: "max steps"},
        prepare=prepare,
    )


# Fields of `HingeDesign` a net sweep may vary for every crease at once (scalar parameter `name`) or
# for one crease (`name[j]`); lengths in µm, the package's MICRO unit system.
NET_PARAMETERS = {
    "hinge_width": "um",
    "t_hinge": "um",
    "misfit_strain": "1",
    "k_scale": "1",
}
NET_GLOBAL_PARAMETERS = {
    "t_structural": "um",
    "drag_coefficient": "1",
    "b_scale": "1",
}


def net_fold(
    *,
    net: str = "cube_net_01",
    fluid: str | None = None,
    t_end: float = 1500.0,
    n_save: int = 301,
    rtol: float | None = None,
    atol: float | None = None,
    max_steps: int = 200_000,
    contact: bool | str = True,
    drag: str = "panel",
    hinges: str = "point",
    angle_tolerance_deg: float = 3.0,
    seam_tolerance: float = 0.01,
    bias: float = 0.0,
    design: Any = None,
    targets: Any = None,
    hinge_lengths: str = "ideal",
    contact_sampling: tuple[int, int] = CONTACT_SAMPLING,
) -> Kernel:
    """Sweep kernel: does a net of panels, or a crease pattern with closed loops, fold? Verdict and
    numbers per design (explicit Tsit5 under the contact guard;
    `origami_jax.loops.load_pattern(net).system(design, ...)` with the literature design for what is
    not swept, in MICRO units, each hinge no wider than its crease). A closed-loop pattern starts
    flat, or pre-folded by `bias` rad along its own angles (`CreasePattern.start_state`); its
    verdict is `misfolded` on another branch.

    **Parameters** (swept): `hinge_width`, `t_hinge`, `misfit_strain`, `k_scale` for every crease, or
    per crease as `name[j]` (e.g. `misfit_strain[3]`: the film stress scatter of one hinge);
    `t_structural`, `drag_coefficient`, `b_scale` for the whole net; `release[j]`: crease `j`'s release
    time (µs, default 0); `target[j]`: the angle crease `j`'s hinge is drawn to fold to (rad; default
    the `targets` setting, else the pattern's angle; give all of them or none).

    On a CPU, `sweep` runs this kernel one design per compiled call, several at once
    (`Kernel.cpu_chunk_size`), unless given a `chunk_size`.

    **Outputs:** `verdict` (0 folded, 1 jammed, 2 misfolded, 3 unfinished, 4 invalid;
    `origami_jax.simulation.VERDICT_CODES`), `folded`, `time_to_fold` (µs, NaN if never),
    `final_angle` (rad, per crease), `max_seam_gap` (µm, every seam), `max_open_seam_gap` (µm, the
    seams whose panels do not touch: the verdict holds a touching seam closed whatever its gap),
    `seams_touching` (how many seams' panels touch at the end; −1 where the simulation failed),
    `min_gap`, `penetration` (µm), `engaged`
    (contact pairs engaged at the end; −1 where the simulation failed), `num_steps`, `result` (the
    solver's code; −1 invalid input).

    **Settings** beyond the solver's: `angle_tolerance_deg` (degrees) and `seam_tolerance` (a
    fraction of the largest panel's size), the verdict's (`origami_jax.simulation.VerdictTolerances`);
    `fluid` (`"air"` or `"koh"`, default `"koh"`) or `design`, a
    whole `HingeDesign` (MICRO units) for what is not swept (its fluid included; not both);
    `targets`: the angles the hinges aim at (rad, one per crease; default the pattern's); and
    `hinge_lengths`:

    - `"ideal"` (default): every design's hinge bends exactly to its target (hinge length
      ``ρ |θ_target|`` with the design's own radius ``ρ``);
    - `"designed"`: the hinge lengths are drawn for the *nominal* design (``l = ρ₀ |θ_target|``, what
      lithography fixes) and a design whose films differ (swept `misfit_strain`, `t_hinge`,
      `t_structural`) bends them to ``l / ρ = θ_target ρ₀ / ρ`` (paper Eq. 7 with ``l = ρ θ``): the
      fold angle of a fabricated hinge whose film stress or thickness is off.

    `contact` (`True`: the default model, `"plate"` or `"sampled"`, or `False`) and
    `contact_sampling` (the sampled model's ``(points_per_edge, rim_points_per_edge)``), as
    `Net.system`'s.
    """
    import diffrax
    import jax.numpy as jnp
    import numpy as np

    from ..contact import check_sampling, contact_kind
    from ..contact._tables import sampling_pair
    from ..loops import CreasePattern, load_pattern
    from ..net._net import default_design
    from ..simulation import DEFAULT_ATOL, DEFAULT_RTOL, RESULTS, Step, VerdictTolerances, simulate
    from ..system import AIR, KOH_SOLUTION, HingeDesign

    t_end = _setting(t_end, "t_end", low=0.0)
    n_save = _setting(n_save, "n_save", low=2, integer=True, high=MAX_SAMPLES)
    max_steps = _setting(max_steps, "max_steps", low=1, integer=True)
    rtol = DEFAULT_RTOL if rtol is None else _setting(rtol, "rtol", low=0.0)
    atol = DEFAULT_ATOL if atol is None else _setting(atol, "atol", low=0.0)
    tolerances = VerdictTolerances.from_degrees(angle_tolerance_deg, seam_tolerance)
    sampling = sampling_pair(contact_sampling)
    if max(sampling) > MAX_CONTACT_SAMPLING:
        raise ValueError(
            f"contact_sampling takes at most {MAX_CONTACT_SAMPLING} points per edge on the ring and "
            f"on the rim (the contact's work grows with their square), got {sampling}."
        )
    check_sampling(contact_kind(contact), sampling)
    if design is not None and fluid is not None:
        raise ValueError("give the fluid in the design (HingeDesign(fluid=...)), not both.")
    if design is not None and not isinstance(design, HingeDesign):
        raise ValueError(f"design must be a HingeDesign, got {type(design).__name__}.")
    fluid = "koh" if fluid is None else fluid
    if fluid not in FLUIDS:
        raise ValueError(f"fluid must be one of {FLUIDS}, got {fluid!r}.")
    if hinge_lengths not in ("ideal", "designed"):
        raise ValueError(f"hinge_lengths must be 'ideal' or 'designed', got {hinge_lengths!r}.")
    if hinge_lengths == "designed" and hinges != "point":
        raise ValueError(
            "hinge_lengths='designed' is implemented for point hinges (hinges='point')."
        )
    the_net = load_pattern(net)
    loops = isinstance(the_net, CreasePattern)
    theta0 = the_net.start_state(bias=bias)[0] if loops else None
    m = the_net.n_creases
    if design is None:
        # As `system` without a design.
        base = default_design(the_net, AIR if fluid == "air" else KOH_SOLUTION)
    else:
        base = design
    aims = None
    if targets is not None:
        aims = np.asarray(targets, dtype=float)
        if aims.shape != (m,) or not np.all(np.isfinite(aims)):
            raise ValueError(
                f"targets must be {m} finite fold angles (rad, one per crease), got {targets!r}."
            )
    parameters = {**NET_PARAMETERS, **NET_GLOBAL_PARAMETERS}
    parameters.update(
        {f"{name}[{j}]": unit for name, unit in NET_PARAMETERS.items() for j in range(m)}
    )
    parameters.update({f"release[{j}]": "us" for j in range(m)})
    parameters.update({f"target[{j}]": "rad" for j in range(m)})
    intended = jnp.asarray(the_net.intended_angles)

    def design_of(params):
        invalid = jnp.zeros((), dtype=bool)
        values = {}
        for name in (*NET_PARAMETERS, *NET_GLOBAL_PARAMETERS):
            default = jnp.asarray(getattr(base, name), dtype=float)
            value = jnp.asarray(params.get(name, default), dtype=float)
            if name in NET_PARAMETERS:
                entries = [params.get(f"{name}[{j}]") for j in range(m)]
                if any(e is not None for e in entries):
                    value = jnp.stack(
                        [value if e is None else jnp.asarray(e, dtype=float) for e in entries]
                    )
            invalid = invalid | jnp.any(~(jnp.isfinite(value) & (value > 0)))
            values[name] = jnp.where(invalid, default, value)
        release = [params.get(f"release[{j}]") for j in range(m)]
        times = None
        if any(r is not None for r in release):
            times = jnp.stack(
                [jnp.zeros(()) if r is None else jnp.asarray(r, float) for r in release]
            )
            invalid = invalid | jnp.any(~(jnp.isfinite(times) & (times >= 0)))
            times = jnp.where(invalid, 0.0, times)
        design = eqx_tree_at_fields(base, values)
        return design, times, invalid

    def aims_of(params):
        swept = [params.get(f"target[{j}]") for j in range(m)]
        if all(a is None for a in swept):
            return None if aims is None else jnp.asarray(aims)
        if any(a is None for a in swept):
            raise ValueError(f"sweep every target[j] of the {m} creases, or none.")
        return jnp.stack([jnp.asarray(a, dtype=float) for a in swept])

    def fn(params):
        design, times, invalid = design_of(params)
        aim = aims_of(params)
        if hinge_lengths == "designed":
            aim = intended if aim is None else aim
            aim = aim * design.curvature() / base.curvature()
        system = the_net.system(
            design,
            targets=aim,
            release_times=times,
            contact=contact,
            drag=drag,
            hinges=hinges,
            # Arc hinges: the net is laid out (lithography) for the nominal design, not each sample.
            **({"layout_design": base} if hinges == "arc" and not loops else {}),
            contact_sampling=sampling,
        )
        trajectory = simulate(
            system,
            Step(),
            theta0=theta0,
            t1=t_end,
            n_save=n_save,
            rtol=rtol,
            atol=atol,
            max_steps=max_steps,
            solver=diffrax.Tsit5(),
            throw=False,
        )
        outcome = the_net.outcome(
            system, trajectory, intended_angles=intended, tolerances=tolerances
        )
        result = jnp.where(invalid, INVALID_INPUT, trajectory.result._value).astype(jnp.int32)
        failed = result != 0

        def masked(x):
            return jnp.where(failed, jnp.nan, x)

        return {
            "verdict": jnp.where(invalid, 4, outcome.code).astype(jnp.int32),
            "folded": (outcome.code == 0) & ~invalid,
            "time_to_fold": masked(
                jnp.where(jnp.isfinite(outcome.time_to_fold), outcome.time_to_fold, jnp.nan)
            ),
            "final_angle": masked(trajectory.theta[-1]),
            "max_seam_gap": masked(outcome.max_seam_gap),
            "max_open_seam_gap": masked(outcome.max_open_seam_gap),
            "seams_touching": jnp.where(
                failed, -1, jnp.sum(outcome.seams_touching.astype(jnp.int32))
            ).astype(jnp.int32),
            "min_gap": masked(outcome.min_gap),
            "penetration": masked(outcome.penetration),
            "engaged": jnp.where(failed, -1, outcome.engaged).astype(jnp.int32),
            "num_steps": jnp.asarray(trajectory.stats["num_steps"], dtype=jnp.int32),
            "result": result,
        }

    messages = {INVALID_INPUT: "invalid input"}
    messages.update({int(item._value): name for name, item in RESULTS._name_to_item.items()})
    return Kernel(
        fn=fn,
        never_raises=True,  # bad values come back as INVALID_INPUT
        name="net-fold",
        settings={
            "net": the_net.name,
            "fluid": fluid if design is None else base.fluid.name,
            "t_end_us": t_end,
            "n_save": n_save,
            "rtol": rtol,
            "atol": atol,
            "max_steps": max_steps,
            # The model by name ("plate", "sampled", or false): stores written with the sampled
            # model recorded `true`, and are not resumed with another.
            "contact": contact_kind(contact) or False,
            "drag": drag,
            "hinges": hinges,
            # Arc hinges on nets are laid out as fillets (stores of the drawn layout differ).
            **({"arc_layout": "fillet"} if hinges == "arc" and not loops else {}),
            "angle_tolerance_deg": angle_tolerance_deg,
            # Named only when not the default (stores written before it existed stay resumable).
            **({} if seam_tolerance == 0.01 else {"seam_tolerance": seam_tolerance}),
            "closed_loops": the_net.n_loops if loops else 0,
            "bias": bias,
            **({} if design is None else {"design": design_settings(design)}),
            **({} if aims is None else {"targets": aims.tolist()}),
            **({} if hinge_lengths == "ideal" else {"hinge_lengths": hinge_lengths}),
            **({} if sampling == CONTACT_SAMPLING else {"contact_sampling": list(sampling)}),
        },
        parameters=parameters,
        output_units={
            "time_to_fold": "us",
            "final_angle": "rad",
            "max_seam_gap": "um",
            "max_open_seam_gap": "um",
            "min_gap": "um",
            "penetration": "um",
        },
        output_dims={"final_angle": ("crease",)},
        result_messages=messages,
        # Contact makes the step counts of scattered nets spread tenfold and unpredictably: on a
        # CPU, chunks of one net side by side beat wide vmapped chunks (benchmarks/history.md).
        cpu_chunk_size=1,
    )


def design_settings(design) -> dict[str, Any]:
    """A `HingeDesign` (or any equinox module) as JSON-able settings: every field by name, arrays
    as numbers or lists, nested modules as dictionaries, static values as text."""
    import numpy as np

    out: dict[str, Any] = {}
    for field in dataclasses.fields(design):
        value = getattr(design, field.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out[field.name] = design_settings(value)
        elif value is None or isinstance(value, bool | int | float | str):
            out[field.name] = value
        elif hasattr(value, "shape"):
            out[field.name] = np.asarray(value, dtype=float).tolist()
        else:
            out[field.name] = str(value)
    return out


def eqx_tree_at_fields(design, values: Mapping[str, Any]):
    """`design` with the named top-level fields replaced (traced values welcome)."""
    import equinox as eqx

    names = list(values)
    return eqx.tree_at(
        lambda d: tuple(getattr(d, n) for n in names), design, tuple(values[n] for n in names)
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
    ),
}


def available_models() -> dict[str, str]:
    """Every model the sweep knows → its description."""
    return {name: model.description for name, model in MODELS.items()}


def get_model(name: str, **options: Any) -> Kernel:
    """Build the sweep `Kernel` of a named model with its `options` (settings).

    **Raises:** `ValueError` for an unknown model or option.
    """
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}; the sweep knows {sorted(MODELS)}.")
    try:
        return MODELS[name].build(**options)
    except TypeError as error:
        raise ValueError(f"model {name!r}: bad settings {sorted(options)}: {error}") from error
