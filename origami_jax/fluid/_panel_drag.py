"""`PanelDrag`: quadratic (pressure) drag on every panel from its own motion through the fluid.

Strip theory: each area element ``dA`` of a panel moving with normal velocity ``v_n = n · v(p)`` through a
fluid of density ``ρ_f`` feels the pressure force ``dF = −½ C_D ρ_f |v_n| v_n n dA``. Summed over a
panel by quadrature (`polygon_quadrature`; point velocities from the bodies' spatial velocities) into
one wrench per panel and mapped to the mechanism's coordinates (`apply_wrenches`, the transpose of
the point Jacobians, ``f = Σ_p (∂x_p/∂q)ᵀ F_p``), it gives the generalized drag of any panel shape moving in any way: rotation about its own crease, and
the translation and rotation its parents impose. For a single flap of length ``L`` rotating about its
hinge it is ``b θ̇|θ̇|`` with ``b = C_D ρ_f A L³ / 8`` (the "strip" formula; the paper's Eq. 11 has
``/16``, which `scale=0.5` reproduces). Where the paper's hinge drag (`HingeDrag`) uses each hinge's own
rate, this uses each panel's absolute motion: a flap carried by a rotating parent is dragged even when its
own hinge is still.

Not modelled (see the physics guide, "Fluids and drag"): the fluid's inertia (added mass), viscous
(linear) drag, interference between panels and the unsteady wake; ``C_D`` is a constant high-Reynolds
number value.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validate import as_float_array, check_finite, check_positive
from ..system import AbstractDrag, AbstractMechanism
from ._quadrature import polygon_quadrature


class PanelQuadrature(eqx.Module):
    """Quadrature points on every panel in its body frame, with area weights (static host data made
    arrays).

    **Fields:** `points` `(p, 3)` (length), `weights` `(p,)` (area), `normals` `(p, 3)` (unit, body
    frame), `body` `(p,)` static tuple of body indices.
    """

    points: Float[Array, "p 3"]
    weights: Float[Array, " p"]
    normals: Float[Array, "p 3"]
    body: tuple[int, ...] = eqx.field(static=True)

    @classmethod
    def from_outlines(cls, outlines: list[np.ndarray], subdivisions: int = 2) -> "PanelQuadrature":
        points, weights, body = [], [], []
        for index, outline in enumerate(outlines):
            p, w = polygon_quadrature(np.asarray(outline, dtype=float), subdivisions)
            points.append(p)
            weights.append(w)
            body += [index] * len(w)
        points = np.concatenate(points)
        normals = np.zeros_like(points)
        normals[:, 2] = 1.0  # outlines lie in their body frame's x–y plane
        return cls(
            jnp.asarray(points),
            jnp.asarray(np.concatenate(weights)),
            jnp.asarray(normals),
            tuple(body),
        )


class PanelDrag(AbstractDrag):
    """Quadratic drag on every panel from its own motion (module docstring).

    **Fields:**
    - `quadrature`: [`origami_jax.fluid.PanelQuadrature`][] of the mechanism's panels.
    - `coefficient`: ``C_D`` (dimensionless), scalar or per panel `(b,)`.
    - `density`: the fluid's density ``ρ_f`` (mass/length³ of the mechanism's units).
    - `scale`: a constant factor (0.5 reproduces the paper's ``/16`` normalisation for a single flap).

    Build it with `PanelDrag.for_mechanism`.
    """

    quadrature: PanelQuadrature
    coefficient: Float[Array, "..."]
    density: Float[Array, ""]
    scale: float = eqx.field(static=True, default=1.0)

    @classmethod
    def for_mechanism(
        cls,
        mechanism: AbstractMechanism,
        *,
        coefficient: Float[ArrayLike, "..."],
        density: Float[ArrayLike, ""],
        scale: float = 1.0,
        subdivisions: int = 2,
    ) -> "PanelDrag":
        """Drag on `mechanism`'s panels (`outlines()`), with ``C_D`` = `coefficient` in a fluid of
        `density` (the mechanism's units). `subdivisions`: each fan triangle of a panel is split into
        ``subdivisions²`` triangles of 7 quadrature points each."""
        coefficient = check_positive(as_float_array(coefficient, "coefficient"), "coefficient")
        density = check_positive(as_float_array(density, "density"), "density")
        if coefficient.ndim > 1 or (
            coefficient.ndim == 1 and coefficient.shape[0] != mechanism.n_bodies
        ):
            raise ValueError(
                f"coefficient must be a scalar or one C_D per panel ({mechanism.n_bodies}), got "
                f"shape {tuple(coefficient.shape)}."
            )
        if not scale > 0:
            raise ValueError(f"scale must be positive, got {scale}.")
        quadrature = PanelQuadrature.from_outlines(mechanism.outlines(), subdivisions)
        return cls(quadrature, coefficient, check_finite(density, "density"), float(scale))

    def force(self, mechanism, q, v):
        poses = mechanism.body_poses(q)
        body = np.asarray(self.quadrature.body)
        rotations, origins = poses[body, :3, :3], poses[body, :3, 3]
        positions = jnp.einsum("pij,pj->pi", rotations, self.quadrature.points) + origins
        normals = jnp.einsum("pij,pj->pi", rotations, self.quadrature.normals)
        twist = mechanism.spatial_velocities(q, v)[body]  # (p, 6): (v_O, ω) of each point's body
        velocity = twist[:, :3] + jnp.cross(twist[:, 3:], positions)
        normal_speed = jnp.sum(velocity * normals, axis=-1)
        coefficient = jnp.broadcast_to(self.coefficient, (mechanism.n_bodies,))[body]
        pressure = (
            -0.5 * self.scale * coefficient * self.density * normal_speed * jnp.abs(normal_speed)
        )
        point_force = (pressure * self.quadrature.weights)[:, None] * normals
        wrench = jnp.concatenate([point_force, jnp.cross(positions, point_force)], axis=-1)
        per_body = jax.ops.segment_sum(wrench, body, num_segments=mechanism.n_bodies)
        return mechanism.apply_wrenches(q, per_body)
