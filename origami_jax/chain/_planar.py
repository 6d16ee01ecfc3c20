"""The dynamics of a planar chain (every hinge axis parallel) in two dimensions, on scalars.

When every hinge axis is parallel to one direction ``e`` (the accordion, any strip folded along parallel
creases) every flap moves in planes normal to ``e``: the chain is a planar linkage. Its equations of
motion are those of the spatial chain restricted to the plane, so nothing is approximated:
- a flap's angular velocity is ``φ̇_i e`` with ``φ_i = Σ_{j≤i} s_j θ_j`` (``s_j = ω_j·e = ±1``); the
  gyroscopic torque ``ω × I ω`` is normal to ``e`` and every hinge torque is a projection on ``e``, so of
  the inertia tensor only ``J_i = eᵀ R_i I_i R_iᵀ e`` (about the CG, along ``e``) enters;
- positions and forces enter through their components in the plane (the offset along ``e`` of a point,
  and gravity along ``e``, give no torque about ``e``).
The result equals the spatial path's to round-off (tests: 1e-12 relative, and Pinocchio on random
planar chains) at ~5× fewer floating-point operations: the 3-flap accordion's forward dynamics take
1,120 per state against 5,860 (XLA's counts, vmapped over 10,000 states).

Coordinates: an orthonormal basis ``(u, v)`` of the plane with ``u × v = e``, ``e = ω_1 / |ω_1|``;
a rotation by ``φ`` about ``e`` maps ``(x, y) ↦ (x cos φ − y sin φ, x sin φ + y cos φ)``. Every 2-vector
is a tuple of two arrays (as in `_scalar`, one fused elementwise pass under `vmap`).
"""

from typing import TYPE_CHECKING

import jax.numpy as jnp
from jaxtyping import Array

from .. import _vec3 as vec3
from .._vec3 import Vec

if TYPE_CHECKING:
    from ._chain import Chain

Vec2 = tuple[Array, Array]


def _add(a: Vec2, b: Vec2) -> Vec2:
    return (a[0] + b[0], a[1] + b[1])


def _sub(a: Vec2, b: Vec2) -> Vec2:
    return (a[0] - b[0], a[1] - b[1])


def _scale(s, a: Vec2) -> Vec2:
    return (s * a[0], s * a[1])


def _dot2(a: Vec2, b: Vec2):
    return a[0] * b[0] + a[1] * b[1]


def _cross2(a: Vec2, b: Vec2):
    """The ``e`` component of ``a × b``."""
    return a[0] * b[1] - a[1] * b[0]


def _perpendicular(a: Vec2) -> Vec2:
    """``e × a``: `a` turned by +90° in the plane."""
    return (-a[1], a[0])


def _rotate(cosine, sine, a: Vec2) -> Vec2:
    return (cosine * a[0] - sine * a[1], sine * a[0] + cosine * a[1])


def _plane_basis(e: Vec) -> tuple[Vec, Vec]:
    """``(u, v)``: `u` is the coordinate axis least aligned with unit `e`, made normal to it; ``v = e × u``.

    Written with comparisons and selects so that it fuses with the rest (no reduction, no gather).
    """
    magnitude = [jnp.abs(x) for x in e]
    pick_x = (magnitude[0] <= magnitude[1]) & (magnitude[0] <= magnitude[2])
    pick_y = ~pick_x & (magnitude[1] <= magnitude[2])
    pick_z = ~pick_x & ~pick_y
    helper: Vec = (
        jnp.where(pick_x, 1.0, 0.0),
        jnp.where(pick_y, 1.0, 0.0),
        jnp.where(pick_z, 1.0, 0.0),
    )
    along = vec3.dot(helper, e)
    u: Vec = (helper[0] - along * e[0], helper[1] - along * e[1], helper[2] - along * e[2])
    inverse_norm = 1 / jnp.sqrt(vec3.dot(u, u))
    u = (u[0] * inverse_norm, u[1] * inverse_norm, u[2] * inverse_norm)
    return u, vec3.cross(e, u)


class PlanarBodies:
    """Per flap at ``θ``, in plane coordinates: the hinge point ``P_i`` (on the axis of hinge ``i``), the
    CG ``C_i``, the mass, ``J_i``, the sign ``s_i`` of the hinge axis along ``e``, and gravity.

    `sin_cos`: ``(sin θ, cos θ)`` of the hinge angles (`origami_jax._math.sin_cos_once`; the complex step
    passes first-order complex ones).
    """

    def __init__(self, chain: "Chain", sin_cos: tuple[Array, Array]):
        n = chain.n_joints
        self.n = n
        first = vec3.vec(chain.axes[0])
        inverse_norm = 1 / jnp.sqrt(vec3.dot(first, first))
        e = (first[0] * inverse_norm, first[1] * inverse_norm, first[2] * inverse_norm)
        u, v = _plane_basis(e)

        def in_plane(x: Vec) -> Vec2:
            return (vec3.dot(x, u), vec3.dot(x, v))

        sines, cosines = sin_cos
        self.sign: list[Array] = []
        self.hinge: list[Vec2] = []  # P_i
        self.cg: list[Vec2] = []  # C_i
        self.mass: list[Array] = []
        self.inertia: list[Array] = []  # J_i
        # Flap i's motion is x ↦ R(φ_i) x + t_i; hinge i's point moves with flap i − 1.
        cos_phi = sin_phi = shift = None
        for i in range(n):
            sign = vec3.dot(vec3.vec(chain.axes[i]), e)
            point = in_plane(vec3.vec(chain.points[i]))
            sine, cosine = sign * sines[..., i], cosines[..., i]  # sin(s θ), cos(s θ) for s = ±1
            if cos_phi is None:
                hinge = point
                cos_phi, sin_phi = cosine, sine
            else:
                assert sin_phi is not None and shift is not None  # set together with cos_phi
                hinge = _add(_rotate(cos_phi, sin_phi, point), shift)
                cos_phi, sin_phi = (
                    cos_phi * cosine - sin_phi * sine,
                    sin_phi * cosine + cos_phi * sine,
                )
            shift = _sub(hinge, _rotate(cos_phi, sin_phi, point))
            cg = _add(
                _rotate(cos_phi, sin_phi, in_plane(vec3.vec(chain.cg_poses[i, :3, 3]))), shift
            )
            rotation = vec3.mat(chain.cg_poses[i, :3, :3])
            e_in_flap = vec3.matvec(vec3.transpose(rotation), e)
            self.sign.append(sign)
            self.hinge.append(hinge)
            self.cg.append(cg)
            self.mass.append(chain.masses[i])
            self.inertia.append(
                vec3.dot(e_in_flap, vec3.matvec(vec3.mat(chain.inertias[i]), e_in_flap))
            )
        self.gravity = in_plane(vec3.vec(chain.gravity))


def planar_mass_matrix_lists(bodies: PlanarBodies) -> list[list[Array]]:
    """``M`` as an n×n nested list of scalars (both halves filled).

    ``M_jk = s_j s_k Σ_{i≥k} [m_i (C_i − P_j)·(C_i − P_k) + J_i]`` for ``j ≤ k``, from the composite
    of flaps ``k..n`` about ``P_k``: its mass, first moment ``h_k`` and polar inertia ``I_k``, carried
    from ``P_{k+1}`` to ``P_k`` by the parallel-axis theorem; then ``M_jk = s_j s_k (I_k + (P_k − P_j)·h_k)``.
    """
    n = bodies.n
    out: list[list] = [[None] * n for _ in range(n)]
    mass = moment = polar = None
    for k in reversed(range(n)):
        lever = _sub(bodies.cg[k], bodies.hinge[k])
        own_polar = bodies.inertia[k] + bodies.mass[k] * _dot2(lever, lever)
        own_moment = _scale(bodies.mass[k], lever)
        if mass is None:
            mass, moment, polar = bodies.mass[k], own_moment, own_polar
        else:
            assert moment is not None and polar is not None  # set together with mass
            shift = _sub(bodies.hinge[k + 1], bodies.hinge[k])
            polar = polar + 2 * _dot2(shift, moment) + mass * _dot2(shift, shift) + own_polar
            moment = _add(_add(moment, _scale(mass, shift)), own_moment)
            mass = mass + bodies.mass[k]
        out[k][k] = polar
        for j in range(k):
            offset = _sub(bodies.hinge[k], bodies.hinge[j])
            entry = bodies.sign[j] * bodies.sign[k] * (polar + _dot2(offset, moment))
            out[j][k] = entry
            out[k][j] = entry
    return out


def planar_inverse_dynamics_lists(bodies: PlanarBodies, theta_dot, theta_ddot) -> list[Array]:
    """Recursive Newton–Euler ``M θ̈ + C θ̇ + G`` in the plane as n scalars; `theta_ddot` may be None.

    Outward: each flap's angular rate ``ω_i`` and acceleration ``α_i``, the acceleration of its hinge
    point (on the parent flap) and of its CG, gravity as a base acceleration ``−g``. Inward: the force
    ``F`` carried through each hinge and the moment ``N`` about its point; ``τ_i = s_i N_i``.
    """
    n = bodies.n
    rate = acceleration = None
    point_acc = _scale(-1.0, bodies.gravity)
    forces: list[Vec2] = []
    moments: list[Array] = []
    for i in range(n):
        if i > 0:
            assert rate is not None and acceleration is not None  # set at i = 0
            link = _sub(bodies.hinge[i], bodies.hinge[i - 1])
            turn = _sub(_scale(acceleration, _perpendicular(link)), _scale(rate * rate, link))
            point_acc = _add(point_acc, turn)
        spin = bodies.sign[i] * theta_dot[i]
        rate = spin if rate is None else rate + spin
        if theta_ddot is not None:
            spin_up = bodies.sign[i] * theta_ddot[i]
            acceleration = spin_up if acceleration is None else acceleration + spin_up
        elif acceleration is None:
            acceleration = 0.0 * rate
        lever = _sub(bodies.cg[i], bodies.hinge[i])
        turn = _sub(_scale(acceleration, _perpendicular(lever)), _scale(rate * rate, lever))
        force = _scale(bodies.mass[i], _add(point_acc, turn))
        forces.append(force)
        moments.append(bodies.inertia[i] * acceleration + _cross2(lever, force))
    out: list = [None] * n
    force_sum: Vec2 | None = None
    moment_sum: Array | None = None
    for i in reversed(range(n)):
        if force_sum is None or moment_sum is None:
            force_sum, moment_sum = forces[i], moments[i]
        else:
            link = _sub(bodies.hinge[i + 1], bodies.hinge[i])
            moment_sum = moments[i] + moment_sum + _cross2(link, force_sum)
            force_sum = _add(force_sum, forces[i])
        out[i] = bodies.sign[i] * moment_sum
    return out
