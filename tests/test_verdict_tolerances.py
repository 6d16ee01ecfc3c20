"""The verdict's tolerances (`VerdictTolerances`): checked values, one-line errors before anything
compiles, and the seam tolerance applied as a fraction of the panel size.

The judged foldings are synthetic (a corner cube held at chosen angles, no simulation): the seam gap
the verdict compares is the traced seam function's, checked here against the host's rigid folding of
the flat pattern (`Net.seam_gaps`, an independent computation from the FOLD geometry)."""

import numpy as np
import pytest

import origami_jax.fab_yield as ojy
import origami_jax.simulation as sim
from origami_jax.net import load_net
from origami_jax.sweep import get_model
from origami_jax.system import KOH_SOLUTION, HingeDesign

from .trajectories import held_trajectory

NET = "corner_cube"


def _held(system, theta, result=None):
    return held_trajectory(system, theta, result)


def test_defaults_and_units():
    tolerances = sim.VerdictTolerances()
    assert tolerances == sim.DEFAULT_TOLERANCES
    assert tolerances.angle == pytest.approx(np.pi / 60)  # 3°
    # The default seam tolerance is derived from the angle tolerance and the geometry (it was the
    # fixed 0.01 of the panel size, still selectable and what stores without the setting mean).
    assert tolerances.seam is None and tolerances.to_dict()["seam_fraction"] == "derived"
    assert sim.VerdictTolerances.from_degrees() == tolerances
    fixed = sim.VerdictTolerances(seam=sim.LEGACY_SEAM_FRACTION)
    assert fixed.seam == 0.01 and fixed.seam_length(200.0) == pytest.approx(2.0)
    assert sim.VerdictTolerances.from_degrees(5.0, 0.05) == sim.VerdictTolerances(
        np.radians(5.0), 0.05
    )
    assert fixed.to_dict() == {"angle_deg": pytest.approx(3.0), "seam_fraction": 0.01}


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"angle": 0.0}, r"angle tolerance must lie in \(0, 3.142\)"),
        ({"angle": 4.0}, r"angle tolerance must lie in \(0, 3.142\)"),
        ({"angle": float("nan")}, "angle tolerance must lie"),
        ({"seam": -0.01}, r"seam tolerance must lie in \(0, 1\)"),
        ({"seam": 1.5}, r"seam tolerance must lie in \(0, 1\)"),
        ({"seam": "1 %"}, "seam tolerance must be a number"),
        ({"angle": True}, "angle tolerance must be a number"),
    ],
)
def test_bad_tolerances_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        sim.VerdictTolerances(**kwargs)


@pytest.fixture(scope="module")
def corner_cube():
    """The corner cube without contact, and its system (building it takes seconds here)."""
    net = load_net(NET)
    return net, net.system(HingeDesign.literature(fluid=KOH_SOLUTION), contact=False)


def test_bad_tolerances_are_refused_before_compiling(corner_cube):
    """Every entry point checks them before building or compiling anything (each call below would
    otherwise take seconds to minutes)."""
    with pytest.raises(ValueError, match="angle tolerance must lie in \\(0, 180\\) degrees"):
        ojy.yield_estimate(NET, n_samples=4, tolerances=sim.VerdictTolerances.from_degrees(-1.0))
    with pytest.raises(ValueError, match="tolerances must be a VerdictTolerances"):
        ojy.yield_estimate(NET, n_samples=4, tolerances=0.0)
    with pytest.raises(ValueError, match="tolerances must be a VerdictTolerances"):
        ojy.soft_yield(NET, tolerances={"seam": 2.0})
    with pytest.raises(ValueError, match="seam tolerance must lie"):
        get_model("net-fold", net=NET, seam_tolerance=-1.0)
    net, system = corner_cube
    trajectory = _held(system, net.intended_angles)
    with pytest.raises(ValueError, match="not both"):
        net.assess(system, trajectory, tolerances=sim.VerdictTolerances(), angle_tolerance=0.1)
    with pytest.raises(ValueError, match="tolerances must be a VerdictTolerances"):
        net.assess(system, trajectory, tolerances=0.05)


@pytest.mark.parametrize(
    "contact",
    # With contact the panel size is the contact model's (the same number); its verdict compiles
    # the contact report (~40 s here): a slow duplicate.
    [pytest.param(True, marks=pytest.mark.slow), False],
)
def test_the_seam_tolerance_is_a_fraction_of_the_panel_size(contact, corner_cube):
    """The corner cube held with one crease 1° short: within the 3° angle tolerance, but its seam
    opens by ~3.5 µm, more than the default 1 % of the 200 µm panels (2 µm): misfolded. A seam
    tolerance of 2 % (4 µm) makes it folded; the reports state the tolerances in length units."""
    net, system = corner_cube
    if contact:
        system = net.system(HingeDesign.literature(fluid=KOH_SOLUTION))
    angles = net.intended_angles - np.radians([0.0, 1.0])
    gap = float(net.seam_gaps(angles)[0])  # host geometry: the rigidly folded flat pattern
    # A crease off by δθ opens the seam along a panel of size L by about L δθ (small angles; the
    # seam's far corner is 200 µm from the crease): 3.49 µm, within 1 %.
    assert gap == pytest.approx(200.0 * np.radians(1.0), rel=0.01), gap
    assert net.panel_size(system) == pytest.approx(200.0)
    trajectory = _held(system, angles)
    # The fixed fraction given: the default is derived now (`test_a_derived_seam_tolerance_...`).
    fixed = sim.VerdictTolerances(seam=0.01)
    strict = net.assess(system, trajectory, tolerances=fixed)
    assert (
        strict.verdict == "misfolded" and strict.reason == "creases at their angles but seams open"
    )
    assert strict.seam_tolerance == pytest.approx(2.0)
    assert strict.seam_gaps[0] == pytest.approx(gap, rel=1e-9)
    # Printed with the system's units (MICRO: µm).
    assert (strict.length_unit, strict.time_unit) == ("µm", "µs")
    assert f"largest gap {gap:.3g} µm (tolerance 2 µm)" in strict.summary()
    loose = net.assess(system, trajectory, tolerances=sim.VerdictTolerances(seam=0.02))
    assert loose.verdict == "folded" and loose.seam_tolerance == pytest.approx(4.0)
    assert loose.angle_tolerance == pytest.approx(np.radians(3.0))
    # The traced verdict agrees.
    codes = sim.VERDICT_CODES
    assert (
        int(net.outcome(system, trajectory, tolerances=fixed).code)
        == codes[sim.FoldVerdict.MISFOLDED]
    )
    outcome = net.outcome(system, trajectory, tolerances=sim.VerdictTolerances(seam=0.02))
    assert int(outcome.code) == codes[sim.FoldVerdict.FOLDED]
    # A tighter angle tolerance (0.5°) fails the 1° crease whatever the seam tolerance.
    tight = sim.VerdictTolerances(angle=np.radians(0.5), seam=0.5)
    assert net.assess(system, trajectory, tolerances=tight).verdict == "misfolded"


def test_the_net_kernel_records_its_seam_tolerance_as_stores_did():
    """Stores written before the setting existed (the fixed 0.01, then the default) stay
    resumable: 0.01 is not in the kernel's settings, the derived default is (null), and
    `stored_tolerances` reads each back."""
    from origami_jax.net import stored_tolerances

    derived = get_model("net-fold", net=NET).settings
    assert derived["seam_tolerance"] is None
    assert get_model("net-fold", net=NET, seam_tolerance="derived").settings == derived
    legacy = get_model("net-fold", net=NET, seam_tolerance=0.01).settings
    assert "seam_tolerance" not in legacy
    assert get_model("net-fold", net=NET, seam_tolerance=0.05).settings["seam_tolerance"] == 0.05
    assert stored_tolerances(derived) == sim.VerdictTolerances()
    assert stored_tolerances(legacy) == sim.VerdictTolerances(seam=0.01)
    assert stored_tolerances({"angle_tolerance_deg": 5.0, "seam_tolerance": 0.05}) == (
        sim.VerdictTolerances.from_degrees(5.0, 0.05)
    )


def test_a_sweep_resumed_from_a_store_of_the_old_default_keeps_its_seam_tolerance(tmp_path):
    """`origami-jax sweep --resume` (`load_config(..., resume_from=)`) of a net-fold store whose
    settings name no seam tolerance (the fixed 0.01, the default when it was written), from a
    config that names none: the kernel keeps 0.01, so the settings match and the verdicts are
    judged as before; a store of the derived one, or a config that names a tolerance, is taken as
    it is."""
    import json

    from origami_jax.sweep import load_config

    path = tmp_path / "sweep.toml"
    path.write_text(
        f'[model]\nname = "net-fold"\nnet = "{NET}"\n'
        "[sweep]\nkind = 'grid'\n[parameters]\nmisfit_strain = { values = [0.0028, 0.0029] }\n"
    )
    out = tmp_path / "store"
    out.mkdir()
    fresh = load_config(path, resume_from=out).kernel.settings  # nothing stored: derived
    assert fresh["seam_tolerance"] is None
    legacy = {k: v for k, v in fresh.items() if k != "seam_tolerance"}
    (out / "sweep.json").write_text(json.dumps({"model": "net-fold", "settings": legacy}))
    assert load_config(path, resume_from=out).kernel.settings == legacy
    assert load_config(path).kernel.settings == fresh  # a new sweep: derived
    (out / "sweep.json").write_text(json.dumps({"model": "net-fold", "settings": fresh}))
    assert load_config(path, resume_from=out).kernel.settings == fresh
    path.write_text(path.read_text().replace("[sweep]", "seam_tolerance = 0.05\n[sweep]"))
    (out / "sweep.json").write_text(json.dumps({"model": "net-fold", "settings": legacy}))
    assert load_config(path, resume_from=out).kernel.settings["seam_tolerance"] == 0.05


def test_cli_tolerance_flags_are_checked_before_compiling(tmp_path, capsys):
    from origami_jax.cli import main

    for command, flag, value, message in (
        ("fold", "--seam-tolerance", "0", "--seam-tolerance must lie strictly between 0 and 1"),
        ("fold", "--tolerance", "200", "--tolerance must lie strictly between 0 and 180 degrees"),
        ("yield", "--angle-tolerance", "-3", "--angle-tolerance must lie strictly between 0 and"),
        ("yield", "--seam-tolerance", "nan", "--seam-tolerance must lie strictly between 0 and 1"),
    ):
        argv = [command, NET, flag, value, "--out", str(tmp_path / command)]
        assert main(argv) == 2, argv
        assert message in capsys.readouterr().err


def test_derived_seam_tolerances_match_the_host_geometry(corner_cube):
    """`derived_seam_tolerances` (traced seam gaps, `seam=None`) against the same formula evaluated
    with the host's rigid folding of the flat pattern (`Net.seam_gaps`, an independent computation
    from the FOLD geometry): each seam's gap at the intended angles plus the root-sum-square over
    creases of the larger gap change when that crease alone is off by the angle tolerance."""
    net, system = corner_cube
    alpha = sim.VerdictTolerances().angle
    intended = net.intended_angles
    base = net.seam_gaps(intended)
    spread = []
    for j in range(net.n_creases):
        step = np.zeros(net.n_creases)
        step[j] = alpha
        spread.append(
            np.maximum(
                np.abs(net.seam_gaps(intended + step) - base),
                np.abs(net.seam_gaps(intended - step) - base),
            )
        )
    expected = base + np.sqrt(np.sum(np.square(spread), axis=0))
    derived = np.asarray(
        sim.derived_seam_tolerances(net.seam_gap_function(system), intended, alpha)
    )
    np.testing.assert_allclose(derived, expected, rtol=1e-9)
    # A crease off by α opens a seam along a 200 µm panel by about 200 α (10.5 µm): the derived
    # tolerance is of that order, five times the default fraction's 2 µm.
    assert np.all(derived > 200.0 * alpha) and np.all(derived < 2 * 200.0 * alpha * np.sqrt(2))


def test_a_derived_seam_tolerance_judges_as_the_creases_do(corner_cube):
    """With `seam=None` the corner cube held with a crease 1° short (its seam 3.5 µm open) is
    folded where the default fraction (2 µm) calls it misfolded; 3.5° short it fails the angle
    tolerance either way. The traced verdict agrees, the report prints the per-seam tolerance, and
    the settings name it."""
    net, system = corner_cube
    derived = sim.VerdictTolerances(seam=None)
    assert derived.to_dict()["seam_fraction"] == "derived"
    assert derived.seam_equivalent_angle == derived.angle
    with pytest.raises(ValueError, match="derived per seam"):
        derived.seam_length(200.0)
    one = _held(system, net.intended_angles - np.radians([0.0, 1.0]))
    assert net.assess(system, one, tolerances=sim.VerdictTolerances(seam=0.01)).verdict == (
        "misfolded"
    )
    assert net.assess(system, one).verdict == "folded"  # derived: the default
    report = net.assess(system, one, tolerances=derived)
    assert report.verdict == "folded", report.summary()
    assert np.all(np.asarray(report.seam_tolerance) > report.seam_gaps)
    codes = sim.VERDICT_CODES
    assert int(net.outcome(system, one, tolerances=derived).code) == codes[sim.FoldVerdict.FOLDED]
    far = _held(system, net.intended_angles - np.radians([0.0, 3.5]))
    assert net.assess(system, far, tolerances=derived).verdict == "misfolded"


def test_the_cli_takes_a_derived_seam_tolerance():
    from origami_jax.cli._common import seam_tolerance_value

    assert seam_tolerance_value("derived") is None and seam_tolerance_value("0.02") == 0.02
    with pytest.raises(Exception, match="'derived'"):
        seam_tolerance_value("two percent")


def test_the_derived_seam_tolerance_of_a_corner_in_closed_form(corner_cube):
    """The corner cube's one seam joins two square flaps of side L = 200 µm folded up by 90° about
    two edges of the base that meet at a corner. At the intended angles the seam is closed (gap 0);
    a flap off by δ moves its far seam corner (at L from its crease) on a circle: a chord of
    2 L sin(δ/2), the seam's gap, and the near corner lies on both creases and does not move. Each
    crease alone, either way, gives that chord, so the derived tolerance is
    sqrt(2) · 2 L sin(α/2) (14.81 µm at 3°); to rounding (exact geometry, rtol 1e-9)."""
    net, system = corner_cube
    size = 200.0
    assert net.panel_size(system) == pytest.approx(size)
    for alpha in np.radians([1.0, 3.0, 6.0]):
        derived = np.asarray(
            sim.derived_seam_tolerances(net.seam_gap_function(system), net.intended_angles, alpha)
        )
        expected = np.sqrt(2.0) * 2 * size * np.sin(alpha / 2)
        np.testing.assert_allclose(derived, [expected], rtol=1e-9)


def test_the_margins_say_at_which_tolerances_a_state_folds(corner_cube):
    """The traced verdict's margins on the corner cube held with one crease 1° short: the angle
    margin is 1°/3° (the crease error over the angle tolerance), the seam margin the seam's gap
    over its tolerance: the chord 2 L sin(1°/2) = 3.49 µm over the derived 14.81 µm, or over the
    fixed 2 µm (1.745: folded only with the seam tolerance doubled). The verdict is folded exactly
    when both margins are below 1."""
    net, system = corner_cube
    size = 200.0
    held = _held(system, net.intended_angles - np.radians([0.0, 1.0]))
    chord = 2 * size * np.sin(np.radians(1.0) / 2)
    alpha = np.radians(3.0)
    derived_tolerance = np.sqrt(2.0) * 2 * size * np.sin(alpha / 2)
    folded = sim.VERDICT_CODES[sim.FoldVerdict.FOLDED]
    for tolerances, seam_tolerance in (
        (sim.VerdictTolerances(), derived_tolerance),
        (sim.VerdictTolerances(seam=0.01), 0.01 * size),
    ):
        outcome = net.outcome(system, held, tolerances=tolerances)
        assert float(outcome.angle_margin) == pytest.approx(1.0 / 3.0, rel=1e-9)
        assert float(outcome.seam_margin) == pytest.approx(chord / seam_tolerance, rel=1e-6)
        passes = float(outcome.angle_margin) < 1 and float(outcome.seam_margin) < 1
        assert (int(outcome.code) == folded) == passes
    assert float(outcome.seam_margin) == pytest.approx(1.745, abs=1e-3)


def test_a_large_patterns_report_is_taken_in_batches_of_samples(monkeypatch):
    """The verdict's per-sample contact report runs over the samples together (`vmap`) up to a
    memory budget, in batches past it (a 500-panel strip's thousand samples at once needed 36 GB):
    the same values either way."""
    import jax.numpy as jnp

    from origami_jax.simulation import _verdict

    def report(q):
        return {"min_gap": jnp.min(q) - 1.0, "touching": jnp.outer(q, q) > 0.5}

    states = jnp.linspace(0.0, 2.0, 21)[:, None] * jnp.arange(1.0, 4.0)
    together = _verdict._each_sample(report, states, size=1)
    monkeypatch.setattr(_verdict, "_REPORT_ELEMENTS", 4)  # batches of 4 samples, one short
    batched = _verdict._each_sample(report, states, size=1)
    for key in together:
        np.testing.assert_array_equal(np.asarray(batched[key]), np.asarray(together[key]))
    assert _verdict._report_size(None) == 0
