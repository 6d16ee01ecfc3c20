"""Published measurements of stressed bilayers, against the package's Timoshenko curvature.

Each `MeasuredHinge` holds a bilayer that a paper released and measured — the two films, their
misfit strain, the radius it rolled to — with the sentences every number was read from and the
assumptions that filled what the paper does not give. `compare_measured_hinges` predicts each radius
with `bilayer_curvature`, the formula `HingeDesign.curvature` uses, and reports the residual;
docs/guides/hinge-measurements.md is the table and its discussion.

Values are SI (metres, pascals). Only two published measurements with every input traceable were
found when the table was assembled; the guide says so, and where each number comes from.
"""

import dataclasses
from typing import NamedTuple

import jax.numpy as jnp

from ._hinge import biaxial_modulus, bilayer_curvature


@dataclasses.dataclass(frozen=True)
class MeasuredFilm:
    """One film of a measured bilayer (SI).

    **Fields:** `name`; `thickness` (m); `youngs_modulus` ``E`` (Pa) and `poisson_ratio` ``ν`` — for
    a (001) cubic crystal, the [100] values, whose ``E/(1 − ν) = C₁₁ + C₁₂ − 2C₁₂²/C₁₁`` is exactly
    the film's biaxial modulus.
    """

    name: str
    thickness: float
    youngs_modulus: float
    poisson_ratio: float

    @property
    def biaxial_modulus(self) -> float:
        """``E' = E / (1 − ν)`` (Pa)."""
        return float(biaxial_modulus(self.youngs_modulus, self.poisson_ratio))


@dataclasses.dataclass(frozen=True)
class MeasuredHinge:
    """A released bilayer whose radius a publication reports, with what the prediction needs.

    **Fields:**
    - `key`: a short name; `citation`: the publication; `url`: where its text was read.
    - `structural`, `stressed`: the two films, in the package's order (layer 1, layer 2: a positive
      misfit curls the bilayer towards layer 2).
    - `misfit_strain` ``ε``: how much the stressed film's stress-free in-plane size falls short of the
      structural film's (dimensionless; lattice mismatch for epitaxial films).
    - `measured_radius`: the radius of the bilayer's mid-surface that the measurement implies (m).
    - `measured`: what the source reports, in its words and units.
    - `quotes`: each sentence a number was taken from, with its address.
    - `assumptions`: everything the source does not give and the table assumes.
    """

    key: str
    citation: str
    url: str
    structural: MeasuredFilm
    stressed: MeasuredFilm
    misfit_strain: float
    measured_radius: float
    measured: str
    quotes: tuple[str, ...]
    assumptions: tuple[str, ...]


class HingeComparison(NamedTuple):
    """The package's prediction for one `MeasuredHinge`.

    **Fields:** `hinge`; `predicted_radius` ``|1/κ|`` from `bilayer_curvature` (m); `measured_radius`
    (m); `residual`: ``(predicted − measured) / measured``.
    """

    hinge: MeasuredHinge
    predicted_radius: float
    measured_radius: float
    residual: float


# Material constants, with the page each was read from:
# - Ga(x)In(1-x)As, http://matprop.ru/GaInAs_mechanic (Ioffe semiconductor data): "Lattice constant
#   ... (6.0583-0.405x) A", "[100] Young's modulus ... Yo= (5.14+3.39x)·10^11 dyn/cm2", "[100]
#   Poisson ratio ... σo = (0.35-0.04x)". InAs is x = 0, GaAs x = 1.
# - Si: "Lattice constant 5.431 A" (http://matprop.ru/Si_basic); "In <100> directions in the (100)
#   plane: G = E/[2(1+nu)] = 130 GPa/[2(1+0.279)] = 50.8 GPa" (http://memsnet.org/memstalk/5269,
#   after Brantley, J. Appl. Phys. 44 (1973) 534).
# - Ge: "Lattice constant 5.658 A" (http://matprop.ru/Ge_basic); "Elastic constant (dyn cm-2)
#   C11=12.6 ×10−11 at 300 K; C12=4.4 ×10−11 at 300 K" (http://www.globalsino.com/EM/page2063.html;
#   the exponent's sign is a misprint for 10^11 dyn/cm², 126 and 44 GPa), whence E[100] =
#   (C11+2C12)(C11−C12)/(C11+C12) and ν[100] = C12/(C11+C12).
_DYN_PER_CM2 = 0.1  # Pa
_A_INAS, _A_GAAS = 6.0583e-10, (6.0583 - 0.405) * 1e-10
_E_INAS, _E_GAAS = 5.14e11 * _DYN_PER_CM2, (5.14 + 3.39) * 1e11 * _DYN_PER_CM2
_NU_INAS, _NU_GAAS = 0.35, 0.35 - 0.04
_A_SI, _A_GE = 5.431e-10, 5.658e-10
_E_SI, _NU_SI = 130e9, 0.279
_C11_GE, _C12_GE = 12.6e11 * _DYN_PER_CM2, 4.4e11 * _DYN_PER_CM2
_E_GE = (_C11_GE + 2 * _C12_GE) * (_C11_GE - _C12_GE) / (_C11_GE + _C12_GE)
_NU_GE = _C12_GE / (_C11_GE + _C12_GE)
_X_GE = 0.4  # Si0.6Ge0.4: Vegard's linear interpolation of a, E and ν (an assumption)
_A_SIGE = (1 - _X_GE) * _A_SI + _X_GE * _A_GE
_E_SIGE = (1 - _X_GE) * _E_SI + _X_GE * _E_GE
_NU_SIGE = (1 - _X_GE) * _NU_SI + _X_GE * _NU_GE

_MATERIAL_QUOTES = {
    "GaInAs": (
        'http://matprop.ru/GaInAs_mechanic (GaxIn1-xAs; InAs x = 0, GaAs x = 1): "Lattice constant '
        '5.8687 A (6.0583-0.405x) A"; "[100] Young\'s modulus ... Yo= (5.14+3.39x)·1011 dyn/cm2"; '
        '"[100] Poisson ratio ... σo = (0.35-0.04x)"'
    ),
    "Si": (
        'http://matprop.ru/Si_basic: "Lattice constant 5.431 A"; http://memsnet.org/memstalk/5269: '
        '"In <100> directions in the (100) plane: G = E/[2(1+nu)] = 130 GPa/[2(1+0.279)] = 50.8 GPa."'
    ),
    "Ge": (
        'http://matprop.ru/Ge_basic: "Lattice constant 5.658 A"; '
        'http://www.globalsino.com/EM/page2063.html: "Elastic constant (dyn cm-2) C11=12.6 ×10−11 at '
        '300 K; C12=4.4 ×10−11 at 300 K"'
    ),
}

_PRINZ_INNER_RADIUS = 1e-9  # "inside diameter of ≈2 nm"
_PRINZ = MeasuredHinge(
    key="prinz2000",
    citation=(
        "V. Ya. Prinz, V. A. Seleznev, A. K. Gutakovsky, A. V. Chehovskiy, V. V. Preobrazhenskii, "
        "M. A. Putyato, T. A. Gavrilova, “Free-standing and overgrown InGaAs/GaAs nanotubes, "
        "nanohelices and their arrays”, Physica E 6 (2000) 828–831, doi:10.1016/S1386-9477(99)00249-0"
    ),
    url="https://www.bibsonomy.org/bibtex/248bb234709b3bcaa969a4c346ce3eb5b/bkoch",
    structural=MeasuredFilm("InAs (1 monolayer)", _A_INAS / 2, _E_INAS, _NU_INAS),
    stressed=MeasuredFilm("GaAs (1 monolayer)", _A_GAAS / 2, _E_GAAS, _NU_GAAS),
    misfit_strain=(_A_INAS - _A_GAAS) / _A_GAAS,
    measured_radius=_PRINZ_INNER_RADIUS + (_A_INAS + _A_GAAS) / 4,
    measured="nanotubes with an inside diameter of ≈2 nm",
    quotes=(
        "https://www.bibsonomy.org/bibtex/248bb234709b3bcaa969a4c346ce3eb5b/bkoch (the abstract): "
        '"Using an ultra-thin film (1 ML GaAs:1 ML InAs), nanotubes with an inside diameter of ≈2 nm '
        'have been obtained, which constitutes the limiting size for this system."',
        _MATERIAL_QUOTES["GaInAs"],
    ),
    assumptions=(
        "A monolayer of a (001) zinc-blende film is half its lattice constant (InAs 0.303 nm, GaAs "
        "0.283 nm), each at its own bulk lattice constant.",
        "The misfit is the bulk lattice mismatch (a_InAs − a_GaAs)/a_GaAs = 7.16 %, fully coherent.",
        "Bulk [100] elastic constants (Ioffe data), although each film is a single monolayer.",
        "The mid-surface radius is the inside radius (1 nm) plus half the bilayer (0.293 nm).",
    ),
)

_ZHANG = MeasuredHinge(
    key="zhang2006",
    citation=(
        "L. Zhang, L. X. Dong, D. J. Bell, B. J. Nelson, C. Schönenberger, D. Grützmacher, “Euler "
        "buckling of individual SiGe/Si microtubes”, Technical Proceedings of the 2006 NSTI "
        "Nanotechnology Conference and Trade Show, Vol. 1, pp. 42–45 (2006); the layer stack from "
        "L. Dong, L. Zhang, B. E. Kratochvil, K. Shou, B. J. Nelson, “Dual-chirality helical "
        "nanobelts: linear-to-rotary motion converters for three-dimensional microscopy” (IEEE)"
    ),
    url="http://www.nsti.org/procs/Nanotech2006v1/1/T60.806",
    structural=MeasuredFilm("Si0.6Ge0.4", 8e-9, _E_SIGE, _NU_SIGE),
    stressed=MeasuredFilm("Si", 10e-9, _E_SI, _NU_SI),
    misfit_strain=(_A_SIGE - _A_SI) / _A_SI,
    measured_radius=1.3e-6 / 2,
    measured="Si/SiGe bilayers of 18 nm thickness rolled into tubes of 1.3 µm diameter",
    quotes=(
        "http://www.nsti.org/procs/Nanotech2006v1/1/T60.806 (the abstract; also "
        'https://briefs.techconnect.org/?p=3300): "Si/SiGe bilayers of 18 nm thickness have been '
        'rolled into tubes of 1.3 μm diameter."',
        "https://studylib.net/doc/18140127/dual-chirality-helical-nanobelts--linear-to (the "
        'abstract): "The conversion ratios of displacement and load for a SiGe/Si DCHNB (an '
        "8-nm-thick Si0.6 Ge0.4 and a 10-nm-thick Si layer) are found to be 171.3◦ /µm and "
        '2.110 × 10−6 N · m/N, respectively."',
        _MATERIAL_QUOTES["Si"],
        _MATERIAL_QUOTES["Ge"],
    ),
    assumptions=(
        "The tube paper gives only the total, 18 nm: the split (8 nm Si0.6Ge0.4 + 10 nm Si) and "
        "the Ge fraction are those of the same group's nanobelt paper, whose stack adds up to 18 nm. "
        "That the tubes used this stack is an assumption.",
        "Si0.6Ge0.4 by Vegard's law between Si and Ge: lattice constant, E[100] and ν[100] "
        "interpolated linearly (misfit 1.67 %, fully coherent, no relaxation).",
        "The reported 1.3 µm diameter is taken as the mid-surface diameter (the 18 nm wall shifts "
        "the radius by at most 9 nm, 1.4 %).",
    ),
)

MEASURED_HINGES: tuple[MeasuredHinge, ...] = (_PRINZ, _ZHANG)
"""The published measurements the table compares with, each with its sources and assumptions."""


def _predicted_radius(hinge: MeasuredHinge) -> float:
    """``|1/κ|`` (m) for `hinge` by `bilayer_curvature` (Timoshenko), the formula of
    `HingeDesign.curvature`, with the films' biaxial moduli ``E/(1 − ν)``."""
    kappa = bilayer_curvature(
        jnp.asarray(hinge.structural.biaxial_modulus),
        jnp.asarray(hinge.structural.thickness),
        jnp.asarray(hinge.stressed.biaxial_modulus),
        jnp.asarray(hinge.stressed.thickness),
        jnp.asarray(hinge.misfit_strain),
    )
    return abs(1.0 / float(kappa))


def compare_measured_hinges(
    hinges: tuple[MeasuredHinge, ...] = MEASURED_HINGES,
) -> tuple[HingeComparison, ...]:
    """Predict each measured bilayer's radius with the package's formula and report the residual.

    **Returns:** one `HingeComparison` per hinge, in order. Needs float64
    (``jax.config.update("jax_enable_x64", True)``) for the radii to carry more than 7 digits.
    """
    rows = []
    for hinge in hinges:
        predicted = _predicted_radius(hinge)
        measured = hinge.measured_radius
        rows.append(HingeComparison(hinge, predicted, measured, (predicted - measured) / measured))
    return tuple(rows)


def _length(metres: float) -> str:
    return f"{metres * 1e9:.3g} nm" if metres < 1e-6 else f"{metres * 1e6:.3g} µm"


def measured_hinges_table(comparisons: tuple[HingeComparison, ...] | None = None) -> str:
    """The comparison as a Markdown table: the films (thickness ``t``, biaxial modulus ``E'``), the
    misfit, the measured and predicted radius, the residual."""
    if comparisons is None:
        comparisons = compare_measured_hinges()
    lines = [
        "| source | structural film (layer 1) | stressed film (layer 2) | misfit ε | "
        "measured radius | predicted radius | residual |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for row in comparisons:
        hinge = row.hinge
        films = [
            f"{film.name}, t = {film.thickness * 1e9:.3g} nm, E' = {film.biaxial_modulus / 1e9:.1f} GPa"
            for film in (hinge.structural, hinge.stressed)
        ]
        lines.append(
            f"| `{hinge.key}` | {films[0]} | {films[1]} | {hinge.misfit_strain:.4f} | "
            f"{_length(row.measured_radius)} | {_length(row.predicted_radius)} | "
            f"{row.residual:+.0%} |"
        )
    return "\n".join(lines)
