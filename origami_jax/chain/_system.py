"""`accordion_system`: the one builder of the accordion's folding system from a `HingeDesign`.

The command line, the paper job, `design` and the sweep kernels all build their accordion here (through
`Accordion`, the pattern, which holds the flap geometry), so they simulate the same model: flaps of the
given size (the paper's 200 µm squares by default), the design's stiffness and drag on every hinge, and fold targets ``(θ_final, −θ_final, θ_final, …)`` (paper Eq. 12 with ``θ_final = π``).
"""

from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..contact import PanelContact
from ..system import FoldingSystem, HingeDesign, HingeDrag, Hinges
from ._chain import accordion, flap_size
from ._extended import extended_accordion


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
    flap_length: Float[ArrayLike, ""] | None = None,
    flap_width: Float[ArrayLike, ""] | None = None,
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
    - `design`: a [`origami_jax.system.HingeDesign`][]: membrane, hinge films, fluid.
    - `n_flaps`: number of flaps (= hinges), static.
    - `flap_length` ``L`` (away from the hinge), `flap_width` (along it): the flaps' size (length
      units of the design, scalars, may be traced); `None`: the paper's 200 µm (`FLAP_SIZE_SI`).
      The pattern, [`origami_jax.chain.Accordion`][], holds them and passes them here.
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
    size = flap_size(design.units, flap_length, flap_width)
    if hinges != "point" or fluid != "paper":
        if not isinstance(n_flaps, int | np.integer) or isinstance(n_flaps, bool) or n_flaps < 1:
            raise ValueError(f"n_flaps must be an integer >= 1, got {n_flaps!r}.")
        n = int(n_flaps)
        if targets is None:
            targets = alternating_targets(n, design.theta_final)
        return extended_accordion(
            design,
            size,
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
        flap_length=size[0],
        flap_width=size[1],
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
        contact_model = PanelContact.for_system(
            chain,
            hinges.stiffness,
            hinges.target,
            thickness=design.t_structural,
            base_outline=_base_rectangle(chain),
        )
    return FoldingSystem(
        chain, hinges, HingeDrag(design.drag(n, *size)), contact=contact_model, units=design.units
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
