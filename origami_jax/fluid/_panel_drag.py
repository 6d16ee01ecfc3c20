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
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .. import _vec3 as vec3
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
        # Each panel in its own frame: a point ``p`` (normal ``n``) of a body moving with body-frame
        # twist ``(u, w)`` about the body origin has normal speed ``n·u + (p × n)·w``, and its pressure
        # force ``f n`` has moment ``f (p × n)`` about that origin; so the per-point work is a few
        # multiply-adds on arrays of points (`_by_body`: bodies × points, the points minor), with no
        # per-point rotation and one world wrench per body at the end.
        poses, twists, wrench_force = mechanism.body_motion(q, v)
        rotation, origin = poses[:, :3, :3], poses[:, :3, 3]
        linear, angular = twists[:, :3], twists[:, 3:]
        # Body-frame twist about the body origin: u = Rᵀ(v_O + ω × o), w = Rᵀ ω; `(n, 1)` components.
        u = vec3.vec(jnp.einsum("bji,bj->bi", rotation, linear + jnp.cross(angular, origin)), 1)
        w = vec3.vec(jnp.einsum("bji,bj->bi", rotation, angular), 1)
        points, normals, weights = _by_body(self.quadrature, mechanism.n_bodies)
        lever = vec3.cross(points, normals)  # p × n, body frame
        normal_speed = vec3.dot(normals, u) + vec3.dot(lever, w)
        coefficient = jnp.broadcast_to(self.coefficient, (mechanism.n_bodies,))[:, None]
        pressure = (
            -0.5 * self.scale * coefficient * self.density * normal_speed * jnp.abs(normal_speed)
        ) * weights  # (n, k): force along the point's normal
        force_body = jnp.stack([jnp.sum(pressure * n_k, axis=1) for n_k in normals], axis=-1)
        moment_body = jnp.stack([jnp.sum(pressure * c_k, axis=1) for c_k in lever], axis=-1)
        force = jnp.einsum("bij,bj->bi", rotation, force_body)
        moment = jnp.einsum("bij,bj->bi", rotation, moment_body) + jnp.cross(origin, force)
        return wrench_force(jnp.concatenate([force, moment], axis=-1))


def _by_body(quadrature: PanelQuadrature, n_bodies: int):
    """The quadrature by body, `(n, k)` per component (points, normals) and for the weights, padded
    with zero weights to the largest body's count `k` (static layout from `quadrature.body`)."""
    body = np.asarray(quadrature.body, dtype=np.int64)
    counts = np.bincount(body, minlength=n_bodies)
    width = max(int(counts.max()), 1)
    index = np.zeros((n_bodies, width), np.int64)
    valid = np.zeros((n_bodies, width), bool)
    for b in range(n_bodies):
        rows = np.flatnonzero(body == b)
        index[b, : len(rows)] = rows
        valid[b, : len(rows)] = True
    points = quadrature.points[index]  # (n, k, 3)
    normals = quadrature.normals[index]
    weights = jnp.where(valid, quadrature.weights[index], 0.0)
    return vec3.vec(points), vec3.vec(normals), weights
