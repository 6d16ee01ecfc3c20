"""Paper part: the paper's model next to the extended one, and Fig. 7 with plausible parameters.

1. The literature device with both models (`origami_jax.chain.compare_models`): Fig. 7's step in
   air, the step in the KOH bath and the 0.1 s etch ramp in KOH, one figure, and the physical reason
   for every difference (docs/physics.md, "The hinge is a bending arc", "The fluid moves with the
   flap", "Panel contact").
2. `origami_jax.design.calibrate_extended`: each model variant (the paper's; with viscous drag; with
   added inertia; with arc hinges; with all) fitted to Fig. 7's four numbers with every freed
   property of the device inside its plausible range; a table, the JSON of every fit and its
   sensitivities, and the finding (docs/physics.md, "Calibrating the extended model").
"""

from pathlib import Path

from ._common import dumps_json, write_atomic

N_STARTS = 2
"""Starts per variant of the plausible calibration (each variant compiles its own fit; the physics
guide's table gives the settings of the run it reports)."""
MAX_STEPS = 16
"""Levenberg–Marquardt steps per start."""


def run(out: Path) -> list[str]:
    import matplotlib.pyplot as plt

    from origami_jax.chain import compare_models, plot_comparison
    from origami_jax.design import calibrate_extended

    out = Path(out)
    comparison = compare_models()
    figure = out / "paper_vs_extended.png"
    plot_comparison(comparison, path=figure)
    plt.close("all")
    write_atomic(out / "paper_vs_extended.json", dumps_json(comparison.to_dict()))
    lines = [
        "The literature device with the paper's model (point hinges, drag b θ̇|θ̇| per hinge, no "
        "contact) and the extended one (arc hinges with mass, bilayer stiffness, quadratic drag on "
        "every flap, added inertia, viscous drag, contact):",
        *comparison.table(),
        "Why they differ:",
        *(f"- {reason}" for reason in comparison.reasons),
        f"figure: {figure}",
    ]

    calibration = calibrate_extended(n_starts=N_STARTS, max_steps=MAX_STEPS)
    folder = out / "calibration"
    folder.mkdir(parents=True, exist_ok=True)
    write_atomic(folder / "extended_fig7.json", dumps_json(calibration.to_dict()))
    write_atomic(folder / "extended_fig7.txt", calibration.summary() + "\n")
    lines += [
        f"Fig. 7 with plausible parameters only ({N_STARTS} starts per variant, bounds from "
        "PLAUSIBLE_RANGES):",
        *calibration.table().splitlines(),
        f"finding: {calibration.finding}",
        f"report and JSON in {folder}",
    ]
    return lines
