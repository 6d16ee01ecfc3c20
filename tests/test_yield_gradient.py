"""The yield's score-function gradient (`yield_gradient`): against closed-form gradients of synthetic
yields (every spread kind, per crease and per net), its standard error against the spread of
repeated estimates, and (slow) against central differences of the Monte Carlo yield of the corner
cube with contact, where the simulation's own derivative is not smooth."""

import numpy as np
import pytest
import xarray as xr
from scipy import stats

import origami_jax.fab_yield as ojy
from origami_jax.simulation import VERDICT_CODES, FoldVerdict

FOLDED = VERDICT_CODES[FoldVerdict.FOLDED]
MISFOLDED = VERDICT_CODES[FoldVerdict.MISFOLDED]

# Synthetic "folds" rule: every crease's drawn value within `HALF` of `AIM` (a band the nominal sits
# off-centre in, so the yield has a clear slope).
AIM = np.array([1.0, 1.1])
HALF = np.array([0.12, 0.15])


def _band_probability(spread: ojy.Spread, mu: float, aim: float, half: float) -> float:
    """P(|x - aim| < half) for one crease's draw x around nominal `mu`, in closed form."""
    lo, hi = aim - half, aim + half
    w = spread.width
    if spread.distribution == "lognormal":
        return stats.norm.cdf(np.log(hi / mu) / w) - stats.norm.cdf(np.log(lo / mu) / w)
    sigma = w * mu if spread.relative else w
    return stats.norm.cdf((hi - mu) / sigma) - stats.norm.cdf((lo - mu) / sigma)


def _closed_form_gradient(spread, mu):
    """dY/dμ_j of Y = Π_j P_j(μ_j), by central differences of the closed form (error ~1e-9)."""
    p = np.array(
        [_band_probability(spread, m, a, h) for m, a, h in zip(mu, AIM, HALF, strict=True)]
    )
    out = []
    for j in range(len(mu)):
        h = 1e-5 * mu[j]
        up = _band_probability(spread, mu[j] + h, AIM[j], HALF[j])
        down = _band_probability(spread, mu[j] - h, AIM[j], HALF[j])
        out.append((up - down) / (2 * h) * np.prod(np.delete(p, j)))
    return np.array(out)


def _fake_estimate(scatter, nominal, n, seed):
    """A `YieldEstimate` whose verdicts follow the synthetic rule on the draws `yield_estimate`
    would make (same `standard_draws`, same `sample_values`): tests the plumbing end to end."""
    nominals = {name: np.broadcast_to(nominal.get(name, 1.0), (2,)) for name in ojy.PARAMETERS}
    nominals["release"] = np.zeros(2)
    values = ojy.sample_values(scatter, nominals, ojy.standard_draws(seed, n, 2))
    x = values["misfit_strain"]
    folded = np.all(np.abs(x - AIM) < HALF, axis=1)
    verdict = np.where(folded, FOLDED, MISFOLDED)
    dataset = xr.Dataset({"verdict": ("design", verdict)})
    return ojy.YieldEstimate(
        fraction=float(folded.mean()),
        interval=(0.0, 1.0),
        confidence=0.95,
        method="wilson",
        counts={},
        n_samples=n,
        seed=seed,
        scatter=scatter,
        dataset=dataset,
        seconds_per_sample=0.0,
        nominal=nominals,
    )


SPREADS = {
    "normal, relative": ojy.Spread("normal", 0.08),
    "normal, absolute": ojy.Spread("normal", 0.09, relative=False),
    "lognormal": ojy.Spread("lognormal", 0.08),
}


@pytest.mark.parametrize("kind", list(SPREADS))
def test_score_gradient_matches_the_closed_form(kind):
    """200,000 synthetic samples per crease: the estimate within 4 standard errors of the closed
    form (a wrong score term, e.g. the relative spread's (z² − 1)/μ left out, is off by ~10 of
    them), the standard error itself under 3 % of the gradient."""
    spread = SPREADS[kind]
    scatter = ojy.Scatter.none().__class__(**{**_off(), "misfit_strain": spread})
    mu = np.array([1.05, 1.02])
    estimate = _fake_estimate(scatter, {"misfit_strain": mu}, 200_000, seed=3)
    result = ojy.yield_gradient(estimate)["misfit_strain"]
    truth = _closed_form_gradient(scatter.misfit_strain, mu)
    assert result.per == "crease" and result.gradient.shape == (2,)
    assert np.all(result.standard_error < 0.03 * np.abs(truth)), (result.summary(), truth)
    np.testing.assert_array_less(np.abs(result.gradient - truth), 4 * result.standard_error)


def test_score_gradient_of_a_per_net_spread_is_the_derivative_along_every_nominal():
    """One draw shared by both creases: the gradient is dY/d ln μ with every crease's nominal
    scaled together; closed form: Y(λ) = Φ(z_hi) − Φ(z_lo) over the z that put both creases in
    their bands."""
    spread = ojy.Spread("normal", 0.08, per="net")
    scatter = ojy.Scatter(**{**_off(), "t_hinge": ojy.Spread(width=0.0), "misfit_strain": spread})
    mu = np.array([1.05, 1.12])

    def yield_at(scale):
        x0 = scale * mu  # x_j = x0_j (1 + w z): each band gives an interval of z
        lo = np.max(((AIM - HALF) / x0 - 1) / spread.width)
        hi = np.min(((AIM + HALF) / x0 - 1) / spread.width)
        return max(0.0, stats.norm.cdf(hi) - stats.norm.cdf(lo))

    truth = (yield_at(1 + 1e-6) - yield_at(1 - 1e-6)) / 2e-6
    estimate = _fake_estimate(scatter, {"misfit_strain": mu}, 200_000, seed=4)
    result = ojy.yield_gradient(estimate, "misfit_strain")["misfit_strain"]
    assert result.per == "net" and result.gradient.shape == ()
    assert "relative" in result.unit
    assert abs(truth) > 0.5 and result.standard_error < 0.03 * abs(truth)
    assert abs(result.gradient - truth) < 4 * result.standard_error, (result.summary(), truth)


def test_standard_error_is_the_spread_of_repeated_estimates():
    """60 estimates of 400 samples each (independent seeds): the spread of their gradients matches
    their mean standard error (ratio 0.75–1.3: the sample standard deviation of 60 values is
    within ±18 % at 2σ), and their mean is the closed form within 3 standard errors of that mean
    (unbiased)."""
    scatter = ojy.Scatter(**{**_off(), "misfit_strain": SPREADS["normal, relative"]})
    mu = np.array([1.05, 1.02])
    truth = _closed_form_gradient(scatter.misfit_strain, mu)  # resolved: relative
    gradients, errors = [], []
    for seed in range(60):
        result = ojy.yield_gradient(_fake_estimate(scatter, {"misfit_strain": mu}, 400, seed))
        gradients.append(result["misfit_strain"].gradient)
        errors.append(result["misfit_strain"].standard_error)
    gradients, errors = np.array(gradients), np.array(errors)
    ratio = np.std(gradients, axis=0, ddof=1) / np.mean(errors, axis=0)
    assert np.all((0.75 < ratio) & (ratio < 1.3)), ratio
    spread_of_mean = np.std(gradients, axis=0, ddof=1) / np.sqrt(len(gradients))
    np.testing.assert_array_less(np.abs(gradients.mean(axis=0) - truth), 3 * spread_of_mean)


def test_yield_gradient_refuses_what_has_no_score():
    scatter = ojy.Scatter(**{**_off(), "misfit_strain": SPREADS["lognormal"]})
    estimate = _fake_estimate(scatter, {"misfit_strain": np.array([1.0, 1.0])}, 50, 0)
    with pytest.raises(ValueError, match="not scattered"):
        ojy.yield_gradient(estimate, "hinge_width")
    with pytest.raises(ValueError, match="unknown parameter"):
        ojy.yield_gradient(estimate, "stress")
    with pytest.raises(ValueError, match="uniform spread has no score"):
        ojy.score(ojy.Spread("uniform", 0.1), np.zeros((3, 2)), np.ones(2))
    with pytest.raises(ValueError, match="at least 2 samples"):
        ojy.score_gradient(np.ones(1), np.zeros((1, 2)))
    hand_made = ojy.YieldEstimate(0.5, (0, 1), 0.95, "wilson", {}, 2, 0, scatter, None, 0.0)
    with pytest.raises(ValueError, match="no nominal values"):
        ojy.yield_gradient(hand_made)
    # Uniform spreads are skipped when no parameter is named (release's usual spread).
    both = ojy.Scatter(
        **{**_off(), "misfit_strain": SPREADS["lognormal"], "release": ojy.Spread("uniform", 5.0)}
    )
    assert list(ojy.yield_gradient(_fake_estimate(both, {}, 50, 0))) == ["misfit_strain"]


def test_process_nominal_values_are_checked():
    with pytest.raises(ValueError, match="process: unknown parameter 'stress'"):
        ojy.yield_estimate("corner_cube", n_samples=2, process={"stress": 1.0})
    with pytest.raises(ValueError, match="process: t_structural must be a number"):
        ojy.yield_estimate("corner_cube", n_samples=2, process={"t_structural": [1.0, 2.0]})
    with pytest.raises(ValueError, match="finite and positive"):
        ojy.yield_estimate("corner_cube", n_samples=2, process={"misfit_strain": -0.001})


def _off() -> dict[str, ojy.Spread]:
    return {name: ojy.Spread(width=0.0) for name in ojy.PARAMETERS}


@pytest.mark.slow  # three Monte Carlo estimates of 192 corner cubes with contact (~10-40 min)
def test_yield_gradient_matches_finite_differences_of_the_monte_carlo_yield_with_contact():
    """The corner cube with contact, its film's misfit strain (stress) scattered 1 % per crease
    around a process 1 % above the design's (the hinge lengths as drawn): the yield's derivative
    along the process's misfit strain (every crease's scaled together, d/d ln ε₀) from the score
    function at ε₀, against central differences of the Monte Carlo yield at ε₀ (1 ± 0.5 %) on the
    same draws. Both are noisy: they must agree within 3 standard errors of their difference, and
    the gradient must stand out of its own noise (> 2.5 standard errors). The yield here is a step
    function of each sample's draws (a crease 0.6° past its seam misfolds, contacts stop and
    deflect flaps, a chattering contact runs out of steps): the simulation's own derivative does
    not exist; the score function does not need it."""
    import jax

    from origami_jax.net import FOLD_KERNEL_SOLVE, load_net
    from origami_jax.simulation import VerdictTolerances
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    jax.config.update("jax_enable_x64", True)
    design = HingeDesign.literature(fluid=KOH_SOLUTION)
    scatter = ojy.Scatter(**{**_off(), "misfit_strain": ojy.Spread("normal", 0.01)})
    n, h, seed = 192, 0.005, 2
    eps0 = 1.01 * float(design.misfit_strain)
    run = {
        "solve": FOLD_KERNEL_SOLVE.replace(t1=600.0, max_steps=20_000),
        "run": ojy.RunOptions(chunk_size=4, progress=False),
    }

    def estimate(scale):
        process = {"misfit_strain": scale * eps0}
        # The tolerance this test was calibrated with (the fixed 0.01 of the panel, the default
        # before the derived one): "a crease 0.6° past its seam misfolds".
        # The paper's dynamics (released at once, no fluid inertia): 600 µs runs.
        paper = load_net("corner_cube").with_model(added_mass=False, viscous=False)
        return ojy.yield_estimate(
            paper, scatter, n, seed, design=design, process=process,
            tolerances=VerdictTolerances(seam=0.01), **run,
        )  # fmt: skip

    centre, up, down = estimate(1.0), estimate(1 + h), estimate(1 - h)
    folded = {
        k: np.asarray(e.dataset["verdict"].values) == FOLDED
        for k, e in (("0", centre), ("+", up), ("-", down))
    }
    differences = (folded["+"].astype(float) - folded["-"]) / (2 * h)
    fd, fd_error = differences.mean(), differences.std(ddof=1) / np.sqrt(n)

    z = ojy.standard_draws(seed, n, 2)["misfit_strain"]
    nominal = centre.nominal["misfit_strain"]
    np.testing.assert_allclose(nominal, eps0, rtol=1e-12)
    along = np.sum(ojy.score(scatter.misfit_strain, z, nominal) * nominal, axis=1)  # d ln p/d ln ε₀
    gradient, error = ojy.score_gradient(folded["0"], along)
    per_crease = ojy.yield_gradient(centre)["misfit_strain"]
    # The per-crease gradients are the same estimator: their ε₀-weighted sum is the directional one.
    assert np.sum(per_crease.gradient * nominal) == pytest.approx(float(gradient), rel=1e-9)

    engaged = np.asarray(centre.dataset["engaged"].values)
    summary = (
        f"yield {centre.fraction:.3f} {centre.counts}, contact engaged at the end in "
        f"{int(np.sum(engaged > 0))}; d yield/d ln eps0: score {gradient:.2f} ± {error:.2f}, "
        f"differences {fd:.2f} ± {fd_error:.2f}"
    )
    print(summary)
    assert np.sum(engaged > 0) > 0, summary
    assert abs(gradient) > 2.5 * error, summary
    assert abs(gradient - fd) < 3 * np.hypot(error, fd_error), summary
