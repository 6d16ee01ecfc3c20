"""`fluid_loads`: the fluid's inertia and viscous drag on a mechanism's panels, at the fold's frequency.

Each panel ``b`` gets the added inertia ``C_a Re Γ_b ρ_f A_b`` and the viscous damping
``C_a ω_b Im Γ_b ρ_f A_b`` (`origami_jax.fluid._added_mass`: ``A_b`` its strip-theory added inertia
per unit density, ``Γ_b`` Sader's hydrodynamic function at ``Re_b = ρ_f ω_b c_b² / (4 μ)``, ``c_b``
its chord across the hinge, ``C_a`` the design's added-mass coefficient). ``ω_b`` is the natural
frequency of the panel's own hinge, ``√(k_b / M_bb)`` with ``M`` the mass matrix half-way to the fold
target, its fluid part (the added inertia of the hinge's whole subtree) weighted by the panel's own
``Re Γ_b``: the folding is a transient, not an oscillation, and its ring-down rings near these
frequencies. ``M_bb`` depends on ``Re Γ``, which depends on ``ω``: the pair is found by fixed-point
passes (``Re Γ`` varies slowly with ``ω``; each pass shrinks the error ~10×, eight settle it to
round-off).
Everything is differentiable in the design.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..system import AbstractMechanism
from ._added_mass import hydrodynamic_function, reynolds_number
from ._viscous import ViscousDrag

FREQUENCY_PASSES = 8
"""Fixed-point passes between the added inertia and the frequency (module docstring)."""


class FluidLoads(NamedTuple):
    """What `fluid_loads` returns.

    - `mechanism`: the mechanism with the panels' added inertias (unchanged without added mass).
    - `viscous`: a [`origami_jax.fluid.ViscousDrag`][], or `None`.
    - `frequency`: ``ω_b`` per panel (rad/time), `(b,)`.
    - `reynolds`: ``Re_b`` per panel, `(b,)` (NaN for an inviscid fluid).
    - `gamma`: ``(Re Γ_b, Im Γ_b)`` per panel, each `(b,)` (``(1, 0)`` for an inviscid fluid).
    - `added`: the added inertias given to `mechanism`, body frames `(b, 6, 6)` (`None` without
      added mass): `mechanism.with_added_inertias(added)` is `mechanism` from the one given.
    """

    mechanism: AbstractMechanism
    viscous: ViscousDrag | None
    frequency: Array
    reynolds: Array
    gamma: tuple[Array, Array]
    added: Array | None = None


def with_added_inertias(mechanism: AbstractMechanism, added) -> AbstractMechanism:
    """`mechanism` with its panels' added inertias replaced (`AbstractMechanism.with_added_inertias`:
    a `PanelTree` or a `StripTree`; `ValueError` for other mechanisms)."""
    return mechanism.with_added_inertias(added)


def fluid_loads(
    mechanism: AbstractMechanism,
    unit_added: Float[ArrayLike, "b 6 6"],
    chord: Float[ArrayLike, " b"],
    stiffness: Float[ArrayLike, " h"],
    target: Float[ArrayLike, " h"],
    *,
    density: Float[ArrayLike, ""],
    viscosity: Float[ArrayLike, ""] | None,
    coefficient: Float[ArrayLike, ""] = 1.0,
    added_mass: bool = True,
    viscous: bool = True,
) -> FluidLoads:
    """The fluid's inertia and viscous drag on `mechanism`'s panels (module docstring).

    **Arguments** (the mechanism's units):
    - `mechanism`: a mechanism that carries added inertias (`carries_added_inertia` once given
      them: a `PanelTree`, a `StripTree`, or the `LoopedPanels` of a crease pattern) whose body
      ``b`` hangs from hinge ``b`` (a pattern's cut creases, numbered after its `b` bodies' hinges,
      close loops and carry no body: a panel's frequency is that of its own tree hinge).
    - `unit_added`: each panel's strip-theory added inertia per unit fluid density, body frame,
      `(b, 6, 6)` (`rectangle_added_inertia`, `polygon_added_inertia`).
    - `chord`: each panel's chord across its hinge (length), `(b,)`: the Reynolds number's length.
    - `stiffness`, `target`: the hinges' ``k`` and fold targets, `(h,)`, ``h ≥ b`` (the
      frequencies).
    - `density`, `viscosity`: the fluid's ``ρ_f`` and ``μ``; `viscosity=None` is an inviscid fluid
      (``Γ = 1``, no viscous drag).
    - `coefficient`: ``C_a`` (the design's `added_mass_coefficient`).
    - `added_mass`, `viscous`: which of the two loads to apply.

    **Raises:** `ValueError` for viscous drag without a viscosity.
    """
    if viscous and viscosity is None:
        raise ValueError(
            "viscous drag needs the fluid's viscosity: give Fluid(..., viscosity=...) (AIR and "
            "KOH_SOLUTION have one)."
        )
    unit_added = jnp.asarray(unit_added)
    chord = jnp.asarray(chord)
    stiffness = jnp.asarray(stiffness)
    middle = 0.5 * jnp.asarray(target)
    scale = jnp.asarray(coefficient) * jnp.asarray(density)
    n = unit_added.shape[0]
    dtype = unit_added.dtype

    def gamma_at(frequency):
        if viscosity is None:
            return jnp.ones(n, dtype), jnp.zeros(n, dtype), jnp.full(n, jnp.nan, dtype)
        reynolds = reynolds_number(density, viscosity, frequency, chord)
        real, imag = hydrodynamic_function(reynolds)
        return real, imag, reynolds

    # M_bb is affine in the added inertia: its own part and the fluid's at Γ = 1 (two mass
    # matrices), then the fixed point on elementwise arithmetic.
    own = jnp.diagonal(mechanism.mass_matrix(middle))[:n]
    fluid = jnp.zeros_like(own)
    if added_mass:
        potential = with_added_inertias(mechanism, scale * unit_added)
        fluid = jnp.diagonal(potential.mass_matrix(middle))[:n] - own
    stiffness = stiffness[:n]

    def frequency_of(real):
        return jnp.sqrt(stiffness / (own + real * fluid))

    real = jnp.ones(n, dtype)
    added = None
    if added_mass:
        # A loop, not unrolled: each pass evaluates Sader's function (Bessel functions of a complex
        # argument); eight copies made a cube net's program half again as large (325 against
        # 223 kB of StableHLO) and its compilation ~15 % longer.
        real = jax.lax.fori_loop(
            0, FREQUENCY_PASSES, lambda _, real: gamma_at(frequency_of(real))[0], real
        )
        added = (scale * real)[:, None, None] * unit_added
        mechanism = with_added_inertias(mechanism, added)
    frequency = frequency_of(real)
    _, imag, reynolds = gamma_at(frequency)
    drag = None
    if viscous:
        damping = (scale * frequency * imag)[:, None, None] * unit_added
        drag = ViscousDrag(damping)
    if not added_mass:
        real = gamma_at(frequency)[0]  # reported, not applied
    return FluidLoads(mechanism, drag, frequency, reynolds, (real, imag), added)
