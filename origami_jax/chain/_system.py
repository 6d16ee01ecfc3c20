"""`accordion_system`: the one builder of the accordion's folding system from a `HingeDesign`.

The command line, the paper job, `design` and the sweep kernels all build their accordion here, so they
simulate the same model: the flaps of the design's geometry, the design's stiffness and drag on every
hinge, and fold targets ``(θ_final, −θ_final, θ_final, …)`` (paper Eq. 12 with ``θ_final = π``).
"""

import dataclasses
from collections.abc import Sequence
from typing import final

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..system import AbstractPattern, FoldingSystem, HingeDesign, HingeDrag, Hinges
from ._chain import accordion
from ._extended import extended_accordion, fluid_parts


def alternating_targets(
    n_joints: int, angle: Float[ArrayLike, ""] = float(np.pi)
) -> Float[Array, " n"]:
    """The accordion's fold targets `(angle, −angle, angle, …)`, rad, shape `(n_joints,)`.

    `angle` may be traced (a design's `theta_final` under `jit` or `grad`)."""
    if not isinstance(n_joints, int | np.integer) or n_joints < 1:
        raise ValueError(f"n_joints must be an integer >= 1, got {n_joints!r}.")
    signs = np.where(np.arange(int(n_joints)) % 2 == 0, 1.0, -1.0)
    return jnp.asarray(angle) * signs


def accordion_system(
    design: HingeDesign,
    n_flaps: int = 3,
    *,
    targets: Float[ArrayLike, " n"] | None = None,
    release_times: Float[ArrayLike, " n"] | None = None,
    gravity: Float[ArrayLike, "3"] | None = None,
    contact: bool = False,
    hinges: str = "point",
    fluid: str | Sequence[str] = "paper",
    strip_nodes: int = 6,
) -> FoldingSystem:
    """The paper's accordion as a [`origami_jax.system.FoldingSystem`][], from a hinge design.

    **Arguments** (in the design's units, `MICRO` by default: µm, µs, ng):
    - `design`: a [`origami_jax.system.HingeDesign`][]: flap geometry and density, hinge films, fluid.
    - `n_flaps`: number of flaps (= hinges), static.
    - `targets`: signed fold target per hinge (rad); default ``(θ_final, −θ_final, …)`` from the
      design (`alternating_targets`).
    - `release_times`: per-hinge release time (time units); default every hinge at ``t = 0``.
    - `gravity`: shape `(3,)`, length/time²; zero by default.
    - `contact`: panels of thickness `t_structural` meet instead of passing through each other
      ([`origami_jax.contact.PanelContact`][] with its defaults): flap 1 lands on the base (the
      membrane still on the substrate, a flap-sized rectangle before the first hinge) and each flap
      on the one before. `False` (default) is the paper's model, where they pass through.
    - `hinges`: `"point"` (the paper's revolute creases, default) or `"arc"`: bending strips of length
      ``ρ |θ_target|`` with their own mass and inertia, the flaps attached at their ends
      ([`origami_jax.net.StripTree`][]; docs/physics.md, "The hinge is a bending arc").
    - `fluid`: `"paper"` (default: ``b θ̇|θ̇|`` per hinge, Eq. 11), `"extended"` (quadratic drag on
      every flap from its own motion, the fluid's added inertia and viscous drag; docs/physics.md,
      "The fluid moves with the flap"), or a sequence of the parts `"hinge"`, `"panel"`,
      `"added_mass"`, `"viscous"` (`origami_jax.chain._extended`).
    - `strip_nodes`: quadrature nodes along each arc hinge's strip (static).

    **Returns:** a `FoldingSystem`: with the defaults a [`origami_jax.chain.Chain`][], the design's
    stiffness ``k`` and bending radius ``ρ`` on every hinge and the paper's hinge drag ``b``
    ([`origami_jax.system.HingeDrag`][]); otherwise a panel tree (`origami_jax.net.PanelTree`, or
    `StripTree` for arc hinges) with the chosen fluid. The hinge spring is the design's
    `stiffness_model` either way (`"bilayer"` is the bending energy of the Timoshenko bilayer).
    """
    if not isinstance(design, HingeDesign):
        raise ValueError(f"design must be a HingeDesign, got {type(design).__name__}.")
    if hinges != "point" or fluid != "paper":
        if not isinstance(n_flaps, int | np.integer) or isinstance(n_flaps, bool) or n_flaps < 1:
            raise ValueError(f"n_flaps must be an integer >= 1, got {n_flaps!r}.")
        n = int(n_flaps)
        if targets is None:
            targets = alternating_targets(n, design.theta_final)
        return extended_accordion(
            design,
            n,
            targets,
            release_times,
            gravity,
            hinges=hinges,
            fluid=fluid,
            contact=contact,
            strip_nodes=strip_nodes,
        )
    chain = accordion(
        n_flaps,
        flap_length=design.flap_length,
        flap_width=design.flap_width,
        thickness=design.t_structural,
        density=design.structural.density,
        gravity=gravity,
        units=design.units,
    )
    n = chain.n_hinges
    if targets is None:
        targets = alternating_targets(n, design.theta_final)
    hinges = Hinges(
        stiffness=design.stiffness(n),
        target=targets,
        radius=design.radius(),
        release_time=release_times,
    )
    contact_model = None
    if contact:
        from ..contact import PanelContact

        contact_model = PanelContact.for_system(
            chain,
            hinges.stiffness,
            hinges.target,
            thickness=design.t_structural,
            base_outline=_base_rectangle(chain),
        )
    return FoldingSystem(
        chain, hinges, HingeDrag(design.drag(n)), contact=contact_model, units=design.units
    )


def _base_rectangle(chain) -> np.ndarray:
    """The membrane before the first hinge, a flap-sized rectangle (world, flat state)."""
    first = chain.outlines()[0]
    pose = np.asarray(chain.body_poses(chain.rest_state()[0]))[0]
    world = first @ pose[:3, :3].T + pose[:3, 3]
    layout = chain.hinge_layout()
    # Mirror the first flap across its hinge line.
    axis, point = layout.axis[0], layout.ends[0, 0]
    relative = world - point
    along = (relative @ axis)[:, None] * axis
    return point + along - (relative - along)


# The physics options of the accordion (`Accordion.with_model`) and their defaults.
ACCORDION_MODEL = {"hinges": "point", "fluid": "paper", "contact": False}


@final
@dataclasses.dataclass(frozen=True)
class Accordion(AbstractPattern):
    """The paper's accordion as a pattern ([`origami_jax.system.AbstractPattern`][]):
    ``Accordion(n_flaps, ...)(design)`` is ``accordion_system(design, n_flaps, hinges=...,
    fluid=..., contact=...)``.

    **Fields** (compared by value: equal accordions share a compiled fit): `n_flaps`, the number of
    flaps (= hinges); `hinges` (`"point"`, the paper's, or `"arc"`), `fluid` (`"paper"`,
    `"extended"` or a tuple of parts), `contact` (default `False`), as `accordion_system` takes
    them.

    What counts as folded: every hinge at its target, ``(θ_final, −θ_final, …)`` of the design
    (`intended_angles`: the literature design's ``θ_final = π``); an accordion has no seams.
    """

    n_flaps: int
    hinges: str = "point"
    fluid: str | tuple[str, ...] = "paper"
    contact: bool = False

    def __post_init__(self):
        if not isinstance(self.n_flaps, int) or isinstance(self.n_flaps, bool) or self.n_flaps < 1:
            raise ValueError(f"n_flaps must be an integer >= 1, got {self.n_flaps!r}.")
        if self.hinges not in ("point", "arc"):
            raise ValueError(f"hinges must be 'point' or 'arc', got {self.hinges!r}.")
        if not isinstance(self.fluid, str):
            object.__setattr__(self, "fluid", tuple(self.fluid))
        fluid_parts(self.fluid)  # raises for a bad value

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

    def with_model(self, **options) -> "Accordion":
        """This accordion with other physics options (`hinges`, `fluid`, `contact`).
        **Raises:** `ValueError` for an unknown option."""
        unknown = sorted(set(options) - set(ACCORDION_MODEL))
        if unknown:
            raise ValueError(
                f"Accordion.with_model: unknown option(s) {unknown}; the model's are "
                f"{sorted(ACCORDION_MODEL)}."
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
        from ..simulation import assess

        self.start_state(bias=bias)
        return assess(system, trajectory, **kwargs)

    def outcome(self, system: FoldingSystem, trajectory, **kwargs):
        """`assess`'s verdict as arrays, traceable (`origami_jax.simulation.fold_outcome`)."""
        from ..simulation import fold_outcome

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
        from ..simulation import fold_pattern

        return fold_pattern(
            self, system, inputs, options, t1=t1, bias=bias, tolerances=tolerances, **kwargs
        )

    def kernel(self, **settings):
        """The accordion's sweep kernel (`origami_jax.sweep.get_model("accordion-step")`) with
        this flap count and `settings`. **Raises:** `ValueError` for a model it does not
        simulate (arc hinges, the extended fluid, contact): the kernel sweeps the paper's."""
        from ..sweep._kernels import accordion_step

        if (self.hinges, self.fluid, self.contact) != ("point", "paper", False):
            raise ValueError(
                "the accordion's sweep kernel simulates the paper's model (point hinges, the "
                f"paper's fluid, no contact), not {self!r}."
            )
        return accordion_step(n_flaps=self.n_flaps, **settings)

    def resume_settings(self) -> dict:
        """What a stored sweep of this accordion records: its flap count."""
        return {"n_flaps": self.n_flaps}
