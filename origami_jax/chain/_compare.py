"""The paper's accordion model next to the extended one: the same device, three runs, and the physical
reason for every difference (the paper job and `notebooks/paper_vs_extended.ipynb` show it).

- **The paper's model**: point hinges with ``k = w(E₁'t₁³ + E₂'t₂³)/(3l)``, quadratic drag
  ``b θ̇|θ̇|`` per hinge, flaps that pass through each other.
- **The extended model**: bending-arc hinges with their mass (`hinges="arc"`), the bonded bilayer's
  stiffness (`stiffness_model="bilayer"`), quadratic drag on every flap, the fluid's added inertia and
  viscous drag (`fluid="extended"`), and panel contact.

Runs (paper Figs. 7 and 10): the step in air, the step in the KOH bath and the paper's 0.1 s ramp in
the KOH bath, all from the literature design (`HingeDesign.literature()`), nothing fitted.
"""

import dataclasses
import math
import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from .. import simulation as sim
from ..net import strip_tree
from ..system import AIR, KOH_SOLUTION, MICRO, HingeDesign
from ._chain import flap_size
from ._extended import _panels, accordion_fluid_loads, eqx_replace, tip_contact_angle
from ._pattern import Accordion
from ._system import accordion_system, alternating_targets

CASES = ("step_air", "step_koh", "ramp_koh")
"""The runs `compare_models` makes: Fig. 7's step in air and in KOH, and the fast etch ramp in KOH."""
CASE_TITLES = {
    "step_air": "step in air (paper Fig. 7)",
    "step_koh": "step in the KOH bath",
    "ramp_koh": "0.1 s etch ramp in the KOH bath (paper Fig. 10)",
}
RUN_LENGTH_US = {"step_air": 5_000.0, "step_koh": 60_000.0}
"""Run lengths of the steps, µs: each covers the extended model's first peak and more. In air the
paper's hinges ring with periods of a few hundred µs, but the extended hinge 1 (arc strip and air
included) has a period of about 2.6 ms: a 600 µs run (Fig. 7's window) ends before it reaches its
target and would report no overshoot. In KOH the extended hinges, with the liquid's inertia, have
periods of 8–32 ms."""


@dataclasses.dataclass(frozen=True)
class ModelComparison:
    """Both models on every case.

    **Fields:** `cases` (names), `paper` and `extended` (``{case: (Trajectory, ResponseMetrics)}``),
    `diagnostics` (``{"air": …, "koh": …}`` from `accordion_diagnostics`), `reasons` (one sentence
    per difference, with its numbers), `seconds` (``{case: (paper, extended)}`` wall time, compile
    included).
    """

    cases: tuple[str, ...]
    paper: dict[str, Any]
    extended: dict[str, Any]
    diagnostics: dict[str, dict]
    reasons: list[str]
    seconds: dict[str, tuple[float, float]]

    def table(self) -> list[str]:
        """One line per case and model: rise times, overshoot, peak of joint 1 (over π)."""
        lines = []
        for case in self.cases:
            for label, runs in (("paper", self.paper), ("extended", self.extended)):
                trajectory, metrics = runs[case]
                peak = float(np.max(np.abs(np.asarray(trajectory.theta[:, 0])))) / math.pi
                rise = " / ".join(f"{float(v):.4g}" for v in np.asarray(metrics.rise_time))
                over = " / ".join(f"{float(v):.3g}" for v in np.asarray(metrics.overshoot))
                lines.append(
                    f"{CASE_TITLES[case]}, {label} model: rise {rise} µs, overshoot {over} %, "
                    f"joint 1 peaks at {peak:.3f} π"
                )
        return lines

    def to_dict(self) -> dict:
        out: dict[str, Any] = {"reasons": self.reasons, "diagnostics": self.diagnostics}
        for case in self.cases:
            out[case] = {
                label: {
                    **runs[case][1].as_dict(),
                    "peak_over_pi": (
                        np.max(np.abs(np.asarray(runs[case][0].theta)), axis=0) / math.pi
                    ).tolist(),
                    "seconds": self.seconds[case][i],
                }
                for i, (label, runs) in enumerate(
                    (("paper", self.paper), ("extended", self.extended))
                )
            }
        return out


def model_designs(fluid):
    """The literature device (`HingeDesign.literature()`) in `fluid` under both models.

    **Arguments:** `fluid`, a [`origami_jax.system.Fluid`][] (`AIR`, `KOH_SOLUTION`, ...).

    **Returns:** `(paper, extended, layout)`: the paper's design (its stiffness formula), the
    extended design (`stiffness_model="bilayer"`), and the extended model's
    [`origami_jax.chain.Accordion`][] layout for 3 flaps (arc hinges, `fluid="extended"`,
    contact). `accordion_system(paper, 3)` builds the paper's model, `layout(extended)` the
    extended one.
    """

    paper = HingeDesign.literature(fluid=fluid)
    extended = HingeDesign.literature(fluid=fluid, stiffness_model="bilayer")
    return paper, extended, Accordion(3, hinges="arc", fluid="extended", contact=True)


def periods(inertias, stiffness: float) -> list[float]:
    """Small-oscillation periods ``2π √(I/k)``, ms, of inertias (ng·µm²) on a spring (µN·µm/rad)."""
    return [2 * math.pi * math.sqrt(i / stiffness) * 1e-3 for i in inertias]


def _peaks_sentence(peaks: dict, case: str, where: str) -> str:
    """The runs' peaks of `case` (both models), as a sentence; empty when `case` was not run."""
    if case not in peaks:
        return ""
    paper, extended = peaks[case]
    return (
        f" The runs {where}: the paper model's joints peak at "
        f"{' / '.join(f'{p:.3f}' for p in paper)} π, the extended model's at "
        f"{' / '.join(f'{p:.3f}' for p in extended)} π."
    )


def _reasons(air: dict, koh: dict, lags: dict | None, peaks: dict) -> list[str]:
    k_paper, k_bilayer = air["stiffness_paper"], air["stiffness_bilayer"]
    inertia_paper = air["inertia_mid_fold_paper"][0]
    inertia_arc = air["inertia_mid_fold_arc"][0]
    air_fluid = air["inertia_mid_fold_arc_fluid"][0]
    koh_fluid = koh["inertia_mid_fold_arc_fluid"][0]
    period_ratio = math.sqrt((inertia_arc / k_bilayer) / (inertia_paper / k_paper))
    reasons = [
        f"Slower fold, every case: the hinge's spring. The bonded bilayer bends about its common "
        f"neutral axis, k = {k_bilayer:.0f} µN·µm/rad against the paper's "
        f"{k_paper:.0f} (each film counted about its own face, which overstates it).",
        f"Slower fold, every case: the hinge's length and mass. With the literature films the arc "
        f"is l = ρπ = {air['strip_length_um']:.0f} µm long (ρ = {air['radius_um']:.1f} µm), longer "
        "than the flap it carries, and weighs "
        f"{air['strip_mass_ng']:.0f} ng against "
        f"the flap's {air['flap_mass_ng']:.1f} ng; joint 1's inertia half-way is "
        f"{inertia_arc / inertia_paper:.1f}× the paper's point hinge's. With the softer spring the "
        f"period grows about {period_ratio:.1f}×.",
        f"Slower ringing in air, damped differently: joint 1's period half-way is about "
        f"{periods(air['inertia_mid_fold_arc_fluid'], k_bilayer)[0]:.1f} ms against the paper "
        f"model's {periods([inertia_paper], k_paper)[0]:.2f} ms, so in a run of a few ms the extended "
        "fold swings only a few times where the paper's swings dozens. The air moves with the flap (added inertia: joint 1's "
        f"inertia {air_fluid / inertia_arc:.2f}× the arc's without it) and drags on it viscously at "
        f"Reynolds numbers {' / '.join(f'{r:.2g}' for r in air['reynolds'])}, where the "
        f"hydrodynamic function's damping part is {' / '.join(f'{g:.2g}' for g in air['gamma_imag'])}: "
        "a linear damping that shrinks each swing by a fixed ratio, where the paper's quadratic drag "
        "vanishes at small rates, so its ringing decays like 1/t.",
        "No overshoot past the base: flap 1's far edge reaches the base at "
        f"{air['tip_contact_angle_over_pi']:.3f} π (the arc lifts the folded flap about 2ρ above "
        "it), so an arc hinge may swing up to that angle and no further (contact); with point "
        "hinges and no contact, as in the paper, any overshoot past π passes through the base."
        + _peaks_sentence(peaks, "step_air", "in air"),
        f"Much slower in KOH: the liquid's added inertia makes joint 1's inertia "
        f"{koh_fluid / inertia_arc:.0f}× the arc's alone (the flap's areal mass is hundreds of "
        "times below the liquid's), which the paper's model lacks; its viscous drag adds to the "
        "quadratic one." + _peaks_sentence(peaks, "step_koh", "in KOH"),
        "Overdamped in KOH in the paper's model only: its drag grows with the liquid's density "
        f"({koh['fluid_density'] / air['fluid_density']:.0f}× the air's) while its inertia stays the "
        "solid's, so the fold creeps to its target; in the extended model the liquid's inertia "
        "grows with its density as the drag does, so the hinges still swing past their targets.",
    ]
    if lags is not None:
        paper_lag, extended_lag = lags["paper"], lags["extended"]
        koh_periods = periods(koh["inertia_mid_fold_arc_fluid"], k_bilayer)
        reasons.append(
            f"The etch ramp: both models' torque is the computed torque of their own dynamics, so "
            f"both follow θ_des; the paper's lags it by at most {paper_lag:.2g} rad, the extended "
            f"one by {extended_lag:.2g} rad. The ramp takes 100 ms: about "
            f"{100 / periods([inertia_paper], k_paper)[0]:.0f} periods of the paper model's joint 1 "
            f"in air (and in KOH its drag leaves it overdamped), but only a few of the extended hinges' in KOH "
            f"({' / '.join(f'{p:.0f}' for p in koh_periods)} ms with the liquid's inertia), and "
            "the ramp's corners (start and end) carry no impulse, so the heavy hinges fall behind "
            "at the start and ring on after the end."
        )
    return reasons


def compare_models(
    cases=CASES,
    options: "sim.SolveOptions | None" = None,
    *,
    run_lengths: dict[str, float] | None = None,
) -> ModelComparison:
    """Simulate the literature accordion with the paper's and the extended model on `cases`
    (module docstring; each case a name from `CASES`).

    **Arguments:** `cases`; `options`, every run's
    [`origami_jax.simulation.SolveOptions`][] (default ``SolveOptions(saveat=SaveAt(n=4001),
    max_steps=400_000, throw=False)``; its `t1` must be `None`: each case has its own);
    `run_lengths` (µs, per step case; default `RUN_LENGTH_US`).

    **Returns:** a [`ModelComparison`][origami_jax.chain.ModelComparison].

    **Raises:** `ValueError` for an unknown case.

    Costs (two shared CPU cores): the extended model compiles in about a minute per input kind; the
    KOH ramp takes the longest to run.
    """

    unknown = [c for c in cases if c not in CASES]
    if unknown or not cases:
        raise ValueError(f"cases must be among {CASES}, got {list(cases)!r}.")
    if options is None:
        options = sim.SolveOptions(saveat=sim.SaveAt(n=4001), max_steps=400_000, throw=False)
    if options.t1 is not None:
        raise ValueError(
            "compare_models runs each case for its own time: give SolveOptions(t1=None)."
        )
    lengths = dict(RUN_LENGTH_US, **(run_lengths or {}))
    paper_runs, extended_runs, seconds, lags = {}, {}, {}, None
    for case in cases:
        fluid = AIR if case.endswith("air") else KOH_SOLUTION
        paper_design, extended_design, layout = model_designs(fluid)
        pair = []
        for design, build in (
            (paper_design, lambda d: accordion_system(d, 3)),
            (extended_design, layout),
        ):
            system = build(design)
            start = time.perf_counter()
            if case.startswith("step"):
                inputs, t1 = sim.Step(), lengths[case]
            else:
                inputs = sim.fast_ramp(
                    system.hinges.target, duration=MICRO.time(sim.FAST_RAMP_DURATION_SI)
                )
                t1 = 1.2 * float(inputs.duration(system))
            trajectory = sim.simulate(system, inputs, options, t1=t1)
            metrics = sim.response_metrics(trajectory)
            if case.startswith("ramp"):
                desired = jax.vmap(lambda t, s=system, r=inputs: r.desired(t, s)[0])(
                    trajectory.times
                )
                lags = dict(lags or {})
                lags["paper" if not pair else "extended"] = float(
                    jnp.max(jnp.abs(trajectory.theta - desired))
                )
            pair.append(((trajectory, metrics), time.perf_counter() - start))
        paper_runs[case], extended_runs[case] = pair[0][0], pair[1][0]
        seconds[case] = (pair[0][1], pair[1][1])
    peaks = {
        case: tuple(
            (np.max(np.abs(np.asarray(runs[case][0].theta)), axis=0) / math.pi).tolist()
            for runs in (paper_runs, extended_runs)
        )
        for case in cases
    }
    diagnostics = {
        "air": accordion_diagnostics(model_designs(AIR)[1]),
        "koh": accordion_diagnostics(model_designs(KOH_SOLUTION)[1]),
    }
    return ModelComparison(
        tuple(cases),
        paper_runs,
        extended_runs,
        diagnostics,
        _reasons(diagnostics["air"], diagnostics["koh"], lags, peaks),
        seconds,
    )


def plot_comparison(comparison: ModelComparison, path=None):
    """One panel per case: each joint's angle over π, the paper's model solid, the extended dashed.
    Returns the figure (saved to `path` when given)."""
    import matplotlib.pyplot as plt

    cases = comparison.cases
    fig, axes = plt.subplots(
        len(cases), 1, figsize=(9, 3.2 * len(cases)), constrained_layout=True, squeeze=False
    )
    colours = ("tab:blue", "tab:orange", "tab:green")
    for ax, case in zip(axes[:, 0], cases, strict=True):
        ramp = case.startswith("ramp")
        scale, unit = (1e-3, "ms") if ramp or case == "step_koh" else (1.0, "µs")
        for label, runs, style in (
            ("paper", comparison.paper, "-"),
            ("extended", comparison.extended, "--"),
        ):
            trajectory = runs[case][0]
            t = np.asarray(trajectory.times) * scale
            theta = np.asarray(trajectory.theta) / math.pi
            for j in range(theta.shape[1]):
                ax.plot(
                    t, theta[:, j], style, color=colours[j % 3], label=f"{label}, joint {j + 1}"
                )
        ax.set_title(CASE_TITLES[case])
        ax.set_xlabel(f"time ({unit})")
        ax.set_ylabel("θ / π")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(ncol=2, fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def accordion_diagnostics(
    design: HingeDesign,
    n: int = 3,
    *,
    flap_length: float | None = None,
    flap_width: float | None = None,
) -> dict:
    """Where the extended accordion differs from the paper's, in numbers (the paper job and
    `notebooks/paper_vs_extended.ipynb` print them). MICRO units (µm, µs, ng).

    **Arguments:** `design`, a [`origami_jax.system.HingeDesign`][] (its fluid sets the fluid
    terms; both stiffness formulas are evaluated whatever its `stiffness_model`); `n`, the number
    of flaps; `flap_length`, `flap_width`, their size (µm; default the paper's 200 µm, as
    `accordion_system`).

    **Returns:** a dict of host floats and lists of `n` floats (one per hinge):

    - `fluid` (name) and `fluid_density` (ng/µm³); `stiffness_paper` and `stiffness_bilayer` (µN·µm/rad, hinge 1): the paper's
      ``w(E₁'t₁³ + E₂'t₂³)/(3l)`` and the bonded bilayer's (docs/physics.md, "The hinge is a bending
      arc");
    - `radius_um` (ρ, µm), `strip_length_um` (``l = ρ |θ_target,1|``, µm), `strip_mass_ng` and
      `flap_mass_ng` (ng, hinge and flap 1);
    - `inertia_mid_fold_paper`, `inertia_mid_fold_arc`, `inertia_mid_fold_arc_fluid` (`n`,
      ng·µm²): the mass matrix's diagonal half-way to the target for point hinges, arc hinges with
      their strips, and arc hinges with the fluid's added inertia;
    - `fluid_frequency_rad_per_us`, `reynolds`, `gamma_real`, `gamma_imag` (`n` each): the
      frequency at which the fluid terms are evaluated, the Reynolds number and the real
      (inertia) and imaginary (damping) parts of Sader's hydrodynamic function, per flap;
    - `tip_contact_angle_over_pi`: the fold angle (over π) at which flap 1's far edge touches the
      base (`tip_contact_angle`).

    **Raises:** `ValueError` from the design's own checks (e.g. a non-positive thickness).
    """
    target = alternating_targets(n, design.theta_final)
    middle = 0.5 * target
    paper_design = eqx_replace(design, stiffness_model="paper")
    bilayer_design = eqx_replace(design, stiffness_model="bilayer")
    size = flap_size(design.units, flap_length, flap_width)
    point = accordion_system(paper_design, n, flap_length=size[0], flap_width=size[1])
    radius = float(design.radius())
    lengths = radius * np.abs(np.asarray(target))
    panels = _panels(design, size, n, jnp.asarray(lengths), None, True)
    arc = strip_tree(
        panels,
        areal_density=design.strip_areal_density(),
        width=design.hinge_width,
        thickness=design.t_structural + design.t_hinge,
    )
    stiffness = bilayer_design.stiffness(n)
    loads = accordion_fluid_loads(design, size, arc, stiffness, target)
    flap_mass = float(panels.masses[0])
    strip_mass = float(design.strip_areal_density() * jnp.mean(design.hinge_width)) * lengths[0]

    def diagonal(mechanism):
        return np.asarray(jnp.diagonal(mechanism.mass_matrix(middle))).tolist()

    return {
        "fluid": design.fluid.name,
        "fluid_density": float(design.fluid.density),
        "stiffness_paper": float(paper_design.stiffness(n)[0]),
        "stiffness_bilayer": float(stiffness[0]),
        "radius_um": radius,
        "strip_length_um": float(lengths[0]),
        "flap_mass_ng": flap_mass,
        "strip_mass_ng": strip_mass,
        "inertia_mid_fold_paper": diagonal(point.mechanism),
        "inertia_mid_fold_arc": diagonal(arc),
        "inertia_mid_fold_arc_fluid": diagonal(loads.mechanism),
        "fluid_frequency_rad_per_us": np.asarray(loads.frequency).tolist(),
        "reynolds": np.asarray(loads.reynolds).tolist(),
        "gamma_real": np.asarray(loads.gamma[0]).tolist(),
        "gamma_imag": np.asarray(loads.gamma[1]).tolist(),
        "tip_contact_angle_over_pi": tip_contact_angle(radius, float(lengths[0]), float(size[0]))
        / np.pi,
    }
