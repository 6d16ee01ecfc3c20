"""The extended fluid: Sader's hydrodynamic function, strip-theory added inertia and viscous drag
against their closed forms for a single flap, the energy balance of a folding with every new term,
and derivatives through them against finite differences."""

import functools

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.special import kv

import origami_jax.simulation as sim
from origami_jax.chain import accordion_system
from origami_jax.fluid import (
    CombinedDrag,
    ViscousDrag,
    bessel_k_ratio,
    circular_hydrodynamic_function,
    fluid_loads,
    hydrodynamic_function,
    polygon_added_inertia,
    rectangle_added_inertia,
)
from origami_jax.net import PanelTree, StripTree
from origami_jax.system import AIR, KOH_SOLUTION, MICRO, Fluid, HingeDesign

from .chain_cases import FAST_COMPILE
from .helpers import stepped_energy_balance

quick_jit = functools.partial(jax.jit, compiler_options=FAST_COMPILE)


# ---- Sader's hydrodynamic function ----------------------------------------------------------------


def test_bessel_ratio_matches_scipy():
    """``K₁/K₀`` on Sader's ray ``z = −i √(i Re)`` for ``Re`` from 1e-3 to 1e4 against
    `scipy.special.kv` (AMOS): 1e-12 relative (measured ~1e-15)."""
    re = np.logspace(-3, 4, 29)
    z = -1j * np.sqrt(1j * re)
    np.testing.assert_allclose(bessel_k_ratio(jnp.asarray(z)), kv(1, z) / kv(0, z), rtol=1e-12)


def test_circular_function_has_stokes_asymptotes():
    """Stokes (1851): a cylinder of radius ``a`` oscillating at ``ω`` has added-mass and damping
    coefficients ``k = 1 + 2/m + O(m⁻³)``, ``k' = 2/m + 1/m² + O(m⁻³)`` with ``m = a √(ω/2ν)``
    (``Re = 2m²`` in Sader's variable): the leading terms of Stokes's Table, the boundary layer of
    thickness ``√(2ν/ω)``."""
    re = np.array([1e2, 1e3, 1e4])
    m = np.sqrt(re / 2)
    gamma = np.asarray(circular_hydrodynamic_function(re))
    assert np.all(np.abs(gamma.real - 1 - 2 / m) < 1.5 / m**3)
    assert np.all(np.abs(gamma.imag - 2 / m - 1 / m**2) < 1.5 / m**3)


def test_rectangular_function_limits_and_derivative():
    """Sader's ``Γ_rect`` tends to the potential-flow value 1 at high ``Re`` (4 % off at 1e4), grows
    as ``Re`` falls (viscous loading), and its derivative matches central differences."""
    real, imag = hydrodynamic_function(jnp.array([1e4, 30.0, 1.0]))
    assert abs(float(real[0]) - 1) < 0.05 and 0 < float(imag[0]) < 0.05
    assert float(real[1]) > 1.3 and float(imag[1]) > 0.4
    assert float(real[2]) > float(real[1]) and float(imag[2]) > float(imag[1])
    slope = jax.grad(lambda r: hydrodynamic_function(r)[1])(30.0)
    h = 1e-4
    central = (hydrodynamic_function(30.0 + h)[1] - hydrodynamic_function(30.0 - h)[1]) / (2 * h)
    np.testing.assert_allclose(slope, central, rtol=1e-7)


# ---- added inertia and viscous drag of a single flap ----------------------------------------------

CHORD, SPAN = 200.0, 150.0  # µm


def test_added_inertia_of_a_plate():
    """Strip theory for a rectangle (Newman 1977: per unit span ``ρπa²`` normal, ``ρπa⁴/8`` pitch),
    the polygon integrator against it, and about an edge ``(9/8) ρπa⁴ w`` (the hinge): exact."""
    a, rho = CHORD / 2, 1.3e-3
    rectangle = rectangle_added_inertia(CHORD, SPAN, rho)
    expected = np.zeros((6, 6))
    expected[2, 2] = rho * np.pi * a**2 * SPAN
    expected[3, 3] = rho * np.pi * a**4 * SPAN / 8
    expected[4, 4] = rho * np.pi * a**2 * SPAN**3 / 12
    np.testing.assert_allclose(rectangle, expected, rtol=1e-14)
    outline = np.array([[-SPAN / 2, -a, 0], [SPAN / 2, -a, 0], [SPAN / 2, a, 0], [-SPAN / 2, a, 0]])
    tiny = 1e-13 * np.max(expected)  # round-off of the quadrature's sums
    np.testing.assert_allclose(polygon_added_inertia(outline, rho), expected, atol=tiny)
    edge = polygon_added_inertia(outline + [0, a, 0], rho)  # the hinge at the body origin
    np.testing.assert_allclose(edge[3, 3], 9 / 8 * rho * np.pi * a**4 * SPAN, rtol=1e-13)
    np.testing.assert_allclose(edge[2, 3], rho * np.pi * a**2 * SPAN * a, rtol=1e-13)


def test_added_inertia_of_a_triangle_by_sections():
    """A triangle (its chord varies along the span) against a fine midpoint sum over sections of
    the same strip-theory energy: the integrator's 4-point rule is exact for its piecewise
    polynomials, the sum converges as 1/N² (2e-7 at N = 4000)."""
    triangle = np.array([[0.0, 0.0, 0.0], [120.0, 30.0, 0.0], [40.0, 150.0, 0.0]])
    ours = np.asarray(polygon_added_inertia(triangle))
    n = 4000
    x = np.linspace(0, 120, n + 1)
    x = 0.5 * (x[1:] + x[:-1])
    # Edges: (0,0)-(120,30): y = x/4; (0,0)-(40,150): y = 3.75 x; (40,150)-(120,30): y = 150 − 1.5 (x − 40).
    lo = x / 4
    hi = np.where(x < 40, 3.75 * x, 150 - 1.5 * (x - 40))
    a, mid, dx = (hi - lo) / 2, (hi + lo) / 2, 120 / n
    lever = np.stack([np.ones_like(x), mid, -x])
    block = np.einsum("in,jn,n->ij", lever, lever, np.pi * a**2) * dx
    block[1, 1] += np.sum(np.pi * a**4 / 8) * dx
    np.testing.assert_allclose(ours[2:5, 2:5], block, rtol=2e-6)
    assert np.all(ours[:2] == 0) and np.all(ours[5] == 0)


def _single_flap(fluid: Fluid, parts, **overrides):
    design = HingeDesign.literature(fluid=fluid, **overrides)
    return design, accordion_system(design, 1, flap_length=CHORD, flap_width=SPAN, fluid=parts)


def test_single_flap_added_inertia_and_viscous_drag_are_the_closed_forms():
    """One flap on a point hinge: the fluid adds ``C_a Re Γ (9/8) ρ_f π a⁴ w`` to its inertia about
    the hinge and a torque ``−C_a ω Im Γ (9/8) ρ_f π a⁴ w θ̇``, ``ω = √(k / I)`` with ``I`` the flap's
    own plus the added inertia (a fixed point, converged here; the builder's passes reach it to
    ~1e-6), ``Re Γ``, ``Im Γ`` Sader's at ``Re = ρ_f ω c² / 4μ``. The strip value over the flap's own
    inertia is ``(27π/128) ρ_f c / (ρ_s t)``: ~276 in KOH, ~0.26 in air."""
    a = CHORD / 2
    for fluid in (KOH_SOLUTION, AIR):
        design, system = _single_flap(
            fluid, ("hinge", "added_mass", "viscous"), added_mass_coefficient=0.8
        )
        _, bare = _single_flap(fluid, ("hinge",))
        rho = float(design.fluid.density)
        closed = 0.8 * 9 / 8 * rho * np.pi * a**4 * SPAN
        own = float(bare.mechanism.mass_matrix(jnp.zeros(1))[0, 0])
        ratio = 27 * np.pi / 128 * rho * CHORD / (float(design.structural.density) * 0.2)
        np.testing.assert_allclose(closed / 0.8 / own, ratio, rtol=1e-6)  # own: t²/12 terms
        k = float(system.hinges.stiffness[0])
        frequency = np.sqrt(k / (own + closed * 1.0))
        for _ in range(40):  # the fixed point, to convergence
            re = rho * frequency * CHORD**2 / (4 * float(design.fluid.viscosity))
            real, imag = (float(x) for x in hydrodynamic_function(re))
            frequency = np.sqrt(k / (own + closed * real))
        q = jnp.array([1.3])
        added = float(system.mechanism.mass_matrix(q)[0, 0]) - own
        np.testing.assert_allclose(added, closed * real, rtol=1e-5)
        viscous = system.drag.parts[1]
        assert isinstance(viscous, ViscousDrag)
        torque = float(viscous.force(system.mechanism, q, jnp.array([0.02]))[0])
        np.testing.assert_allclose(torque, -closed * frequency * imag * 0.02, rtol=1e-5)


def test_fluid_loads_reject_a_fluid_without_viscosity():
    design = HingeDesign.literature(fluid=Fluid(1.2))
    with pytest.raises(ValueError, match="viscosity"):
        accordion_system(design, 2, fluid="extended")
    with pytest.raises(ValueError, match="choose one"):
        accordion_system(HingeDesign.literature(), 2, fluid=("hinge", "panel"))
    with pytest.raises(ValueError, match="fluid must be"):
        accordion_system(HingeDesign.literature(), 2, fluid="water")
    with pytest.raises(ValueError, match="panel tree"):
        fluid_loads(
            accordion_system(HingeDesign.literature(), 1).mechanism,
            jnp.zeros((1, 6, 6)),
            jnp.ones(1),
            jnp.ones(1),
            jnp.ones(1),
            density=1.0,
            viscosity=1.0,
        )


def test_viscosities_in_units():
    """Air 1.81e-5 Pa·s and 30 wt% KOH 2.2 mPa·s; MICRO's viscosity unit ng/(µm·µs) is 1 Pa·s."""
    np.testing.assert_allclose(AIR.to(MICRO).viscosity, 1.81e-5, rtol=1e-12)
    np.testing.assert_allclose(KOH_SOLUTION.to(MICRO).viscosity, 2.2e-3, rtol=1e-12)
    assert Fluid(1.0).to(MICRO).viscosity is None


# ---- a folding with every new term ----------------------------------------------------------------


@pytest.fixture(scope="module")
def koh_folding():
    """Two flaps on massive arc hinges in KOH, bilayer springs, quadratic panel drag, added inertia
    and viscous drag, stepped to (π, −π); 3 ms (the fluid's inertia, ~280 times the flaps', slows
    the fold to milliseconds), tight tolerances."""
    design = HingeDesign.literature(fluid=KOH_SOLUTION, stiffness_model="bilayer")
    system = accordion_system(design, 2, hinges="arc", fluid="extended")
    trajectory = sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(
            saveat=sim.SaveAt(n=1501),
            solver=diffrax.Tsit5(),
            stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-12),
        ),
        t1=3000.0,
    )
    return system, trajectory


@pytest.mark.slow  # one KOH folding with every fluid term; the terms are checked singly below
def test_energy_lost_is_the_fluids_dissipation(koh_folding):
    """Kinetic (flaps, strips and fluid) + spring energy − the step input's work ``Σ k θ_target θ``
    falls by exactly the work the fluid's drags take out, ``∫ Σ_parts (−q̇ᵀ f) dt`` (Simpson on the
    1501 samples: 1e-6 of the input's work, measured ~1e-8); most of the released energy is gone by
    then, and each part dissipates (none adds energy)."""
    system, trajectory = koh_folding
    assert isinstance(system.mechanism, StripTree) and isinstance(system.drag, CombinedDrag)
    balance, lost, scale, rates = stepped_energy_balance(system, trajectory)
    assert all(r.min() >= -1e-12 * np.abs(r).max() for r in rates)
    assert lost[-1] > 0.3 * scale
    np.testing.assert_allclose(balance, balance[0], atol=1e-6 * scale)


def _design_at(x):
    """The bilayer literature design in air with ``μ``, the film's misfit strain (its stress) and
    ``C_a`` scaled by ``exp(x₀)``, ``exp(x₁)`` and set to ``x₂``."""
    base = HingeDesign.literature(stiffness_model="bilayer")
    fluid = Fluid(AIR.density, name="air", viscosity=AIR.viscosity * jnp.exp(x[0]))
    return eqx.tree_at(
        lambda d: (d.fluid, d.misfit_strain, d.added_mass_coefficient),
        base,
        (fluid.to(MICRO), base.misfit_strain * jnp.exp(x[1]), x[2]),
    )


def _check_against_central_differences(function, x, h=1e-4, tolerance=1e-5):
    ours = np.asarray(jax.jit(jax.jacfwd(function))(x))
    value = jax.jit(function)
    central = np.stack(
        [(value(x + h * e) - value(x - h * e)) / (2 * h) for e in np.eye(x.shape[0])], axis=-1
    )
    assert np.all(np.max(np.abs(central), axis=tuple(range(central.ndim - 1))) > 0)
    np.testing.assert_allclose(ours, central, atol=tolerance * np.max(np.abs(central)))


@pytest.mark.slow  # every fluid term's derivatives through a folding; the terms' closed forms run by default
def test_derivatives_of_the_dynamics_match_finite_differences():
    """``∂θ̈/∂(log μ, log σ, C_a)`` of two flaps on massive arc hinges in air with panel drag, added
    inertia and viscous drag, at a folding state, by forward-mode autodiff through the whole build
    (strip geometry and mass, the frequency fixed point, Sader's function) and the dynamics, against
    central differences (step 1e-4: agreement to 1e-6 of the largest entry, measured ~1e-9): the
    viscosity reaches the drag and the added mass, the film stress the strip's length, its mass and
    the hinge's stiffness."""

    def acceleration(x):
        system = accordion_system(_design_at(x), 2, hinges="arc", fluid="extended")
        q, v = jnp.array([1.9, -0.7]), jnp.array([0.03, -0.05])
        return system.accelerations(q, v, system.hinges.stiffness * system.hinges.target)

    _check_against_central_differences(acceleration, jnp.array([0.0, 0.0, 0.8]), tolerance=1e-6)


@pytest.mark.slow
def test_derivatives_through_a_simulation_match_finite_differences():
    """``∂θ(t = 40 µs)/∂(log μ, log σ, C_a)`` of one flap on a massive arc hinge in air with the
    extended fluid, by forward-mode autodiff through `simulate` (`diffrax.ForwardMode`), against
    central differences (step 1e-4, rtol 1e-10 solves: agreement to 1e-5 of the largest entry)."""

    def angle(x):
        system = accordion_system(_design_at(x), 1, hinges="arc", fluid="extended")
        trajectory = sim.simulate(
            system,
            sim.Step(),
            sim.SolveOptions(
                saveat=sim.SaveAt(n=2),
                solver=diffrax.Tsit5(),
                stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-12),
                adjoint=diffrax.ForwardMode(),
            ),
            t1=40.0,
        )
        return trajectory.theta[-1]

    _check_against_central_differences(angle, jnp.array([0.0, 0.0, 0.8]))


@pytest.mark.slow
def test_panel_tree_twists_and_wrenches_match_autodiff():
    """`PanelTree.spatial_velocities` / `apply_wrenches` (motion subspaces) against the mechanism
    contract's autodiff defaults (differentiating the body poses), arc hinges included."""
    from origami_jax.system import AbstractMechanism

    system = accordion_system(HingeDesign.literature(), 3, hinges="arc")
    tree = system.mechanism.panels
    assert isinstance(tree, PanelTree)
    rng = np.random.default_rng(5)
    q, v = jnp.asarray(rng.uniform(-3, 3, 3)), jnp.asarray(rng.normal(size=3) * 0.05)
    wrenches = jnp.asarray(rng.normal(size=(3, 6)))
    ours = quick_jit(lambda t, q, v, w: (t.spatial_velocities(q, v), t.apply_wrenches(q, w)))
    reference = quick_jit(
        lambda t, q, v, w: (
            AbstractMechanism.spatial_velocities(t, q, v),
            AbstractMechanism.apply_wrenches(t, q, w),
        )
    )
    for a, b in zip(ours(tree, q, v, wrenches), reference(tree, q, v, wrenches), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * float(jnp.max(jnp.abs(b))))
