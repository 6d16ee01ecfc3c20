"""Folding order as a design variable: etch-front release times (against the host's
`release_times_from_front` and a closed form), scaled scatters, the search's checks, and (slow) a net
that jams under friction unless one crease goes first.

`examples/two_flaps.fold` (the release-time tests): a 300 × 200 µm base with a 200 µm square flap
on each short side, both folding 180° flat onto the base.

`examples/flap_under_flap.fold` (the order tests): the same base with a 280 µm flap A on its left
side folding 180° flat onto it and a 200 µm flap B on its right side folding to 120°, leaning over
A. B at its target stands in A's path (B's free edge is 264 µm from A's crease), so A must pass
before B gets there: with B up first, A's face comes down on B's free edge. Frictionless, A pushes
B's edge back and slides past it (the plates' exact contact), and the net folds in any order; with
friction at the bath's upper value (μ = 0.3) A stops there near 140°. A takes ~700 µs in KOH to pass
140°, B ~370 µs to reach its blocking range (above 115.5°)."""

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.fab_yield as ojy
from origami_jax.fab_yield import _order
from origami_jax.net import FOLD_KERNEL_SOLVE, load_net, release_times_from_front

TWO_FLAPS = str(Path(__file__).parents[1] / "examples" / "two_flaps.fold")
T_END = 1100.0  # µs: the second flap, released 150 µs after the first, has settled by ~900 µs
SPEED = 2.0  # µm/µs: the front crosses the 300 µm between the creases in 150 µs
FLAP_UNDER_FLAP = str(Path(__file__).parents[1] / "examples" / "flap_under_flap.fold")
ORDER_SPEED = 0.5  # µm/µs: A (crease at x = 0) 600 µs before B (x = 300 µm)
ORDER_T_END = 2300.0  # µs: B, released at 1160 µs by the front along +x, has settled by ~1900 µs


def _paper(path, friction=None):
    """The net of `path` with the paper's dynamics (no fluid inertia, released at once): release
    times hundreds of µs apart order the folds only when each hinge is released at once (a
    quasi-static release takes tens of ms). `friction`: a Coulomb coefficient at the contacts."""
    net = load_net(path).with_model(added_mass=False, viscous=False)
    if friction is None:
        return net
    from origami_jax.cli._common import DEFAULT_FRICTION_SLIP
    from origami_jax.contact import Friction

    return net.with_model(friction=Friction(friction, DEFAULT_FRICTION_SLIP))


def test_front_release_times_match_the_host_and_a_closed_form():
    """Crease 0 (the left flap, its crease on x = 0) and crease 1 (x = 300 µm); the pattern spans
    x in [-200, 500] µm, y in [0, 200] µm: a front along +x starts at x = -200 µm."""
    net = load_net(TWO_FLAPS)
    np.testing.assert_allclose(ojy.front_release_times(net, 0.0, SPEED), [100.0, 250.0])
    np.testing.assert_allclose(ojy.front_release_times(net, np.pi, SPEED), [250.0, 100.0])
    np.testing.assert_allclose(ojy.front_release_times(net, np.pi / 2, SPEED), [50.0, 50.0])
    cube = load_net("cube_net_01")
    for angle in (0.3, 2.0, 4.0):
        host = release_times_from_front(cube, (np.cos(angle), np.sin(angle)), 0.7)
        np.testing.assert_allclose(ojy.front_release_times(cube, angle, 0.7), host, atol=1e-9)


def test_front_release_times_are_differentiable():
    """d(times)/d(angle) and d(times)/d(speed) against central differences (exact up to rounding:
    the times are linear in the speed's inverse and smooth in the angle away from a tie of the
    pattern's first point; tolerance 1e-6 relative)."""
    net = load_net(TWO_FLAPS)
    angle, speed, h = 0.3, 0.7, 1e-6
    jac = jax.jit(jax.jacobian(lambda a, s: ojy.front_release_times(net, a, s), argnums=(0, 1)))(
        jnp.asarray(angle), jnp.asarray(speed)
    )
    d_angle = (
        ojy.front_release_times(net, angle + h, speed)
        - ojy.front_release_times(net, angle - h, speed)
    ) / (2 * h)
    d_speed = (
        ojy.front_release_times(net, angle, speed + h)
        - ojy.front_release_times(net, angle, speed - h)
    ) / (2 * h)
    np.testing.assert_allclose(jac[0], d_angle, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(jac[1], d_speed, rtol=1e-6, atol=1e-6)


def test_front_candidates():
    schedules = ojy.front_candidates(TWO_FLAPS, SPEED, 4)
    assert list(schedules) == ["simultaneous", "front 0°", "front 90°", "front 180°", "front 270°"]
    np.testing.assert_array_equal(schedules["simultaneous"], [0.0, 0.0])
    np.testing.assert_allclose(schedules["front 0°"], [100.0, 250.0])
    with pytest.raises(ValueError, match="speed must be positive"):
        ojy.front_candidates(TWO_FLAPS, 0.0)
    with pytest.raises(ValueError, match="n_directions"):
        ojy.front_candidates(TWO_FLAPS, SPEED, 0)


def test_scaled_scatter_keeps_the_draws():
    """Scaling a scatter multiplies every sample's deviation from nominal by the factor (normal and
    uniform spreads are linear in the width for the same standard draws)."""
    scatter = ojy.Scatter(release=ojy.Spread("uniform", 40.0, relative=False))
    nominal = {name: np.full(3, 1.0) for name in ojy.PARAMETERS}
    nominal["release"] = np.full(3, 100.0)  # large enough that no draw is shifted
    draws = ojy.standard_draws(3, 50, 3)
    base = ojy.sample_values(scatter, nominal, draws)
    double = ojy.sample_values(scatter.scaled(2.0), nominal, draws)
    for name in ojy.PARAMETERS:
        np.testing.assert_allclose(double[name] - nominal[name], 2 * (base[name] - nominal[name]))
    assert scatter.scaled(0.5).release.distribution == "uniform"
    for bad in (0.0, -1.0, float("inf"), "2"):
        with pytest.raises(ValueError, match="scale factor"):
            scatter.scaled(bad)


def test_bad_searches_are_refused_before_compiling():
    with pytest.raises(ValueError, match="non-empty mapping"):
        ojy.order_search(TWO_FLAPS, {})
    with pytest.raises(ValueError, match="schedule 'late' must be 2 finite release times >= 0"):
        ojy.order_search(TWO_FLAPS, {"ok": [0.0, 0.0], "late": [0.0, -5.0]})
    with pytest.raises(ValueError, match="schedule 'short' must be 2"):
        ojy.order_search(TWO_FLAPS, {"short": [0.0]})
    with pytest.raises(ValueError, match="as schedules"):
        ojy.order_search(TWO_FLAPS, {"a": [0.0, 0.0]}, release_times=[0.0, 1.0])
    with pytest.raises(ValueError, match="unknown scatter parameter"):
        ojy.order_search(TWO_FLAPS, {"a": [0.0, 0.0]}, {"stress": {"width": 0.1}})
    with pytest.raises(ValueError, match="same samples: give n_samples as a count"):
        ojy.order_search(TWO_FLAPS, {"a": [0.0, 0.0]}, n_samples=ojy.SampleUntil(0.1))


@pytest.mark.slow  # builds the surrogate (the net's contact tables and kernel: ~20 s here)
def test_soft_yield_takes_an_etch_front():
    solve = FOLD_KERNEL_SOLVE.replace(t1=T_END)
    surrogate = ojy.soft_yield(_paper(TWO_FLAPS), ojy.Scatter.none(), n_samples=1, solve=solve)
    assert "front_angle" in ojy.DESIGN_VARIABLES and "front_speed" in ojy.DESIGN_VARIABLES
    with pytest.raises(ValueError, match="both front_angle and front_speed"):
        surrogate({"front_angle": 0.0})
    with pytest.raises(ValueError, match="no release times"):
        surrogate({"front_angle": 0.0, "front_speed": 1.0, "release": np.zeros(2)})


def test_order_search_summary_and_best():
    """The search's bookkeeping on hand-made estimates (no simulation)."""

    class _Estimate:
        def __init__(self, fraction):
            self.fraction, self.interval, self.counts = fraction, (0.0, 1.0), {"folded": 1}

    search = _order.OrderSearch(
        schedules={"a": np.zeros(2), "b": np.ones(2)},
        estimates={"a": _Estimate(0.1), "b": _Estimate(0.9)},
        best="b",
    )
    assert "<- best" in search.summary().splitlines()[1]
    assert search.rows()[1] == {
        "schedule": "b",
        "release_us": [1.0, 1.0],
        "yield": 0.9,
        "interval": [0.0, 1.0],
        "counts": {"folded": 1},
    }


@pytest.mark.slow  # two compilations of the net, six simulations (~2 min)
def test_with_friction_b_first_jams_the_flap_and_a_first_folds_it():
    """Without scatter. Frictionless (the default), A's face comes down on B's free edge, pushes it
    back and slides past: every order folds (A flat, B at 120° over it), no plate through another.
    With friction μ = 0.3 (the top of the wet range) the same contact holds A: released with B
    first (the front along −x, B 600 µs before A) A stops near 140° on B's edge, B pushed back a
    little (below 120°); with A first (the front along +x) both fold, and the search picks it.
    Released together is a knife edge (A jams at μ 0.1 and 0.3, slips past at 0.2): not asserted."""
    schedules = {
        "front 0°": ojy.front_release_times(FLAP_UNDER_FLAP, 0.0, ORDER_SPEED),
        "front 180°": ojy.front_release_times(FLAP_UNDER_FLAP, np.pi, ORDER_SPEED),
    }
    options = dict(
        solve=FOLD_KERNEL_SOLVE.replace(t1=ORDER_T_END), run=ojy.RunOptions(progress=False)
    )
    smooth = ojy.order_search(_paper(FLAP_UNDER_FLAP), schedules, ojy.Scatter.none(), 1, **options)
    for estimate in smooth.estimates.values():
        assert estimate.counts["folded"] == 1, estimate.summary()
        assert float(estimate.dataset["penetration"].values[0]) == 0.0
    search = ojy.order_search(
        _paper(FLAP_UNDER_FLAP, friction=0.3), schedules, ojy.Scatter.none(), 1, **options
    )
    blocked, ordered = search.estimates["front 180°"], search.estimates["front 0°"]
    assert blocked.counts["jammed"] == 1, blocked.summary()
    assert ordered.counts["folded"] == 1, ordered.summary()
    assert search.best == "front 0°"
    final = np.degrees(blocked.dataset["final_angle"].values[0])
    assert 130.0 < final[0] < 150.0 and 110.0 < final[1] < 120.0, final
    assert int(blocked.dataset["engaged"].values[0]) > 0
    assert float(blocked.dataset["penetration"].values[0]) == 0.0
    final = np.degrees(ordered.dataset["final_angle"].values[0])
    np.testing.assert_allclose(final, [180.0, 120.0], atol=3.0)


def test_representative_samples_pick_a_typical_member_of_each_misfold_mode():
    """The sample nearest the median final angles of its verdict (no simulation: a hand-made
    dataset); folded samples and failed ones (NaN) are not picked."""
    import types

    import xarray as xr

    from origami_jax.plotting.fab_yield import representative_samples

    verdict = np.array([0, 2, 2, 2, 1, 4])
    angles = np.array([[3.1, 3.1], [1.0, 1.0], [1.1, 1.0], [3.0, 3.0], [2.0, 2.4], [np.nan] * 2])
    dataset = xr.Dataset(
        {"verdict": ("design", verdict), "final_angle": (("design", "crease"), angles)}
    )
    picks = representative_samples(types.SimpleNamespace(dataset=dataset))
    assert picks == {"misfolded": 2, "jammed": 4}


@pytest.mark.slow  # 24 contact simulations of the net, most of them jammed (~2 min)
def test_choosing_the_order_raises_the_yield():
    """Monte Carlo of three schedules on the same 8 fabricated nets (film stress 1 %, release
    times ±25 µs), friction μ = 0.3 at the contacts: released together, or B first (the front
    along −x), almost every net jams; with the front along +x (A first) every net folds, and the
    two 95 % Wilson intervals do not overlap. Measured: 1/8, 8/8 and 1/8 (7 jammed each). The lock
    is marginal, a tip on B's edge whose outcome is not monotone in the films or the friction
    (docs/physics.md, "A tip resting on an edge"), hence the margins below, not exact counts."""
    scatter = ojy.Scatter.from_mapping(
        {
            "defaults": False,
            "misfit_strain": {"width": 0.01},
            "release": {"distribution": "uniform", "width": 25.0, "relative": False},
        }
    )
    schedules = {
        "simultaneous": [0.0, 0.0],
        "front 0°": ojy.front_release_times(FLAP_UNDER_FLAP, 0.0, ORDER_SPEED),
        "front 180°": ojy.front_release_times(FLAP_UNDER_FLAP, np.pi, ORDER_SPEED),
    }
    search = ojy.order_search(
        _paper(FLAP_UNDER_FLAP, friction=0.3),
        schedules,
        scatter,
        8,
        seed=1,
        solve=FOLD_KERNEL_SOLVE.replace(t1=ORDER_T_END),
        run=ojy.RunOptions(chunk_size=8, progress=False),
    )
    ordered = search.estimates["front 0°"]
    assert search.best == "front 0°", search.summary()
    assert ordered.fraction >= 0.75, search.summary()
    for name in ("simultaneous", "front 180°"):
        other = search.estimates[name]
        assert other.fraction <= 0.25, search.summary()
        assert other.counts["jammed"] >= 6, search.summary()
        assert ordered.interval[0] > other.interval[1], search.summary()


def test_yield_cli_release_flags_are_checked_before_compiling(tmp_path, capsys):
    from origami_jax.cli import main

    for extra, message in (
        (["--release", "0"], "--release: 1 values for 2 creases"),
        (["--release", "0,x"], "--release expects comma-separated numbers"),
        (["--etch-front", "1,0"], "--etch-front expects DX,DY,SPEED"),
        (["--etch-front", "1,0,0"], "speed must be positive"),
        (["--release", "0,1", "--etch-front", "1,0,2"], "not both"),
    ):
        argv = ["yield", TWO_FLAPS, *extra, "--no-progress", "--out", str(tmp_path / "out")]
        assert main(argv) == 2, extra
        assert message in capsys.readouterr().err, extra
