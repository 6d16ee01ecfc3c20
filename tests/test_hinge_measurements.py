"""The table of published bilayer measurements (docs/guides/hinge-measurements.md): its predictions
are Timoshenko's formula, written out again here in NumPy; its residuals are finite and reported; every
entry says where its numbers come from; the guide's table is the package's."""

import math
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

from origami_jax.system import (
    MEASURED_HINGES,
    HingeDesign,
    Material,
    compare_measured_hinges,
    measured_hinges_table,
)
from origami_jax.system._units import SI

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "guides" / "hinge-measurements.md"


def _timoshenko_radius(e1, t1, nu1, e2, t2, nu2, eps):
    """Timoshenko (1925) for a bilayer under equal biaxial misfit, written out independently:
    ``1/ρ = 6 ε (1 + m)² / (h (3 (1 + m)² + (1 + m n)(m² + 1/(m n))))`` with ``m = t₁/t₂``,
    ``n = E₁'/E₂'``, ``h = t₁ + t₂`` and the biaxial moduli ``E' = E/(1 − ν)``."""
    b1, b2 = np.float64(e1) / (1 - nu1), np.float64(e2) / (1 - nu2)
    m, n, h = np.float64(t1) / t2, b1 / b2, np.float64(t1) + t2
    kappa = 6 * eps * (1 + m) ** 2 / (h * (3 * (1 + m) ** 2 + (1 + m * n) * (m**2 + 1 / (m * n))))
    return abs(1 / kappa)


def test_there_are_measurements():
    # Two: no third published measurement with every input traceable was found (the guide says so).
    assert len(MEASURED_HINGES) >= 2
    assert len({hinge.key for hinge in MEASURED_HINGES}) == len(MEASURED_HINGES)


@pytest.mark.parametrize("hinge", MEASURED_HINGES, ids=lambda h: h.key)
def test_prediction_is_timoshenko(hinge):
    (row,) = compare_measured_hinges((hinge,))
    s, f = hinge.structural, hinge.stressed
    expected = _timoshenko_radius(
        s.youngs_modulus,
        s.thickness,
        s.poisson_ratio,
        f.youngs_modulus,
        f.thickness,
        f.poisson_ratio,
        hinge.misfit_strain,
    )
    assert row.predicted_radius == pytest.approx(expected, rel=1e-12, abs=0)
    assert row.measured_radius == hinge.measured_radius


def test_prediction_is_what_hinge_design_computes():
    """The table's radius is the one `HingeDesign.radius` gives for the same films (the density and
    the flap's size do not enter the curvature)."""
    hinge = MEASURED_HINGES[-1]
    (row,) = compare_measured_hinges((hinge,))

    def material(film):
        return Material(film.youngs_modulus, film.poisson_ratio, 1000.0)

    design = HingeDesign(
        hinge_width=1e-6,
        t_structural=hinge.structural.thickness,
        t_hinge=hinge.stressed.thickness,
        misfit_strain=hinge.misfit_strain,
        structural=material(hinge.structural),
        hinge=material(hinge.stressed),
        units=SI,
    )
    assert float(design.radius()) == pytest.approx(row.predicted_radius, rel=1e-12, abs=0)


def test_known_values():
    """The Si/SiGe tube by hand: 10 nm Si (E' = 130/(1 − 0.279) GPa) on 8 nm Si0.6Ge0.4, misfit
    0.4 (5.658 − 5.431)/5.431: ρ = 731 nm, 12 % more than the measured 650 nm. Prinz's two monolayers:
    5.48 nm predicted against 1.29 nm."""
    rows = {row.hinge.key: row for row in compare_measured_hinges()}
    zhang = rows["zhang2006"]
    assert zhang.hinge.misfit_strain == pytest.approx(0.4 * (5.658 - 5.431) / 5.431, rel=1e-12)
    assert zhang.hinge.stressed.biaxial_modulus == pytest.approx(130e9 / (1 - 0.279), rel=1e-12)
    assert zhang.predicted_radius == pytest.approx(731.16e-9, rel=1e-4)
    assert zhang.residual == pytest.approx(0.1249, abs=1e-3)
    prinz = rows["prinz2000"]
    assert prinz.predicted_radius == pytest.approx(5.4819e-9, rel=1e-4)
    assert prinz.measured_radius == pytest.approx(1e-9 + (6.0583e-10 + 5.6533e-10) / 4, rel=1e-12)


def test_residuals_are_finite_and_consistent():
    for row in compare_measured_hinges():
        assert math.isfinite(row.residual) and math.isfinite(row.predicted_radius)
        assert row.residual == pytest.approx(
            (row.predicted_radius - row.measured_radius) / row.measured_radius, rel=1e-12
        )


@pytest.mark.parametrize("hinge", MEASURED_HINGES, ids=lambda h: h.key)
def test_every_entry_is_sourced(hinge):
    assert hinge.citation.strip() and hinge.url.startswith("http")
    assert hinge.measured.strip()
    assert hinge.quotes and all('"' in quote and "http" in quote for quote in hinge.quotes)
    assert hinge.url in " ".join(hinge.quotes)
    assert hinge.assumptions
    for film in (hinge.structural, hinge.stressed):
        assert film.thickness > 0 and film.youngs_modulus > 0 and -1 < film.poisson_ratio < 0.5
    assert hinge.misfit_strain > 0 and hinge.measured_radius > 0


def test_bilayer_curvature_is_symmetric_in_the_films():
    """Swapping the films flips the curvature's side, not its size: the table may name either film
    the stressed one."""
    from origami_jax.system import bilayer_curvature

    hinge = MEASURED_HINGES[0]
    s, f = hinge.structural, hinge.stressed
    forward = bilayer_curvature(
        s.biaxial_modulus, s.thickness, f.biaxial_modulus, f.thickness, hinge.misfit_strain
    )
    swapped = bilayer_curvature(
        f.biaxial_modulus, f.thickness, s.biaxial_modulus, s.thickness, hinge.misfit_strain
    )
    assert float(jnp.abs(forward - swapped) / forward) < 1e-12


def test_the_guide_shows_the_packages_table():
    text = GUIDE.read_text(encoding="utf-8")
    assert measured_hinges_table() in text, (
        "docs/guides/hinge-measurements.md's table differs from measured_hinges_table(); paste the "
        "function's output into the guide"
    )
    for hinge in MEASURED_HINGES:
        assert hinge.url in text, f"the guide does not cite {hinge.key}'s source"
