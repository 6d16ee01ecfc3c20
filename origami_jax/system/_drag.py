"""Fluid forces on a folding mechanism: the `AbstractDrag` contract and the paper's hinge drag.

A drag model maps the mechanism's state to a generalized force (torque per hinge for chains and trees).
`HingeDrag` is the paper's model (Eq. 11): ``−b θ̇|θ̇|`` at each hinge, from its own rate. It is what
the accordion's figures use; drag computed from each panel's own motion through the fluid is the
physical alternative (see the physics guide, "Fluids and drag").
"""

import abc
from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._validate import as_float_array, check_finite
from ._mechanism import AbstractMechanism


class AbstractDrag(eqx.Module):
    """A fluid force model: `force(mechanism, q, v) -> generalized force` (shape `(nv,)`)."""

    @abc.abstractmethod
    def force(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"], v: Float[Array, " nv"]
    ) -> Float[Array, " nv"]:
        """Generalized fluid force at ``(q, v)``, in the mechanism's units; it must never add energy
        (``vᵀ force ≤ 0``)."""

    def dissipation(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"], v: Float[Array, " nv"]
    ) -> Float[Array, ""]:
        """Power the fluid takes out of the mechanism, ``−vᵀ force ≥ 0`` (energy/time)."""
        return -jnp.dot(v, self.force(mechanism, q, v))


class HingeDrag(AbstractDrag):
    """The paper's drag (Eq. 11): a torque ``−b θ̇|θ̇|`` at each hinge from its own rate ``θ̇``.

    **Fields:** `coefficient` ``b`` per hinge, shape `(h,)`, torque·time²/rad² (e.g.
    [`origami_jax.system.HingeDesign.drag`][], the paper's ``C_D ν A L³ / 16``).
    """

    coefficient: Float[Array, " h"]

    def __init__(self, coefficient: Float[ArrayLike, " h"] | Sequence[float]):
        coefficient = check_finite(as_float_array(coefficient, "coefficient"), "coefficient")
        if coefficient.ndim != 1:
            raise ValueError(
                f"HingeDrag.coefficient must have shape (h,), got {tuple(coefficient.shape)}."
            )
        self.coefficient = coefficient

    def hinge_torque(self, theta_dot: Float[Array, "*t h"]) -> Float[Array, "*t h"]:
        """The resisting torque ``b θ̇|θ̇|`` per hinge (positive opposes positive rates)."""
        return self.coefficient * theta_dot * jnp.abs(theta_dot)

    def force(self, mechanism, q, v):
        theta_dot = mechanism.hinge_rates(q, v)
        return mechanism.hinge_force(q, -self.hinge_torque(theta_dot))
