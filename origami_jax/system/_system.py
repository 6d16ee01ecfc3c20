"""`FoldingSystem`: the one model object that `simulate`, `design` and `sweep` take.

A folding device is a mechanism (rigid panels and hinges, [`origami_jax.system.AbstractMechanism`][]),
the physics of its hinges ([`origami_jax.system.Hinges`][]: stiffness, fold targets, release times),
the fluid it folds in ([`origami_jax.system.AbstractDrag`][]) and, where panels can meet, a contact
model ([`origami_jax.system.AbstractContact`][]). Its equations of motion are

    M(q) v̇ + C(q, v) v + G(q) = J_hᵀ (τ − K θ) + f_drag(q, v) + f_contact(q, v),

with ``θ`` the hinge angles, ``K θ`` the hinge springs about the flat state and ``τ`` the input torque
(the release: ``K θ_target`` for the paper's step, Eq. 12). Build one with a builder such as
[`origami_jax.chain.accordion_system`][]; everything in it is a pytree leaf or static metadata, so a
batch of systems is a `vmap` away and `jax.grad` reaches every physical number.
"""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._exported import exported_jit
from ._agitation import Agitation
from ._drag import AbstractDrag
from ._hinges import Hinges
from ._mechanism import AbstractMechanism
from ._units import MICRO, UnitSystem


class AbstractContact(eqx.Module):
    """A contact model between bodies of a mechanism (and its fixed base): a smooth generalized force.

    Contract: `force` is the negative gradient of `potential` plus a dissipative part, so contact never
    adds energy (``vᵀ (force + ∇potential) ≤ 0``).
    """

    @abc.abstractmethod
    def force(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"], v: Float[Array, " nv"]
    ) -> Float[Array, " nv"]:
        """Generalized contact force at ``(q, v)``."""

    @abc.abstractmethod
    def potential(self, mechanism: AbstractMechanism, q: Float[Array, " nq"]) -> Float[Array, ""]:
        """Stored contact energy at ``q`` (energy units)."""


class FoldingSystem(eqx.Module):
    """A folding device: mechanism, hinges, fluid and contact (module docstring for the equations).

    **Fields:**
    - `mechanism`: an [`origami_jax.system.AbstractMechanism`][] (e.g. a [`origami_jax.chain.Chain`][]).
    - `hinges`: [`origami_jax.system.Hinges`][], one entry per hinge of the mechanism.
    - `drag`: an [`origami_jax.system.AbstractDrag`][] (the paper's `HingeDrag` for the accordion).
    - `contact`: an [`origami_jax.system.AbstractContact`][], or `None` (panels pass through each
      other: the paper's model).
    - `agitation`: an [`origami_jax.system.Agitation`][] (random forcing by the bath at a
      temperature, balanced by the drag's viscous part), or `None` (default: deterministic).
    - `units` (static): the unit system of every number in the system (default `MICRO`: µm, µs, ng).

    **Raises:** `ValueError` when the hinge count of `hinges` is not the mechanism's.
    """

    mechanism: AbstractMechanism
    hinges: Hinges
    drag: AbstractDrag
    contact: AbstractContact | None = None
    units: UnitSystem = eqx.field(static=True, default=MICRO)
    agitation: Agitation | None = None

    def __check_init__(self):
        if not isinstance(self.mechanism, AbstractMechanism):
            raise ValueError(
                f"mechanism must be an AbstractMechanism (e.g. a Chain), got {type(self.mechanism)}."
            )
        if self.hinges.n_hinges != self.mechanism.n_hinges:
            raise ValueError(
                f"the hinges describe {self.hinges.n_hinges} hinges but the mechanism has "
                f"{self.mechanism.n_hinges}; give one stiffness, target and radius per hinge."
            )
        if self.agitation is not None and not isinstance(self.agitation, Agitation):
            raise ValueError(
                f"agitation must be an origami_jax.system.Agitation or None, got "
                f"{type(self.agitation).__name__}."
            )

    @property
    def n_hinges(self) -> int:
        """Number of hinges (static)."""
        return self.mechanism.n_hinges

    def generalized_force(
        self,
        q: Float[Array, " nq"],
        v: Float[Array, " nv"],
        tau: Float[Array, " h"],
    ) -> Float[Array, " nv"]:
        """Everything but inertia: ``J_hᵀ (τ − K θ) + f_drag + f_contact`` at ``(q, v)`` under input ``τ``."""
        mechanism = self.mechanism
        theta = mechanism.hinge_angles(q)
        force = mechanism.hinge_force(q, tau - self.hinges.stiffness * theta)
        force = force + self.drag.force(mechanism, q, v)
        if self.contact is not None:
            force = force + self.contact.force(mechanism, q, v)
        return force

    def accelerations(
        self,
        q: Float[ArrayLike, " nq"],
        v: Float[ArrayLike, " nv"],
        tau: Float[ArrayLike, " h"],
        *,
        forward_mode_only: bool = False,
    ) -> Float[Array, " nv"]:
        """``v̇`` under input torque ``τ`` (see `AbstractMechanism.forward_dynamics`); NumPy
        inputs are taken as JAX arrays."""
        q, v, tau = jnp.asarray(q), jnp.asarray(v), jnp.asarray(tau)
        return self.mechanism.forward_dynamics(
            q, v, self.generalized_force(q, v, tau), forward_mode_only=forward_mode_only
        )

    def rest_frequencies(self) -> np.ndarray:
        """The angular frequencies ``ω`` of the hinge springs against the mechanism's inertia at
        its rest (flat) state, ascending (host NumPy, `(nv,)`, rad per time unit): the square roots
        of the generalized eigenvalues of ``K = −∂(J_hᵀ(−K θ))/∂q`` and ``M(q₀)``, drag and contact
        left out. Every mode of ``M s² + C s + K`` with such a spring has a root at least ``ω``
        in size whatever its damping (the two roots multiply to ``ω²``), so an explicit solver
        needs steps no longer than a few ``1/ω_max`` (its stability limit), even at rest: how long
        a run must take, known before it starts. Needs concrete numbers and a mechanism whose
        velocities are its coordinates' rates, free of constraints (`ValueError` otherwise: closed
        loops hold their hinge angles to each other, and their mass matrix in them is singular)."""
        mechanism = self.mechanism
        if mechanism.n_coordinates != mechanism.n_velocities:
            raise ValueError("rest_frequencies needs velocities that are the coordinates' rates.")
        stiffness, mass = (np.asarray(a, dtype=float) for a in _rest_stiffness_and_mass(self))
        try:
            inverse_root = np.linalg.inv(np.linalg.cholesky(mass))
        except np.linalg.LinAlgError:
            raise ValueError(
                "rest_frequencies needs a mass matrix positive definite at rest (a mechanism free "
                "of constraints; a pattern of closed loops is not)."
            ) from None
        reduced = inverse_root @ (0.5 * (stiffness + stiffness.T)) @ inverse_root.T
        return np.sqrt(np.maximum(np.linalg.eigvalsh(reduced), 0.0))

    def stiffest_rest_frequency_bound(self) -> float:
        """A lower bound of the largest of `rest_frequencies`, ``max_i sqrt(k_i / M_ii)`` (rad per
        time unit): each coordinate's Rayleigh quotient, for a mechanism whose coordinates are its
        hinge angles (so the springs' stiffness is ``diag(k)``) and free of constraints (closed
        loops' constraints lower the frequencies below it); from `rest_inertia`, the program the
        contact's defaults already ran, so it costs no compilation where they did. An explicit
        solver's steps are no longer than a few over it, as over the exact value.
        **Raises:** `ValueError` for a mechanism whose coordinates are not its hinge angles."""
        mechanism = self.mechanism
        if not mechanism.coordinates_are_hinge_angles:
            raise ValueError(
                "stiffest_rest_frequency_bound needs coordinates that are the hinge angles; use "
                "rest_frequencies."
            )
        inertia = np.asarray(rest_inertia(mechanism), dtype=float)
        stiffness = np.broadcast_to(np.asarray(self.hinges.stiffness, dtype=float), inertia.shape)
        return float(np.sqrt(np.max(stiffness / inertia)))

    def energy(self, q: Float[Array, " nq"], v: Float[Array, " nv"]) -> Float[Array, ""]:
        """Kinetic + hinge spring (``½ Σ k θ²``) + gravity + contact energy (energy units).

        With a step input the input's potential ``−Σ k θ_target θ`` adds to this to give a conserved
        quantity in the absence of drag (see `origami_jax.simulation.input_energy`)."""
        mechanism = self.mechanism
        theta = mechanism.hinge_angles(q)
        total = (
            mechanism.kinetic_energy(q, v)
            + 0.5 * jnp.sum(self.hinges.stiffness * theta**2)
            + mechanism.potential_energy(q)
        )
        if self.contact is not None:
            total = total + self.contact.potential(mechanism, q)
        return total


@exported_jit("rest_stiffness_and_mass")
def _rest_stiffness_and_mass(system: FoldingSystem) -> tuple[Array, Array]:
    """The hinge springs' stiffness ``−∂(J_hᵀ(−K θ))/∂q`` and the mass matrix at the rest state,
    `(nv, nv)` each (one compiled program, kept across runs like the contact's defaults)."""
    mechanism = system.mechanism
    q0, _ = mechanism.rest_state()

    def spring(q):
        return mechanism.hinge_force(q, -system.hinges.stiffness * mechanism.hinge_angles(q))

    return -jax.jacfwd(spring)(q0), mechanism.mass_matrix(q0)


@exported_jit("rest_inertia", by_value=True)
def rest_inertia(mechanism: AbstractMechanism) -> Float[Array, " nv"]:
    """The diagonal of `mechanism`'s mass matrix at its rest state, `(nv,)` (mass·length² per rad²
    for hinge angles): one compiled program per mechanism, kept across runs (the contact's default
    damping and `FoldingSystem.stiffest_rest_frequency_bound` read it)."""
    return jnp.diag(mechanism.mass_matrix(mechanism.rest_state()[0]))
