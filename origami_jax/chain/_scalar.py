"""The recursive dynamics written on scalars: the fast path for chains of a few hinges.

Every 3-vector is a tuple of three arrays and every 3×3 matrix a tuple of three rows, with one Python loop
over the hinges. Under `vmap` each operation is then one elementwise pass over the batch, which XLA fuses
into a handful of vectorised loops; the same algebra on `(…, n, 3)` arrays spends its time on tiny minor
dimensions of size 3 (measured on the CPU for the 3-flap accordion vmapped over 10,000 states: ~27 ns per
state for the scalar Cholesky against ~3 µs for the array kinematics alone).

The algorithm is the one of `_dynamics` (composite rigid bodies for ``M``, Newton–Euler for the bias), in
the inertial frame about its origin, with spatial vectors ordered ``(linear, angular)``.
"""

from typing import TYPE_CHECKING, NamedTuple, cast

import jax.numpy as jnp
from jaxtyping import Array

from .. import _vec3 as vec3
from .._math import sin_cos_once
from .._vec3 import Mat, Vec

if TYPE_CHECKING:
    from ._chain import Chain


class ScalarBodies:
    """Hinge twists and per-flap spatial inertias about the origin at ``θ``, as scalars.

    `sin_cos`: ``(sin θ, cos θ)`` when the caller has them (the complex step of `_dynamics` passes
    first-order complex ones); by default computed here.
    """

    def __init__(self, chain: "Chain", theta: Array, sin_cos: tuple[Array, Array] | None = None):
        n = chain.n_joints
        self.n = n
        self.v: list[Vec] = []  # linear part of hinge twists at the origin, p × w
        self.w: list[Vec] = []  # world hinge axes
        self.mass: list[Array] = []
        self.moment: list[Vec] = []  # m c
        self.inertia: list[Mat] = []  # rotational inertia about the origin, world frame
        rotation_before: Mat | None = None  # e^{ξ̂_1θ_1}⋯e^{ξ̂_{i−1}θ_{i−1}}; None is the identity
        translation_before: Vec | None = None
        sines, cosines = sin_cos_once(theta) if sin_cos is None else sin_cos
        for i in range(n):
            axis, point = vec3.vec(chain.axes[i]), vec3.vec(chain.points[i])
            s, c = sines[..., i], cosines[..., i]
            one_minus_c = 1 - c
            # Rodrigues for a unit axis: R = c I + s ω̂ + (1 − c) ω ωᵀ.
            x, y, z = axis
            rotation = (
                (c + one_minus_c * x * x, one_minus_c * x * y - s * z, one_minus_c * x * z + s * y),
                (one_minus_c * y * x + s * z, c + one_minus_c * y * y, one_minus_c * y * z - s * x),
                (one_minus_c * z * x - s * y, one_minus_c * z * y + s * x, c + one_minus_c * z * z),
            )
            translation = vec3.sub(
                point, vec3.matvec(rotation, point)
            )  # rotation about the axis through q
            if rotation_before is None:
                w, p = axis, point
                rotation_after, translation_after = rotation, translation
            else:
                assert translation_before is not None  # set together with rotation_before
                w = vec3.matvec(rotation_before, axis)
                p = vec3.add(vec3.matvec(rotation_before, point), translation_before)
                rotation_after = vec3.matmul(rotation_before, rotation)
                translation_after = vec3.add(
                    vec3.matvec(rotation_before, translation), translation_before
                )
            flap_rotation = vec3.matmul(rotation_after, vec3.mat(chain.cg_poses[i, :3, :3]))
            cg = vec3.add(
                vec3.matvec(rotation_after, vec3.vec(chain.cg_poses[i, :3, 3])), translation_after
            )
            mass = chain.masses[i]
            # Rotate the CG inertia into the world (R I Rᵀ) and move it to the origin (parallel axes).
            rotated = vec3.matmul(
                vec3.matmul(flap_rotation, vec3.mat(chain.inertias[i])),
                vec3.transpose(flap_rotation),
            )
            c2 = vec3.dot(cg, cg)
            inertia = tuple(
                tuple(
                    rotated[a][b] + mass * ((c2 if a == b else 0.0) - cg[a] * cg[b])
                    for b in range(3)
                )
                for a in range(3)
            )
            self.w.append(w)
            self.v.append(vec3.cross(p, w))
            self.mass.append(mass)
            self.moment.append(vec3.scale(mass, cg))
            self.inertia.append(inertia)  # type: ignore[arg-type]
            rotation_before, translation_before = rotation_after, translation_after


def _apply_inertia(mass, moment: Vec, inertia: Mat, lin: Vec, ang: Vec) -> tuple[Vec, Vec]:
    # Spatial inertia about the origin times a motion vector: (m a − h × α, h × a + I_o α).
    return vec3.sub(vec3.scale(mass, lin), vec3.cross(moment, ang)), vec3.add(
        vec3.cross(moment, lin), vec3.matvec(inertia, ang)
    )


def mass_matrix_lists(bodies: ScalarBodies) -> list[list[Array]]:
    """Composite-rigid-body ``M`` as an n×n nested list of scalars (symmetric, both halves filled)."""
    n = bodies.n
    out: list[list] = [[None] * n for _ in range(n)]
    mass: Array | None = None
    moment: Vec | None = None
    inertia: Mat | None = None
    for k in reversed(range(n)):
        if mass is None:
            mass, moment, inertia = bodies.mass[k], bodies.moment[k], bodies.inertia[k]
        else:
            assert moment is not None and inertia is not None  # set together with mass
            mass = mass + bodies.mass[k]
            moment = vec3.add(moment, bodies.moment[k])
            inertia = cast(Mat, tuple(vec3.add(inertia[r], bodies.inertia[k][r]) for r in range(3)))
        force, torque = _apply_inertia(mass, moment, inertia, bodies.v[k], bodies.w[k])
        for j in range(k + 1):
            entry = vec3.dot(bodies.v[j], force) + vec3.dot(bodies.w[j], torque)
            out[j][k] = entry
            out[k][j] = entry
    return out


def newton_euler_lists(bodies: ScalarBodies, gravity: Array, theta_dot, theta_ddot) -> list[Array]:
    """Recursive Newton–Euler ``M θ̈ + C θ̇ + G`` as a list of n scalars; `theta_ddot` may be None."""
    n = bodies.n
    zero = 0.0 * theta_dot[0]
    vel_lin: Vec = (zero, zero, zero)
    vel_ang: Vec = (zero, zero, zero)
    acc_lin: Vec = vec3.scale(-1.0, vec3.vec(gravity))  # gravity as a base acceleration −g
    acc_ang: Vec = (zero, zero, zero)
    forces, torques = [], []
    for i in range(n):
        rate = theta_dot[i]
        s_lin, s_ang = bodies.v[i], bodies.w[i]
        vel_lin = vec3.add(vel_lin, vec3.scale(rate, s_lin))
        vel_ang = vec3.add(vel_ang, vec3.scale(rate, s_ang))
        # d/dt S_i = V_{i−1} × S_i = V_i × S_i (S_i × S_i = 0).
        cross_lin = vec3.add(vec3.cross(vel_ang, s_lin), vec3.cross(vel_lin, s_ang))
        cross_ang = vec3.cross(vel_ang, s_ang)
        acc_lin = vec3.add(acc_lin, vec3.scale(rate, cross_lin))
        acc_ang = vec3.add(acc_ang, vec3.scale(rate, cross_ang))
        if theta_ddot is not None:
            acc_lin = vec3.add(acc_lin, vec3.scale(theta_ddot[i], s_lin))
            acc_ang = vec3.add(acc_ang, vec3.scale(theta_ddot[i], s_ang))
        args = (bodies.mass[i], bodies.moment[i], bodies.inertia[i])
        f_acc, n_acc = _apply_inertia(*args, acc_lin, acc_ang)
        f_mom, n_mom = _apply_inertia(*args, vel_lin, vel_ang)
        forces.append(vec3.add(f_acc, vec3.cross(vel_ang, f_mom)))
        torques.append(
            vec3.add(n_acc, vec3.add(vec3.cross(vel_lin, f_mom), vec3.cross(vel_ang, n_mom)))
        )
    out: list = [None] * n
    force_sum = torque_sum = None
    for i in reversed(range(n)):
        force_sum = forces[i] if force_sum is None else vec3.add(force_sum, forces[i])
        torque_sum = torques[i] if torque_sum is None else vec3.add(torque_sum, torques[i])
        out[i] = vec3.dot(bodies.v[i], force_sum) + vec3.dot(bodies.w[i], torque_sum)
    return out


class CholeskyLists(NamedTuple):
    """Cholesky factor ``M = L Lᵀ`` as nested lists of scalars: the strict lower triangle and ``1/L_jj``."""

    low: list[list[Array]]
    inverse_diagonal: list[Array]


def cholesky_lists(matrix: list[list[Array]]) -> CholeskyLists:
    """Factor a symmetric positive-definite ``M`` given as nested lists of scalars."""
    n = len(matrix)
    low: list[list] = [[None] * n for _ in range(n)]
    inverse_diagonal: list = [None] * n
    for j in range(n):
        diagonal = matrix[j][j]
        for k in range(j):
            diagonal = diagonal - low[j][k] * low[j][k]
        inverse_diagonal[j] = 1 / jnp.sqrt(diagonal)
        for i in range(j + 1, n):
            entry = matrix[i][j]
            for k in range(j):
                entry = entry - low[i][k] * low[j][k]
            low[i][j] = entry * inverse_diagonal[j]
    return CholeskyLists(low, inverse_diagonal)


def cholesky_solve_factored(factor: CholeskyLists, rhs: list[Array]) -> list[Array]:
    """Solve ``L Lᵀ x = rhs`` by forward and back substitution (`rhs` may carry extra batch axes)."""
    low, inverse_diagonal = factor
    n = len(rhs)
    y: list = [None] * n
    for i in range(n):
        entry = rhs[i]
        for k in range(i):
            entry = entry - low[i][k] * y[k]
        y[i] = entry * inverse_diagonal[i]
    x: list = [None] * n
    for i in reversed(range(n)):
        entry = y[i]
        for k in range(i + 1, n):
            entry = entry - low[k][i] * x[k]
        x[i] = entry * inverse_diagonal[i]
    return x
