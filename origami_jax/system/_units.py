"""Consistent unit systems, so that kernels stay unit-agnostic and numbers stay O(1).

The chain kernels (kinematics, mass matrix, dynamics) never look at units: any consistent system works.
Physical constants (moduli, densities, residual stress) are defined once in SI and converted into the
system a builder is asked for. ``MICRO`` (µm, µs, ng) is the default because, in float32, SI values of a
200 µm flap give ``det(M) ≈ 1e-55``, which underflows; in ``MICRO`` the same numbers are O(1)–O(1e6).
"""

import dataclasses


@dataclasses.dataclass(frozen=True)
class UnitSystem:
    """A consistent (length, time, mass) unit system, given by the SI value of each base unit.

    Derived units follow: force = mass·length/time², torque = force·length, stress = force/length²,
    density = mass/length³, rotational stiffness = torque/rad, quadratic drag = torque·time²/rad².

    **Fields:**
    - `name`: a label for messages.
    - `metre_per_length`: metres in one length unit (1e-6 for µm).
    - `second_per_time`: seconds in one time unit (1e-6 for µs).
    - `kilogram_per_mass`: kilograms in one mass unit (1e-12 for ng).
    """

    name: str
    metre_per_length: float
    second_per_time: float
    kilogram_per_mass: float

    def __post_init__(self):
        for field in ("metre_per_length", "second_per_time", "kilogram_per_mass"):
            value = getattr(self, field)
            if not (isinstance(value, int | float) and value > 0):
                raise ValueError(f"UnitSystem.{field} must be a positive number, got {value!r}.")

    @property
    def length_symbol(self) -> str:
        """The length unit's symbol for printing ("µm"; a number of metres when it has no name)."""
        return _symbol(self.metre_per_length, "m")

    @property
    def time_symbol(self) -> str:
        """The time unit's symbol for printing ("µs"; a number of seconds when it has no name)."""
        return _symbol(self.second_per_time, "s")

    def scale(self, *, length: int = 0, time: int = 0, mass: int = 0) -> float:
        """SI value of one unit of dimension ``length^a · time^b · mass^c`` in this system."""
        return (
            self.metre_per_length**length
            * self.second_per_time**time
            * self.kilogram_per_mass**mass
        )

    def from_si(self, value, *, length: int = 0, time: int = 0, mass: int = 0):
        """Convert an SI value of dimension ``length^a · time^b · mass^c`` into this system."""
        return value / self.scale(length=length, time=time, mass=mass)

    def to_si(self, value, *, length: int = 0, time: int = 0, mass: int = 0):
        """Convert a value of dimension ``length^a · time^b · mass^c`` in this system into SI."""
        return value * self.scale(length=length, time=time, mass=mass)

    # Named conversions for the quantities the package meets, SI value in, this system out.
    def length(self, metres):
        """Length: metres → this system."""
        return self.from_si(metres, length=1)

    def time(self, seconds):
        """Time: seconds → this system."""
        return self.from_si(seconds, time=1)

    def mass(self, kilograms):
        """Mass: kilograms → this system."""
        return self.from_si(kilograms, mass=1)

    def density(self, kg_per_m3):
        """Density: kg/m³ → this system."""
        return self.from_si(kg_per_m3, mass=1, length=-3)

    def stress(self, pascals):
        """Stress or modulus: Pa → this system."""
        return self.from_si(pascals, mass=1, length=-1, time=-2)

    def torque(self, newton_metres):
        """Torque or rotational stiffness (per rad): N·m → this system."""
        return self.from_si(newton_metres, mass=1, length=2, time=-2)

    def acceleration(self, metres_per_s2):
        """Acceleration: m/s² → this system."""
        return self.from_si(metres_per_s2, length=1, time=-2)


def _symbol(si_value: float, base: str) -> str:
    for factor, prefix in ((1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"), (1e-12, "p")):
        if abs(si_value / factor - 1) < 1e-12:
            return prefix + base
    return f"{si_value:g} {base}"


SI = UnitSystem("SI", 1.0, 1.0, 1.0)
"""Metre, second, kilogram (force N, torque N·m, stress Pa)."""

MICRO = UnitSystem("micro", 1e-6, 1e-6, 1e-12)
"""µm, µs, ng: force µN, torque µN·µm = pN·m = 1e-12 N·m, stress MPa, density ng/µm³ = 1e6 kg/m³."""
