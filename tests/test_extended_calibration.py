"""Fig. 7 with plausible parameters (`calibrate_extended`) and the paper's model next to the extended
one (`compare_models`).

By default only what compiles nothing runs: the variants free nothing outside `PLAUSIBLE_RANGES`,
the literature device starts inside every bound, and the report's arithmetic (relative misses, the
met flag, the finding, JSON) on a stand-in fit. The fits themselves and the comparison compile
panel-tree simulations with forward-mode sensitivities (minutes on two cores): `-m slow`.
"""

import json
import math
import types

import numpy as np
import pytest

import origami_jax.design as ojd
from origami_jax.chain import Accordion
from origami_jax.design._extended_fit import _TARGET_LABELS, _finding, _variant_fit
from origami_jax.system import HingeDesign


def test_variants_free_only_plausible_parameters_and_start_inside():
    """Every variant frees properties of the device only (no `k_scale`/`b_scale`), each with a
    plausible range, and the literature device lies inside every range (the fit's first start)."""
    assert set(ojd.VARIANTS) == {"paper", "viscous", "added_mass", "arc", "all"}
    for variant in ojd.VARIANTS.values():
        assert set(variant.free) <= set(ojd.PLAUSIBLE_RANGES), variant.name
        assert not {"k_scale", "b_scale"} & set(variant.free)
        design = HingeDesign.literature(stiffness_model=variant.stiffness_model)
        space = ojd.parameter_space(design, variant.free, ojd.plausible_bounds(variant.free))
        x = np.asarray(space.read(design))
        assert np.all(x >= np.asarray(space.lower) * (1 - 1e-12)), variant.name
        assert np.all(x <= np.asarray(space.upper) * (1 + 1e-12)), variant.name


def test_fig7_targets_are_the_papers_four_numbers():
    targets = ojd.fig7_targets()
    assert targets.labels == list(_TARGET_LABELS[:3]) + [_TARGET_LABELS[3]] or set(
        targets.labels
    ) == set(_TARGET_LABELS)
    values = dict(zip(targets.labels, np.asarray(targets.target_values()), strict=True))
    assert values["rise_time[joint 2]"] == 101.0 and values["overshoot[joint 1]"] == 0.39


def test_unknown_variant_is_refused_before_compiling():
    with pytest.raises(ValueError, match="variants must be among"):
        ojd.calibrate_extended(["paper", "magic"])


def _stand_in_result(achieved, at_bound):
    """A `DesignResult`-shaped stand-in: four target rows, all fifteen metric labels, a sensitivity
    whose rows are their index (so the report's row selection can be checked)."""
    labels = [f"{k}[joint {j}]" for k in ojd.KINDS for j in (1, 2, 3)]
    targets = [
        types.SimpleNamespace(label=label, achieved=a, target=t)
        for label, a, t in zip(_TARGET_LABELS, achieved, (37.0, 101.0, 38.0, 0.39), strict=True)
    ]
    names = ("misfit_strain", "hinge_width")
    return types.SimpleNamespace(
        metric_labels=labels,
        targets=targets,
        sensitivity=np.arange(len(labels))[:, None] * np.ones((1, 2)),
        parameters=dict(zip(names, (2e-3, 200.0), strict=True)),
        names=names,
        lower=np.array([8.5e-4, 20.0]),
        upper=np.array([4.25e-3, 200.0]),
        at_bound=at_bound,
        hinge=HingeDesign.literature(stiffness_model="bilayer"),
        pattern=Accordion(3, hinges="arc", fluid="extended"),  # the flaps' size is the pattern's
        cost=0.5,
        result_message="",
        iterations=7,
        identifiability=types.SimpleNamespace(verdict="rank 2"),
    )


def test_report_arithmetic_and_finding():
    """Relative misses are (achieved − target)/target; met means all four within the tolerance; the
    sensitivity rows are the four numbers' rows; the finding names the closest variant and the
    parameters at a bound; everything is JSON."""
    near = _variant_fit(ojd.VARIANTS["arc"], _stand_in_result([37.3, 100.0, 38.1, 0.392], {}), 0.02)
    far = _variant_fit(
        ojd.VARIANTS["paper"],
        _stand_in_result([84.7, 20.0, 20.6, 0.80], {"hinge_width": "upper"}),
        0.02,
    )
    np.testing.assert_allclose(far.relative_error, [47.7 / 37, -81 / 101, -17.4 / 38, 0.41 / 0.39])
    assert near.met and not far.met
    assert math.isclose(far.worst, 47.7 / 37)
    rows = {label: i for i, label in enumerate(_stand_in_result([1] * 4, {}).metric_labels)}
    np.testing.assert_array_equal(far.sensitivity[:, 0], [rows[label] for label in _TARGET_LABELS])
    # The arc's far edge meets the base past π (docs/physics.md, "Panel contact"); points have none.
    assert 1.0 < near.tip_contact_angle_over_pi < 2.0 and far.tip_contact_angle_over_pi is None
    reached, text = _finding([far], 0.02)
    assert not reached and "hinge_width at its upper bound" in text and "'paper'" in text
    reached, text = _finding([far, near], 0.02)
    assert reached and "'arc'" in text
    report = ojd.ExtendedCalibration((far, near), 0.02, reached, text)
    json.dumps(report.to_dict())
    assert "paper" in report.table() and "Finding:" in report.summary()
    assert report.fit("arc") is near


# ---- the fits and the comparison (slow) -----------------------------------------------------------


@pytest.fixture(scope="module")
def calibration():
    # Two variants that bracket the rest: the paper's model and everything (few steps: the test
    # checks the report against the simulation, not the optimum; the paper job runs the full fit).
    return ojd.calibrate_extended(["paper", "all"], n_starts=2, max_steps=6)


@pytest.mark.slow
def test_every_fitted_parameter_stays_inside_its_plausible_range(calibration):
    for fit in calibration.fits:
        for name, value in fit.parameters.items():
            lower, upper = ojd.PLAUSIBLE_RANGES[name].lower, ojd.PLAUSIBLE_RANGES[name].upper
            assert lower <= value <= upper, (fit.variant.name, name, value)


@pytest.mark.slow
def test_reported_numbers_are_those_of_an_independent_simulation(calibration):
    """The four numbers of each fit against the fitted design simulated afresh with the package's
    default solver and tolerances (not the fit's Tsit5 at rtol 1e-8): 0.5 % (the metrics'
    interpolation between samples and the two solvers' errors)."""
    import origami_jax.simulation as sim
    from origami_jax.chain import accordion_system

    for fit in calibration.fits:
        v = fit.variant
        system = accordion_system(fit.result.hinge, 3, hinges=v.hinges, fluid=v.fluid)
        trajectory = sim.simulate(
            system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=2401)), t1=606.0
        )
        metrics = sim.response_metrics(trajectory)
        fresh = np.concatenate([np.asarray(metrics.rise_time), [metrics.overshoot[0] / 100]])
        np.testing.assert_allclose(fit.achieved, fresh, rtol=5e-3, err_msg=v.name)


@pytest.mark.slow
def test_sensitivity_matches_finite_differences(calibration):
    """∂(rise time of joint 1)/∂log(misfit strain) of the extended fit against a central difference
    of two fresh simulations (step 1e-3 in log): 2 % (the difference's truncation and solver noise
    over a step this size)."""
    import dataclasses

    import origami_jax.simulation as sim
    from origami_jax.chain import accordion_system

    fit = calibration.fit("all")
    column = list(fit.parameters).index("misfit_strain")
    h = 1e-3

    def rise(scale):
        hinge = dataclasses.replace(
            fit.result.hinge, misfit_strain=fit.result.hinge.misfit_strain * scale
        )
        system = accordion_system(hinge, 3, hinges="arc", fluid="extended")
        trajectory = sim.simulate(
            system,
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(n=1201), rtol=1e-10, atol=1e-12),
            t1=606.0,
        )
        return float(sim.response_metrics(trajectory).rise_time[0])

    central = (rise(math.exp(h)) - rise(math.exp(-h))) / (2 * h)
    np.testing.assert_allclose(fit.sensitivity[0, column], central, rtol=0.02)


@pytest.mark.slow
def test_comparison_shows_the_differences_its_reasons_give():
    """The reasons `compare_models` writes, checked on its runs: the extended fold is slower in air
    (softer bilayer spring, heavier and longer arc), joint 1 never passes flap 1's contact angle with
    the base, and in KOH the extended fold is slower still (the liquid's added inertia) but, unlike
    the paper's, not overdamped."""
    from origami_jax.chain import compare_models

    comparison = compare_models(["step_air", "step_koh"])
    for case in ("step_air", "step_koh"):
        paper_rise = np.asarray(comparison.paper[case][1].rise_time)
        extended_rise = np.asarray(comparison.extended[case][1].rise_time)
        assert extended_rise[0] > paper_rise[0], case
    trajectory = comparison.extended["step_air"][0]
    peak = float(np.max(np.abs(np.asarray(trajectory.theta[:, 0])))) / math.pi
    assert peak <= comparison.diagnostics["air"]["tip_contact_angle_over_pi"] + 0.01
    # The air run is long enough to reach the extended hinges' first peak (period ~2.6 ms): the
    # swing past π is stopped by contact at the contact angle, not cut off by the run's end.
    assert peak > 1.0
    # KOH: the paper model is overdamped (its drag grows with the liquid's density, its inertia
    # does not); the extended one, whose inertia grows with the density too, still overshoots.
    paper_koh = np.asarray(comparison.paper["step_koh"][1].overshoot)
    extended_koh = np.asarray(comparison.extended["step_koh"][1].overshoot)
    assert np.all(paper_koh < 2.0) and np.all(extended_koh > 5.0)
    assert len(comparison.reasons) >= 6
