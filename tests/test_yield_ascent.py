"""Yield ascent (`yield_ascent`, its loop `ascend`): on synthetic yields with a closed form (a net
"folds" iff its drawn values land in windows off-centre from the start), the ascent moves the
nominal values towards the windows and raises the yield to near its closed-form maximum, every
iterate's estimate covers the closed-form yield there; the stopping rules, bounds, the paired
comparison, and the errors before anything compiles. A slow test climbs the corner cube's yield
with contact from a film deposited more stressed than its hinges were drawn for."""

import json
import math

import numpy as np
import pytest
import xarray as xr
from scipy import optimize, stats

import origami_jax.fab_yield as ojy
from origami_jax.simulation import VERDICT_CODES, FoldVerdict

FOLDED = VERDICT_CODES[FoldVerdict.FOLDED]
MISFOLDED = VERDICT_CODES[FoldVerdict.MISFOLDED]
M = 2  # creases

# Windows the drawn values must land in ({name: (centre (m,), half-width (m,))}).
WINDOWS = {
    "misfit_strain": (np.array([1.10, 1.00]), np.array([0.08, 0.08])),
    "hinge_width": (np.array([9.0, 10.0]), np.array([1.0, 1.0])),
}
SCATTER = ojy.Scatter(
    **{
        **{n: ojy.Spread(width=0.0) for n in ojy.PARAMETERS},
        "misfit_strain": ojy.Spread("normal", 0.05),  # relative
        "hinge_width": ojy.Spread("normal", 0.5, relative=False),  # µm
    }
)
START = {n: np.ones(M) for n in ojy.PARAMETERS} | {
    "misfit_strain": np.array([1.0, 1.0]),
    "hinge_width": np.array([10.0, 10.0]),
    "release": np.zeros(M),
}


def _ascend(estimate_at, start, scatter, parameters, *args, **kwargs):
    """`ojy.ascend` with its `AscentSettings` given as keywords (`steps=`, `bounds=`, ...)."""
    call = {k: kwargs.pop(k) for k in ("n_samples", "seed") if k in kwargs}
    settings = ojy.AscentSettings(**kwargs)
    return ojy.ascend(estimate_at, start, scatter, parameters, *args, settings=settings, **call)


def _synthetic(scatter, windows):
    """An `estimate_at` for `ascend`: the draws `yield_estimate` would make (`standard_draws`,
    `sample_values`), a sample folded iff every windowed parameter's value of every crease lies in
    its window."""

    def estimate_at(nominal, seed, n, label):
        values = ojy.sample_values(scatter, nominal, ojy.standard_draws(seed, n, M))
        folded = np.ones(n, dtype=bool)
        for name, (centre, half) in windows.items():
            folded &= np.all(np.abs(values[name] - centre) < half, axis=1)
        k = int(folded.sum())
        return ojy.YieldEstimate(
            fraction=k / n,
            interval=ojy.wilson_interval(k, n),
            confidence=0.95,
            method="wilson",
            counts={"folded": k, "misfolded": n - k},
            n_samples=n,
            seed=seed,
            scatter=scatter,
            dataset=xr.Dataset({"verdict": ("design", np.where(folded, FOLDED, MISFOLDED))}),
            seconds_per_sample=0.0,
            nominal={k: np.array(v) for k, v in nominal.items()},
        )

    return estimate_at


def _window_probability(spread, mu, centre, half):
    """P(|x − centre| < half) for a draw x around `mu`, in closed form (normal or lognormal)."""
    lo, hi = centre - half, centre + half
    w = spread.width
    if spread.distribution == "lognormal":
        return stats.norm.cdf(np.log(hi / mu) / w) - stats.norm.cdf(np.log(lo / mu) / w)
    sigma = w * mu if spread.relative else w
    return stats.norm.cdf((hi - mu) / sigma) - stats.norm.cdf((lo - mu) / sigma)


def _closed_form(scatter, windows, nominal):
    """The yield: a product over parameters and creases (independent draws)."""
    y = 1.0
    for name, (centre, half) in windows.items():
        spread = getattr(scatter, name)
        if spread.per == "net":  # one draw z for every crease: P(z in the intersection)
            w, mu = spread.width, nominal[name]
            lo = np.max(np.log((centre - half) / mu) / w)
            hi = np.min(np.log((centre + half) / mu) / w)
            y *= max(0.0, stats.norm.cdf(hi) - stats.norm.cdf(lo))
        else:
            y *= float(np.prod(_window_probability(spread, nominal[name], centre, half)))
    return y


def _maximum(scatter, windows):
    """The closed-form maximum of the per-crease product: each factor maximised on its own."""
    best = 1.0
    for name, (centre, half) in windows.items():
        spread = getattr(scatter, name)
        for c, h in zip(centre, half, strict=True):
            res = optimize.minimize_scalar(
                lambda mu, c=c, h=h, s=spread: -_window_probability(s, mu, c, h),
                bounds=(c - h, c + h),
                method="bounded",
            )
            best *= -res.fun
    return best


@pytest.mark.parametrize("fresh_draws", [False, True])
def test_ascent_climbs_a_synthetic_yield_to_near_its_maximum(fresh_draws):
    """Two creases, a relative misfit-strain spread (stepped in ln μ) and an absolute hinge-width
    spread (stepped in µm), windows off-centre for crease 0 of each: from a closed-form yield of
    0.15 (maximum 0.69), 400 samples per iterate. Every iterate's 95 % Wilson interval covers the
    closed-form yield at its nominal values (a wrong `nominal` handed to the estimator, or an
    estimate of another point, misses it by far more than the interval); crease 0's two nominal
    values end nearer their windows than they started; the best iterate's closed-form yield is
    within 0.06 of the maximum (the stopping rule stops where the gradient is within 2 standard
    errors of 0: near the top, the yield changes by less than the noise of 400 samples, ±0.05)."""
    result = _ascend(
        _synthetic(SCATTER, WINDOWS),
        START,
        SCATTER,
        ["misfit_strain", "hinge_width"],
        n_samples=400,
        seed=1,
        steps=15,
        fresh_draws=fresh_draws,
        confirm_samples=2000,
    )
    truth = np.array(
        [
            _closed_form(SCATTER, WINDOWS, {**START, **it.nominal})
            for it in result.iterates  # the moved parameters' values at each iterate
        ]
    )
    top = _maximum(SCATTER, WINDOWS)
    assert truth[0] == pytest.approx(0.15, abs=0.01) and top == pytest.approx(0.69, abs=0.01)
    low, high = result.intervals.T
    assert np.all((low <= truth) & (truth <= high)), (result.summary(), truth)
    for name, (centre, _) in WINDOWS.items():
        path = result.path(name)
        assert abs(path[result.best, 0] - centre[0]) < 0.5 * abs(path[0, 0] - centre[0]), name
    assert truth[result.best] > top - 0.06, (result.summary(), truth, top)
    # The seeds: one for all (common random numbers) or one per iterate; the confirmation's fresh.
    seeds = [it.estimate.seed for it in result.iterates]
    assert seeds == ([1] * len(seeds) if not fresh_draws else list(range(1, 1 + len(seeds))))
    confirmation = result.confirmation
    assert confirmation.seed not in seeds and confirmation.n_samples == 2000
    truth_best = truth[result.best]
    assert confirmation.interval[0] <= truth_best <= confirmation.interval[1]
    assert "re-estimated on fresh draws" in result.summary()


def test_steps_halve_when_the_yield_falls_and_stay_in_the_trust_region():
    """The rule as documented: each step's largest move is `step` spread widths (ln μ / w for the
    relative spread, Δμ / w for the absolute one), halved after an iterate whose yield fell."""
    result = _ascend(
        _synthetic(SCATTER, WINDOWS), START, SCATTER, ["misfit_strain", "hinge_width"], 200, 3,
        steps=12, step=0.8,
    )  # fmt: skip
    its = result.iterates
    assert its[0].step == 0.8
    for k in range(1, len(its) - 1):
        fell = its[k].estimate.fraction < its[k - 1].estimate.fraction
        assert its[k].step == pytest.approx(its[k - 1].step / (2 if fell else 1))
    for a, b in zip(its[:-1], its[1:], strict=True):
        moves = np.concatenate(
            [
                np.log(b.nominal["misfit_strain"] / a.nominal["misfit_strain"]) / 0.05,
                (b.nominal["hinge_width"] - a.nominal["hinge_width"]) / 0.5,
            ]
        )
        assert np.max(np.abs(moves)) == pytest.approx(a.step, rel=1e-9)


def test_per_net_lognormal_and_release_times():
    """A film thickness drawn once per net (lognormal, stepped in ln μ along every crease together)
    and release times with an absolute normal spread (µs, per crease), both off their windows:
    the yield rises to within 0.06 of its closed-form maximum, the thickness stays uniform across
    the creases, and every interval covers the closed form."""
    scatter = ojy.Scatter(
        **{
            **{n: ojy.Spread(width=0.0) for n in ojy.PARAMETERS},
            "t_hinge": ojy.Spread("lognormal", 0.04, per="net"),
            "release": ojy.Spread("normal", 10.0, relative=False),
        }
    )
    windows = {
        "t_hinge": (np.array([0.11, 0.11]), np.array([0.008, 0.008])),
        "release": (np.array([60.0, 80.0]), np.array([15.0, 15.0])),
    }
    start = {**START, "t_hinge": np.array([0.1, 0.1]), "release": np.array([40.0, 80.0])}
    result = _ascend(
        _synthetic(scatter, windows), start, scatter, ("t_hinge", "release"), 400, 5, steps=15
    )
    truth = np.array(
        [_closed_form(scatter, windows, {**start, **it.nominal}) for it in result.iterates]
    )
    # The maximum: the thickness at the window's geometric centre (the lognormal's median there
    # puts the window symmetric in ln t), the release times at their windows' centres.
    top = _closed_form(
        scatter,
        windows,
        {"t_hinge": np.full(M, math.sqrt(0.102 * 0.118)), "release": windows["release"][0]},
    )
    assert truth[0] < top - 0.3, (truth[0], top)
    low, high = result.intervals.T
    assert np.all((low <= truth) & (truth <= high)), (result.summary(), truth)
    assert truth[result.best] > top - 0.06, (result.summary(), truth, top)
    path = result.path("t_hinge")
    assert np.allclose(path[:, 0], path[:, 1], rtol=1e-12)
    assert result.path("release").min() >= 0.0
    # A bound below the window holds the per-net thickness there, every crease alike.
    held = _ascend(
        _synthetic(scatter, windows), start, scatter, "t_hinge", 400, 5, steps=15,
        bounds={"t_hinge": (0.09, 0.105)},
    )  # fmt: skip
    path = held.path("t_hinge")
    assert np.all(path[:, 0] == path[:, 1]) and path[-1, 0] == pytest.approx(0.105)
    assert "blocked by the bounds" in held.stopped


def test_stops_where_the_samples_show_no_direction():
    """Every sample folds (windows far wider than the spread) or every sample fails: the
    estimator is exactly 0 with standard error 0, so the ascent stops at the start and says why."""
    wide = {n: (c, 100 * h) for n, (c, h) in WINDOWS.items()}
    result = _ascend(_synthetic(SCATTER, wide), START, SCATTER, "misfit_strain", 50, 0)
    assert len(result.iterates) == 1 and result.best == 0
    assert "every sample folded" in result.stopped
    narrow = {n: (c + 50 * h, h) for n, (c, h) in WINDOWS.items()}
    result = _ascend(_synthetic(SCATTER, narrow), START, SCATTER, "hinge_width", 50, 0)
    assert "every sample failed" in result.stopped and "widen" in result.stopped


def test_bounds_hold_the_ascent():
    """Crease 0's hinge-width window is centred on 9 µm; bounds at 9.6 µm stop it there."""
    result = _ascend(
        _synthetic(SCATTER, WINDOWS), START, SCATTER, "hinge_width", 400, 2, steps=10,
        bounds={"hinge_width": (9.6, 12.0)},
    )  # fmt: skip
    path = result.path("hinge_width")
    assert path.min() >= 9.6 and path[-1, 0] == pytest.approx(9.6)


def test_paired_comparison_counts_the_same_nets():
    """Gained and lost samples between two iterates on the same draws, and McNemar's exact p-value
    against the two-sided binomial tail computed here from its definition."""
    result = _ascend(
        _synthetic(SCATTER, WINDOWS), START, SCATTER, ["misfit_strain", "hinge_width"], 300, 4,
        steps=4,
    )  # fmt: skip
    f = [it.estimate.dataset["verdict"].values == FOLDED for it in result.iterates]
    paired = result.paired(0, len(f) - 1)
    gained, lost = int(np.sum(f[-1] & ~f[0])), int(np.sum(f[0] & ~f[-1]))
    assert (paired["gained"], paired["lost"]) == (gained, lost) and gained > lost
    n = gained + lost
    tail = sum(math.comb(n, i) for i in range(min(gained, lost) + 1)) / 2**n
    assert paired["p_value"] == pytest.approx(min(1.0, 2 * tail), rel=1e-9)
    assert "gained" in result.summary()
    data = result.to_dict()
    assert len(data["iterations"]) == len(result.iterates) and data["best_vs_start"] == paired
    fresh = _ascend(
        _synthetic(SCATTER, WINDOWS), START, SCATTER, "hinge_width", 400, 4, steps=1,
        fresh_draws=True,
    )  # fmt: skip
    with pytest.raises(ValueError, match="different draws"):
        fresh.paired(0, 1)


def test_ascent_figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from origami_jax.plotting.fab_yield import ascent_figure

    result = _ascend(
        _synthetic(SCATTER, WINDOWS), START, SCATTER, ["misfit_strain", "hinge_width"], 100, 0,
        steps=3,
    )  # fmt: skip
    fig = ascent_figure(result, title="synthetic")
    axes = fig.get_axes()
    assert len(axes) == 3  # the yield, then one panel per parameter
    x, y = axes[0].get_lines()[0].get_data()
    np.testing.assert_allclose(y, result.yields)
    plt.close(fig)


CALL = {"n_samples": 10, "seed": 0}


@pytest.mark.parametrize(
    "change, message",
    [
        ({"parameters": "stress"}, "unknown parameter 'stress'"),
        ({"parameters": "t_structural"}, "does not scatter"),
        ({"parameters": []}, "at least one parameter"),
        ({"parameters": ["hinge_width", "hinge_width"]}, "name one twice"),
        ({"step": 0.0}, "step .* must be finite and > 0"),
        ({"step": -1.0}, "step .* must be finite and > 0"),
        ({"step": float("nan")}, "step .* must be finite and > 0"),
        ({"steps": 0}, "steps .* integer >= 1"),
        ({"significance": -1.0}, "significance"),
        ({"bounds": {"hinge_width": (10.5, 12.0)}}, "not inside its bounds"),
        ({"bounds": {"hinge_width": (12.0, 10.0)}}, "low < high"),
        ({"bounds": {"misfit_strain": (0.5, 2.0)}}, "not moved"),
        ({"n_samples": 1}, "n_samples must be an integer >= 2"),
        ({"confirm_samples": 10, "confirm_seed": 0}, "confirm_seed 0"),
    ],
)
def test_ascend_refuses_bad_input_before_estimating(change, message):
    def never(*args):
        raise AssertionError("estimated before checking")

    call = {"parameters": "hinge_width", **CALL, **change}
    parameters = call.pop("parameters")
    with pytest.raises(ValueError, match=message):
        _ascend(never, START, SCATTER, parameters, **call)


def test_uniform_and_relative_release_spreads_are_refused():
    uniform = ojy.Scatter(release=ojy.Spread("uniform", 50.0, relative=False))
    with pytest.raises(ValueError, match="uniform spread, which has no score"):
        ojy.check_ascent(uniform, "release", START, steps=1, step=0.5, significance=2, bounds=None)
    relative = ojy.Scatter(release=ojy.Spread("normal", 0.1, relative=True))
    with pytest.raises(ValueError, match="relative = false"):
        ojy.check_ascent(relative, "release", START, steps=1, step=0.5, significance=2, bounds=None)


def test_yield_ascent_checks_before_compiling():
    """The public function on a real net: its errors come from the checks, before any kernel."""
    scatter = ojy.Scatter(misfit_strain=ojy.Spread("normal", 0.01))
    with pytest.raises(ValueError, match="unknown parameter 'stress'"):
        ojy.yield_ascent("corner_cube", "stress", scatter)
    with pytest.raises(ValueError, match="drag_coefficient does not scatter"):
        ojy.yield_ascent("corner_cube", "drag_coefficient", scatter)
    with pytest.raises(ValueError, match="not inside its bounds"):
        ojy.yield_ascent(
            "corner_cube", "misfit_strain", scatter, process={"misfit_strain": 0.02},
            settings=ojy.AscentSettings(bounds={"misfit_strain": (0.001, 0.01)}),
        )  # fmt: skip
    with pytest.raises(ValueError, match="cannot resume"):
        ojy.yield_ascent("corner_cube", "misfit_strain", scatter, run=ojy.RunOptions(resume=True))
    with pytest.raises(ValueError, match="takes a net"):
        ojy.yield_ascent("vertex_degree4", "misfit_strain", scatter)
    elsewhere = ojy.YieldEstimate(
        0.5, (0.2, 0.8), 0.95, "wilson", {}, 64, 7, scatter, None, 0.0, nominal=START
    )
    with pytest.raises(ValueError, match="first must be a yield estimate at the start"):
        ojy.yield_ascent("corner_cube", "misfit_strain", scatter, first=elsewhere)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--improve", "0"], "--improve must be between 1 and 1000"),
        (["--improve", "2", "--improve-step", "0"], "--improve-step must be a positive"),
        (["--improve", "2", "--improve-parameters", "release"], "release does not scatter"),
        (["--improve", "2", "--improve-parameters", "stress"], "unknown parameter 'stress'"),
        (["--improve-parameters", "misfit_strain"], "needs --improve STEPS"),
        (["--improve", "2", "--resume"], "cannot resume an ascent"),
        (["--process", "stress=0.01"], "--process expects NAME=VALUE with NAME one of"),
        (["--process", "release=1"], "--process expects NAME=VALUE"),
        (["--process", "misfit_strain=-0.01"], "misfit_strain must be finite and positive"),
        (["--process", "hinge_width=1,2,3"], "hinge_width must be a number or one per crease (2)"),
        (["--process", "t_structural=0.2,0.2"], "t_structural must be a number, got shape"),
        (["--process", "t_hinge=x"], "--process t_hinge expects comma-separated numbers"),
        (["--process", "t_hinge=0.1", "--process", "t_hinge=0.2"], "t_hinge is given twice"),
        (["--rtol", "0"], "--rtol must lie strictly between 0 and 1"),
    ],
)
def test_cli_improve_refuses_bad_flags_before_compiling(tmp_path, capsys, extra, message):
    from origami_jax.cli import main

    argv = ["yield", "corner_cube", "--samples", "4", "--out", str(tmp_path / "out"), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out" / "sweep.json").exists()


def test_cli_process_and_rtol_reach_the_estimate_and_the_ascent(tmp_path, capsys, monkeypatch):
    # The plumbing only (the estimate itself is replaced): --process values arrive as the nominal
    # process of the estimate and --rtol as its tolerance (and, through the same options, those of
    # --improve's start).
    import origami_jax.fab_yield as fab_yield
    from origami_jax.cli import main

    seen = {}

    def fake_estimate(pattern, scatter, n_samples, seed, **options):
        seen.update(options)
        raise RuntimeError("stop here")

    monkeypatch.setattr(fab_yield, "yield_estimate", fake_estimate)
    argv = ["yield", "corner_cube", "--samples", "4", "--out", str(tmp_path / "out")]
    argv += ["--process", "misfit_strain=0.0105", "--process", "hinge_width=2.5,3"]
    assert main(argv + ["--rtol", "1e-5"]) == 1
    assert "stop here" in capsys.readouterr().err
    assert seen["process"] == {"misfit_strain": 0.0105, "hinge_width": [2.5, 3.0]}
    assert seen["solve"].rtol == 1e-5 and seen["solve"].atol == pytest.approx(1e-7, rel=1e-12)


@pytest.mark.slow  # two or three estimates of 8 corner cubes with contact (~3-15 min)
def test_cli_improve_writes_the_iterations(tmp_path, capsys):
    """`origami-jax yield --improve`: at the design's film stress with 1 % scatter and seams within
    5 % every sample folds, so the ascent stops at its start, which is the estimate itself (not
    estimated again); result.json's improve holds it, the best's re-estimate and improve.png."""
    from origami_jax.cli import main

    config = tmp_path / "film.toml"
    config.write_text("defaults = false\n[misfit_strain]\nwidth = 0.01\n")
    out = tmp_path / "out"
    argv = ["yield", "corner_cube", "--samples", "8", "--seed", "2", "--scatter", str(config)]
    argv += ["--t-end", "600", "--chunk-size", "8", "--seam-tolerance", "0.05", "--no-progress"]
    argv += ["--improve", "2", "--out", str(out), "--no-fluid-inertia"]  # released at once
    assert main(argv) == 0, capsys.readouterr().err
    result = json.loads((out / "result.json").read_text())
    improve = result["improve"]
    assert improve["iterations"][0]["yield"] == result["yield"] == 1.0
    assert len(improve["iterations"]) == 1 and "every sample folded" in improve["stopped"]
    assert improve["confirmation"]["seed"] == 3 and improve["confirmation"]["n_samples"] == 8
    assert not (out / "improve" / "iterate-00").exists()
    assert (out / "improve" / "confirmation" / "sweep.nc").is_file()
    assert (out / "improve.png").stat().st_size > 1000


def _off() -> dict[str, ojy.Spread]:
    return {name: ojy.Spread(width=0.0) for name in ojy.PARAMETERS}


@pytest.mark.slow  # at most 5 estimates of 32 corner cubes with contact, and a re-estimate
def test_yield_ascent_raises_an_underfolding_corner_cubes_yield():
    """The corner cube with contact, its film's misfit strain scattered 1 % per crease around a
    process 3 % below the design's (the hinge lengths as drawn for the design, so the creases
    stop about 2.7° short and the seam between the flaps stays open by 6–19 µm; verdict: 3° per
    crease, seams within 5 % of the panel, 10 µm): the ascent over the process's misfit strain
    must raise the yield, significantly on the same nets (McNemar p < 0.01), move the film stress
    up towards the design's, and the best iterate re-estimated on fresh draws must beat the start
    beyond both intervals (its lower limit above the start's upper one). The start folds 5/32.

    An overfolding process is no test of the ascent since edge contact: the flaps stop on each
    other at the seam and fold (31/32 at 12 % above the design's strain), so the yield falls
    only on the underfolding side."""
    import jax

    from origami_jax.net import FOLD_KERNEL_SOLVE, load_net
    from origami_jax.simulation import VerdictTolerances
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    jax.config.update("jax_enable_x64", True)
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    scatter = ojy.Scatter(**{**_off(), "misfit_strain": ojy.Spread("normal", 0.01)})
    eps = float(design.misfit_strain)
    result = ojy.yield_ascent(
        # The paper's dynamics (released at once, no fluid inertia): 600 µs runs.
        load_net("corner_cube").with_model(added_mass=False, viscous=False),
        "misfit_strain",
        scatter,
        n_samples=32,
        seed=0,
        settings=ojy.AscentSettings(steps=4, step=1.0, confirm_samples=32),
        design=design,
        process={"misfit_strain": 0.97 * eps},
        tolerances=VerdictTolerances(seam=0.05),
        solve=FOLD_KERNEL_SOLVE.replace(t1=600.0, max_steps=20_000),
        run=ojy.RunOptions(chunk_size=8, progress=False),
    )
    print(result.summary())
    start = result.iterates[0].estimate
    paired = result.paired()
    assert start.counts["folded"] <= 8, result.summary()
    assert result.best > 0, result.summary()
    assert paired["gained"] > paired["lost"] and paired["p_value"] < 0.01, result.summary()
    assert result.confirmation.interval[0] > start.interval[1], result.summary()
    assert np.all(result.path("misfit_strain")[result.best] > 0.97 * eps)
