"""Hinge physics: materials, fluids, the Timoshenko bilayer, hinge stiffness and drag (paper Eqs. 7, 11).

A stressed chromium film on a silicon-nitride membrane curls the hinge to radius ``ρ`` (Timoshenko); the
hinge length that folds the flap by ``θ_final`` is ``l = ρ θ_final``; the hinge is a spring of stiffness
``k`` and each flap feels quadratic drag ``b θ̇|θ̇|`` from the fluid it folds in. `HingeDesign` holds every
physical parameter as a pytree leaf, so gradients flow from any of them through `stiffness` and `drag` to
the dynamics. Constants are defined in SI and converted into the design's `UnitSystem` (default `MICRO`:
µm, µs, ng ⇒ stress MPa, torque µN·µm = pN·m).
"""

import math
from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._typing import FloatsLike
from .._validate import as_float_array, check_finite, check_positive, is_traced
from ._units import MICRO, SI, UnitSystem


class Material(eqx.Module):
    """An isotropic elastic thin film.

    **Fields:**
    - `youngs_modulus`: ``E``, stress units of `units` (Pa in SI, MPa in MICRO).
    - `poisson_ratio`: ``ν``, dimensionless, in (−1, ½).
    - `density`: mass/length³ of `units` (kg/m³ in SI, ng/µm³ in MICRO).
    - `units`: the unit system of the values (static), SI by default.
    """

    youngs_modulus: Float[Array, "..."]
    poisson_ratio: Float[Array, "..."]
    density: Float[Array, "..."]
    units: UnitSystem = eqx.field(static=True)

    def __init__(
        self,
        youngs_modulus: ArrayLike,
        poisson_ratio: ArrayLike,
        density: ArrayLike,
        units: UnitSystem = SI,
    ):
        self.youngs_modulus = check_positive(
            as_float_array(youngs_modulus, "youngs_modulus"), "youngs_modulus", "stress"
        )
        nu = check_finite(as_float_array(poisson_ratio, "poisson_ratio"), "poisson_ratio")
        if is_traced(nu):
            nu = eqx.error_if(nu, (nu <= -1) | (nu >= 0.5), "poisson_ratio must lie in (-1, 0.5).")
        elif np.any((np.asarray(nu) <= -1) | (np.asarray(nu) >= 0.5)):
            raise ValueError(f"poisson_ratio must lie in (-1, 0.5) for a stable solid, got {nu}.")
        self.poisson_ratio = nu
        self.density = check_positive(as_float_array(density, "density"), "density", "mass/length³")
        self.units = units

    @property
    def biaxial_modulus(self) -> Float[Array, "..."]:
        """``E' = E / (1 − ν)``, the modulus of a film under equal in-plane biaxial strain (stress units)."""
        return self.youngs_modulus / (1 - self.poisson_ratio)

    def to(self, units: UnitSystem) -> "Material":
        """The same material with its values expressed in `units`."""
        if units == self.units:
            return self
        return Material(
            units.stress(self.units.to_si(self.youngs_modulus, mass=1, length=-1, time=-2)),
            self.poisson_ratio,
            units.density(self.units.to_si(self.density, mass=1, length=-3)),
            units,
        )


LIQUID_DENSITY = 100.0
"""The density (kg/m³) from which a `Fluid` is a liquid: every liquid is denser (water 1000, KOH
baths ~1300, liquid hydrocarbons from ~600), every gas at ordinary pressures lighter (air 1.2)."""


class Fluid(eqx.Module):
    """The fluid the flaps fold in.

    Its density enters the quadratic (pressure) drag and the added (fluid) inertia; its dynamic
    viscosity the viscous (linear) drag and the viscous correction of the added inertia
    (`origami_jax.fluid`; docs/physics.md, "The fluid moves with the flap"). The paper's model uses the
    density only.

    **Fields:** `density` (mass/length³ of `units`), `viscosity` (dynamic viscosity, mass/(length·time)
    of `units`: Pa·s in SI, ng/(µm·µs) = Pa·s in MICRO; `None` when unknown: the viscous models then
    refuse the fluid), `units` (static, SI by default), `name` (static), `liquid` (static: `True`
    for a liquid such as the etch bath, `False` for a gas; by default from the density, a liquid
    from `LIQUID_DENSITY` (100 kg/m³) up — every liquid is above it, every gas at ordinary
    pressures below 10 kg/m³; `None` when the density is traced and `liquid` not given). A net in
    a liquid carries the fluid's inertia by default (`origami_jax.net.Net.system`).
    """

    density: Float[Array, "..."]
    viscosity: Float[Array, "..."] | None
    units: UnitSystem = eqx.field(static=True)
    name: str = eqx.field(static=True)
    liquid: bool | None = eqx.field(static=True)

    def __init__(
        self,
        density: ArrayLike,
        units: UnitSystem = SI,
        name: str = "fluid",
        *,
        viscosity: ArrayLike | None = None,
        liquid: bool | None = None,
    ):
        self.density = check_positive(as_float_array(density, "density"), "density", "mass/length³")
        if liquid is None and not is_traced(self.density):
            si_density = np.asarray(units.to_si(np.asarray(self.density), mass=1, length=-3))
            liquid = bool(np.all(si_density >= LIQUID_DENSITY))
        elif liquid is not None and not isinstance(liquid, bool):
            raise ValueError(f"liquid must be True, False or None, got {liquid!r}.")
        self.liquid = liquid
        self.viscosity = (
            None
            if viscosity is None
            else check_positive(
                as_float_array(viscosity, "viscosity"), "viscosity", "mass/(length·time)"
            )
        )
        self.units = units
        self.name = name

    def to(self, units: UnitSystem) -> "Fluid":
        """The same fluid with its values expressed in `units`."""
        if units == self.units:
            return self
        viscosity = None
        if self.viscosity is not None:
            viscosity = units.from_si(
                self.units.to_si(self.viscosity, mass=1, length=-1, time=-1),
                mass=1,
                length=-1,
                time=-1,
            )
        return Fluid(
            units.density(self.units.to_si(self.density, mass=1, length=-3)),
            units,
            self.name,
            viscosity=viscosity,
            liquid=self.liquid,
        )


# Sources:
# - SiNx (LPCVD low-stress silicon nitride): E ≈ 250 GPa, ν ≈ 0.23, ρ ≈ 3100 kg/m³. Petersen, "Silicon as a
#   mechanical material", Proc. IEEE 70 (1982) 420 (E); MEMSnet/MatWeb LPCVD Si3N4 data (ν, ρ); the 200 nm
#   membranes of the paper's Fig. 4.
# - Cr (evaporated film, bulk values): E ≈ 279 GPa, ν ≈ 0.21, ρ ≈ 7190 kg/m³. CRC Handbook of Chemistry and
#   Physics, "Elastic constants of metals" and "Density of elements"; Kaye & Laby, Tables of Physical and
#   Chemical Constants §2.2.2.
SINX = Material(250e9, 0.23, 3100.0)
"""Low-stress LPCVD silicon nitride, SI values (structural membrane)."""
CR = Material(279e9, 0.21, 7190.0)
"""Chromium, SI values (stressed hinge film)."""

# - Air at 20 °C and 1 atm: density 1.204 kg/m³ (ideal gas, 28.96 g/mol), dynamic viscosity
#   1.81e-5 Pa·s (CRC Handbook of Chemistry and Physics, "Properties of dry air" and "Viscosity of
#   gases").
# - KOH etch bath, 30 wt% aqueous KOH at 20 °C: density 1.29 g/cm³, dynamic viscosity 2.2 mPa·s (CRC
#   Handbook, "Concentrative properties of aqueous solutions", KOH; consistent with Sipos, Hefter &
#   May, J. Chem. Eng. Data 45 (2000) 613, at 25 °C). The fold happens while the hinge is released in
#   this bath; at the usual 80 °C the density is ~2 % lower and the viscosity about half.
AIR = Fluid(1.204, SI, "air", viscosity=1.81e-5)
"""Air at 20 °C, 1 atm (SI)."""
KOH_SOLUTION = Fluid(1290.0, SI, "30 wt% KOH solution", viscosity=2.2e-3)
"""30 wt% aqueous KOH at 20 °C (SI)."""

# Literature defaults (paper Fig. 4): 200 nm SiNx, 100 nm Cr, ~1 GPa tensile residual stress in the
# evaporated Cr. The paper gives neither the hinge width nor C_D: a hinge spanning the 200 µm width of
# the paper's square flaps (the flaps themselves are the accordion pattern's,
# `origami_jax.chain.Accordion`), and C_D = 1.17 for a flat plate broadside to the flow (Hoerner,
# Fluid-Dynamic Drag, 1965, ch. 3), are our choices, not the paper's.
_LITERATURE_SI = dict(
    hinge_width=200e-6,
    t_structural=200e-9,
    t_hinge=100e-9,
    residual_stress=1e9,
)
_LITERATURE_THETA_FINAL = jnp.pi
_LITERATURE_DRAG_COEFFICIENT = 1.17
# Fields a HingeDesign once carried and no longer does: the accordion's flap geometry.
_MOVED_TO_PATTERN = ("flap_length", "flap_width")


def _moved(name: str) -> str:
    return (
        f"HingeDesign has no {name}: the flap geometry belongs to the accordion pattern, use "
        f"Accordion({name}=...) (origami_jax.chain; accordion_system takes it too)."
    )


def biaxial_modulus(youngs_modulus: ArrayLike, poisson_ratio: ArrayLike) -> Array:
    """``E' = E / (1 − ν)`` (units of `youngs_modulus`)."""
    return jnp.asarray(youngs_modulus) / (1 - jnp.asarray(poisson_ratio))


def bilayer_curvature(
    biaxial_1: ArrayLike,
    thickness_1: ArrayLike,
    biaxial_2: ArrayLike,
    thickness_2: ArrayLike,
    misfit_strain: ArrayLike,
) -> Array:
    """Timoshenko curvature of a bilayer with misfit strain ``ε`` (the paper's Eq. 7 is misprinted; docs/physics.md).

    ``κ = 6 E₁' E₂' t₁ t₂ (t₁ + t₂) ε / (E₁'² t₁⁴ + E₂'² t₂⁴ + 2 E₁' E₂' t₁ t₂ (2t₁² + 3t₁t₂ + 2t₂²))``.
    As ``t₂ → 0`` it tends to Stoney's ``6 E₂' t₂ ε / (E₁' t₁²)``.

    **Arguments:** biaxial moduli ``E'`` (any stress unit, the same for both), thicknesses ``t`` (length),
    layer 1 the structural film, layer 2 the stressed one; `misfit_strain` ``ε`` (dimensionless, > 0 curls
    towards layer 2).

    **Returns:** ``κ = 1/ρ`` in 1/length.
    """
    e1, t1, e2, t2, eps = (
        jnp.asarray(x) for x in (biaxial_1, thickness_1, biaxial_2, thickness_2, misfit_strain)
    )
    numerator = 6 * e1 * e2 * t1 * t2 * (t1 + t2) * eps
    denominator = (
        e1**2 * t1**4
        + e2**2 * t2**4
        + 2 * e1 * e2 * t1 * t2 * (2 * t1**2 + 3 * t1 * t2 + 2 * t2**2)
    )
    return numerator / denominator


def _check_fold_angle(theta_final: Array) -> None:
    """A fold angle is at most π (the flap folded flat onto its neighbour): a larger value is almost
    always degrees given for radians, and the hinge length ``l = ρ θ_final`` follows it silently
    (100 "rad" makes a 7.8 mm hinge). Checked when the value is known (traced values, e.g. inside
    a fit, are bounded by the fit)."""
    if is_traced(theta_final):
        return
    largest = float(np.max(np.asarray(theta_final)))
    if largest > math.pi * (1 + 1e-6):  # π rounded to float32 is a little above π
        raise ValueError(
            f"theta_final is a fold angle in radians, at most π (180°, the flap folded flat onto "
            f"its neighbour); got {largest:g} rad ({math.degrees(largest):.4g}°), which "
            "would make the hinge ρ·θ_final long. Give radians (numpy.radians converts degrees)."
        )


class HingeDesign(eqx.Module):
    """Physical parameters of bilayer hinges, from which ``k`` and ``b`` per hinge follow.

    Every numeric field is a pytree leaf (scalar, or shape `(n,)` for per-hinge values) in the units of
    `units` (default `MICRO`: lengths µm, stresses MPa, densities ng/µm³), so `jax.grad` reaches any of them.
    Build the Fig. 4 defaults with `HingeDesign.literature()`. The panels the hinges fold are the
    pattern's (a net's panels, the accordion's flaps: `origami_jax.chain.Accordion(flap_length=...,
    flap_width=...)`), not the design's.

    **Fields:**
    - `hinge_width` ``w`` (length).
    - `t_structural` ``t₁`` (SiNx membrane and flap), `t_hinge` ``t₂`` (Cr film) (length).
    - `misfit_strain` ``ε`` (dimensionless; pass `residual_stress` to the constructor instead to get
      ``ε = σ / E₂'``).
    - `theta_final`: the fold angle the free hinge reaches, rad, in (0, π] (``l = ρ θ_final``).
    - `drag_coefficient` ``C_D`` (dimensionless).
    - `structural`, `hinge`: `Material`s (converted into `units`); `fluid`: `Fluid` (converted).
    - `k_scale`, `b_scale`: dimensionless factors on ``k`` and ``b`` (calibration knobs), default 1.
    - `added_mass_coefficient` ``C_a`` (dimensionless, default 1): the fluid inertia of a panel is
      ``C_a`` times the two-dimensional potential-flow (strip theory) value (`origami_jax.fluid`); a
      finite square plate has about 0.58 of it (docs/physics.md, "The fluid moves with the flap"). Only
      the extended fluid model reads it.
    - `stiffness_model` (static): `"paper"` ``k = w (E₁'t₁³ + E₂'t₂³) / (3 l)`` (default), `"plate"`,
      each film's own plate bending, ``/(12 l)`` — a factor 4 softer (docs/physics.md, "Where the
      paper's formulas are questionable") — or `"bilayer"`, ``k = w D / l`` with ``D`` the flexural
      rigidity of the bonded bilayer about its neutral axis (`flexural_rigidity`): the bending energy
      ``½ w l D (κ − κ₀)²`` of a strip of length ``l`` held at curvature ``κ = θ / l`` away from its
      Timoshenko curvature ``κ₀ = θ_final / l``.
    - `drag_model` (static): `"paper"` ``b = C_D ν A L³ / 16`` (default) or `"strip"`, quadratic drag
      integrated along the plate, ``/8`` (``A`` and ``L`` the folded panel's, see `drag`).
    - `units` (static).
    """

    hinge_width: Float[Array, "..."]
    t_structural: Float[Array, "..."]
    t_hinge: Float[Array, "..."]
    misfit_strain: Float[Array, "..."]
    theta_final: Float[Array, "..."]
    drag_coefficient: Float[Array, "..."]
    structural: Material
    hinge: Material
    fluid: Fluid
    k_scale: Float[Array, "..."]
    b_scale: Float[Array, "..."]
    added_mass_coefficient: Float[Array, "..."]
    stiffness_model: Literal["paper", "plate", "bilayer"] = eqx.field(static=True)
    drag_model: Literal["paper", "strip"] = eqx.field(static=True)
    units: UnitSystem = eqx.field(static=True)

    def __init__(
        self,
        *,
        hinge_width: FloatsLike,
        t_structural: FloatsLike,
        t_hinge: FloatsLike,
        misfit_strain: FloatsLike | None = None,
        residual_stress: FloatsLike | None = None,
        theta_final: FloatsLike = _LITERATURE_THETA_FINAL,
        drag_coefficient: FloatsLike = _LITERATURE_DRAG_COEFFICIENT,
        structural: Material = SINX,
        hinge: Material = CR,
        fluid: Fluid = AIR,
        k_scale: FloatsLike = 1.0,
        b_scale: FloatsLike = 1.0,
        added_mass_coefficient: FloatsLike = 1.0,
        stiffness_model: str = "paper",  # str, not Literal: a wrong value gets the ValueError below
        drag_model: str = "paper",
        units: UnitSystem = MICRO,
        **moved,
    ):
        for name in _MOVED_TO_PATTERN:
            if name in moved:
                raise ValueError(_moved(name))
        if moved:
            raise TypeError(f"HingeDesign got unexpected keyword argument(s) {sorted(moved)}.")
        if stiffness_model not in ("paper", "plate", "bilayer"):
            raise ValueError(
                f"stiffness_model must be 'paper', 'plate' or 'bilayer', got {stiffness_model!r}."
            )
        if drag_model not in ("paper", "strip"):
            raise ValueError(f"drag_model must be 'paper' or 'strip', got {drag_model!r}.")
        if (misfit_strain is None) == (residual_stress is None):
            raise ValueError(
                "Give exactly one of misfit_strain (dimensionless) or residual_stress (stress units of "
                "`units`, MPa in MICRO); the strain follows from the stress as ε = σ / E₂'."
            )
        self.units = units
        self.stiffness_model = stiffness_model
        self.drag_model = drag_model
        self.structural = structural.to(units)
        self.hinge = hinge.to(units)
        self.fluid = fluid.to(units)
        for name, value in (
            ("hinge_width", hinge_width),
            ("t_structural", t_structural),
            ("t_hinge", t_hinge),
            ("theta_final", theta_final),
            ("drag_coefficient", drag_coefficient),
        ):
            setattr(self, name, check_positive(as_float_array(value, name), name))
        _check_fold_angle(self.theta_final)
        if misfit_strain is None:
            assert residual_stress is not None  # exactly one of the two was checked above
            stress = check_positive(
                as_float_array(residual_stress, "residual_stress"), "residual_stress"
            )
            misfit_strain = stress / self.hinge.biaxial_modulus
        self.misfit_strain = check_positive(
            as_float_array(misfit_strain, "misfit_strain"),
            "misfit_strain",
            "tensile misfit in the hinge film, which curls the hinge towards it",
        )
        self.k_scale = check_positive(as_float_array(k_scale, "k_scale"), "k_scale")
        self.b_scale = check_positive(as_float_array(b_scale, "b_scale"), "b_scale")
        self.added_mass_coefficient = check_positive(
            as_float_array(added_mass_coefficient, "added_mass_coefficient"),
            "added_mass_coefficient",
        )

    @classmethod
    def literature(cls, units: UnitSystem = MICRO, **overrides) -> "HingeDesign":
        """Fig. 4 defaults in `units`: 200 nm SiNx, 100 nm Cr at 1 GPa residual stress, 200 µm wide
        hinges (as wide as the paper's square flaps), ``θ_final = π``, ``C_D = 1.17``, air.

        `overrides` replace any constructor argument, in `units` (e.g. ``fluid=KOH_SOLUTION``,
        ``k_scale=3.07``, ``misfit_strain=2e-3``).
        """
        kwargs = {
            "hinge_width": units.length(_LITERATURE_SI["hinge_width"]),
            "t_structural": units.length(_LITERATURE_SI["t_structural"]),
            "t_hinge": units.length(_LITERATURE_SI["t_hinge"]),
        }
        if "misfit_strain" not in overrides:
            kwargs["residual_stress"] = units.stress(_LITERATURE_SI["residual_stress"])
        kwargs.update(overrides)
        return cls(units=units, **kwargs)

    def __getattr__(self, name: str):
        # Only reached for attributes the design does not have: the flap geometry gets a pointer to
        # where it moved.
        if name in _MOVED_TO_PATTERN:
            raise AttributeError(_moved(name))
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def curvature(self) -> Array:
        """Timoshenko curvature ``κ = 1/ρ`` of the hinge (1/length)."""
        return bilayer_curvature(
            self.structural.biaxial_modulus,
            self.t_structural,
            self.hinge.biaxial_modulus,
            self.t_hinge,
            self.misfit_strain,
        )

    def radius(self) -> Array:
        """Radius of curvature ``ρ`` of the free hinge (length); ≈ 78 µm with literature values."""
        return 1 / self.curvature()

    def hinge_length(self) -> Array:
        """``l = ρ θ_final`` (length): the arc that bends by ``θ_final`` at the free curvature."""
        return self.radius() * self.theta_final

    def flexural_rigidity(self) -> Array:
        """Bending rigidity ``D`` of the bonded bilayer strip per unit width (torque, µN·µm in MICRO).

        ``D = (E₁²t₁⁴ + E₂²t₂⁴ + 2 E₁E₂t₁t₂(2t₁² + 3t₁t₂ + 2t₂²)) / (12 (E₁t₁ + E₂t₂))``, the two layers'
        ``Σ E_i (t_i³/12 + t_i d_i²)`` about their common neutral axis (the denominator of the
        Timoshenko curvature, Eq. 7, over ``12 (E₁t₁ + E₂t₂)``), with the plate moduli
        ``E_i = E / (1 − ν²)`` of a strip in cylindrical bending (a wide strip keeps the crease
        straight; Timoshenko & Woinowsky-Krieger, *Theory of Plates and Shells*, 1959, §1–2).
        """
        e1 = self.structural.youngs_modulus / (1 - self.structural.poisson_ratio**2)
        e2 = self.hinge.youngs_modulus / (1 - self.hinge.poisson_ratio**2)
        t1, t2 = self.t_structural, self.t_hinge
        numerator = (
            e1**2 * t1**4
            + e2**2 * t2**4
            + 2 * e1 * e2 * t1 * t2 * (2 * t1**2 + 3 * t1 * t2 + 2 * t2**2)
        )
        return numerator / (12 * (e1 * t1 + e2 * t2))

    def strip_areal_density(self) -> Array:
        """Mass per unit area of the hinge strip, ``ρ₁t₁ + ρ₂t₂`` (membrane and stressed film;
        mass/length², ng/µm² in MICRO)."""
        return self.structural.density * self.t_structural + self.hinge.density * self.t_hinge

    def stiffness(self, n_joints: int) -> Float[Array, " n"]:
        """Rotational stiffness ``k`` of each hinge, shape `(n_joints,)`, torque/rad (µN·µm in MICRO).

        ``k = k_scale · w (E₁'t₁³ + E₂'t₂³) / (c l)`` with ``c = 3`` (`"paper"`) or 12 (`"plate"`);
        ``k = k_scale · w D / l`` (`"bilayer"`, `flexural_rigidity`).
        """
        if self.stiffness_model == "bilayer":
            rigidity = self.flexural_rigidity()
        else:
            bending = (
                self.structural.biaxial_modulus * self.t_structural**3
                + self.hinge.biaxial_modulus * self.t_hinge**3
            )
            rigidity = bending / (3.0 if self.stiffness_model == "paper" else 12.0)
        k = self.k_scale * self.hinge_width * rigidity / self.hinge_length()
        return jnp.broadcast_to(k, (n_joints,))

    def drag(
        self, n_joints: int, flap_length: ArrayLike, flap_width: ArrayLike
    ) -> Float[Array, " n"]:
        """Quadratic drag coefficient ``b`` of each hinge folding a rectangular flap of length
        ``L`` = `flap_length` (away from the hinge) and width `flap_width` (along it), both in
        length units of the design (the accordion pattern's, `origami_jax.chain.Accordion`);
        shape `(n_joints,)`, torque·time²/rad².

        ``b = b_scale · C_D ν A L³ / c`` with ``A = L × flap_width``, ``ν`` the fluid density and ``c = 16``
        (`"paper"`) or 8 (`"strip"`).
        """
        flap_length = jnp.asarray(flap_length)
        area = flap_length * flap_width
        denominator = 16.0 if self.drag_model == "paper" else 8.0
        b = (
            self.b_scale
            * self.drag_coefficient
            * self.fluid.density
            * area
            * flap_length**3
            / denominator
        )
        return jnp.broadcast_to(b, (n_joints,))
