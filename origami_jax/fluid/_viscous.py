"""Viscous (linear) drag on every panel, and the sum of several drag models.

`ViscousDrag` resists each panel's own motion through the fluid with a body-frame damping matrix:
the wrench ``W = −C V`` with ``V = (v, ω)`` the panel's twist in its body frame about its origin and
``C`` a symmetric positive semi-definite 6×6 (force·time/length, force·time, force·length·time
blocks). For the unsteady viscous flow around an oscillating plate ``C = ω Im Γ · A`` with ``A`` the
panel's potential-flow added inertia and ``Γ`` Sader's hydrodynamic function at the fold's frequency
``ω`` (`origami_jax.fluid.fluid_loads`); a single flap on a point hinge then feels the torque
``−ω Im Γ (9/8) ρ_f π a⁴ w θ̇``. The power it takes out is ``Σ Vᵀ C V ≥ 0``.

`CombinedDrag` adds several drag models (the paper's quadratic drag and the viscous one, say): the
Morison decomposition of a fluid force into inertia, quadratic (separated-flow) drag and, here, a
linear viscous part (Morison, O'Brien, Johnson & Schaaf, Petroleum Transactions AIME 189 (1950) 149).
"""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._validate import as_float_array, check_shape, check_symmetric_positive
from ..system import AbstractDrag


class ViscousDrag(AbstractDrag):
    """Linear drag ``W = −C V`` on every panel in its body frame (module docstring).

    **Fields:** `damping` ``C``, `(b, 6, 6)`, one symmetric positive semi-definite matrix per body, on
    body twists ordered ``(linear, angular)`` about the body frame's origin (the mechanism's units).
    """

    damping: Float[Array, "b 6 6"]

    def __init__(self, damping: Float[ArrayLike, "b 6 6"]):
        damping = as_float_array(damping, "damping")
        check_shape(damping, (None, 6, 6), "damping", "Give one 6x6 matrix per body.")
        self.damping = check_symmetric_positive(
            damping, "damping", definite=False, hint="Viscous damping takes energy out: C ⪰ 0."
        )

    def body_twists(self, mechanism, q, v) -> tuple[Array, Array, Array]:
        """Each body's twist ``(v, ω)`` in its body frame about its origin, `(b, 6)`, with the body
        rotations `(b, 3, 3)` and origins `(b, 3)`."""
        body, rotations, origins, _ = self._motion(mechanism, q, v)
        return body, rotations, origins

    @staticmethod
    def _motion(mechanism, q, v):
        """`body_twists` and the mechanism's wrench map, from one kinematics (`body_motion`)."""
        poses, twist, wrench_force = mechanism.body_motion(q, v)
        rotations, origins = poses[:, :3, :3], poses[:, :3, 3]
        # `twist`: world, about the origin, (v_O, ω).
        linear = twist[:, :3] + jnp.cross(twist[:, 3:], origins)  # velocity of each body origin
        body = jnp.concatenate(
            [
                jnp.einsum("bji,bj->bi", rotations, linear),
                jnp.einsum("bji,bj->bi", rotations, twist[:, 3:]),
            ],
            axis=-1,
        )
        return body, rotations, origins, wrench_force

    def force(self, mechanism, q, v):
        body, rotations, origins, wrench_force = self._motion(mechanism, q, v)
        wrench = -jnp.einsum("bij,bj->bi", self.damping, body)
        force = jnp.einsum("bij,bj->bi", rotations, wrench[:, :3])
        moment = jnp.einsum("bij,bj->bi", rotations, wrench[:, 3:]) + jnp.cross(origins, force)
        return wrench_force(jnp.concatenate([force, moment], axis=-1))

    def dissipation(self, mechanism, q, v):
        body, _, _ = self.body_twists(mechanism, q, v)
        return jnp.sum(body * jnp.einsum("bij,bj->bi", self.damping, body))


class CombinedDrag(AbstractDrag):
    """The sum of several drag models (module docstring). **Fields:** `parts`, a tuple of
    [`origami_jax.system.AbstractDrag`][]."""

    parts: tuple[AbstractDrag, ...]

    def __check_init__(self):
        if not self.parts or not all(isinstance(p, AbstractDrag) for p in self.parts):
            raise ValueError("CombinedDrag needs one or more AbstractDrag models.")

    def force(self, mechanism, q, v):
        total = self.parts[0].force(mechanism, q, v)
        for part in self.parts[1:]:
            total = total + part.force(mechanism, q, v)
        return total

    def dissipation(self, mechanism, q, v):
        return sum(
            (part.dissipation(mechanism, q, v) for part in self.parts[1:]),
            self.parts[0].dissipation(mechanism, q, v),
        )
