"""The recursive dynamics written on scalars: the fast path for chains of a few hinges.

Every 3-vector is a tuple of three arrays and every 3×3 matrix a tuple of three rows, with one Python loop
over the hinges. Under `vmap` each operation is then one elementwise pass over the batch, which XLA fuses
into a handful of vectorised loops; the same algebra on `(…, n, 3)` arrays spends its time on tiny minor
dimensions of size 3 (measured on the CPU for the 3-flap accordion vmapped over 10,000 states: ~27 ns per
state for the scalar Cholesky against ~3 µs for the array kinematics alone).

The algorithm is the one of `_dynamics` (composite rigid bodies for ``M``, Newton–Euler for the bias), in
the inertial frame about its origin, with spatial vectors ordered ``(linear, angular)``.
"""

from typing import NamedTuple, cast

import equinox.internal as eqxi
import jax
import jax.numpy as jnp
from jaxtyping import Array

from .._math import SIN_COS_REDUCTION_LIMIT, sin_cos_reduced
from ._chain import Chain

Vec = tuple[Array, Array, Array]
Mat = tuple[Vec, Vec, Vec]


def _add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _scale(s, a: Vec) -> Vec:
    return (s * a[0], s * a[1], s * a[2])


def _dot(a: Vec, b: Vec):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec, b: Vec) -> Vec:
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def _matvec(m: Mat, x: Vec) -> Vec:
    return (_dot(m[0], x), _dot(m[1], x), _dot(m[2], x))


def _matmul(a: Mat, b: Mat) -> Mat:
    columns = tuple((b[0][k], b[1][k], b[2][k]) for k in range(3))
    return tuple(tuple(_dot(a[r], columns[k]) for k in range(3)) for r in range(3))  # type: ignore[return-value]


def _vec(array) -> Vec:
    return (array[..., 0], array[..., 1], array[..., 2])


def _mat(array) -> Mat:
    return (_vec(array[..., 0, :]), _vec(array[..., 1, :]), _vec(array[..., 2, :]))


class ScalarBodies:
    """Hinge twists and per-flap spatial inertias about the origin at ``θ``, as scalars.

    `sin_cos`: ``(sin θ, cos θ)`` when the caller has them (the complex step of `_dynamics` passes
    first-order complex ones); by default computed here.
    """

    def __init__(self, chain: Chain, theta: Array, sin_cos: tuple[Array, Array] | None = None):
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
            axis, point = _vec(chain.axes[i]), _vec(chain.points[i])
            s, c = sines[..., i], cosines[..., i]
            one_minus_c = 1 - c
            # Rodrigues for a unit axis: R = c I + s ω̂ + (1 − c) ω ωᵀ.
            x, y, z = axis
            rotation = (
                (c + one_minus_c * x * x, one_minus_c * x * y - s * z, one_minus_c * x * z + s * y),
                (one_minus_c * y * x + s * z, c + one_minus_c * y * y, one_minus_c * y * z - s * x),
                (one_minus_c * z * x - s * y, one_minus_c * z * y + s * x, c + one_minus_c * z * z),
            )
            translation = _sub(point, _matvec(rotation, point))  # rotation about the axis through q
            if rotation_before is None:
                w, p = axis, point
                rotation_after, translation_after = rotation, translation
            else:
                assert translation_before is not None  # set together with rotation_before
                w = _matvec(rotation_before, axis)
                p = _add(_matvec(rotation_before, point), translation_before)
                rotation_after = _matmul(rotation_before, rotation)
                translation_after = _add(_matvec(rotation_before, translation), translation_before)
            flap_rotation = _matmul(rotation_after, _mat(chain.cg_poses[i, :3, :3]))
            cg = _add(_matvec(rotation_after, _vec(chain.cg_poses[i, :3, 3])), translation_after)
            mass = chain.masses[i]
            # Rotate the CG inertia into the world (R I Rᵀ) and move it to the origin (parallel axes).
            rotated = _matmul(
                _matmul(flap_rotation, _mat(chain.inertias[i])), _transpose(flap_rotation)
            )
            c2 = _dot(cg, cg)
            inertia = tuple(
                tuple(
                    rotated[a][b] + mass * ((c2 if a == b else 0.0) - cg[a] * cg[b])
                    for b in range(3)
                )
                for a in range(3)
            )
            self.w.append(w)
            self.v.append(_cross(p, w))
            self.mass.append(mass)
            self.moment.append(_scale(mass, cg))
            self.inertia.append(inertia)  # type: ignore[arg-type]
            rotation_before, translation_before = rotation_after, translation_after


def sin_cos_once(theta: Array) -> tuple[Array, Array]:
    """``(sin θ, cos θ)`` of the hinge angles; on the CPU evaluated once, by vectorised polynomials.

    XLA:CPU has no multi-output fusion: every fused kernel re-evaluates the elementwise expressions it
    reads, and the forward dynamics split into seven kernels (one per Cholesky pivot and the output),
    each recomputing all the sines and cosines, which cost ~10 ns apiece in float64 (`jnp.sin`). On
    the CPU they are therefore computed inside a conditional (a fusion boundary) by
    `sin_cos_reduced` (fdlibm's polynomials, 2 ulp, ~1.7 ns). Vmapped over 128 accordion states the
    right-hand side went from 47 to 20 µs per call. Other backends fuse differently, have fast
    transcendentals, and pay a device-to-host copy for every conditional's branch index, so they get
    plain `jnp.sin`/`jnp.cos` (`lax.platform_dependent` picks at lowering time).
    """
    return jax.lax.platform_dependent(
        theta, cpu=_sin_cos_in_own_kernel, default=lambda x: (jnp.sin(x), jnp.cos(x))
    )


def _sin_cos_in_own_kernel(theta: Array) -> tuple[Array, Array]:
    # Per element: the polynomials within their reduction range, `jnp.sin`/`jnp.cos` beyond it, NaN
    # where the angle is not finite (what sin/cos give). `unvmap_any` keeps the branch index
    # unbatched under `vmap`, so the switch stays a branch and does not become a select that
    # evaluates both; every element gets the same value in either branch, so a batch member's
    # result never depends on the other members (a blown-up trial state of one member would
    # otherwise switch the whole batch to `jnp.sin`, 1 ulp apart, and chaotic contact dynamics
    # amplify that into a different trajectory).
    finite = jnp.isfinite(theta)
    beyond = finite & (jnp.abs(theta) > SIN_COS_REDUCTION_LIMIT)

    def reduced(x):
        s, c = sin_cos_reduced(x)
        return jnp.where(finite, s, jnp.nan), jnp.where(finite, c, jnp.nan)

    def mixed(x):
        s, c = reduced(x)
        return jnp.where(beyond, jnp.sin(x), s), jnp.where(beyond, jnp.cos(x), c)

    return jax.lax.cond(eqxi.unvmap_any(jnp.any(beyond)), mixed, reduced, theta)


def _transpose(m: Mat) -> Mat:
    return tuple(tuple(m[r][k] for r in range(3)) for k in range(3))  # type: ignore[return-value]


def _apply_inertia(mass, moment: Vec, inertia: Mat, lin: Vec, ang: Vec) -> tuple[Vec, Vec]:
    # Spatial inertia about the origin times a motion vector: (m a − h × α, h × a + I_o α).
    return _sub(_scale(mass, lin), _cross(moment, ang)), _add(
        _cross(moment, lin), _matvec(inertia, ang)
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
            moment = _add(moment, bodies.moment[k])
            inertia = cast(Mat, tuple(_add(inertia[r], bodies.inertia[k][r]) for r in range(3)))
        force, torque = _apply_inertia(mass, moment, inertia, bodies.v[k], bodies.w[k])
        for j in range(k + 1):
            entry = _dot(bodies.v[j], force) + _dot(bodies.w[j], torque)
            out[j][k] = entry
            out[k][j] = entry
    return out


def newton_euler_lists(bodies: ScalarBodies, gravity: Array, theta_dot, theta_ddot) -> list[Array]:
    """Recursive Newton–Euler ``M θ̈ + C θ̇ + G`` as a list of n scalars; `theta_ddot` may be None."""
    n = bodies.n
    zero = 0.0 * theta_dot[0]
    vel_lin: Vec = (zero, zero, zero)
    vel_ang: Vec = (zero, zero, zero)
    acc_lin: Vec = _scale(-1.0, _vec(gravity))  # gravity as a base acceleration −g
    acc_ang: Vec = (zero, zero, zero)
    forces, torques = [], []
    for i in range(n):
        rate = theta_dot[i]
        s_lin, s_ang = bodies.v[i], bodies.w[i]
        vel_lin = _add(vel_lin, _scale(rate, s_lin))
        vel_ang = _add(vel_ang, _scale(rate, s_ang))
        # d/dt S_i = V_{i−1} × S_i = V_i × S_i (S_i × S_i = 0).
        cross_lin = _add(_cross(vel_ang, s_lin), _cross(vel_lin, s_ang))
        cross_ang = _cross(vel_ang, s_ang)
        acc_lin = _add(acc_lin, _scale(rate, cross_lin))
        acc_ang = _add(acc_ang, _scale(rate, cross_ang))
        if theta_ddot is not None:
            acc_lin = _add(acc_lin, _scale(theta_ddot[i], s_lin))
            acc_ang = _add(acc_ang, _scale(theta_ddot[i], s_ang))
        args = (bodies.mass[i], bodies.moment[i], bodies.inertia[i])
        f_acc, n_acc = _apply_inertia(*args, acc_lin, acc_ang)
        f_mom, n_mom = _apply_inertia(*args, vel_lin, vel_ang)
        forces.append(_add(f_acc, _cross(vel_ang, f_mom)))
        torques.append(_add(n_acc, _add(_cross(vel_lin, f_mom), _cross(vel_ang, n_mom))))
    out: list = [None] * n
    force_sum = torque_sum = None
    for i in reversed(range(n)):
        force_sum = forces[i] if force_sum is None else _add(force_sum, forces[i])
        torque_sum = torques[i] if torque_sum is None else _add(torque_sum, torques[i])
        out[i] = _dot(bodies.v[i], force_sum) + _dot(bodies.w[i], torque_sum)
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
