"""Hinge physics: bilayer curvature, stiffness, drag, materials, units, gradients."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

import origami_jax.system as osys

# Closed forms evaluated two ways in float64: round-off only.
FORMULA_RTOL = 1e-13


def test_bilayer_curvature_hand_checked():
    # E1' = E2' = t1 = t2 = ε = 1: κ = 6·2 / (1 + 1 + 2·(2 + 3 + 2)) = 12/16 by hand.
    assert float(osys.bilayer_curvature(1.0, 1.0, 1.0, 1.0, 1.0)) == pytest.approx(0.75, rel=1e-15)
    # E1' = 2, t1 = 1, E2' = 1, t2 = 2, ε = 0.01 (hand): numerator 6·2·1·1·2·3·0.01 = 0.72;
    # denominator 4·1 + 1·16 + 2·2·1·1·2·(2 + 6 + 8) = 20 + 128 = 148.
    assert float(osys.bilayer_curvature(2.0, 1.0, 1.0, 2.0, 0.01)) == pytest.approx(
        0.72 / 148, rel=1e-15
    )


def test_literature_radius_and_stiffness():
    """SPEC: with literature values ρ ≈ 78 µm and l = ρπ ≈ 246 µm; k by hand in µN·µm."""
    design = osys.HingeDesign.literature()
    e1 = 250e3 / (1 - 0.23)  # MPa
    e2 = 279e3 / (1 - 0.21)
    strain = 1e3 / e2  # 1 GPa residual stress
    t1, t2 = 0.2, 0.1
    kappa = (
        6
        * e1
        * e2
        * t1
        * t2
        * (t1 + t2)
        * strain
        / (
            e1**2 * t1**4
            + e2**2 * t2**4
            + 2 * e1 * e2 * t1 * t2 * (2 * t1**2 + 3 * t1 * t2 + 2 * t2**2)
        )
    )
    assert 1 / kappa == pytest.approx(78.28, abs=0.01)
    assert float(design.radius()) == pytest.approx(1 / kappa, rel=FORMULA_RTOL)
    assert float(design.hinge_length()) == pytest.approx(np.pi / kappa, rel=FORMULA_RTOL)
    k = 200.0 * (e1 * t1**3 + e2 * t2**3) / (3 * np.pi / kappa)
    np.testing.assert_allclose(design.stiffness(3), np.full(3, k), rtol=FORMULA_RTOL)
    # Drag in air: C_D ν A L³ / 16 with ν = 1.204 kg/m³ = 1.204e-6 ng/µm³.
    b = 1.17 * 1.204e-6 * 200.0 * 200.0 * 200.0**3 / 16
    np.testing.assert_allclose(design.drag(3, 200.0, 200.0), np.full(3, b), rtol=FORMULA_RTOL)


def test_documented_alternatives():
    paper = osys.HingeDesign.literature()
    plate = osys.HingeDesign.literature(stiffness_model="plate")
    strip = osys.HingeDesign.literature(drag_model="strip")
    np.testing.assert_allclose(paper.stiffness(2) / plate.stiffness(2), 4.0, rtol=FORMULA_RTOL)
    flap = (200.0, 150.0)  # µm, length and width
    np.testing.assert_allclose(strip.drag(2, *flap) / paper.drag(2, *flap), 2.0, rtol=FORMULA_RTOL)
    scaled = osys.HingeDesign.literature(k_scale=3.07, b_scale=18.6, fluid=osys.KOH_SOLUTION)
    np.testing.assert_allclose(scaled.stiffness(1), 3.07 * paper.stiffness(1), rtol=FORMULA_RTOL)
    np.testing.assert_allclose(
        scaled.drag(1, *flap), 18.6 * paper.drag(1, *flap) * 1290.0 / 1.204, rtol=FORMULA_RTOL
    )


def test_bilayer_flexural_rigidity_is_the_neutral_axis_sum():
    """`stiffness_model="bilayer"`: the bonded strip's ``D`` is ``Σ E_i (t_i³/12 + t_i d_i²)`` about
    its neutral axis (the transformed section, summed here layer by layer with the plate moduli
    ``E / (1 − ν²)``), and ``k = w D / l``; two equal layers are one homogeneous plate of twice the
    thickness, ``D = E (2t)³ / 12``. Closed forms two ways: round-off only."""
    design = osys.HingeDesign.literature(stiffness_model="bilayer")
    moduli = np.array([250e3 / (1 - 0.23**2), 279e3 / (1 - 0.21**2)])  # MPa
    thickness = np.array([0.2, 0.1])  # µm
    middle = np.array([0.1, 0.25])  # mid-planes above the bottom face
    neutral = np.sum(moduli * thickness * middle) / np.sum(moduli * thickness)
    rigidity = np.sum(moduli * (thickness**3 / 12 + thickness * (middle - neutral) ** 2))
    assert float(design.flexural_rigidity()) == pytest.approx(rigidity, rel=FORMULA_RTOL)
    k = 200.0 * rigidity / float(design.hinge_length())
    np.testing.assert_allclose(design.stiffness(2), np.full(2, k), rtol=FORMULA_RTOL)
    film = osys.Material(200e9, 0.3, 3000.0)
    equal = osys.HingeDesign.literature(
        structural=film, hinge=film, t_structural=0.1, t_hinge=0.1, stiffness_model="bilayer"
    )
    plate = 200e3 / (1 - 0.3**2) * 0.2**3 / 12
    assert float(equal.flexural_rigidity()) == pytest.approx(plate, rel=FORMULA_RTOL)


def test_thin_hinge_limit_is_stoney():
    """As t₂ → 0, κ → 6 E₂' t₂ ε / (E₁' t₁²) (Stoney), with a relative error O(t₂/t₁)."""
    e1, e2, t1, eps = 324.7, 353.2, 0.2, 2.8e-3
    for t2 in (1e-3, 1e-5, 1e-7):
        stoney = 6 * e2 * t2 * eps / (e1 * t1**2)
        ratio = float(osys.bilayer_curvature(e1, t1, e2, t2, eps)) / stoney
        assert abs(ratio - 1) < 20 * t2 / t1
    assert float(osys.bilayer_curvature(e1, t1, e2, 0.0, eps)) == 0.0
    # The derivative at t₂ = 0 is Stoney's slope, finite.
    slope = jax.grad(osys.bilayer_curvature, argnums=3)(e1, t1, e2, 0.0, eps)
    assert float(slope) == pytest.approx(6 * e2 * eps / (e1 * t1**2), rel=1e-14)


def test_units_convert_consistently():
    micro = osys.HingeDesign.literature()
    si = osys.HingeDesign.literature(units=osys.SI)
    np.testing.assert_allclose(si.stiffness(1), micro.stiffness(1) * 1e-12, rtol=FORMULA_RTOL)
    np.testing.assert_allclose(
        si.drag(1, 200e-6, 150e-6), micro.drag(1, 200.0, 150.0) * 1e-12 * 1e-12, rtol=FORMULA_RTOL
    )
    np.testing.assert_allclose(si.radius(), micro.radius() * 1e-6, rtol=FORMULA_RTOL)
    assert osys.MICRO.stress(1e6) == pytest.approx(1.0)
    assert osys.MICRO.density(1e6) == pytest.approx(1.0)
    assert osys.MICRO.torque(1e-12) == pytest.approx(1.0)
    sinx = osys.SINX.to(osys.MICRO)
    assert float(sinx.youngs_modulus) == pytest.approx(250e3)
    assert float(sinx.biaxial_modulus) == pytest.approx(250e3 / 0.77)
    # Symbols for printing: named where a prefix fits, the SI value otherwise.
    assert (osys.MICRO.length_symbol, osys.MICRO.time_symbol) == ("µm", "µs")
    assert (osys.SI.length_symbol, osys.SI.time_symbol) == ("m", "s")
    odd = osys.UnitSystem("odd", 2e-6, 1e-3, 1.0)
    assert (odd.length_symbol, odd.time_symbol) == ("2e-06 m", "ms")


def test_stiffness_gradients_wrt_design():
    base = osys.HingeDesign.literature()
    names = ("hinge_width", "t_structural", "t_hinge", "misfit_strain", "theta_final")

    def stiffness(scales):
        # Relative scale factors, so check_grads' step is a relative perturbation of each parameter.
        overrides = {name: getattr(base, name) * s for name, s in zip(names, scales, strict=True)}
        return osys.HingeDesign.literature(**overrides).stiffness(2)

    check_grads(jax.jit(stiffness), (jnp.ones(len(names)),), order=1, modes=["fwd", "rev"])
    # k ∝ w and k ∝ 1/θ_final exactly: logarithmic sensitivities 1 and −1.
    k0 = stiffness(jnp.ones(len(names)))[0]
    log_sensitivity = jax.jacfwd(stiffness)(jnp.ones(len(names)))[0] / k0
    assert float(log_sensitivity[0]) == pytest.approx(1.0, rel=1e-12)
    assert float(log_sensitivity[4]) == pytest.approx(-1.0, rel=1e-12)


def test_per_hinge_parameters():
    design = osys.HingeDesign.literature(hinge_width=jnp.array([100.0, 200.0, 300.0]))
    k = design.stiffness(3)
    np.testing.assert_allclose(k / k[0], [1.0, 2.0, 3.0], rtol=FORMULA_RTOL)


def test_hinge_errors():
    with pytest.raises(ValueError, match="t_hinge must be positive"):
        osys.HingeDesign.literature(t_hinge=-0.1)
    with pytest.raises(ValueError, match="hinge_width must be positive"):
        osys.HingeDesign.literature(hinge_width=0.0)
    with pytest.raises(ValueError, match="exactly one of misfit_strain"):
        osys.HingeDesign.literature(misfit_strain=1e-3, residual_stress=1e3)
    with pytest.raises(ValueError, match="stiffness_model"):
        osys.HingeDesign.literature(stiffness_model="wrong")
    with pytest.raises(ValueError, match="poisson_ratio"):
        osys.Material(1e9, 0.6, 1000.0)
    with pytest.raises(ValueError, match="density must be positive"):
        osys.Fluid(-1.0)
    with pytest.raises(ValueError, match="NaN"):
        osys.HingeDesign.literature(t_hinge=float("nan"))
    # The flap geometry moved to the accordion pattern: a one-line pointer there.
    moved = "HingeDesign has no flap_length: the flap geometry belongs to the accordion pattern"
    with pytest.raises(ValueError, match=moved):
        osys.HingeDesign.literature(flap_length=150.0)
    with pytest.raises(AttributeError, match=moved):
        osys.HingeDesign.literature().flap_length  # noqa: B018
    with pytest.raises(TypeError, match="unexpected keyword"):
        osys.HingeDesign.literature(flap_lenght=150.0)
