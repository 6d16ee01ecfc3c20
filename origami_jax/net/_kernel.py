"""`fold_kernel`: the sweep kernel of a net or a closed-loop crease pattern, built from the pattern
object (`Net.kernel`, `CreasePattern.kernel`).

One design per call: the pattern's system with the design's hinges (`pattern.system`, its own
physics model), simulated from its start state (`pattern.start_state`) with explicit Tsit5 and
judged by its traceable verdict (`pattern.outcome`). The sweep's `"net-fold"` model
(`origami_jax.sweep.get_model`) is this kernel of the pattern a catalogue name or file names
(the name becomes a pattern there, in the sweep's model registry).
"""

import dataclasses
from typing import Any

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from .._exported import SOLVE_COMPILE
from .._kernel import (
    FLUIDS,
    INVALID_INPUT,
    KeptKernels,
    Kernel,
    check_setting,
    design_settings,
    replace_fields,
    structure_key,
)
from .._limits import (
    CONTACT_SAMPLING,
    KERNEL_MAX_STEPS,
    MAX_CONTACT_SAMPLING,
    MAX_SAMPLES,
    default_t_end,
)
from ..contact import check_sampling, contact_kind, sampling_pair
from ..simulation import (
    LEGACY_SEAM_FRACTION,
    ImplicitStep,
    SaveAt,
    SolveOptions,
    Step,
    VerdictTolerances,
    kernel_result_messages,
    simulate,
    start_bias,
)
from ..system import AIR, KOH_SOLUTION, HingeDesign
from ._content import value_key

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

FOLD_KERNEL_SOLVE = SolveOptions(saveat=SaveAt(n=301), max_steps=KERNEL_MAX_STEPS, throw=False)
"""The fold kernel's solve unless given one: `t1=None`, run to `default_t_end` (1500 µs after a
step release, the longer of that and a fifth of a release ramp past it), 301 samples, 200,000
steps, the simulation's tolerances (change one with `FOLD_KERNEL_SOLVE.replace(t1=600.0)`)."""


def surface_settings(pattern) -> dict:
    """What a stored run records of `pattern`'s adhesion and friction: their numbers (the design's
    units), each only when on, so that a store written without them still resumes and one written
    with them is not resumed with other values."""
    recorded = {}
    if pattern.adhesion is not None:
        a = pattern.adhesion
        recorded["adhesion"] = {
            "work": float(a.work),
            "range": float(a.range),
            "line": float(a.line),
            "samples": a.samples,
        }
    if pattern.friction is not None:
        f = pattern.friction
        recorded["friction"] = {"coefficient": float(f.coefficient), "slip": float(f.slip)}
    return recorded


def model_settings(pattern, design: HingeDesign | None = None, system=None) -> dict:
    """What a stored run records of `pattern`'s physics options beyond its contact, drag and
    hinges, as they act on `design` (default the pattern's default design; its fluid decides the
    defaults), each only when on (so a store written before the option existed still resumes,
    and one written with it is not resumed without): the fluid's inertia and viscosity on its
    panels (`added_mass`, `viscous`), the release ramp (`release_ramp_us`, µs: `system`'s where
    given, one the pattern built with `design`, else `nominal_release_ramp(design)`), and
    adhesion and friction (`surface_settings`)."""
    inertia = pattern.fluid_inertia(design)
    recorded = {
        name: True for name, on in zip(("added_mass", "viscous"), inertia, strict=True) if on
    }
    if system is not None:
        ramp = pattern.release_ramp_for(system)
    else:
        ramp = pattern.nominal_release_ramp(design)
    if ramp is not None:
        recorded["release_ramp_us"] = ramp
    agitation = getattr(pattern, "agitation", None)
    if agitation is not None:
        recorded["agitation"] = {
            "temperature_K": float(agitation.temperature),
            "key": [int(x) for x in np.asarray(agitation.key)],
        }
    return {**recorded, **surface_settings(pattern)}


def fold_kernel(
    pattern,
    *,
    fluid: str | None = None,
    design: HingeDesign | None = None,
    solve: SolveOptions | None = None,
    tolerances: VerdictTolerances | None = None,
    bias: float = 0.0,
    targets: Any = None,
    hinge_lengths: str = "ideal",
) -> Kernel:
    """Sweep kernel: does a net of panels, or a crease pattern with closed loops, fold? Verdict and
    numbers per design (explicit Tsit5 under the contact guard unless `solve` names a solver; `pattern.system(design, ...)`, its
    own physics model (`Net.with_model`), with the literature design for what is not swept, in
    MICRO units, each hinge no wider than its crease). A closed-loop pattern starts flat, or
    pre-folded by `bias` rad along its own angles (`CreasePattern.start_state`); its verdict is
    `misfolded` on another branch.

    **Parameters** (swept): `hinge_width`, `t_hinge`, `misfit_strain`, `k_scale` for every crease, or
    per crease as `name[j]` (e.g. `misfit_strain[3]`: the film stress scatter of one hinge);
    `t_structural`, `drag_coefficient`, `b_scale` for the whole net; `release[j]`: crease `j`'s release
    time (µs, default 0); `target[j]`: the angle crease `j`'s hinge is drawn to fold to (rad; default
    the `targets` setting, else the pattern's angle; give all of them or none); with an agitated
    pattern (`Net.with_model(agitation=...)`), `noise_seed`: the member's noise, a whole number in
    ``[0, 2³¹)`` folded into the agitation's key (default: the key as it is).

    On a CPU, `sweep` runs this kernel one design per compiled call, several at once
    (`Kernel.cpu_chunk_size`), unless given a `chunk_size`.

    **Outputs:** `verdict` (0 folded, 1 jammed, 2 misfolded, 3 unfinished, 4 invalid;
    `origami_jax.simulation.VERDICT_CODES`), `folded`, `time_to_fold` (µs, NaN if never),
    `final_angle` (rad, per crease), `max_seam_gap` (µm, every seam), `max_open_seam_gap` (µm, the
    seams whose panels do not touch: the verdict holds a touching seam closed whatever its gap),
    `seams_touching` (how many seams' panels touch at the end; −1 where the simulation failed),
    `min_gap`, `penetration` (µm), `engaged`
    (contact pairs engaged at the end; −1 where the simulation failed), `angle_margin` and
    `seam_margin` (the largest crease error over the angle tolerance, the largest open seam's gap
    over its tolerance, at the end: a succeeded run is folded at the angle tolerance × ``a`` and
    the seam tolerances × ``s`` iff both are below those factors,
    `origami_jax.simulation.FoldOutcome`; NaN where the simulation failed), `num_steps`, `result`
    (the solver's code; −1 invalid input); with the fixed-step engine also `contacts_left_out`
    (its steps whose working set of contact pairs missed one within reach: 0 expected,
    `ImplicitStep.active_pairs`).

    **Arguments** (fixed for the whole sweep, recorded in its settings and checked on resume):
    - `pattern`: a `Net` or a `CreasePattern` (an [`origami_jax.system.AbstractPattern`][] with
      seams); its physics options (`contact`, `drag`, `hinges`, `contact_sampling`, the fluid's
      inertia, the release ramp: `with_model`) are the kernel's. Every member is released over
      one ramp, the nominal design's (`nominal_release_ramp`: in the etch bath, by default, a
      quasi-static release of the net carrying the fluid's inertia).
    - `fluid` (`"air"` or `"koh"`, default `"koh"`) or `design`, a whole `HingeDesign` (MICRO
      units) for what is not swept (its fluid included; not both).
    - `solve`: a [`origami_jax.simulation.SolveOptions`][]: its `t1` (µs), `saveat.n`, `rtol`,
      `atol` and `max_steps` (default `FOLD_KERNEL_SOLVE`: `default_t_end`, 1500 µs or a fifth of
      the release ramp past it, 301 samples, 200,000 steps);
      its `solver`: explicit Tsit5 unless given (any diffrax solver, or the fixed-step engine
      `ImplicitStep(dt=...)`: every member of a vmapped batch does the same work; recorded in the
      settings); it never throws (a failed member's `result` says so).
    - `tolerances`: the verdict's (`origami_jax.simulation.VerdictTolerances`; default 3°, each
      seam's tolerance derived from it and the geometry). Recorded in the settings as
      `angle_tolerance_deg` and `seam_tolerance` (a fraction, or null: derived); a store whose
      settings name no `seam_tolerance` was judged with the fixed 0.01 of the largest panel (the
      default then), and `stored_tolerances` reads it back so.
    - `bias`: a closed-loop pattern's pre-fold (rad; nets take 0; with `ImplicitStep` a
      pattern's 0 becomes `origami_jax.simulation.FIXED_STEP_PRE_FOLD`: `start_bias`).
    - `targets`: the angles the hinges aim at (rad, one per crease; default the pattern's).
    - `hinge_lengths`: `"ideal"` (default): every design's hinge bends exactly to its target
      (hinge length ``ρ |θ_target|`` with the design's own radius ``ρ``); `"designed"`: the hinge
      lengths are drawn for the *nominal* design (``l = ρ₀ |θ_target|``, what lithography fixes)
      and a design whose films differ (swept `misfit_strain`, `t_hinge`, `t_structural`) bends
      them to ``l / ρ = θ_target ρ₀ / ρ`` (paper Eq. 7 with ``l = ρ θ``): the fold angle of a
      fabricated hinge whose film stress or thickness is off.

    The same `Kernel` object for the same pattern (by its contents, `content_key`, and name: a
    net loaded again is the same) and the same settings (by value); and the same traced program
    (`Kernel.program`) for settings that differ only in the verdict's tolerance values, the
    numbers of the nominal `design` (not its fluid or models) and its release ramp's length, which
    reach the program as data (`Kernel.inputs`). The sweep engine traces and compiles a program once per
    process, so a second yield, sweep or fit of the net, or one at another tolerance or nominal
    design, compiles nothing again (a fixed seam fraction against a derived seam tolerance, or
    arc hinges drawn for another nominal design, are another program). The last four of each
    are kept.

    **Raises:** `ValueError` before anything compiles for bad settings.
    """
    settings = dict(
        fluid=fluid, design=design, solve=solve, tolerances=tolerances, bias=bias,
        targets=targets, hinge_lengths=hinge_lengths,
    )  # fmt: skip
    content_key = getattr(pattern, "content_key", None)
    if content_key is None:  # a pattern without one: its own kernel, as built
        return _fold_kernel(pattern, settings, None)
    content = content_key()
    # The name too: a kernel's settings record it (a store's, checked on resume).
    key = (content, pattern.name, value_key(settings))
    return _KEPT.get(key, lambda: _fold_kernel(pattern, settings, content))


_KEPT = KeptKernels()
# The kernels' traced programs (`Kernel.program`), by the pattern's contents and what shapes the
# program (not the verdict's tolerances, the nominal design's numbers or the release ramp's length,
# which reach it as `Kernel.inputs`): kernels that differ only in those share compiled programs.
_PROGRAMS = KeptKernels()


def _fold_kernel(pattern, settings: dict[str, Any], content) -> Kernel:
    """`fold_kernel`, built from its `settings` (its keyword arguments); `content`, the pattern's
    `content_key()` (`None`: a pattern without one, whose program is not shared)."""
    fluid, design, solve = settings["fluid"], settings["design"], settings["solve"]
    tolerances, bias, targets = settings["tolerances"], settings["bias"], settings["targets"]
    hinge_lengths = settings["hinge_lengths"]
    solve = FOLD_KERNEL_SOLVE if solve is None else solve
    if not isinstance(solve, SolveOptions):
        raise ValueError(f"solve must be a SolveOptions, got {type(solve).__name__}.")
    if solve.saveat.ts is not None:
        raise ValueError("the fold kernel saves evenly spaced samples: give SaveAt(n=...).")
    if design is not None and fluid is not None:
        raise ValueError("give the fluid in the design (HingeDesign(fluid=...)), not both.")
    if design is not None and not isinstance(design, HingeDesign):
        raise ValueError(f"design must be a HingeDesign, got {type(design).__name__}.")
    fluid = "koh" if fluid is None else fluid
    if fluid not in FLUIDS:
        raise ValueError(f"fluid must be one of {FLUIDS}, got {fluid!r}.")
    # As `system` without a design.
    base = (
        pattern.default_design(AIR if fluid == "air" else KOH_SOLUTION)
        if design is None
        else design
    )
    # One release for every member: the nominal design's (the etch is the same for all).
    ramp = pattern.nominal_release_ramp(base)
    if solve.t1 is None:
        solve = solve.replace(t1=default_t_end(ramp))
    t_end = check_setting(solve.number("t1"), "t_end", low=0.0)
    if ramp is not None and isinstance(t_end, int | float) and ramp >= t_end:
        # Every member would be judged before its hinges' torques are whole.
        raise ValueError(
            f"the pattern's release ramp ({ramp:g} µs) lasts to or past t_end ({t_end:g} µs): "
            "no hinge is whole before the end; give a t_end past the ramp and its settling "
            f"(CLI: --t-end; default {default_t_end(ramp):g} µs, past it), or another "
            "release_ramp (with_model)."
        )
    n_save = check_setting(solve.saveat.n, "n_save", low=2, integer=True, high=MAX_SAMPLES)
    max_steps = check_setting(solve.max_steps, "max_steps", low=1, integer=True)
    rtol = check_setting(solve.number("rtol"), "rtol", low=0.0)
    atol = check_setting(solve.number("atol"), "atol", low=0.0)
    # Explicit Tsit5 under the contact guard unless the options name another solver: any diffrax
    # solver, or the fixed-step engine (`ImplicitStep`, the same work for every member of a batch).
    solver = diffrax.Tsit5() if solve.solver is None else solve.solver
    if not isinstance(solver, diffrax.AbstractSolver | ImplicitStep):
        raise ValueError(
            f"solve.solver must be a diffrax solver or an ImplicitStep, got {type(solver).__name__}."
        )
    tolerances = VerdictTolerances() if tolerances is None else tolerances
    if not isinstance(tolerances, VerdictTolerances):
        raise ValueError(
            f"tolerances must be a VerdictTolerances, got {type(tolerances).__name__}."
        )
    agitation = getattr(pattern, "agitation", None)
    if agitation is not None:
        check_agitated_kernel(pattern, solver, base)
    contact = pattern.contact
    sampling = check_kernel_sampling(contact, pattern.contact_sampling)
    if hinge_lengths not in ("ideal", "designed"):
        raise ValueError(f"hinge_lengths must be 'ideal' or 'designed', got {hinge_lengths!r}.")
    if hinge_lengths == "designed" and pattern.hinges != "point":
        raise ValueError(
            "hinge_lengths='designed' is implemented for point hinges (hinges='point')."
        )
    bias = start_bias(pattern, solver, bias)
    theta0 = pattern.start_state(bias=bias)[0]
    m = pattern.n_hinges
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
    if agitation is not None:
        parameters["noise_seed"] = "1"
    intended = jnp.asarray(pattern.intended_angles)

    def design_of(params, base):
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
        design = replace_fields(base, values)
        return design, times, invalid

    def aims_of(params):
        swept = [params.get(f"target[{j}]") for j in range(m)]
        if all(a is None for a in swept):
            return None if aims is None else jnp.asarray(aims)
        if any(a is None for a in swept):
            raise ValueError(f"sweep every target[j] of the {m} creases, or none.")
        return jnp.stack([jnp.asarray(a, dtype=float) for a in swept])

    arcs_on_net = pattern.hinges == "arc" and not pattern.n_loops
    layout = {"layout_design": base} if arcs_on_net else {}
    # Values the program takes as data (`Kernel.inputs`), so that another tolerance, nominal design
    # or ramp compiles nothing again. Arc hinges on a net are drawn (lithography) for the nominal
    # design on the host: there it stays a constant of the program.
    inputs: dict[str, Any] = {"angle_tolerance": tolerances.angle}
    if tolerances.seam is not None:
        inputs["seam_tolerance"] = tolerances.seam
    if ramp is not None:
        inputs["release_ramp"] = ramp
    if not arcs_on_net:
        inputs["design"] = base
    solve_options = SolveOptions(
        # The verdict reads angles and rates: no accelerations, one right-hand side less to compile.
        saveat=SaveAt(n=n_save, accelerations=False),
        solver=solver,
        rtol=rtol,
        atol=atol,
        max_steps=max_steps,
        throw=False,
    )

    def run(params):
        """The member's system, its simulated trajectory, and whether its parameters are invalid
        (then a harmless stand-in design was simulated)."""
        nominal = params.get("design", base)
        design, times, invalid = design_of(params, nominal)
        aim = aims_of(params)
        if hinge_lengths == "designed":
            aim = intended if aim is None else aim
            aim = aim * design.curvature() / nominal.curvature()
        # The system of this member's design: its numbers are traced, so it is built in the trace.
        # Arc hinges on a net: laid out (lithography) for the nominal design, not each sample's.
        system = pattern.system(design, targets=aim, release_times=times, **layout)
        if agitation is not None and "noise_seed" in params:
            seed = jnp.asarray(params["noise_seed"], dtype=float)
            # A seed is a whole number in [0, 2³¹): anything else is an invalid member.
            invalid = invalid | ~((seed >= 0) & (seed < 2.0**31) & (seed == jnp.floor(seed)))
            seed = jnp.where(invalid, 0.0, seed)
            system = eqx.tree_at(lambda s: s.agitation.key, system, member_key(agitation, seed))
        release = Step(ramp=params.get("release_ramp"))
        trajectory = simulate(system, release, solve_options, theta0=theta0, t1=t_end)
        return system, trajectory, invalid

    def fn(params):
        system, trajectory, invalid = run(params)
        seam = params.get("seam_tolerance")
        outcome = pattern.outcome(
            system,
            trajectory,
            intended_angles=intended,
            angle_tolerance=params["angle_tolerance"],
            # A fixed fraction of the largest panel (static: the contact tables' scale).
            seam_tolerance=None if seam is None else seam * pattern.panel_size(system),
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
            "angle_margin": masked(outcome.angle_margin),
            "seam_margin": masked(outcome.seam_margin),
            "num_steps": jnp.asarray(trajectory.stats["num_steps"], dtype=jnp.int32),
            "result": result,
            # The fixed-step engine's steps whose working set of contact pairs missed one that
            # came within reach (0 expected; more: its forces were missed, raise active_pairs).
            **(
                {"contacts_left_out": jnp.asarray(left_out, dtype=jnp.int32)}
                if (left_out := trajectory.stats.get("contacts_left_out")) is not None
                else {}
            ),
        }

    program, program_key = fn, None
    if content is not None:
        structure = {
            "solve": solve_options,
            "t_end": t_end,
            "bias": bias,
            "aims": aims,
            "hinge_lengths": hinge_lengths,
            "base": value_key(base) if arcs_on_net else None,
        }
        key = (content, value_key(structure), structure_key(inputs))
        program = _PROGRAMS.get(key, lambda: fn)
        # Across processes: the pattern by its contents (as `kept_system` keeps its systems), the
        # solve's options as objects (the key refuses a solver whose code it cannot vouch for).
        program_key = (
            "net-fold",
            type(pattern).__name__,
            content,
            structure,
            structure_key(inputs),
        )

    def with_inputs(params):
        return program({**inputs, **params})

    def replay(params):
        return run({**inputs, **params})[:2]

    resume = pattern.resume_settings()
    return Kernel(
        fn=with_inputs,
        program=program,
        inputs=inputs,
        program_key=program_key,
        never_raises=True,  # bad values come back as INVALID_INPUT
        # An adaptive solve's chunk compiles in about 60 % of the time with XLA's loop emitters
        # and runs as fast; the fixed-step engine's compiles no sooner and runs slower with them.
        compiler_options=None if isinstance(solver, ImplicitStep) else SOLVE_COMPILE,
        replay=replay,
        name="net-fold",
        # The keys and values stores have recorded since before patterns were objects (a store
        # written then still resumes): the pattern by name, optional settings only when not
        # their defaults.
        settings={
            "net": resume["net"],
            "fluid": fluid if design is None else base.fluid.name,
            "t_end_us": t_end,
            "n_save": n_save,
            "rtol": rtol,
            "atol": atol,
            "max_steps": max_steps,
            # Named only when not the default (Tsit5): stores written before it existed resume.
            **({} if solve.solver is None else {"solver": _solver_name(solver)}),
            # The model by name ("plate", "sampled", or false): stores written with the sampled
            # model recorded `true`, and are not resumed with another.
            "contact": contact_kind(contact) or False,
            "drag": pattern.drag,
            "hinges": pattern.hinges,
            # Arc hinges on nets are laid out as fillets (stores of the drawn layout differ), or
            # as the file draws its hinge strips.
            **(
                {"arc_layout": "fillet" if pattern.drawn_layout is None else "strips"}
                if layout
                else {}
            ),
            "angle_tolerance_deg": tolerances.angle_deg,
            # No key: the fixed 0.01 that was the default (stores written then still resume);
            # null: derived (the default now).
            **(
                {}
                if tolerances.seam == LEGACY_SEAM_FRACTION
                else {"seam_tolerance": tolerances.seam}
            ),
            "closed_loops": resume["closed_loops"],
            "bias": bias,
            **({} if design is None else {"design": design_settings(design)}),
            **({} if aims is None else {"targets": aims.tolist()}),
            **({} if hinge_lengths == "ideal" else {"hinge_lengths": hinge_lengths}),
            **({} if sampling == CONTACT_SAMPLING else {"contact_sampling": list(sampling)}),
            **model_settings(pattern, base),
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
        result_messages=kernel_result_messages(),
        # Contact makes the step counts of scattered nets spread tenfold and unpredictably: on a
        # CPU, chunks of one net side by side beat wide vmapped chunks (benchmarks/history.md).
        cpu_chunk_size=1,
    )


def member_key(agitation, noise_seed) -> Array:
    """The agitation key of a sweep member: `agitation.key` folded with its `noise_seed` (a whole
    number in `[0, 2³¹)`, carried as a float column), `uint32[2]`."""
    seed = jnp.asarray(noise_seed).astype(jnp.uint32)
    return jax.random.fold_in(agitation.key, seed)


def check_agitation_balanced(pattern, viscous: bool) -> None:
    """A one-line error, before anything is built, for an agitated `pattern` whose systems would
    carry no viscous drag (`viscous`, as `fluid_inertia` resolves it) to balance the noise."""
    if getattr(pattern, "agitation", None) is not None and not viscous:
        raise ValueError(
            f"{pattern.name}: agitation needs the fluid's viscous drag to balance its noise "
            "(with_model(viscous=True); on by default in a liquid, the etch bath)."
        )


def check_agitated_kernel(pattern, solver, design: HingeDesign) -> None:
    """One-line errors, before anything compiles, for a kernel of an agitated pattern: its solver
    must take the random force under contact (`ImplicitStep`), and its systems in `design`'s fluid
    must carry the fluid's viscous drag that balances the noise."""
    if not isinstance(solver, ImplicitStep):
        raise ValueError(
            "an agitated pattern's sweeps and yields fold with the fixed-step engine, which adds "
            "the random force to each step under contact: give SolveOptions(solver="
            "ImplicitStep(dt=...)) (CLI: --solver implicit-step --dt US)."
        )
    check_agitation_balanced(pattern, pattern.fluid_inertia(design)[1])


def stored_tolerances(settings) -> VerdictTolerances:
    """The verdict's tolerances a fold kernel's `settings` record (a stored sweep's, e.g. its
    `sweep.json`'s `settings`): `angle_tolerance_deg` (default 3) and `seam_tolerance` (a fraction,
    or null: derived; absent: `LEGACY_SEAM_FRACTION`, the fixed 0.01 that was the default when
    the store was written).

    **Raises:** `ValueError` for settings that are not a mapping or hold a bad tolerance."""
    if not isinstance(settings, dict):
        raise ValueError(f"settings must be a mapping, got {type(settings).__name__}.")
    seam = settings.get("seam_tolerance", LEGACY_SEAM_FRACTION)
    return VerdictTolerances.from_degrees(settings.get("angle_tolerance_deg", 3.0), seam)


def check_kernel_sampling(contact, sampling) -> tuple[int, int]:
    """The contact sampling of a fold kernel, checked before anything is built: a pair of at most
    `MAX_CONTACT_SAMPLING` points per edge, for the sampled model only."""
    sampling = sampling_pair(sampling)
    if max(sampling) > MAX_CONTACT_SAMPLING:
        raise ValueError(
            f"contact_sampling takes at most {MAX_CONTACT_SAMPLING} points per edge on the ring and "
            f"on the rim (the contact's work grows with their square), got {sampling}."
        )
    check_sampling(contact_kind(contact), sampling)
    return sampling


def _solver_name(solver) -> str:
    """A solver as a store records it: the engine with its fixed settings, or a diffrax solver's
    class name. (The Euler scheme, the default, is not named: stores written before the engine
    had schemes resume.)"""
    if isinstance(solver, ImplicitStep):
        fields = ", ".join(
            f"{f.name}={getattr(solver, f.name)!r}"
            for f in dataclasses.fields(solver)
            if not (f.name == "scheme" and solver.scheme == "euler")
        )
        return f"ImplicitStep({fields})"
    return type(solver).__name__
