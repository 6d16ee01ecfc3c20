"""Hinge joint models of a panel tree: the revolute crease and the bending-arc hinge.

A joint connects a panel to its parent with one degree of freedom, the fold angle ``q`` (rad, valley
positive). Everything is written in the *rest frame*: the world frame at ``q = 0`` (the flat, as
fabricated pattern). A joint model gives, for every hinge at once,

- `transform(q)`: the displacement ``J(q) = (R, t)`` that the hinge applies to everything beyond it,
  as a rigid motion of the rest frame (``x ↦ R x + t``); ``J(0)`` is the identity;
- `motion(q)`: its motion subspace ``S(q) = (J̇ J⁻¹)^∨ / q̇``, a spatial motion vector about the origin
  ordered ``(linear, angular)``: ``(ṫ − ω × t, ω)`` per unit rate;
- `motion_derivative(q)`: ``dS/dq``, which enters the accelerations as the velocity-product term
  ``(dS/dq) q̇²`` (zero for a revolute joint).

The tree (`origami_jax.net._dynamics`) composes the displacements along the tree and moves every
``S`` into the world with its parent's displacement, so a new hinge model is one more subclass.
Vectors and matrices are returned by component (`origami_jax._vec3`: a 3-vector is a tuple of three arrays
shaped like ``q``, `(n, *batch)`, a matrix a tuple of three rows), the layout the tree algorithms
compute in.

**Revolute** (`RevoluteJoints`): a rotation by ``q`` about the unit axis ``ω`` through the point
``p``; ``S = (p × ω, ω)`` is constant.

**Bending arc** (`ArcJoints`): the hinge is a strip of length ``l`` bending at uniform curvature
``κ = q / l`` (constant-curvature kinematics, Webster & Jones, IJRR 29, 2010). In the crease frame
(``x = ω`` along the crease, ``y = d`` into the child, ``z = n = ω × d``), the strip leaves the
parent's edge at ``p`` along ``d`` and its end sits at ``l (sin q / q, (1 − cos q) / q)`` in ``(y, z)``,
turned by ``q`` about ``x``; the child is attached to that end (at rest, ``l`` away from the crease).
Hence ``R`` is the same rotation as the revolute joint's and

    t(q) = p − R p + l ((sin q / q − cos q) d + ((1 − cos q) / q − sin q) n),
    S(q) = (p × ω + l (f₁(q) d − f₂(q) n), ω),   f₁ = (q − sin q) / q²,  f₂ = (1 − cos q) / q².

At ``q = 0`` the instantaneous axis is the strip's midline, ``p + l d / 2``, and ``l → 0`` gives the
revolute joint. ``f₁``, ``f₂`` and ``sin q / q`` are evaluated by their Taylor series for ``|q| < 1``
(through ``q¹⁶``, remainder below 1e-17 relative) and in closed form beyond, each branch fed a safe
argument, so values and derivatives of every order are exact to rounding at and near ``q = 0``.
The strip is massless here (its mass belongs to the adjacent panels).
"""

import abc
import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .. import _vec3 as vec3
from .._math import sin_cos_once
from .._vec3 import Mat, Vec


@jax.custom_jvp
def sin_cos(q: Array) -> tuple[Array, Array]:
    """``(sin q, cos q)`` by `origami_jax._math.sin_cos_once` (on the CPU computed once, by
    vectorised polynomials), with the exact derivatives ``(cos q dq, −sin q dq)`` rather than the
    polynomials' own (less accurate than their values)."""
    return sin_cos_once(q)


@sin_cos.defjvp
def _sin_cos_jvp(primals, tangents):
    (q,), (dq,) = primals, tangents
    s, c = sin_cos(q)
    return (s, c), (c * dq, -s * dq)


def axis_rotations(axes: Vec, q: Float[Array, " n *batch"]) -> Mat:
    """Rotations by ``q`` about unit `axes` (Rodrigues, ``R = c I + s ω̂ + (1 − c) ω ωᵀ``)."""
    s, c = sin_cos(q)
    one_minus_c = 1 - c
    x, y, z = axes
    return (
        (c + one_minus_c * x * x, one_minus_c * x * y - s * z, one_minus_c * x * z + s * y),
        (one_minus_c * y * x + s * z, c + one_minus_c * y * y, one_minus_c * y * z - s * x),
        (one_minus_c * z * x - s * y, one_minus_c * z * y + s * x, c + one_minus_c * z * z),
    )


class AbstractJoints(eqx.Module):
    """One-degree-of-freedom hinges, one per panel (module docstring: the contract).

    **Fields:** `axes`, unit crease directions ``ω`` at rest, `(n, 3)`; `points`, a point ``p`` on
    each crease (on the parent's edge), `(n, 3)`, length. Both in the rest (world) frame.
    """

    axes: eqx.AbstractVar[Float[Array, "n 3"]]
    points: eqx.AbstractVar[Float[Array, "n 3"]]

    constant_motion: ClassVar[bool] = False
    """``S`` does not depend on ``q`` (then `motion_derivative` is zero and is never evaluated)."""

    @abc.abstractmethod
    def transform(self, q: Float[Array, " n *batch"]) -> tuple[Mat, Vec]:
        """Displacement ``J(q) = (R, t)`` of each hinge in the rest frame: the rotation (a `Mat`)
        and the translation (a `Vec`, length). `q` has shape `(n, *batch)` (hinges first); the
        components broadcast against it (constant ones may keep size-1 batch axes)."""

    @abc.abstractmethod
    def motion(self, q: Float[Array, " n *batch"]) -> tuple[Vec, Vec]:
        """Motion subspace ``S(q) = (linear, angular)`` of each hinge in the rest frame, about the
        origin, per unit rate (linear part in length, angular dimensionless); shapes as in
        `transform`."""

    def motion_derivative(self, q: Float[Array, " n *batch"]) -> tuple[Vec, Vec]:
        """``dS/dq`` of each hinge (each row depends on its own angle only, so one forward-mode
        pass with a unit tangent gives every row)."""
        return jax.jvp(self.motion, (q,), (jnp.ones_like(q),))[1]

    def take(self, index) -> "AbstractJoints":
        """The hinges at `index` (an integer array), as a joint set of the same kind."""
        return jax.tree_util.tree_map(lambda x: x[index], self)


class RevoluteJoints(AbstractJoints):
    """Point hinges: a rotation by ``q`` about the axis ``ω`` through ``p`` (the paper's creases)."""

    axes: Float[Array, "n 3"]
    points: Float[Array, "n 3"]

    constant_motion: ClassVar[bool] = True

    def transform(self, q):
        extra = q.ndim - 1
        rotation = axis_rotations(vec3.vec(self.axes, extra), q)
        point = vec3.vec(self.points, extra)
        # A rotation about the axis through p maps x to R(x − p) + p.
        return rotation, vec3.sub(point, vec3.matvec(rotation, point))

    def motion(self, q):
        extra = q.ndim - 1
        axis = vec3.vec(self.axes, extra)
        return vec3.cross(vec3.vec(self.points, extra), axis), axis


# Taylor coefficients in q² (index k: the q^{2k} coefficient), through q¹⁶: for |q| < 1 the next term
# is below 1/19! ≈ 8e-18 relative to the leading one.
_SINC = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(9))  # sin q / q
_F1 = tuple((-1) ** k / math.factorial(2 * k + 3) for k in range(9))  # (q − sin q) / q³
_F2 = tuple((-1) ** k / math.factorial(2 * k + 2) for k in range(9))  # (1 − cos q) / q²
_SERIES_LIMIT = 1.0


def _horner(coefficients: tuple[float, ...], z: Array) -> Array:
    out = jnp.full_like(z, coefficients[-1])
    for c in coefficients[-2::-1]:
        out = out * z + c
    return out


def arc_functions(q: Float[Array, "*batch"]) -> tuple[Array, Array, Array]:
    """``(sin q / q, (q − sin q) / q², (1 − cos q) / q²)``, exact to rounding with all derivatives.

    Series below ``|q| = 1``, closed forms above; each branch sees a safe argument (the other
    branch's value where it is not used), so no NaN reaches a derivative.
    """
    small = jnp.abs(q) < _SERIES_LIMIT
    qs = jnp.where(small, q, 0.0)
    ql = jnp.where(small, 1.0, q)
    z = qs * qs
    sin_l, cos_l = jnp.sin(ql), jnp.cos(ql)
    sinc = jnp.where(small, _horner(_SINC, z), sin_l / ql)
    f1 = jnp.where(small, qs * _horner(_F1, z), (ql - sin_l) / (ql * ql))
    f2 = jnp.where(small, _horner(_F2, z), (1 - cos_l) / (ql * ql))
    return sinc, f1, f2


class ArcJoints(AbstractJoints):
    """Bending-arc hinges of strip length ``l`` (module docstring: the kinematics).

    **Fields:** `axes` ``ω`` and `points` ``p`` (the strip's edge on the parent), `directions` ``d``,
    the unit in-plane direction from the crease into the child (perpendicular to ``ω``; ``ω × d`` is
    the panel normal), `(n, 3)`; `lengths` ``l``, `(n,)`, length (zero gives a revolute hinge).
    """

    axes: Float[Array, "n 3"]
    points: Float[Array, "n 3"]
    directions: Float[Array, "n 3"]
    lengths: Float[Array, " n"]

    def transform(self, q):
        extra = q.ndim - 1
        axis, point = vec3.vec(self.axes, extra), vec3.vec(self.points, extra)
        direction, length = vec3.vec(self.directions, extra), vec3.expand(self.lengths, extra)
        rotation = axis_rotations(axis, q)
        sinc, _, f2 = arc_functions(q)
        normal = vec3.cross(axis, direction)
        along = length * (sinc - jnp.cos(q))
        up = length * (q * f2 - jnp.sin(q))
        translation = vec3.add(
            vec3.sub(point, vec3.matvec(rotation, point)),
            vec3.add(vec3.scale(along, direction), vec3.scale(up, normal)),
        )
        return rotation, translation

    def motion(self, q):
        extra = q.ndim - 1
        axis, point = vec3.vec(self.axes, extra), vec3.vec(self.points, extra)
        direction, length = vec3.vec(self.directions, extra), vec3.expand(self.lengths, extra)
        _, f1, f2 = arc_functions(q)
        normal = vec3.cross(axis, direction)
        lin = vec3.add(
            vec3.cross(point, axis),
            vec3.sub(vec3.scale(length * f1, direction), vec3.scale(length * f2, normal)),
        )
        return lin, axis
