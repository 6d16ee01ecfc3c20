"""Yield under fabrication scatter: the interval's coverage, the scatter's draws and checks, the
estimate with zero scatter (a net that folds: 1; one aimed at 80°: 0), the fabricated hinges' fold
angles against the closed-form Timoshenko curvature, resume after an interruption, the CLI.

Every simulated case runs the smallest net of the catalogue, the corner cube (two creases, one
seam), for 600 µs in KOH with the paper's dynamics (its nominal folding is done by ~320 µs), in
chunks of 4 samples: the cases
share two compiled kernels (the persistent compilation cache of `conftest.py`)."""

import dataclasses
import functools
import json
import math

import jax
import numpy as np
import pytest
import xarray as xr
from scipy import stats

import origami_jax.fab_yield as ojy
from origami_jax.fab_yield._scatter import _resolved
from origami_jax.net import FOLD_KERNEL_SOLVE, load_net
from origami_jax.simulation import FoldVerdict, SaveAt, VerdictTolerances
from origami_jax.system import KOH_SOLUTION, HingeDesign

NET = "corner_cube"
# The estimate's machinery on the paper's dynamics (no fluid inertia, released at once): 600 µs
# runs. The bath's default dynamics: `tests/test_release_ramp.py`.
PATTERN = load_net(NET).with_model(added_mass=False, viscous=False)
T_END = 600.0  # µs
CHUNK = 4
SOLVE = FOLD_KERNEL_SOLVE.replace(t1=T_END)
RUN = {"solve": SOLVE, "run": ojy.RunOptions(chunk_size=CHUNK, progress=False)}


def _run(**changes):
    """`RUN`'s run options with `changes` (`out`, `resume`, `on_chunk`, `step_budget`)."""
    return {**RUN, "run": dataclasses.replace(RUN["run"], **changes)}


# The final angle of a crease that no contact holds against the Timoshenko ratio: what is left of
# the quadratic-drag ring-down at 600 µs (0.06° with the nominal films), well inside the verdict's 3°.
ANGLE_ATOL_DEG = 0.2


# ---- intervals ---------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["wilson", "clopper-pearson"])
def test_intervals_match_scipy_and_closed_forms(method):
    scipy_method = {"wilson": "wilson", "clopper-pearson": "exact"}[method]
    for k, n in [(0, 10), (3, 10), (10, 10), (17, 40), (1, 1), (250, 1000)]:
        for confidence in (0.9, 0.95, 0.99):
            ours = ojy.binomial_interval(k, n, confidence, method)
            theirs = stats.binomtest(k, n).proportion_ci(confidence, method=scipy_method)
            np.testing.assert_allclose(ours, (theirs.low, theirs.high), rtol=1e-10, atol=1e-12)
    # k = 0 in closed form: Wilson's upper end z²/(n + z²), Clopper-Pearson's 1 - (α/2)^(1/n).
    z = stats.norm.ppf(0.975)
    expected = z * z / (10 + z * z) if method == "wilson" else 1 - 0.025 ** (1 / 10)
    low, high = ojy.binomial_interval(0, 10, 0.95, method)
    assert low == 0.0 and high == pytest.approx(expected, rel=1e-12)


def _coverage(method: str, p: float, n: int, confidence: float) -> float:
    """Exact coverage: the binomial probability of the k whose interval holds p."""
    k = np.arange(n + 1)
    holds = [
        lo <= p <= hi
        for lo, hi in (ojy.binomial_interval(int(i), n, confidence, method) for i in k)
    ]
    return float(np.sum(stats.binom.pmf(k, n, p)[np.asarray(holds)]))


def test_intervals_cover_the_truth_at_their_rate():
    """A synthetic Bernoulli yield: (1) the exact coverage (sum over k of the binomial pmf) of
    Clopper-Pearson is at least the confidence at every p; Wilson's, averaged over p, is within 1.5
    points of it (Brown, Cai & DasGupta 2001 report it close to nominal); (2) 4000 seeded
    experiments per case reproduce the exact coverage within 4 binomial standard errors."""
    confidence = 0.95
    grid = np.linspace(0.02, 0.98, 49)
    for n in (10, 40, 200):
        clopper = [_coverage("clopper-pearson", p, n, confidence) for p in grid]
        assert min(clopper) >= confidence - 1e-12, (n, min(clopper))
        wilson = [_coverage("wilson", p, n, confidence) for p in grid]
        assert abs(np.mean(wilson) - confidence) < 0.015, (n, np.mean(wilson))
    rng = np.random.default_rng(11)
    trials = 4000
    for method in ("wilson", "clopper-pearson"):
        for p, n in [(0.9, 30), (0.5, 50), (0.97, 100)]:
            exact = _coverage(method, p, n, confidence)
            ks = rng.binomial(n, p, size=trials)
            table = {int(k): ojy.binomial_interval(int(k), n, confidence, method) for k in set(ks)}
            hits = np.mean([table[int(k)][0] <= p <= table[int(k)][1] for k in ks])
            sigma = math.sqrt(exact * (1 - exact) / trials)
            assert abs(hits - exact) < 4 * sigma, (method, p, n, hits, exact)


def test_interval_errors():
    with pytest.raises(ValueError, match="k .* from 0 to n"):
        ojy.wilson_interval(5, 4)
    with pytest.raises(ValueError, match="n .* >= 1"):
        ojy.clopper_pearson_interval(0, 0)
    with pytest.raises(ValueError, match="confidence"):
        ojy.wilson_interval(1, 4, 1.0)
    with pytest.raises(ValueError, match="method"):
        ojy.binomial_interval(1, 4, 0.95, "wald")


# ---- scatter -----------------------------------------------------------------------------------


def test_draws_follow_the_stated_distributions():
    """10⁵ draws: the sample mean and standard deviation of each distribution against its closed
    form, within 5 standard errors."""
    n, m = 100_000, 2
    nominal = {name: np.full(m, 2.0) for name in ojy.PARAMETERS}
    nominal["release"] = np.full(m, 50.0)
    scatter = ojy.Scatter(
        misfit_strain=ojy.Spread("normal", 0.05),
        t_hinge=ojy.Spread("lognormal", 0.1),
        hinge_width=ojy.Spread("uniform", 0.3, relative=False),
        t_structural=ojy.Spread("uniform", 0.1),
        drag_coefficient=ojy.Spread("normal", 0.2, relative=False),
        release=ojy.Spread("normal", 5.0),
    )
    values = ojy.sample_values(scatter, nominal, ojy.standard_draws(3, n, m))
    s2 = 0.1**2
    expected = {  # (mean, standard deviation)
        "misfit_strain": (2.0, 0.1),
        "t_hinge": (2.0 * math.exp(s2 / 2), 2.0 * math.sqrt((math.exp(s2) - 1) * math.exp(s2))),
        "hinge_width": (2.0, 0.3 / math.sqrt(3)),
        "t_structural": (2.0, 0.2 / math.sqrt(3)),
        "drag_coefficient": (2.0, 0.2),
        "release": (50.0, 5.0),
    }
    for name, (mean, sd) in expected.items():
        x = values[name][:, 1]
        assert abs(x.mean() - mean) < 5 * sd / math.sqrt(n), name
        assert abs(x.std() - sd) < 5 * sd / math.sqrt(2 * n), name
    # Per net: every crease of a sample shares its draw; per crease: independent.
    assert np.all(values["t_structural"][:, 0] == values["t_structural"][:, 1])
    assert abs(np.corrcoef(values["misfit_strain"].T)[0, 1]) < 0.02
    # Common random numbers: another width of one parameter leaves the others' draws alone.
    wider = ojy.sample_values(
        ojy.Scatter(
            **{
                **{n_: getattr(scatter, n_) for n_ in ojy.PARAMETERS},
                "misfit_strain": ojy.Spread("normal", 0.1),
            }
        ),
        nominal,
        ojy.standard_draws(3, n, m),
    )
    np.testing.assert_array_equal(wider["t_hinge"], values["t_hinge"])
    np.testing.assert_allclose(wider["misfit_strain"] - 2.0, 2 * (values["misfit_strain"] - 2.0))


def test_release_draws_are_shifted_to_start_at_zero():
    nominal = {name: np.ones(3) for name in ojy.PARAMETERS}
    nominal["release"] = np.zeros(3)
    scatter = ojy.Scatter(release=ojy.Spread("normal", 10.0))
    draws = ojy.standard_draws(0, 500, 3)
    release = ojy.sample_values(scatter, nominal, draws)["release"]
    unshifted = 10.0 * draws["release"]
    expected = unshifted - np.minimum(0.0, unshifted.min(axis=1, keepdims=True))
    np.testing.assert_allclose(release, expected, rtol=1e-15)
    assert release.min() == 0.0 and np.any(unshifted.min(axis=1) > 0)  # both kinds occur
    np.testing.assert_allclose(np.diff(release, axis=1), np.diff(unshifted, axis=1), atol=1e-12)


@pytest.mark.parametrize(
    ("config", "message"),
    [
        ({"misfit_strain": {"width": -0.05}}, "misfit_strain: width must be finite and >= 0"),
        ({"film_stress": {"width": 0.05}}, "unknown scatter parameter.*'film_stress'"),
        ({"t_hinge": {"width": 0.05, "sigma": 1}}, "t_hinge: unknown field.*'sigma'"),
        ({"t_hinge": {"distribution": "gauss"}}, "distribution must be one of"),
        ({"t_structural": {"width": 0.05, "per": "crease"}}, "one t_structural for the whole net"),
        ({"release": {"width": 5.0, "per": "net"}}, "only moves the time origin"),
        (
            {"hinge_width": {"distribution": "lognormal", "relative": False}},
            "lognormal .* relative",
        ),
        ({"misfit_strain": 0.05}, "must be a table"),
        ({"misfit_strain": {"width": "5%"}}, "width must be a number"),
    ],
)
def test_bad_scatter_configs_are_refused(config, message):
    with pytest.raises(ValueError, match=message):
        ojy.Scatter.from_mapping(config)


def test_bad_estimates_are_refused_before_compiling(tmp_path):
    with pytest.raises(ValueError, match="unknown scatter parameter"):
        ojy.yield_estimate(PATTERN, {"stress": {"width": 0.1}}, n_samples=4)
    with pytest.raises(ValueError, match="n_samples"):
        ojy.yield_estimate(PATTERN, ojy.Scatter(), n_samples=0)
    with pytest.raises(ValueError, match="relative width of nominal release times"):
        ojy.yield_estimate(PATTERN, ojy.Scatter(release=ojy.Spread("uniform", 0.2, relative=True)))
    with pytest.raises(ValueError, match="release_times must be 2"):
        ojy.yield_estimate(PATTERN, release_times=[0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="bias pre-folds closed-loop patterns only"):
        ojy.yield_estimate(PATTERN, bias=0.05)
    with pytest.raises(ValueError, match=r"bias must be a pre-fold angle in \[0, 1\) rad"):
        ojy.yield_estimate("vertex_degree4", bias=-0.1)
    with pytest.raises(ValueError, match="interval"):
        _estimate("none", 4).with_interval(0.95, "wald")
    for rtol in (0.0, 1.5):
        with pytest.raises(ValueError, match="rtol must be a number strictly between 0 and 1"):
            ojy.yield_estimate(PATTERN, solve=SOLVE.replace(rtol=rtol))
    for rtol in (True, "1e-5"):
        with pytest.raises(ValueError, match="take numbers"):
            ojy.yield_estimate(PATTERN, solve=SOLVE.replace(rtol=rtol))
    path = tmp_path / "scatter.toml"
    path.write_text("[misfit_strain]\nwidth = 0.05\nper = 'wafer'\n")
    with pytest.raises(ValueError, match="per must be 'crease' or 'net'"):
        ojy.load_scatter(path)
    path.write_text("defaults = false\n[misfit_strain]\nwidth = 0.05\n")
    scatter = ojy.load_scatter(path)
    assert scatter.active() == {"misfit_strain": _resolved("misfit_strain", ojy.Spread(width=0.05))}


def test_float32_is_refused_before_compiling():
    # In float32 a cube net's samples ran out of their 200,000 steps (minutes each) and came back
    # unfinished: refused at once instead.
    jax.config.update("jax_enable_x64", False)
    try:
        with pytest.raises(RuntimeError, match="yield_estimate needs float64"):
            ojy.yield_estimate(PATTERN, n_samples=2, **RUN)
    finally:
        jax.config.update("jax_enable_x64", True)


def test_rtol_reaches_the_solver(monkeypatch):
    # The plumbing only (the sweep is replaced): the tolerance is the kernel's, so a resumed
    # estimate checks it too; atol keeps the defaults' ratio to it.
    import origami_jax.fab_yield._estimate as estimate

    kernels = []

    def fake_sweep(kernel, *args, **kwargs):
        kernels.append(kernel)
        raise RuntimeError("stop here")

    monkeypatch.setattr(estimate, "sweep", fake_sweep)  # where the estimate reads it
    for rtol, expected in ((1e-5, (1e-5, 1e-7)), (None, (1e-7, 1e-9))):
        solve = SOLVE if rtol is None else SOLVE.replace(rtol=rtol, atol=1e-2 * rtol)
        with pytest.raises(RuntimeError, match="stop here"):
            ojy.yield_estimate(PATTERN, n_samples=2, **{**RUN, "solve": solve})
        settings = kernels[-1].settings
        assert (settings["rtol"], settings["atol"]) == pytest.approx(expected, rel=1e-12)


def test_each_engine_gets_its_own_kernel(monkeypatch):
    # The kernels are kept per process by their settings: an estimate with the fixed steps after
    # one with the adaptive default (the same everything else) must not get the adaptive kernel.
    import origami_jax.fab_yield._estimate as estimate
    from origami_jax.simulation import ImplicitStep

    kernels = []

    def fake_sweep(kernel, *args, **kwargs):
        kernels.append(kernel)
        raise RuntimeError("stop here")

    monkeypatch.setattr(estimate, "sweep", fake_sweep)
    for solver in (None, ImplicitStep(dt=2.5), ImplicitStep(dt=5.0)):
        with pytest.raises(RuntimeError, match="stop here"):
            ojy.yield_estimate(
                PATTERN, n_samples=2, **{**RUN, "solve": SOLVE.replace(solver=solver)}
            )
    solvers = [k.settings.get("solver") for k in kernels]
    assert solvers[0] is None and len(set(solvers)) == 3, solvers
    assert "dt=5.0" in solvers[2]


# ---- simulated estimates -----------------------------------------------------------------------


@functools.cache
def _estimate(scatter: str, n: int, targets_deg: float | None = None):
    scatters = {"none": ojy.Scatter.none(), "default": ojy.Scatter()}
    targets = None if targets_deg is None else np.radians([targets_deg, targets_deg])
    return ojy.yield_estimate(
        PATTERN, scatters[scatter], n_samples=n, seed=1, targets=targets, **RUN
    )


def test_zero_scatter_gives_yield_one_for_a_net_that_folds():
    estimate = _estimate("none", 4)
    assert estimate.fraction == 1.0 and estimate.counts["folded"] == 4, estimate.summary()
    low, high = estimate.interval
    assert high == 1.0 and low == pytest.approx(4 / (4 + stats.norm.ppf(0.975) ** 2))
    # Another interval of the same counts: statistics only, nothing simulated again.
    wider = estimate.with_interval(0.99, "clopper-pearson")
    assert wider.interval == ojy.binomial_interval(4, 4, 0.99, "clopper-pearson")
    assert (wider.confidence, wider.method, wider.counts) == (
        0.99,
        "clopper-pearson",
        estimate.counts,
    )
    assert estimate.seconds_per_sample > 0
    ds = estimate.dataset
    assert ds.sizes["design"] == 4 and "misfit_strain[1]" in ds.coords
    assert json.loads(ds.attrs["scatter"])["misfit_strain"]["width"] == 0.0
    # The seams the verdict judges by their gap: every seam, or fewer where panels touch.
    touching = ds["seams_touching"].values
    assert np.all(touching >= 0) and ds["max_open_seam_gap"].attrs["units"] == "um"
    open_gap, every_gap = ds["max_open_seam_gap"].values, ds["max_seam_gap"].values
    assert np.all(open_gap <= every_gap)
    np.testing.assert_array_equal(open_gap[touching == 0], every_gap[touching == 0])


@pytest.mark.slow  # a second kernel (the short run's) to compile
def test_samples_still_moving_at_the_end_are_judged_where_they_settle(tmp_path):
    # 200 µs is too short for the corner cube (it folds by ~320 µs): every sample is unfinished
    # there. Settled to 600 µs, each is run again from the start with the same sample spacing:
    # the same kernel and numbers as a 600 µs estimate, so the same final angles to rounding,
    # folded.
    short = SOLVE.replace(t1=T_END / 3, saveat=SaveAt(n=(SOLVE.saveat.n - 1) // 3 + 1))

    def estimate(t_settle, **changes):
        run = dataclasses.replace(RUN["run"], t_settle=t_settle, **changes)
        return ojy.yield_estimate(PATTERN, ojy.Scatter.none(), 4, 1, solve=short, run=run)

    at_end = estimate(None)
    assert at_end.counts["unfinished"] == 4 and at_end.to_dict()["continued"] == 0
    settled = estimate(T_END, out=tmp_path / "settle")
    assert settled.counts["folded"] == 4, settled.summary()
    assert settled.to_dict()["continued"] == 4 and settled.to_dict()["t_settle_us"] == T_END
    assert "4 still moving at the end, run on to 600 µs" in settled.summary()
    # The store's samples are the samples as judged (the settling pass merged in).
    on_disk = xr.load_dataset(tmp_path / "settle" / "sweep.nc")
    assert on_disk["verdict"].values.tolist() == [0] * 4 and on_disk.attrs["continued"] == 4
    direct = _estimate("none", 4).dataset
    for name in ("final_angle", "time_to_fold", "max_seam_gap", "num_steps"):
        np.testing.assert_allclose(
            settled.dataset[name].values, direct[name].values, rtol=1e-12, err_msg=name
        )
    # A settling time not past the end settles nothing; a bad one is refused before compiling.
    assert estimate(T_END / 3).counts == at_end.counts
    for bad in (0.0, -1.0, float("nan"), True, "8000"):
        with pytest.raises(ValueError, match="t_settle must be a positive end time"):
            ojy.yield_estimate(PATTERN, solve=SOLVE, run=ojy.RunOptions(t_settle=bad))


def test_samples_whose_working_set_missed_a_contact_are_reported():
    """The fixed-step engine's kernel outputs `contacts_left_out` (steps whose working set of
    contact pairs missed one within reach); the estimate counts the samples with any, in its
    summary and record. The adaptive solvers have no working set: nothing reported."""
    adaptive = _estimate("none", 4)
    assert adaptive.contacts_left_out is None
    assert "samples_with_contacts_left_out" not in adaptive.to_dict()
    steps = xr.DataArray(np.array([0, 2, 0, 1], dtype=np.int32), dims=("design",))
    fixed = dataclasses.replace(adaptive, dataset=adaptive.dataset.assign(contacts_left_out=steps))
    assert fixed.contacts_left_out == 2 and fixed.to_dict()["samples_with_contacts_left_out"] == 2
    assert "2 sample(s) had a contact outside the fixed-step engine's working set" in (
        fixed.summary()
    )


@pytest.mark.slow  # the fixed-step engine's kernel, twice (a working set of one pair is another)
def test_a_fixed_step_yield_counts_the_contacts_its_working_set_missed():
    from origami_jax.simulation import ImplicitStep

    def estimate(active_pairs):
        solver = ImplicitStep(dt=2.5, active_pairs=active_pairs)
        return ojy.yield_estimate(
            PATTERN, ojy.Scatter(), 4, seed=1, solve=SOLVE.replace(solver=solver), run=RUN["run"]
        )

    default = estimate(None)
    assert default.contacts_left_out == 0
    assert np.all(default.dataset["contacts_left_out"].values == 0)
    starved = estimate(1)  # one pair per step: the seam's other pairs come within reach unseen
    assert starved.contacts_left_out > 0, starved.summary()


def test_zero_scatter_gives_yield_zero_for_a_net_aimed_at_80_degrees():
    estimate = _estimate("none", 4, targets_deg=80.0)
    assert estimate.fraction == 0.0 and estimate.counts["misfolded"] == 4, estimate.summary()
    assert estimate.interval[0] == 0.0
    np.testing.assert_allclose(np.degrees(estimate.dataset["final_angle"]), 80.0, atol=0.2)


@pytest.mark.slow  # a closed-loop kernel to compile and 8 samples to fold: ~35 s
def test_a_closed_loop_pattern_folds_on_its_branch_or_is_misfolded_on_the_other():
    # A single degree-4 vertex (one closed loop), pre-folded 0.01 rad along its own angles: with
    # no scatter every sample folds to the pattern. Its hinges aimed at the mirror image (every
    # target negated) flip it onto the other branch, which the verdict judges against the
    # pattern: misfolded. One compiled kernel for both (the targets are data).
    from origami_jax.loops import load_pattern

    # The paper's dynamics (released at once, no fluid inertia), as the other cases here.
    pattern = load_pattern("vertex_degree4").with_model(added_mass=False, viscous=False)
    run = {**RUN, "n_samples": 4, "seed": 1, "bias": 0.01}
    folds = ojy.yield_estimate(pattern, ojy.Scatter.none(), **run)
    assert folds.counts["folded"] == 4, folds.summary()
    mirrored = ojy.yield_estimate(
        pattern, ojy.Scatter.none(), targets=-pattern.intended_angles, **run
    )
    assert mirrored.counts["misfolded"] == 4, mirrored.summary()
    final = np.asarray(mirrored.dataset["final_angle"].values)
    # At rest on the mirror branch, within the ring-down left at 600 µs.
    assert np.max(np.abs(final + pattern.intended_angles)) < np.radians(0.2)


def _timoshenko_curvature(e1, t1, e2, t2, strain):
    """Paper Eq. 7 (with the 2t₂² term), written out here independently of the package."""
    numerator = 6 * e1 * e2 * t1 * t2 * (t1 + t2) * strain
    denominator = (
        e1**2 * t1**4
        + e2**2 * t2**4
        + 2 * e1 * e2 * t1 * t2 * (2 * t1**2 + 3 * t1 * t2 + 2 * t2**2)
    )
    return numerator / denominator


def test_fabricated_hinges_fold_to_the_timoshenko_ratio():
    """With the default scatter, a crease whose drawn hinge underfolds comes to rest at its angle:
    the designed length over the drawn film's radius, 90° κ(drawn) / κ(nominal) (paper Eq. 7, here
    written out independently). One that overfolds reaches it or is stopped by the other panel."""
    estimate = _estimate("default", 8)
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    e1 = float(design.structural.biaxial_modulus)
    e2 = float(design.hinge.biaxial_modulus)
    kappa0 = _timoshenko_curvature(
        e1, float(design.t_structural), e2, float(design.t_hinge), float(design.misfit_strain)
    )
    kappa = _timoshenko_curvature(
        e1,
        estimate.samples("t_structural")[:, None],
        e2,
        estimate.samples("t_hinge"),
        estimate.samples("misfit_strain"),
    )
    free_angle = 90.0 * kappa / kappa0
    ds = estimate.dataset
    final = np.degrees(ds["final_angle"].values)
    # A hinge that underfolds swings its panel away from the others: nothing stops it.
    under = free_angle < 90.0
    assert under.sum() >= 4
    np.testing.assert_allclose(final[under], free_angle[under], atol=ANGLE_ATOL_DEG)
    # One that overfolds leans towards its neighbour: it reaches its angle, or the neighbour's
    # rim stops it on the way (at the closed seam, ~90°), or the neighbour got inside first and
    # holds it out: the inner flap's rim rests on its inner face, the rim point nearest the seam's
    # corner (50 µm up the seam) ĝ + t off it, which turns it out by about (ĝ + t)/50 µm = 1.4°.
    over = ~under
    assert np.all(final[over] < free_angle[over] + ANGLE_ATOL_DEG)
    reached = np.abs(final - free_angle) < ANGLE_ATOL_DEG
    held = over & ~reached
    assert held.sum() >= 1
    at_seam = np.abs(final - 90.0) < 0.5
    partner_inside = (reached & over)[:, ::-1]  # two creases: the other flap at its angle, past 90°
    held_out = (final > 90.0 - 1.5) & (final < 90.0) & partner_inside
    assert np.all((at_seam | held_out)[held])
    # The verdicts agree with the angles: a crease more than 3° off cannot be folded.
    off = np.any(np.abs(final - 90.0) > 3.0, axis=1)
    assert not np.any(ds["folded"].values[off])
    assert sum(estimate.counts.values()) == 8


def test_a_sample_folds_again_alone_with_its_whole_trajectory():
    """`sample_fold` folds one sample of an estimate again on its own: its system carries the
    sample's drawn films (each hinge aimed at 90° κ(drawn) / κ(nominal), the Timoshenko ratio
    written out here), its trajectory runs the estimate's solve to its end, and it comes to rest
    where the stored sample did (the same simulation compiled alone, not in a chunk: the adaptive
    solve's tolerance apart) with the stored verdict."""
    estimate = _estimate("default", 8)
    ds = estimate.dataset
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    e1, e2 = float(design.structural.biaxial_modulus), float(design.hinge.biaxial_modulus)
    kappa0 = _timoshenko_curvature(
        e1, float(design.t_structural), e2, float(design.t_hinge), float(design.misfit_strain)
    )
    for index in (1, -1):
        sample = estimate.sample_fold(index)
        row = index % 8
        kappa = _timoshenko_curvature(
            e1,
            estimate.samples("t_structural")[row],
            e2,
            estimate.samples("t_hinge")[row],
            estimate.samples("misfit_strain")[row],
        )
        np.testing.assert_allclose(sample.system.hinges.target, np.pi / 2 * kappa / kappa0)
        times = np.asarray(sample.trajectory.times)
        assert times.shape == (SOLVE.saveat.n,) and times[-1] == pytest.approx(T_END)
        np.testing.assert_allclose(
            sample.trajectory.theta[-1], ds["final_angle"].values[row], atol=1e-4
        )
        stored = list(FoldVerdict)[int(ds["verdict"].values[row])]
        assert sample.verdict == str(stored) and sample.report.verdict == stored
    for bad in (8, -9, 1.0, True):
        with pytest.raises(ValueError, match=r"index must be a sample number in \[0, 8\)"):
            estimate.sample_fold(bad)


@pytest.mark.slow
def test_a_sample_run_on_to_settle_is_folded_again_to_where_it_settled():
    # As in the settling test above: every sample is still moving at 200 µs and run on to 600.
    short = SOLVE.replace(t1=T_END / 3, saveat=SaveAt(n=(SOLVE.saveat.n - 1) // 3 + 1))
    run = dataclasses.replace(RUN["run"], t_settle=T_END)
    settled = ojy.yield_estimate(PATTERN, ojy.Scatter.none(), 2, 1, solve=short, run=run)
    sample = settled.sample_fold(0)
    times = np.asarray(sample.trajectory.times)
    assert times.shape == (SOLVE.saveat.n,) and times[-1] == pytest.approx(T_END)
    assert sample.verdict == "folded" and sample.report.verdict == FoldVerdict.FOLDED
    np.testing.assert_allclose(
        sample.trajectory.theta[-1], settled.dataset["final_angle"].values[0], atol=1e-4
    )


class _Stop(Exception):
    pass


def test_resume_after_an_interruption_gives_the_same_samples(tmp_path):
    reference = _estimate("default", 8).dataset
    out = tmp_path / "estimate"

    def stop(done, total):
        raise _Stop

    with pytest.raises(_Stop):
        ojy.yield_estimate(PATTERN, ojy.Scatter(), 8, 1, **_run(out=out, on_chunk=stop))
    assert len(list((out / "chunks").glob("part-*.nc"))) == 1
    with pytest.raises(FileExistsError, match="resume=True"):  # checked before compiling
        ojy.yield_estimate(PATTERN, ojy.Scatter(), 8, 1, **_run(out=out))
    resumed = ojy.yield_estimate(PATTERN, ojy.Scatter(), 8, 1, **_run(out=out, resume=True))
    assert resumed.seconds_per_sample > 0
    ds = resumed.dataset
    for name in reference.coords:
        np.testing.assert_array_equal(ds[name].values, reference[name].values, err_msg=name)
    for name in ("verdict", "final_angle", "num_steps"):
        np.testing.assert_allclose(ds[name].values, reference[name].values, rtol=1e-12)
    assert resumed.counts == _estimate("default", 8).counts


def test_the_yield_at_other_tolerances_is_a_count_of_the_stored_margins():
    """Every sample's verdict recomputed from its margins at factor 1 is its stored verdict
    (folded or not); the margins are the host's numbers (the final angles' largest error over the
    3°, rtol 1e-12); the yield grows with either tolerance (a curve over factors 0.25–4 is
    non-decreasing along each axis and the diagonal); and the grid's counts are those of the
    margins at the grid's factors."""
    estimate = _estimate("default", 8)
    ds = estimate.dataset
    sensitivity = estimate.tolerance_sensitivity
    assert sensitivity is not None and sensitivity.factors == ojy.TOLERANCE_FACTORS
    folded = np.asarray(ds["folded"].values, dtype=bool)
    np.testing.assert_array_equal(sensitivity.folded_at(1.0, 1.0), folded)
    assert sensitivity.folded[1, 1] == estimate.counts["folded"]
    ok = np.asarray(ds["result"].values) == 0
    errors = np.abs(np.asarray(ds["final_angle"].values) - load_net(NET).intended_angles)
    np.testing.assert_allclose(
        np.asarray(ds["angle_margin"].values)[ok],
        np.max(errors, axis=1)[ok] / np.radians(3.0),
        rtol=1e-12,
    )
    dense = np.geomspace(0.25, 4.0, 41)
    for a, s in ((dense, dense), (dense, 1.0), (1.0, dense)):
        curve = sensitivity.yield_at(a, s)
        assert np.all(np.diff(curve) >= 0), curve
    f = np.asarray(sensitivity.factors)
    expected = [[np.sum(sensitivity.folded_at(a, s)) for s in f] for a in f]
    np.testing.assert_array_equal(sensitivity.folded, expected)
    # Another interval: the sensitivity's follows.
    wider = estimate.with_interval(0.99, "clopper-pearson")
    assert wider.tolerance_sensitivity.method == "clopper-pearson"
    assert wider.to_dict()["tolerance_sensitivity"]["rows"][4]["interval"] == list(wider.interval)


@pytest.mark.slow
def test_resuming_a_run_stored_with_the_old_fixed_seam_tolerance_keeps_it(tmp_path):
    """A run stored when the seam tolerance's default was the fixed 0.01 of the panel (its settings
    name none; its chunks hold no margins), resumed without tolerances: it keeps 0.01, its stored
    verdicts stay, the new samples are judged against 2 µm (the margins say so), and the
    sensitivity is not reported (the old samples have no margins). (~1 min: a kernel of its own.)"""
    import xarray as xr

    out = tmp_path / "old"
    fixed = VerdictTolerances(seam=0.01)

    def stop(done, total):
        raise _Stop

    with pytest.raises(_Stop):
        ojy.yield_estimate(
            PATTERN, ojy.Scatter(), 8, 1, tolerances=fixed, **_run(out=out, on_chunk=stop)
        )
    assert "seam_tolerance" not in json.loads((out / "sweep.json").read_text())["settings"]
    [chunk] = list((out / "chunks").glob("part-*.nc"))
    old = xr.load_dataset(chunk).drop_vars(["angle_margin", "seam_margin"])
    old.to_netcdf(chunk)  # as a store written before the margins existed
    stored_verdicts = np.asarray(old["verdict"].values)
    resumed = ojy.yield_estimate(PATTERN, ojy.Scatter(), 8, 1, **_run(out=out, resume=True))
    assert resumed.tolerances == {"angle_deg": 3.0, "seam_fraction": 0.01}
    assert resumed.tolerance_sensitivity is None
    ds = resumed.dataset
    np.testing.assert_array_equal(
        ds["verdict"].sel(design=old["design"].values).values, stored_verdicts
    )
    new = np.isfinite(ds["seam_margin"].values)
    assert new.sum() == 8 - len(stored_verdicts)
    open_gap = ds["max_open_seam_gap"].values[new]
    np.testing.assert_allclose(ds["seam_margin"].values[new], open_gap / 2.0, rtol=1e-12)


@pytest.mark.slow  # two estimates of 8 samples to compile and run: ~25 s
def test_a_step_budget_runs_the_stragglers_again_and_gives_the_same_samples(tmp_path):
    # With a budget of the median sample's steps about half the samples reach it in the first
    # pass; run again together with the full max_steps they give exactly what one pass gives (a
    # member's result does not depend on its chunk), and a resumed estimate recomputes nothing.
    reference = _estimate("default", 8)
    steps = np.asarray(reference.dataset["num_steps"].values)
    budget = int(np.median(steps))
    out = tmp_path / "budget"
    two = ojy.yield_estimate(PATTERN, ojy.Scatter(), 8, 1, **_run(step_budget=budget, out=out))
    assert two.dataset.attrs["stragglers"] == int(np.sum(steps > budget)) > 0
    assert (out / "stragglers" / "sweep.nc").is_file()
    for name in ("verdict", "result", "num_steps", "final_angle", "max_seam_gap"):
        np.testing.assert_array_equal(
            two.dataset[name].values, reference.dataset[name].values, err_msg=name
        )
    assert two.counts == reference.counts
    again = ojy.yield_estimate(
        PATTERN, ojy.Scatter(), 8, 1, **_run(step_budget=budget, out=out, resume=True)
    )
    assert again.counts == reference.counts and again.seconds_per_sample == 0
    with pytest.raises(ValueError, match="step_budget must be a whole number"):
        ojy.yield_estimate(PATTERN, run=ojy.RunOptions(step_budget=200_000))


@pytest.mark.slow  # the CLI estimate, its widths, sensitivity, gradient and figures: ~26 s
def test_cli_writes_result_and_figure(tmp_path, capsys):
    from origami_jax.cli import main

    config = tmp_path / "scatter.toml"
    config.write_text("[misfit_strain]\nwidth = 0.05\n")
    out = tmp_path / "cli"
    argv = ["yield", NET, "--samples", "4", "--seed", "1", "--scatter", str(config)]
    argv += ["--no-fluid-inertia"]  # released at once, as the library cases
    argv += ["--t-end", str(T_END), "--chunk-size", str(CHUNK), "--no-progress", "--widths", "0,1"]
    argv += ["--out", str(out)]
    assert main(argv) == 2  # a width factor of 0: refused before compiling
    assert "--widths factors must be positive" in capsys.readouterr().err
    argv[argv.index("0,1")] = "0.1,1"  # nearly no scatter: a cheap second estimate
    code = main(argv)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    result = json.loads((out / "result.json").read_text())
    assert result["n_samples"] == 4 and sum(result["counts"].values()) == 4
    assert result["fluid_inertia"] is False and result["release_ramp_us"] is None
    assert result["t_end_us"] == T_END
    low, high = result["interval"]
    assert low <= result["yield"] <= high
    # The default seam tolerance is derived from the angle tolerance (it was the fixed 0.01).
    assert result["tolerances"] == {"angle_deg": 3.0, "seam_fraction": "derived"}
    # The yield at the tolerances × 0.5, 1, 2 (a 3 × 3 grid), from the stored margins; at 1 × 1
    # the estimate's own.
    rows = result["tolerance_sensitivity"]["rows"]
    assert len(rows) == 9 and result["tolerance_sensitivity"]["factors"] == [0.5, 1.0, 2.0]
    [one] = [r for r in rows if r["angle_factor"] == r["seam_factor"] == 1.0]
    assert one["folded"] == result["counts"]["folded"] and one["interval"] == result["interval"]
    assert "yield at the tolerances x0.5" in captured.out
    # The score-function gradient of every normally scattered parameter (release is not scattered).
    assert set(result["gradient"]) == {"misfit_strain", "t_hinge", "hinge_width", "t_structural"}
    assert len(result["gradient"]["hinge_width"]["gradient"]) == 2
    assert result["gradient"]["t_hinge"]["per"] == "net"
    for name in ("yield.png", "misfolds.png", "yield_widths.png", "yield_tolerances.png"):
        assert (out / name).stat().st_size > 1000, name
    assert (out / "sweep.nc").is_file() and (out / "widths" / "x0.1" / "sweep.nc").is_file()
    assert [w["factor"] for w in result["widths"]] == [0.1, 1.0]
    assert result["widths"][1]["counts"] == result["counts"]
    assert sum(result["widths"][0]["counts"].values()) == 4
    assert "yield" in captured.out
    assert main(argv) == 2  # the same folder again: refused before compiling, in one line
    assert "--resume" in capsys.readouterr().err
    # A sample folded again on its own, its whole folding kept (resumed: nothing else simulated).
    assert main([*argv, "--resume", "--sample", "1"]) == 0
    assert "[yield] sample 1: " in capsys.readouterr().out
    stored = xr.load_dataset(out / "sweep.nc")
    folder = out / "samples" / "sample-1"
    again = json.loads((folder / "result.json").read_text())
    verdict = str(list(FoldVerdict)[int(stored["verdict"].values[1])])
    assert again["stored_verdict"] == verdict and again["verdict"] == verdict
    assert again["drawn"]["misfit_strain[0]"] == float(stored["misfit_strain[0]"].values[1])
    times = np.loadtxt(folder / "trajectory.csv", delimiter=",", skiprows=1)[:, 0]
    assert times.shape == (SOLVE.saveat.n,) and times[-1] == pytest.approx(T_END)
    for name in ("trajectory.fold", "angles.png", "frames.png"):
        assert (folder / name).stat().st_size > 1000, name
    assert json.loads((out / "result.json").read_text())["samples_folded_again"] == [
        {"sample": 1, "verdict": verdict, "stored_verdict": verdict}
    ]
    bad = [*argv[:-2], "--out", str(tmp_path / "bad")]
    for sample in ("4", "-1", "x"):
        assert main([*bad, "--sample", sample]) == 2
        assert "--sample expects" in capsys.readouterr().err
    assert main([*bad, "--seam-tolerance", "1.5"]) == 2
    assert "--seam-tolerance must lie strictly between 0 and 1" in capsys.readouterr().err
    config.write_text("[misfit_strain]\nwidth = -1\n")
    assert main([*argv[:-2], "--out", str(tmp_path / "bad")]) == 2
    assert "width must be finite and >= 0" in capsys.readouterr().err
    # A pre-fold is for closed-loop patterns; those take no etch front or ascent (one line each).
    config.write_text("[misfit_strain]\nwidth = 0.05\n")
    assert main([*bad, "--bias", "0.05"]) == 2
    assert "--bias pre-folds closed-loop patterns" in capsys.readouterr().err
    loop = ["yield", "vertex_degree4", "--out", str(tmp_path / "loop"), "--no-progress"]
    assert main([*loop, "--improve", "2"]) == 2
    assert "--etch-front and --improve take nets" in capsys.readouterr().err
    assert main([*loop, "--bias", "1.5"]) == 2
    assert "--bias must be a pre-fold angle" in capsys.readouterr().err
    assert main([*bad, "--step-budget", "0"]) == 2
    assert "--step-budget must be between 1 and 199999" in capsys.readouterr().err
    # A precision: a half-width below 0.5; its cap at least the first round; not with an ascent.
    assert main([*bad, "--precision", "0.5"]) == 2
    assert "--precision must lie strictly between 0 and 0.5" in capsys.readouterr().err
    assert main([*bad, "--max-samples", "40"]) == 2
    assert "--max-samples caps --precision's rounds" in capsys.readouterr().err
    assert main([*bad, "--precision", "0.1", "--max-samples", "2"]) == 2
    assert "--max-samples must be between 4 and" in capsys.readouterr().err
    assert main([*bad, "--precision", "0.1", "--improve", "2"]) == 2
    assert "--improve takes a fixed --samples" in capsys.readouterr().err
    # Agitation: an effective temperature > 0, with the fixed-step engine.
    assert main([*bad, "--agitation", "1e9"]) == 2
    assert "use --solver implicit-step" in capsys.readouterr().err
    assert main([*bad, "--agitation", "-1", "--solver", "implicit-step", "--dt", "2.5"]) == 2
    assert "--agitation must be an effective temperature > 0 K" in capsys.readouterr().err


def test_bad_sample_numbers_are_refused_before_compiling(tmp_path, capsys):
    from origami_jax.cli import main

    one = ["yield", NET, "--samples", "4", "--out", str(tmp_path / "o"), "--no-progress"]
    for sample, message in (
        ("4", "--sample expects sample numbers from 0 to 3 (at most 4 samples), got '4'"),
        ("-1", "from 0 to 3"),
        ("1,x", "--sample expects comma-separated sample numbers (from 0)"),
        (",", "--sample expects comma-separated finite sample numbers (from 0)"),
    ):
        assert main([*one, f"--sample={sample}"]) == 2
        assert message in capsys.readouterr().err
    # With --precision the count is not known ahead: numbers up to --max-samples are taken.
    assert main([*one, "--precision", "0.2", "--max-samples", "8", "--sample", "8"]) == 2
    assert "from 0 to 7" in capsys.readouterr().err
    family = ["yield", "cube_nets", "--out", str(tmp_path / "f"), "--sample", "1"]
    assert main(family) == 2
    assert "--sample takes one net, not a family" in capsys.readouterr().err
    assert not (tmp_path / "o").exists() and not (tmp_path / "f").exists()


def test_yield_takes_the_figures_flags_fold_takes():
    from origami_jax.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["yield", NET]).figures == "png"
    assert parser.parse_args(["yield", NET, "--figures", "none"]).figures == "none"
    assert parser.parse_args(["yield", NET, "--no-figures"]).figures == "none"
    with pytest.raises(SystemExit):
        parser.parse_args(["yield", NET, "--figures", "all"])  # a yield has no animation


# ---- agitation ---------------------------------------------------------------------------------

# The corner cube with the fluid's viscous drag (which balances the noise), released at once, at
# an effective temperature whose wobble, sqrt(k_B T / k), is ~0.3° on its hinges.
AGITATED = load_net(NET).with_model(added_mass=False, viscous=True, release_ramp=None)


def _agitated(temperature: float = 1e9):
    from origami_jax.system import Agitation

    return AGITATED.with_model(agitation=Agitation(temperature))


def test_an_agitated_yield_gives_each_sample_its_noise_and_records_it(monkeypatch):
    """Each sample's noise seed is a column of the sweep (the seed's one sequence: the first n of
    a longer estimate are those of n); the kernel records the agitation and sweeps `noise_seed`;
    refused before compiling without the fixed-step engine or the viscous drag."""
    import origami_jax.fab_yield._estimate as estimate
    from origami_jax.simulation import ImplicitStep

    tables = []

    def fake_sweep(kernel, table, *args, **kwargs):
        tables.append((kernel, table))
        raise RuntimeError("stop here")

    monkeypatch.setattr(estimate, "sweep", fake_sweep)
    solve = SOLVE.replace(solver=ImplicitStep(dt=2.5))
    for n, seed in ((6, 3), (3, 3), (3, 4)):
        with pytest.raises(RuntimeError, match="stop here"):
            ojy.yield_estimate(_agitated(), n_samples=n, seed=seed, solve=solve, run=RUN["run"])
    kernel, longer = tables[0]
    seeds = [np.asarray(table.columns()["noise_seed"]) for _, table in tables]
    np.testing.assert_array_equal(seeds[1], seeds[0][:3])
    assert not np.any(seeds[2] == seeds[1])
    assert np.all((seeds[0] >= 0) & (seeds[0] < 2**31) & (seeds[0] == np.round(seeds[0])))
    assert "noise_seed" in kernel.parameters
    assert kernel.settings["agitation"]["temperature_K"] == 1e9
    with pytest.raises(ValueError, match="fixed-step engine"):
        ojy.yield_estimate(_agitated(), n_samples=2, **RUN)
    dry = _agitated().with_model(viscous=False)
    with pytest.raises(ValueError, match="viscous drag to balance its noise"):
        ojy.yield_estimate(dry, n_samples=2, solve=solve, run=RUN["run"])
    with pytest.raises(ValueError, match="origami_jax.system.Agitation"):
        AGITATED.with_model(agitation=300.0)


@pytest.mark.slow  # the agitated fixed-step kernel, and the same kernel without agitation
def test_an_agitated_yield_is_reproducible_and_wobbles_by_its_temperature():
    """Agitated estimates of the corner cube (no fabrication scatter, so only the noise differs
    between samples): the same seed gives the same samples (the first 2 of 4 are those of 2, each
    sample computed alone, the CPU's default chunk: in a vmapped chunk a member's last bits
    depend on the others', whose Newton iterations it shares, and the noise amplifies them); the
    samples' final angles differ from one another and from the unagitated fold by about the
    thermal wobble ``sqrt(k_B T / k)`` (between a tenth of it and ten times it: the end state is a
    snapshot of a fluctuating hinge, held at its target by the seam's contact or not); the
    seam's plates never pass through each other."""
    from origami_jax.simulation import ImplicitStep
    from origami_jax.system import BOLTZMANN

    solve = SOLVE.replace(solver=ImplicitStep(dt=2.5))
    run = {"solve": solve, "run": dataclasses.replace(RUN["run"], chunk_size=1)}
    pattern = _agitated()
    four = ojy.yield_estimate(pattern, ojy.Scatter.none(), 4, seed=2, **run)
    two = ojy.yield_estimate(pattern, ojy.Scatter.none(), 2, seed=2, **run)
    calm = ojy.yield_estimate(AGITATED, ojy.Scatter.none(), 1, seed=2, **run)
    angles = np.asarray(four.dataset["final_angle"].values)
    np.testing.assert_allclose(two.dataset["final_angle"].values, angles[:2], rtol=0, atol=1e-12)
    k = float(AGITATED.system(AGITATED.default_design(KOH_SOLUTION)).hinges.stiffness[0])
    wobble = math.sqrt(1e9 * BOLTZMANN / 1e-12 / k)
    spread = np.abs(angles - np.asarray(calm.dataset["final_angle"].values)[0])
    assert 0.1 * wobble < np.max(spread) < 10 * wobble, (spread, wobble)
    assert np.all(np.asarray(four.dataset["penetration"].values) < 0.2)
    assert four.counts["invalid"] == 0


# ---- sampling to a precision -------------------------------------------------------------------


def test_sample_until_sizes_each_round_for_the_half_width_asked():
    """`SampleUntil.next_count`: nothing more once the interval is narrow enough or the cap is
    reached; otherwise the smallest count (at least 25 % more) at which the same yield gives the
    interval asked for, so the count before it would not have; the settings are checked."""
    until = ojy.SampleUntil(half_width=0.1, first=20, most=400)
    half = lambda k, n: np.diff(ojy.binomial_interval(k, n, 0.95, "wilson"))[0] / 2  # noqa: E731
    assert until.next_count(0, 20) is None  # 0 of 20: the interval is [0, 0.16]
    assert half(0, 20) <= 0.1
    for folded, n in [(2, 20), (10, 20), (3, 25), (15, 40)]:
        more = until.next_count(folded, n)
        assert more is not None and more >= n + math.ceil(0.25 * n)
        p = folded / n
        assert half(round(p * more), more) <= 0.1
        if more > n + math.ceil(0.25 * n):
            assert half(round(p * (more - 1)), more - 1) > 0.1
    # Near a yield of 0.5 the Wilson interval needs ~96 samples for ±0.1.
    assert 90 <= until.next_count(10, 20) <= 100
    assert ojy.SampleUntil(half_width=0.01, first=20, most=50).next_count(10, 20) == 50
    assert ojy.SampleUntil(half_width=0.01, first=20, most=50).next_count(25, 50) is None
    for bad, match in [
        ({"half_width": 0.5}, "half_width"),
        ({"first": 0}, "first"),
        ({"first": 30, "most": 20}, "most"),
        ({"method": "wald"}, "method"),
    ]:
        with pytest.raises(ValueError, match=match):
            ojy.SampleUntil(**bad)
    with pytest.raises(ValueError, match="or a SampleUntil"):
        ojy.yield_estimate(PATTERN, n_samples=2.5)


def test_an_estimate_to_a_precision_holds_the_first_samples_of_the_sequence(tmp_path):
    """Sampled in rounds to ±0.2 from 4 samples (at most 12), the samples are the first ones of
    the seed's one sequence of draws: the same drawn films as an estimate of that many samples at
    once (and a sample's result depends on its own draws only: a sweep's members are independent,
    tested with the sweep engine); a resumed estimate takes the same rounds from its folders and
    runs nothing."""
    until = ojy.SampleUntil(half_width=0.2, first=4, most=12)
    out = tmp_path / "until"
    estimate = ojy.yield_estimate(PATTERN, ojy.Scatter(), until, seed=3, **_run(out=str(out)))
    n = estimate.n_samples
    assert 4 < n <= 12 and estimate.dataset.attrs["rounds"] >= 2
    assert until.reached(estimate.counts["folded"], n) or n == 12
    np.testing.assert_array_equal(estimate.dataset["design"].values, np.arange(n))
    assert sorted(p.name for p in out.glob("samples-*"))  # the later rounds' folders
    drawn = ojy.sample_values(ojy.Scatter(), estimate.nominal, ojy.standard_draws(3, n, 2))
    for name in ("misfit_strain", "t_hinge", "hinge_width"):
        np.testing.assert_array_equal(estimate.samples(name), drawn[name], err_msg=name)
    resumed = ojy.yield_estimate(
        PATTERN, ojy.Scatter(), until, seed=3, **_run(out=str(out), resume=True)
    )
    assert resumed.n_samples == n and resumed.counts == estimate.counts
    assert resumed.seconds_per_sample == 0.0  # nothing run again
    np.testing.assert_array_equal(resumed.dataset["verdict"], estimate.dataset["verdict"])
    assert xr.load_dataset(out / "sweep.nc").sizes["design"] == n  # every round's, as reported


# ---- the differentiable surrogate --------------------------------------------------------------


def test_soft_yield_refuses_bad_arguments():
    with pytest.raises(ValueError, match="temperature_deg"):
        ojy.soft_yield(NET, temperature_deg=0.0)
    with pytest.raises(ValueError, match="targets must be 2"):
        ojy.soft_yield(NET, targets=[1.0, 1.0, 1.0])


@pytest.mark.slow  # compiles the reverse-mode gradient of a vmapped simulation (minutes)
def test_soft_yield_gradient_matches_finite_differences_without_contact():
    """The surrogate's gradient with respect to the drawn hinge angles (reverse mode through every
    sample's simulation) against central differences of the surrogate itself at two steps (0.1°,
    0.025°), which agree with each other: within 3 % of the gradient's size. Without contact: with
    it, the differences of the surrogate change with the step (a panel stopped by another moves the
    final state non-smoothly), so there the gradient is not checked."""
    import jax
    import jax.numpy as jnp

    from origami_jax.net import load_net

    surrogate = ojy.soft_yield(
        load_net(NET).with_model(contact=False, added_mass=False, viscous=False),
        ojy.Scatter(),
        n_samples=4,
        seed=1,
        solve=SOLVE,
        temperature_deg=3.0,
    )
    with pytest.raises(ValueError, match="unknown design variable"):
        surrogate({"misfit_strain": np.ones(2)})
    x0 = jnp.asarray(surrogate.nominal["target"])
    value = jax.jit(lambda t: surrogate({"target": t}))
    gradient = np.asarray(jax.jit(jax.grad(lambda t: surrogate({"target": t})))(x0))
    assert np.all(np.isfinite(gradient))
    differences = []
    for step_deg in (0.1, 0.025):
        h = np.radians(step_deg)
        row = []
        for j in range(2):
            step = np.zeros(2)
            step[j] = h
            row.append(float(value(x0 + step) - value(x0 - step)) / (2 * h))
        differences.append(row)
    scale = np.max(np.abs(differences))
    assert scale > 1e-2, differences  # the surrogate is not flat here
    np.testing.assert_allclose(differences[0], differences[1], atol=0.03 * scale)
    np.testing.assert_allclose(gradient, differences[1], atol=0.03 * scale)
