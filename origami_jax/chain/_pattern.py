"""`Accordion`: the paper's chain of flaps as a pattern (`origami_jax.system.AbstractPattern`):
its systems (`accordion_system`), verdict, fold and sweep kernel (`accordion_step`)."""

import dataclasses
import math
from typing import final

import numpy as np
from jaxtyping import ArrayLike, Float

from .._validate import is_traced
from ..simulation import assess, fold_outcome, fold_pattern
from ..system import (
    AbstractPattern,
    FoldingSystem,
    HingeDesign,
    UnitSystem,
    check_known_names,
)
from ._chain import flap_size
from ._extended import fluid_parts
from ._kernel import accordion_step
from ._system import accordion_system

ACCORDION_MODEL = {"hinges": "point", "fluid": "paper", "contact": False}
ACCORDION_GEOMETRY = {"flap_length": "length", "flap_width": "length"}
"""The accordion's geometry fields (`Accordion.with_geometry`) and their kind of unit."""


@final
@dataclasses.dataclass(frozen=True)
class Accordion(AbstractPattern):
    """The paper's accordion as a pattern ([`origami_jax.system.AbstractPattern`][]):
    ``Accordion(n_flaps, ...)(design)`` is ``accordion_system(design, n_flaps, flap_length=...,
    flap_width=..., hinges=..., fluid=..., contact=...)``.

    **Fields** (compared by value: equal accordions share a compiled fit): `n_flaps`, the number of
    flaps (= hinges); `hinges` (`"point"`, the paper's, or `"arc"`), `fluid` (`"paper"`,
    `"extended"` or a tuple of parts), `contact` (default `False`), as `accordion_system` takes
    them; `flap_length` ``L`` (away from the hinge) and `flap_width` (along it), the flaps' size in
    the length units of the design it is folded with (µm for the default `MICRO`); `None` (default):
    the paper's 200 µm square flaps. The flap geometry is the pattern's, not the hinge design's.

    What counts as folded: every hinge at its target, ``(θ_final, −θ_final, …)`` of the design
    (`intended_angles`: the literature design's ``θ_final = π``); an accordion has no seams.
    """

    n_flaps: int
    hinges: str = "point"
    fluid: str | tuple[str, ...] = "paper"
    contact: bool = False
    flap_length: float | Float[ArrayLike, ""] | None = None
    flap_width: float | Float[ArrayLike, ""] | None = None

    def __post_init__(self):
        if not isinstance(self.n_flaps, int) or isinstance(self.n_flaps, bool) or self.n_flaps < 1:
            raise ValueError(f"n_flaps must be an integer >= 1, got {self.n_flaps!r}.")
        if self.hinges not in ("point", "arc"):
            raise ValueError(f"hinges must be 'point' or 'arc', got {self.hinges!r}.")
        if not isinstance(self.fluid, str):
            object.__setattr__(self, "fluid", tuple(self.fluid))
        fluid_parts(self.fluid)  # raises for a bad value
        for name in ("flap_length", "flap_width"):
            value = getattr(self, name)
            if value is None or is_traced(value):  # traced: a fit of the flap size (design)
                continue
            if isinstance(value, bool) or not isinstance(value, int | float):
                try:
                    value = float(value)  # a NumPy or JAX scalar: kept as a float, hashable
                except (TypeError, ValueError):
                    raise ValueError(f"{name} must be a number (length), got {value!r}.") from None
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and positive (length), got {value!r}.")
            object.__setattr__(self, name, float(value))

    @property
    def name(self) -> str:
        return "accordion"

    @property
    def n_hinges(self) -> int:
        return self.n_flaps

    def hinge_name(self, j: int) -> str:
        return f"joint {j + 1}"  # as the paper numbers a chain's joints

    @property
    def intended_angles(self) -> np.ndarray:
        """``(π, −π, π, …)`` (rad, `(n_flaps,)`): the literature design's targets."""
        return np.pi * np.where(np.arange(self.n_flaps) % 2 == 0, 1.0, -1.0)

    @property
    def seams(self):
        return None  # a chain of flaps closes no seams

    @property
    def continues_from_angles(self) -> bool:
        return True  # a chain's (and a flap tree's) state is its hinge angles and rates

    def geometry(self, units: UnitSystem) -> dict:
        """``{"flap_length": L, "flap_width": w}`` in `units` (a design's): the fields, or the
        paper's 200 µm where they are `None`."""
        size = flap_size(units, self.flap_length, self.flap_width)
        return dict(zip(ACCORDION_GEOMETRY, size, strict=True))

    def with_geometry(self, **geometry) -> "Accordion":
        """This accordion with other flap geometry (`flap_length`, `flap_width`; values may be
        traced, as in a fit of the flap size). **Raises:** `ValueError` for another name."""
        check_known_names(
            "Accordion.with_geometry",
            geometry,
            ACCORDION_GEOMETRY,
            kind="field",
            whose="geometry's",
        )
        return dataclasses.replace(self, **geometry)

    def with_model(self, **options) -> "Accordion":
        """This accordion with other physics options (`hinges`, `fluid`, `contact`).
        **Raises:** `ValueError` for an unknown option."""
        check_known_names(
            "Accordion.with_model", options, sorted(ACCORDION_MODEL), kind="option", whose="model's"
        )
        return dataclasses.replace(self, **options)

    def default_design(self, fluid=None) -> HingeDesign:
        """The literature design (`HingeDesign.literature`), in `fluid` if given."""
        return HingeDesign.literature(**({} if fluid is None else {"fluid": fluid}))

    def system(
        self,
        design: HingeDesign | None = None,
        *,
        targets: Float[ArrayLike, " n"] | None = None,
        release_times: Float[ArrayLike, " n"] | None = None,
    ) -> FoldingSystem:
        """`accordion_system(design, n_flaps, ...)` with this accordion's physics options
        (`design` default: the literature design)."""
        design = self.default_design() if design is None else design
        return accordion_system(
            design,
            self.n_flaps,
            flap_length=self.flap_length,
            flap_width=self.flap_width,
            targets=targets,
            release_times=release_times,
            hinges=self.hinges,
            fluid=self.fluid,
            contact=self.contact,
        )

    def start_state(self, system: FoldingSystem | None = None, *, bias: float = 0.0):
        """Flat, at rest (`(θ0, θ̇0)`, zeros `(n_flaps,)`): `bias` must be 0."""
        if bias:
            raise ValueError("the accordion starts flat: bias pre-folds closed-loop patterns only.")
        return np.zeros(self.n_flaps), np.zeros(self.n_flaps)

    def assess(self, system: FoldingSystem, trajectory, *, bias: float = 0.0, **kwargs):
        """The verdict on a folding (`origami_jax.simulation.assess`, keyword arguments go there),
        against the system's hinge targets."""
        self.start_state(bias=bias)
        return assess(system, trajectory, **kwargs)

    def outcome(self, system: FoldingSystem, trajectory, **kwargs):
        """`assess`'s verdict as arrays, traceable (`origami_jax.simulation.fold_outcome`)."""
        return fold_outcome(system, trajectory, **kwargs)

    def fold(
        self,
        system: FoldingSystem,
        inputs=None,
        options=None,
        *,
        t1: float | None = None,
        bias: float = 0.0,
        tolerances=None,
        **kwargs,
    ):
        """Step-release `system` (one this accordion built) from flat and judge the run
        (`origami_jax.simulation.fold_pattern`: runs of 1000 µs continued while it still moves,
        or one run to `t1`; `options` an `origami_jax.simulation.SolveOptions`; other keyword
        arguments, `segment`, `max_segments` and `on_continue`, go there).

        **Returns:** `(trajectory, report)`."""
        return fold_pattern(
            self, system, inputs, options, t1=t1, bias=bias, tolerances=tolerances, **kwargs
        )

    def kernel(self, **settings):
        """The accordion's sweep kernel (`origami_jax.sweep.get_model("accordion-step")`) with
        this flap count and `settings`. **Raises:** `ValueError` for a model it does not
        simulate (arc hinges, the extended fluid, contact): the kernel sweeps the paper's."""
        if (self.hinges, self.fluid, self.contact) != ("point", "paper", False):
            raise ValueError(
                "the accordion's sweep kernel simulates the paper's model (point hinges, the "
                f"paper's fluid, no contact), not {self!r}."
            )
        return accordion_step(
            n_flaps=self.n_flaps,
            flap_length=self.flap_length,
            flap_width=self.flap_width,
            **settings,
        )

    def resume_settings(self) -> dict:
        """What a stored sweep of this accordion records: its flap count."""
        return {"n_flaps": self.n_flaps}
