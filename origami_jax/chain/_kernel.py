"""`accordion_step`: the accordion's sweep kernel (`Accordion.kernel`, the sweep's
`"accordion-step"` model): step-response metrics of the `n`-flap accordion.

The flap count fixes array shapes, so it is a *static* parameter: the sweep engine runs one compiled
call per flap count (an outer loop over separately compiled groups), every other parameter is
batched.
"""

from collections.abc import Mapping
from typing import Any

import diffrax
import jax.numpy as jnp

from .._exported import SOLVE_COMPILE
from .._kernel import FLUIDS, INVALID_INPUT, Kernel, check_setting
from .._limits import MAX_FLAPS, MAX_SAMPLES
from ..simulation import (
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    SaveAt,
    SolveOptions,
    Step,
    implicit_solver,
    kernel_result_messages,
    response_metrics,
    simulate,
)
from ..system import AIR, KOH_SOLUTION, MICRO, Fluid, HingeDesign
from ._chain import flap_size
from ._system import accordion_system

# Parameters of "accordion-step" and their units: lengths in µm, the package's MICRO unit system. The
# flap geometry is the pattern's (`Accordion`), the rest the hinge design's (`HingeDesign`).
_GEOMETRY = ("flap_length", "flap_width")
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
    flap_length: float | None = None,
    flap_width: float | None = None,
) -> Kernel:
    """Sweep kernel: step response metrics of the accordion (paper Fig. 7).

    Parameters not swept take `HingeDesign.literature()` values (200 nm SiNx, 100 nm Cr at 1 GPa,
    hinge as wide as the flap, `C_D = 1.17`, `θ_final = π`) and the accordion's flaps (`flap_length`,
    `flap_width`, default the paper's 200 µm squares); lengths are in µm. The system is
    `origami_jax.chain.accordion_system(design, n_flaps, flap_length=..., flap_width=...)`, stepped
    to its hinge targets
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
    - `flap_length`, `flap_width`: the flaps' size when not swept, µm (`Accordion.kernel` passes
      its own; recorded among the settings' `defaults`).

    **Outputs** per design: per joint (dim `joint`) `rise_time`, `t10`, `t90`, `overshoot` (%),
    `peak_time`, `settling_time` (µs), `final_error` (rad), flags `rise_ill_conditioned`,
    `settling_ill_posed`; per design `stiffness`, `drag`, `hinge_length`, `num_steps`, and `result`
    (`origami_jax.simulation.RESULTS` codes; −1 = invalid input). Floats are NaN where `result != 0`.
    """
    # Not the simulation's default (`StiffnessSwitching`): under `vmap` its switch would run both the
    # explicit and the implicit step for every member; a sweep picks one.
    solvers = {"kvaerno5": implicit_solver(), "tsit5": diffrax.Tsit5()}
    if solver not in solvers:
        raise ValueError(f"solver must be one of {sorted(solvers)}, got {solver!r}.")
    if fluid not in FLUIDS:
        raise ValueError(f"fluid must be one of {FLUIDS}, got {fluid!r}.")
    n_flaps = check_setting(n_flaps, "n_flaps", low=1, integer=True, high=MAX_FLAPS)
    t_end = check_setting(t_end, "t_end", low=0.0)
    n_save = check_setting(n_save, "n_save", low=2, integer=True, high=MAX_SAMPLES)
    max_steps = check_setting(max_steps, "max_steps", low=1, integer=True)
    rtol = DEFAULT_RTOL if rtol is None else check_setting(rtol, "rtol", low=0.0)
    atol = DEFAULT_ATOL if atol is None else check_setting(atol, "atol", low=0.0)
    literature = HingeDesign.literature(MICRO)
    floats = [n for n, u in ACCORDION_PARAMETERS.items() if n not in ("n_flaps", "fluid")]
    size = flap_size(
        MICRO,
        *(
            None if v is None else check_setting(v, n, low=0.0)
            for n, v in zip(_GEOMETRY, (flap_length, flap_width), strict=True)
        ),
    )
    defaults = {
        n: float(size[_GEOMETRY.index(n)] if n in _GEOMETRY else getattr(literature, n))
        for n in floats
        if n not in ("k_scale", "b_scale")
    }
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
        geometry = {k: safe.pop(k) for k in _GEOMETRY}
        design = HingeDesign(
            **safe,
            fluid=Fluid(density, MICRO, "swept"),
            stiffness_model=stiffness_model,
            drag_model=drag_model,
            units=MICRO,
        )
        return design, n, invalid, geometry

    def cost(params: Mapping[str, Any]):
        # Steps of an adaptive solve scale with the fastest natural frequency times the run length:
        # ω_max² = λ_max(M(0)⁻¹ K), from the symmetric K^½ M⁻¹ K^½ (eigvalsh runs on every backend).
        design, n, invalid, geometry = design_of(params)
        system = accordion_system(design, n, **geometry)
        root_k = jnp.sqrt(system.hinges.stiffness)
        m_inverse = jnp.linalg.inv(system.mechanism.mass_matrix(jnp.zeros(n)))
        omega_max = jnp.sqrt(jnp.max(jnp.linalg.eigvalsh(root_k[:, None] * m_inverse * root_k)))
        return jnp.where(invalid, jnp.inf, omega_max * t_end)

    def fn(params: Mapping[str, Any]) -> dict[str, Any]:
        design, n, invalid, geometry = design_of(params)
        system = accordion_system(design, n, **geometry)
        stiffness, drag = system.hinges.stiffness, system.drag.coefficient
        trajectory = simulate(
            system,
            Step(),
            SolveOptions(
                saveat=SaveAt(n=n_save),
                solver=solvers[solver],
                rtol=rtol,
                atol=atol,
                max_steps=max_steps,
                throw=False,
            ),
            t1=t_end,
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
    # Every value `fn` and `cost` close over, by value (the rest is this package's source).
    settings = {
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
    }
    return Kernel(
        fn=fn,
        never_raises=True,  # bad values come back as INVALID_INPUT
        name="accordion-step",
        settings=settings,
        program_key=("accordion-step", settings),
        # Its chunks compile in 70-90 % of the time with XLA's loop emitters (Kvaerno5 running as
        # fast, Tsit5 within 10 %).
        compiler_options=SOLVE_COMPILE,
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
        result_messages=kernel_result_messages(),
        cost=cost,
        categories={"fluid": FLUIDS},
    )
