"""Folding on until the panels settle (`fold_until_settled`, `Net.fold`, `origami-jax fold` without
`--t1`): a run whose panels still move at the end is continued from where it stopped, one segment at
a time (`join_trajectories`), until it settles or the cap."""

import dataclasses
import json

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax._limits import FOLD_SEGMENT, MAX_FOLD_SEGMENTS
from origami_jax.chain import accordion_system
from origami_jax.cli import build_parser, main
from origami_jax.net import load_net
from origami_jax.simulation import SaveAt, SolveOptions, fold_until_settled, join_trajectories
from origami_jax.system import BOLTZMANN, KOH_SOLUTION, Agitation, HingeDesign


def _segment(t0, t1, n, angle0, steps, result=sim.RESULTS.successful):
    times = jnp.linspace(t0, t1, n)
    theta = (angle0 + 0.01 * (times - t0))[:, None] * jnp.array([1.0, -1.0])
    zeros = jnp.zeros_like(theta)
    stats = {
        "num_steps": jnp.asarray(steps),
        "num_accepted_steps": jnp.asarray(steps - 1),
        "num_rejected_steps": jnp.asarray(1),
        "max_steps": jnp.asarray(500_000),
        "switch_time": jnp.asarray(jnp.inf),
    }
    return sim.Trajectory(
        times=times,
        theta=theta,
        theta_dot=zeros + 0.01,
        theta_ddot=zeros,
        tau=zeros,
        target=jnp.array([1.5, -1.5]),
        stats=stats,
        result=result,
    )


def test_joined_trajectory_is_one_run_without_the_repeated_sample():
    first = _segment(0.0, 100.0, 11, 0.0, 40)
    then = _segment(100.0, 200.0, 11, 1.0, 25, result=sim.RESULTS.max_steps_reached)
    joined = join_trajectories(first, then)
    assert joined.times.shape == (21,) and joined.theta.shape == (21, 2)
    np.testing.assert_array_equal(joined.times, np.linspace(0.0, 200.0, 21))
    assert np.all(np.diff(np.asarray(joined.times)) > 0)  # the shared sample once
    np.testing.assert_array_equal(joined.theta[:11], first.theta)
    np.testing.assert_array_equal(joined.theta[11:], then.theta[1:])
    assert int(joined.stats["num_steps"]) == 65
    assert int(joined.stats["num_accepted_steps"]) == 63
    assert int(joined.stats["num_rejected_steps"]) == 2
    assert joined.result == sim.RESULTS.max_steps_reached  # the later run's code
    assert not bool(joined.succeeded)
    assert joined.state is None  # runs in hinge angles keep no separate state
    # Runs that keep their mechanism's state (q, v) have it joined like the samples.
    with_state = [
        eqx.tree_at(lambda t: t.state, run, (run.theta * 2, run.theta_dot * 3), is_leaf=_none)
        for run in (first, then)
    ]
    q, v = join_trajectories(*with_state).state
    np.testing.assert_array_equal(q, joined.theta * 2)
    np.testing.assert_array_equal(v, joined.theta_dot * 3)


def _none(x):
    return x is None


def test_a_folded_run_still_moving_is_continued_until_it_rests():
    """A run `folded` at its last sample but not at rest (walls bouncing within the tolerances)
    is continued like an `unfinished` one; the first report that is folded and settled stops it.
    The judge here is the real one with its `settled` overridden for the first two segments."""
    system, real = _flap_in_koh()
    reports = []

    def judge(trajectory):
        report = real(trajectory)
        if len(reports) < 2:
            report = dataclasses.replace(report, verdict=sim.FoldVerdict.FOLDED, settled=False)
        reports.append(report)
        return report

    options = SolveOptions(saveat=SaveAt(n=101), throw=False)
    _, report, segments = fold_until_settled(system, sim.Step(), judge, options, segment=400.0)
    assert segments == 3 and report.verdict == "folded" and report.settled, report.summary()
    assert [r.settled for r in reports] == [False, False, True]


def test_joining_refuses_batches_and_mismatched_runs():
    first = _segment(0.0, 100.0, 11, 0.0, 40)
    with pytest.raises(ValueError, match="coordinates"):
        join_trajectories(first, eqx.tree_at(lambda t: t.theta, first, first.theta[:, :1]))
    batch = jax.tree.map(lambda x: jnp.stack([x, x]), first)
    with pytest.raises(ValueError, match="batches"):
        join_trajectories(batch, batch)


def _flap_in_koh():
    # One flap in the etch bath: overdamped, it creeps to its target and is folded at ~600 µs.
    system = accordion_system(HingeDesign.literature(fluid=KOH_SOLUTION), 1)
    return system, lambda trajectory: sim.assess(system, trajectory)


def test_a_run_folds_on_until_it_settles_and_is_one_run_continued():
    system, judge = _flap_in_koh()
    calls = []
    trajectory, report, segments = fold_until_settled(
        system,
        sim.Step(),
        judge,
        SolveOptions(saveat=SaveAt(n=101), throw=False),
        segment=100.0,
        on_continue=lambda end, next_end: calls.append((end, next_end)),
    )
    assert report.verdict == "folded" and 1 < segments < 8, report.summary()
    assert calls == [(100.0 * k, 100.0 * (k + 1)) for k in range(1, segments)]
    times = np.asarray(trajectory.times)
    assert times.shape == (100 * segments + 1,) and np.all(np.diff(times) > 0)
    assert times[-1] == pytest.approx(100.0 * segments)
    # The same folding as one run to the same end: each segment restarts the adaptive solver at
    # the last sample, so the two take different steps; both at rtol 1e-7 over a ~1.5 rad swing
    # make ~1e-7 rad each, 1e-5 leaves room for the error's growth over the run.
    # (101 samples, every `segments`-th of the joined run's: the segments' compiled solve.)
    whole = sim.simulate(
        system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=101), throw=False), t1=times[-1]
    )
    np.testing.assert_allclose(whole.times, times[::segments], rtol=1e-12)
    np.testing.assert_allclose(trajectory.theta[::segments], whole.theta, atol=1e-5)
    assert report.settled  # continued while folded but still creeping, until at rest
    assert sim.assess(system, whole).verdict == "folded"
    # Capped: the verdict says it was still moving.
    capped, report, segments = fold_until_settled(
        system,
        sim.Step(),
        judge,
        SolveOptions(saveat=SaveAt(n=101), throw=False),
        segment=100.0,
        max_segments=2,
    )
    assert (report.verdict, segments, float(capped.times[-1])) == ("unfinished", 2, 200.0)
    # `assess` pads a run to the next power of two of samples (one compiled verdict for runs of
    # nearby lengths); the verdict is the unpadded run's.
    unpadded = jax.jit(lambda t: sim.fold_outcome(system, t))
    for run in (trajectory, capped):
        assert sim.padded_sample_count(run.times.shape[0]) > run.times.shape[0]
        expected, report = unpadded(run), sim.assess(system, run)
        assert report.verdict == list(sim.FoldVerdict)[int(expected.code)]
        assert report.settled == bool(expected.settled)
        assert report.time_to_fold == (
            None if np.isinf(expected.time_to_fold) else float(expected.time_to_fold)
        )


def test_a_crease_still_moving_slowly_is_not_at_rest():
    """`settled` (and so `unfinished` against `misfolded`) on synthetic runs of one crease aimed at
    90°, 101 samples over 100 µs (tail: the last 10): each moves less than the tail bound (1.5°, half
    the 3° tolerance) over its tail, and only the drift tells them apart."""
    system, _ = _flap_in_koh()
    target = float(system.hinges.target[0])
    times = np.linspace(0.0, 100.0, 101)

    def judged(offset):
        angles = target + np.radians(offset)[:, None]
        held = _segment(0.0, 100.0, 101, 0.0, 10)
        run = eqx.tree_at(lambda t: t.theta, held, jnp.asarray(angles))
        report = sim.assess(system, run)
        return report.verdict, report.settled

    # Creeping towards the angle, 20° away, at 0.1°/µs (1° over the tail, the run's length 10°).
    assert judged(-30.0 + 0.1 * times) == ("unfinished", False)
    # An exponential approach still 20° away with a 300 µs time constant: ~0.6° over the tail, and
    # the geometric extrapolation of its drift gives the ~20° still to go.
    assert judged(-20.0 * np.exp(-(times - 100.0) / 300.0)) == ("unfinished", False)
    # At rest 20° short, ringing by 0.5° with a period of 7 samples: the tail turns, so its
    # amplitude alone decides: settled, and (no contact to explain it) misfolded.
    assert judged(-20.0 + 0.5 * np.sin(2 * np.pi * times / 7.0)) == ("misfolded", True)
    # The same approach with a 3 µs time constant has nothing left to go: at rest, misfolded.
    assert judged(-20.0 - 30.0 * np.exp(-times / 3.0)) == ("misfolded", True)
    # A run of two samples is its own tail (no drift to judge): at rest when it moved less than
    # the bound.
    two = _segment(0.0, 100.0, 2, target - 0.5, 10)
    report = sim.assess(system, eqx.tree_at(lambda t: t.theta, two, jnp.full((2, 1), target - 0.5)))
    assert (report.verdict, report.settled) == ("misfolded", True)
    # A crease that only starts to move (a weak hinge in the etch bath, 100 µs after release)
    # moved less than 1.5° over the tail of its first 100 µs (its last 10 samples): not at rest,
    # folded on.
    slow = accordion_system(HingeDesign.literature(fluid=KOH_SOLUTION, k_scale=0.1), 1)
    run, report, segments = fold_until_settled(
        slow,
        sim.Step(),
        lambda tr: sim.assess(slow, tr),
        SolveOptions(saveat=SaveAt(n=101), throw=False),
        segment=100.0,
        max_segments=2,
    )
    assert (report.verdict, segments) == ("unfinished", 2), report.summary()
    tail_motion = np.degrees(np.ptp(np.asarray(run.theta[91:101, 0])))
    assert tail_motion < 1.5  # the first segment's tail alone would have looked at rest


def test_an_agitated_crease_at_rest_is_settled_and_one_drifting_beyond_its_noise_is_not():
    """Under agitation a crease at rest wobbles by ``σ = sqrt(k_B T / k)`` (`thermal_wobble`): the
    tail bound grows by six wobbles, and a drift is seen in the tail's part means once they move
    one way by more than ``4 √2 σ``. Synthetic runs of the flap's crease, 301 samples over 100 µs
    (tail: the last 30, parts of 10), Gaussian noise (independent samples) of the wobble."""
    system, _ = _flap_in_koh()
    target = float(system.hinges.target[0])
    k_b = system.units.from_si(BOLTZMANN, length=2, time=-2, mass=1)  # pJ per kelvin
    times = np.linspace(0.0, 100.0, 301)
    unit_noise = np.random.default_rng(7).normal(0.0, 1.0, times.shape)

    def agitated(wobble_deg):
        temperature = float(system.hinges.stiffness[0]) * np.radians(wobble_deg) ** 2 / k_b
        return eqx.tree_at(
            lambda s: s.agitation, system, Agitation(temperature), is_leaf=lambda x: x is None
        )

    def judged(which, offset, wobble_deg):
        held = _segment(0.0, 100.0, 301, 0.0, 10)
        angles = target + np.radians(offset + wobble_deg * unit_noise)[:, None]
        report = sim.assess(which, eqx.tree_at(lambda t: t.theta, held, jnp.asarray(angles)))
        return report.verdict, report.settled

    np.testing.assert_allclose(sim.thermal_wobble(agitated(0.5)), [np.radians(0.5)], rtol=1e-12)
    assert sim.thermal_wobble(system) == 0.0
    # Wobbling by 0.5° at its angle, and at rest 20° short: the tail's spread (~2° between samples)
    # is over the noiseless bound (1.5°), so judged without the bath's noise neither is at rest
    # (the first would be folded on to the cap, the second is unfinished); with it, both are.
    assert np.ptp(0.5 * unit_noise[-30:]) > 1.5
    assert judged(system, 0.0, 0.5) == ("folded", False)
    assert judged(agitated(0.5), 0.0, 0.5) == ("folded", True)
    assert judged(system, -20.0, 0.5) == ("unfinished", False)
    assert judged(agitated(0.5), -20.0, 0.5) == ("misfolded", True)
    # Creeping at 0.15°/µs 20° short under a 0.1° wobble: 1.5° over the tail (within the widened
    # bound, 2.1°), but its part means move 1° one way (over 4 √2 σ = 0.57°): still moving. Slower,
    # at 0.05°/µs (0.33°), the drift is within what the noise could make: judged at rest.
    creeping = -20.0 + 0.15 * (times - 100.0)
    assert judged(agitated(0.1), creeping, 0.1) == ("unfinished", False)
    assert judged(agitated(0.1), creeping / 3 - 40 / 3, 0.1) == ("misfolded", True)


def test_a_run_too_short_or_a_crease_released_late_is_unfinished_not_misfolded():
    """Issue 50: a tiny end time, or a crease released near or after the end, was judged
    `misfolded` (and `settled`). Synthetic runs of one crease aimed at 90°, 101 samples."""
    system, _ = _flap_in_koh()

    def judged(system, t1, angles):
        held = _segment(0.0, t1, 101, 0.0, 10)
        run = eqx.tree_at(lambda t: t.theta, held, jnp.asarray(angles)[:, None])
        return sim.assess(system, run)

    # The first µs after release: the crease speeds up from flat, 0.001° by the end.
    times = np.linspace(0.0, 1.0, 101)
    report = judged(system, 1.0, np.radians(1e-3) * times**2)
    assert (report.verdict, report.settled) == ("unfinished", False), report.reason
    # At rest at 0 for the whole run, released after its end (3000 µs of a 1000 µs run) or in its
    # last tenth (950 µs): unfinished, and the reason names the crease and its release time.
    for release in (3000.0, 950.0):
        late = accordion_system(
            HingeDesign.literature(fluid=KOH_SOLUTION), 1, release_times=[release]
        )
        report = judged(late, 1000.0, np.zeros(101))
        assert (report.verdict, report.settled) == ("unfinished", False)
        assert f"crease 0 released at {release:g} µs" in report.reason
    # Released well before the tail and at rest short of its angle: misfolded, as before.
    early = accordion_system(HingeDesign.literature(fluid=KOH_SOLUTION), 1, release_times=[500.0])
    report = judged(early, 1000.0, np.full(101, 0.5))
    assert (report.verdict, report.settled) == ("misfolded", True)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (dict(segment=0.0), "segment"),
        (dict(segment=float("nan")), "segment"),
        (dict(segment=10.0, max_segments=0), "max_segments"),
        (dict(segment=10.0, options=SolveOptions(t1=5.0)), r"not SolveOptions\(t1=\)"),
    ],
)
def test_bad_continuations_are_refused_before_any_run(options, message):
    system, judge = _flap_in_koh()
    with pytest.raises(ValueError, match=message):
        fold_until_settled(system, sim.Step(), judge, **options)


def test_t1_is_optional_and_checked_when_given(capsys):
    args = build_parser().parse_args(["fold", "cube_net_01"])
    assert args.t1 is None and args.fluid == "koh"  # released devices fold in the etch bath
    assert FOLD_SEGMENT * MAX_FOLD_SEGMENTS >= 4000.0  # room for a net that rings in air
    assert main(["fold", "cube_net_01", "--t1", "-5", "--no-figures"]) == 2
    assert "--t1" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("param", "message"),
    [
        ("hinge_width=100,200", "2 values for 6 creases"),
        ("hinge_wdth=100", "not a hinge parameter"),
        ("hinge_width=1e,2", "one number per hinge"),
        ("hinge_width=nan", "finite"),
        ("hinge_width", "NAME=VALUE"),
        ("flap_length=150", "the flap size belongs to the accordion"),
    ],
)
def test_bad_hinge_parameters_are_refused_in_one_line(param, message, capsys):
    assert main(["fold", "vertex_degree6", "--param", param, "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--param", "hinge_width=100", "--param", "hinge_width=150"], "given twice"),
        (["--noise-seed", "5"], "--noise-seed seeds --agitation's random force"),
        (["--flat-creases", "hinge"], "--flat-creases hinge is for closed-loop patterns"),
        (["--no-rigid-check"], "--no-rigid-check is for closed-loop patterns"),
        (["--arc-layout", "drawn"], "it needs --hinges arc"),
        (["--targets", "90,90,400,90,90"], "within [-180, 180]"),
        (["--list"], "--list lists the shipped nets and takes no NET"),
    ],
)
def test_options_that_would_do_nothing_are_refused_in_one_line(argv, message, capsys, tmp_path):
    """An option that cannot act on this run (it belongs to closed loops, to arc hinges, to
    agitation) is refused, not dropped without a word; so is the same --param twice."""
    out = tmp_path / "out"
    assert main(["fold", "cube_net_01", *argv, "--no-figures", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--adhesion", "abc"], "--adhesion expects W[,RANGE[,LINE]]"),
        (["--adhesion", "0.05,1,2,3"], "up to 3 comma-separated numbers"),
        (["--adhesion", "-0.05"], "the work of adhesion W must be finite"),
        (["--adhesion", "0.05", "--no-contact"], "needs contact"),
        (["--adhesion", "0.05,0.4", "--no-contact"], "need the plate contact"),
        (["--friction", "0.3", "--contact", "sampled"], "need the plate contact"),
        (["--friction", "nan"], "--friction expects MU[,SLIP]"),
        (["--friction", "0.3,-1"], "the friction's SLIP must be finite"),
        (["--release-ramp", "-1"], "--release-ramp must be a time >= 0 µs"),
        (["--release-ramp", "inf"], "--release-ramp must be a time >= 0 µs"),
        (["--t1", "500"], "--t1 500 µs ends within the release ramp"),
        (["--agitation", "1e9"], "use --solver implicit-step"),
        (["--agitation", "1e9", "--solver", "implicit-bdf2", "--dt", "2.5"], "Euler steps"),
        (["--agitation", "0", "--solver", "implicit-step", "--dt", "2.5"], "temperature > 0 K"),
        (
            [
                "--agitation",
                "1e9",
                "--solver",
                "implicit-step",
                "--dt",
                "2.5",
                "--noise-seed",
                "-1",
            ],
            "--noise-seed must be a whole number >= 0",
        ),
        (
            ["--agitation", "1e9", "--solver", "implicit-step", "--dt", "2.5", "--fluid", "air"],
            "it needs --fluid koh",
        ),
        (
            ["--agitation", "1e9", "--solver", "implicit-step", "--dt", "2.5"]
            + ["--no-fluid-inertia"],
            "drop --no-fluid-inertia",
        ),
    ],
)
def test_bad_surface_physics_is_refused_in_one_line(argv, message, capsys, tmp_path):
    assert main(["fold", "cube_net_01", *argv, "--no-figures", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_surface_flags_become_the_patterns_options():
    # --adhesion W,,LINE: the range defaults to twice the contact's activation gap; SI in, the
    # design's units (MICRO: J/m² is 1, J/m is 1e6 µN) out; --friction MU: the default slip.
    import argparse

    from origami_jax.cli._common import DEFAULT_FRICTION_SLIP, surface_model

    net = load_net("cube_net_01")
    design = net.default_design()
    args = argparse.Namespace(adhesion="0.05,,2e-8", friction="0.3")
    options = surface_model(args, net, design)
    activation = float(net.system(design).contact.activation)
    assert float(options["adhesion"].work) == pytest.approx(0.05, rel=1e-12)
    assert float(options["adhesion"].range) == pytest.approx(2 * activation, rel=1e-12)
    assert float(options["adhesion"].line) == pytest.approx(0.02, rel=1e-12)
    assert float(options["friction"].coefficient) == 0.3
    assert float(options["friction"].slip) == pytest.approx(DEFAULT_FRICTION_SLIP, rel=1e-12)
    none = argparse.Namespace(adhesion=None, friction=None)
    assert surface_model(none, net, design) == {}


def test_a_hinge_parameter_given_per_crease_reaches_each_crease():
    # The hinge-width warning asks for one width per crease: --param takes them in crease order.
    from origami_jax.cli._fold import _design, _params
    from origami_jax.loops import load_pattern

    pattern = load_pattern("vertex_degree6")
    widths = [100.0, 200.0, 100.0, 100.0, 200.0, 100.0]
    params = _params(["hinge_width=" + ",".join(map(str, widths)), "k_scale=2"])
    assert params == {"hinge_width": widths, "k_scale": 2.0}
    design = _design(pattern, "koh", params)
    assert design.fluid.name == KOH_SOLUTION.name and float(design.k_scale) == 2.0
    np.testing.assert_array_equal(np.asarray(design.hinge_width), widths)
    stiffness = np.asarray(design.stiffness(6))
    # A bilayer hinge's stiffness is proportional to its width along the crease.
    np.testing.assert_allclose(stiffness / stiffness[0], np.asarray(widths) / widths[0], rtol=1e-12)


def test_without_a_hinge_width_each_hinge_is_at_most_its_crease():
    # The literature hinge is 200 µm wide; four creases of the degree-6 vertex are 141 µm long.
    # Without a width of the user's, each hinge is as wide as the narrower of the two (no warning:
    # pytest turns warnings into errors); a width given is taken as given.
    from origami_jax.cli._fold import _design
    from origami_jax.loops import load_pattern

    pattern = load_pattern("vertex_degree6")
    lengths = pattern.crease_lengths
    width = np.asarray(_design(pattern, "air", {}).hinge_width)
    np.testing.assert_allclose(width, np.minimum(lengths, 200.0), rtol=1e-15)
    assert np.sum(width < 200.0) == 4 and np.isclose(width.min(), 200 / np.sqrt(2), rtol=1e-12)
    assert float(_design(pattern, "air", {"hinge_width": 150.0}).hinge_width) == 150.0


@pytest.mark.slow  # compiles and folds a cube net with contact: about a minute on 2 cores
def test_a_cube_net_still_moving_at_the_first_segments_end_folds_on(tmp_path, capsys):
    # In the etch bath (the default fluid) with the paper's dynamics the cube net closes at
    # ~1,350 µs: the first 1,000 µs end with it still moving, the second segment finds it folded.
    argv = ["fold", "cube_net_01", "--no-fluid-inertia", "--no-figures", "--out", str(tmp_path)]
    code = main(argv)
    assert code == 0, capsys.readouterr().err
    assert "folding on to 2000" in capsys.readouterr().out
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["verdict"] == "folded" and result["segments"] == 2
    assert result["t1"] == pytest.approx(2 * FOLD_SEGMENT)
    assert 1000.0 < result["time_to_fold"] < 2000.0
    header = (tmp_path / "trajectory.csv").read_text().splitlines()[0]
    assert header.startswith("time [us],theta_0 [rad]") and "theta_4 [rad]" in header
    times = np.loadtxt(tmp_path / "trajectory.csv", delimiter=",", skiprows=1)[:, 0]
    assert times[-1] == pytest.approx(2 * FOLD_SEGMENT) and np.all(np.diff(times) > 0)


@pytest.mark.slow  # compiles and folds a cube net (without contact): ~30 s on 2 cores
def test_net_fold_runs_until_the_cube_closes_or_to_t1():
    net = load_net("cube_net_01")
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    # The paper's dynamics in the bath: released at once, the cube closes at ~1,350 µs.
    system = net.system(design, contact=False, added_mass=False, viscous=False)
    options = sim.SolveOptions(saveat=sim.SaveAt(n=101), throw=False)
    trajectory, report = net.fold(system, options=options)
    assert report.verdict == "folded", report.summary()
    assert float(trajectory.times[-1]) > 1000.0  # the first segment ended still moving
    short, report = net.fold(system, options=options, t1=500.0)
    assert report.verdict == "unfinished" and float(short.times[-1]) == 500.0


@pytest.mark.parametrize("name", ["cube_net_01", "corner_cube", "waterbomb_base"])
def test_result_names_each_crease_and_seam_in_the_fold_file(name):
    # result.json numbers creases and seams from 0 (as the verdict and --targets do) and says
    # which FOLD edges and faces they are: checked here against the file's own assignments and
    # faces, read without the package.
    from origami_jax.cli._fold import numbering
    from origami_jax.fold import catalogue_path
    from origami_jax.loops import load_pattern

    raw = json.loads(catalogue_path(name).read_text())
    assignment = raw["edges_assignment"]
    faces = [set(face) for face in raw["faces_vertices"]]
    where = numbering(load_pattern(name))
    creases = [e for edges in where["crease_edges"] for e in edges]
    assert sorted(creases) == [e for e, a in enumerate(assignment) if a in "MV"]
    for crease in where["crease_edges"]:  # a crease's edges lie between the same two faces
        sides = {
            tuple(i for i, f in enumerate(faces) if set(raw["edges_vertices"][e]) <= f)
            for e in crease
        }
        assert len(sides) == 1 and len(next(iter(sides))) == 2
    assert len(where["seam_faces"]) == len(where["seam_edges"])
    for pair, edges in zip(where["seam_faces"], where["seam_edges"], strict=True):
        assert pair[0] != pair[1]
        for face, edge in zip(pair, edges, strict=True):
            assert assignment[edge] in "BC" and set(raw["edges_vertices"][edge]) <= faces[face]
    if name == "cube_net_01":  # its 7 seams close the cube: 12 cube edges less 5 creases
        assert len(where["seam_faces"]) == 7


def test_a_pattern_refused_is_named_once_and_told_which_flag_to_give(capsys):
    # A unitless Origami Simulator export needs a length scale: the message names the CLI's flag.
    assert main(["fold", "origami_simulator_miura", "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "--length-scale" in err and len(err.strip().splitlines()) == 1
    # The square twist is refused by its own check, which names the pattern: named once.
    assert main(["fold", "square_twist", "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert err.count("square_twist:") == 1 and "not rigidly foldable" in err


def test_a_film_too_thick_to_close_the_net_is_warned_about(capsys):
    """Point creases turn panels about their mid-surfaces, so walls stop short by about t/L: a
    cube net of 2 µm squares in the literature's 200 nm film (t/L 5.7°) is warned about before
    it runs (it jams ~6-11° short), the catalogue's 200 µm one (0.06°) is not."""
    from origami_jax.cli._panels import warn_if_films_too_thick_to_close

    design = HingeDesign.literature()
    warn_if_films_too_thick_to_close(load_net("cube_net_01"), design, "cube_net_01", 3.0)
    assert capsys.readouterr().err == ""
    small = load_net("cube_net_01", length_scale=0.01)  # 2 µm squares
    warn_if_films_too_thick_to_close(small, design, "small", 3.0)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "10 % of the smallest panel (2 µm)" in err
    assert "within ~5.7°, more than the 3° tolerance" in err
    warn_if_films_too_thick_to_close(small, design, "small", 10.0)  # a looser tolerance
    assert capsys.readouterr().err == ""
