"""Physically plausible ranges of the hinge design's parameters, with where each comes from.

A calibration that frees a parameter should keep it inside what the device can be: a film's
thickness within its deposition tolerance, a modulus within what thin films of that material
measure, a residual stress within what the deposition gives. Fitting outside these ranges reproduces
a figure with a device that cannot exist; when no plausible set reaches the targets, the model is
missing an effect, and the calibration report says so (docs/physics.md, "Calibrating the extended
model").

Values in the `MICRO` unit system (µm, MPa, dimensionless) of `HingeDesign`; `misfit_strain` is the
residual stress over the film's biaxial modulus (``σ / E₂'``, ``E₂' = 353 GPa`` for Cr).
"""

import dataclasses

from ..system import CR


@dataclasses.dataclass(frozen=True)
class PlausibleRange:
    """A parameter's plausible range (`lower`, `upper`, in `MICRO` units) and its `source`."""

    lower: float
    upper: float
    source: str


_CR_BIAXIAL_MPA = float(CR.biaxial_modulus) * 1e-6

PLAUSIBLE_RANGES: dict[str, PlausibleRange] = {
    "misfit_strain": PlausibleRange(
        300.0 / _CR_BIAXIAL_MPA,
        1500.0 / _CR_BIAXIAL_MPA,
        "residual stress of evaporated Cr films 0.3-1.5 GPa tensile (the paper's ~1 GPa ± 50 %; "
        "Klokholm & Berry, J. Electrochem. Soc. 115 (1968) 823; Hoffman, Thin Solid Films 34 "
        "(1976) 185), over Cr's biaxial modulus",
    ),
    "t_hinge": PlausibleRange(
        0.09,
        0.11,
        "100 nm Cr (paper Fig. 4) ± 10 %, e-beam evaporation with a quartz-crystal monitor",
    ),
    "t_structural": PlausibleRange(
        0.19, 0.21, "200 nm LPCVD SiNx (paper Fig. 4) ± 5 %, the deposition's uniformity"
    ),
    "hinge.youngs_modulus": PlausibleRange(
        180e3,
        280e3,
        "thin-film Cr: nanoindentation and bulge tests give 180-280 GPa, bulk 279 GPa (CRC)",
    ),
    "structural.youngs_modulus": PlausibleRange(
        200e3,
        300e3,
        "LPCVD SiNx, 200-300 GPa with stoichiometry and anneal (Petersen, Proc. IEEE 70 (1982) "
        "420; MEMS data compilations)",
    ),
    "hinge_width": PlausibleRange(
        20.0,
        200.0,
        "not given in the paper; at most the 200 µm flap width the model assumes",
    ),
    "drag_coefficient": PlausibleRange(
        1.1,
        2.0,
        "flat plate broadside to the flow: 1.17 (square or disk) to 1.98 (two-dimensional strip) "
        "(Hoerner, Fluid-Dynamic Drag, 1965, ch. 3)",
    ),
    "added_mass_coefficient": PlausibleRange(
        0.58,
        1.0,
        "fraction of the 2-D strip-theory added mass: 0.58 for a square plate (DNV-RP-C205, "
        "2010, Table A-2) to 1 (an infinitely long plate)",
    ),
}
"""Plausible ranges of the `HingeDesign` parameters a Fig. 7 calibration may free (module
docstring). The fluid's density and viscosity (air, KOH solution) are known well enough to stay
fixed; `k_scale` and `b_scale` are model corrections, not properties of the device."""


def plausible_bounds(names) -> dict[str, tuple[float, float]]:
    """``{name: (lower, upper)}`` for `names` from `PLAUSIBLE_RANGES` (`KeyError` for others)."""
    return {name: (PLAUSIBLE_RANGES[name].lower, PLAUSIBLE_RANGES[name].upper) for name in names}
