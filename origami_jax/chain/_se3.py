"""SE(3) and so(3) helpers: hat/vee, twist exponentials, adjoints.

Twists are ordered ``ξ = (v, ω)`` (linear part first), as in Murray, Li & Sastry (1994) and the paper.
A revolute joint with unit axis ``ω`` through a point ``q`` has ``v = −ω × q``. All functions are pure JAX,
broadcast over leading axes, and differentiable everywhere, including ``θ = 0``.
"""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float


def hat(omega: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 3 3"]:
    """Skew-symmetric matrix ``ω̂`` with ``ω̂ x = ω × x``."""
    w = jnp.asarray(omega)
    zero = jnp.zeros_like(w[..., 0])
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    rows = (
        jnp.stack([zero, -z, y], axis=-1),
        jnp.stack([z, zero, -x], axis=-1),
        jnp.stack([-y, x, zero], axis=-1),
    )
    return jnp.stack(rows, axis=-2)


def vee(matrix: Float[ArrayLike, "*batch 3 3"]) -> Float[Array, "*batch 3"]:
    """Inverse of `hat`: the vector of a skew-symmetric 3×3 matrix (its skew part, if not skew)."""
    m = jnp.asarray(matrix)
    return 0.5 * jnp.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]],
        axis=-1,
    )


def twist_hat(xi: Float[ArrayLike, "*batch 6"]) -> Float[Array, "*batch 4 4"]:
    """The 4×4 matrix ``ξ̂ = [[ω̂, v], [0, 0]]`` of a twist ``ξ = (v, ω)``."""
    xi = jnp.asarray(xi)
    top = jnp.concatenate([hat(xi[..., 3:]), xi[..., :3, None]], axis=-1)
    bottom = jnp.zeros(xi.shape[:-1] + (1, 4), xi.dtype)
    return jnp.concatenate([top, bottom], axis=-2)


def twist_vee(matrix: Float[ArrayLike, "*batch 4 4"]) -> Float[Array, "*batch 6"]:
    """Inverse of `twist_hat`: ``(v, ω)`` from ``[[ω̂, v], [0, 0]]``."""
    m = jnp.asarray(matrix)
    return jnp.concatenate([m[..., :3, 3], vee(m[..., :3, :3])], axis=-1)


def revolute_twist(
    axis: Float[ArrayLike, "*batch 3"], point: Float[ArrayLike, "*batch 3"]
) -> Float[Array, "*batch 6"]:
    """Twist ``(−ω × q, ω)`` of a revolute joint about unit axis ``ω`` through point ``q``."""
    axis = jnp.asarray(axis)
    return jnp.concatenate([-jnp.cross(axis, jnp.asarray(point)), axis], axis=-1)


def _series_coefficients(angle_squared: Array) -> tuple[Array, Array, Array]:
    # A = sin a / a, B = (1 − cos a) / a², C = (a − sin a) / a³ as functions of a², which are entire:
    # below a² = 1e-2 the Taylor series to a⁸ is exact to ~1e-16, and above it the
    # closed forms lose at most ~1e-13 to cancellation. The double `where` keeps the closed form from
    # being evaluated (and differentiated) at a = 0.
    small = angle_squared < 1e-2
    a2 = jnp.where(small, 1.0, angle_squared)
    a = jnp.sqrt(a2)
    s, c = jnp.sin(a), jnp.cos(a)
    x = angle_squared
    series_a = 1 - x / 6 * (1 - x / 20 * (1 - x / 42 * (1 - x / 72)))
    series_b = 0.5 * (1 - x / 12 * (1 - x / 30 * (1 - x / 56 * (1 - x / 90))))
    series_c = (1 - x / 20 * (1 - x / 42 * (1 - x / 72 * (1 - x / 110)))) / 6
    coeff_a = jnp.where(small, series_a, s / a)
    coeff_b = jnp.where(small, series_b, (1 - c) / a2)
    coeff_c = jnp.where(small, series_c, (a - s) / (a2 * a))
    return coeff_a, coeff_b, coeff_c


def exp_so3(omega: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 3 3"]:
    """Rotation ``exp(ω̂)`` by Rodrigues' formula; ``|ω|`` is the angle (rad)."""
    omega = jnp.asarray(omega)
    coeff_a, coeff_b, _ = _series_coefficients(jnp.sum(omega * omega, axis=-1))
    w = hat(omega)
    eye = jnp.eye(3, dtype=w.dtype)
    return eye + coeff_a[..., None, None] * w + coeff_b[..., None, None] * (w @ w)


def exp_twist(
    xi: Float[ArrayLike, "*batch 6"], theta: Float[ArrayLike, "*batch"]
) -> Float[Array, "*batch 4 4"]:
    """Homogeneous transform ``exp(ξ̂ θ)`` of a general twist ``ξ = (v, ω)`` (exact, closed form).

    Works for any ``ω`` (unit for a revolute joint, zero for a pure translation) and is smooth in
    ``θ``, including ``θ = 0``.

    **Arguments:**
    - `xi`: twists ``(v, ω)``, shape `(*batch, 6)`.
    - `theta`: joint values (rad for unit ``ω``), shape `(*batch,)`.

    **Returns:** transforms, shape `(*batch, 4, 4)`.
    """
    xi = jnp.asarray(xi)
    theta = jnp.asarray(theta)
    v = xi[..., :3] * theta[..., None]
    omega = xi[..., 3:] * theta[..., None]
    coeff_a, coeff_b, coeff_c = _series_coefficients(jnp.sum(omega * omega, axis=-1))
    w = hat(omega)
    w2 = w @ w
    eye = jnp.eye(3, dtype=w.dtype)
    rotation = eye + coeff_a[..., None, None] * w + coeff_b[..., None, None] * w2
    left_jacobian = eye + coeff_b[..., None, None] * w + coeff_c[..., None, None] * w2
    translation = jnp.einsum("...ij,...j->...i", left_jacobian, v)
    return make_transform(rotation, translation)


def make_transform(
    rotation: Float[ArrayLike, "*batch 3 3"], translation: Float[ArrayLike, "*batch 3"]
) -> Float[Array, "*batch 4 4"]:
    """Homogeneous transform ``[[R, p], [0, 1]]``."""
    rotation = jnp.asarray(rotation)
    translation = jnp.asarray(translation)
    top = jnp.concatenate([rotation, translation[..., None]], axis=-1)
    bottom = jnp.broadcast_to(
        jnp.array([0.0, 0.0, 0.0, 1.0], dtype=top.dtype), top.shape[:-2] + (1, 4)
    )
    return jnp.concatenate([top, bottom], axis=-2)


def inverse_transform(g: Float[ArrayLike, "*batch 4 4"]) -> Float[Array, "*batch 4 4"]:
    """Inverse ``[[Rᵀ, −Rᵀ p], [0, 1]]`` of a rigid transform (exact, no matrix inversion)."""
    g = jnp.asarray(g)
    rt = jnp.swapaxes(g[..., :3, :3], -1, -2)
    return make_transform(rt, -jnp.einsum("...ij,...j->...i", rt, g[..., :3, 3]))


def adjoint(g: Float[ArrayLike, "*batch 4 4"]) -> Float[Array, "*batch 6 6"]:
    """Adjoint ``Ad_g = [[R, p̂ R], [0, R]]`` acting on twists ``(v, ω)``: ``(g ξ̂ g⁻¹)^∨ = Ad_g ξ``."""
    g = jnp.asarray(g)
    rotation, translation = g[..., :3, :3], g[..., :3, 3]
    top = jnp.concatenate([rotation, hat(translation) @ rotation], axis=-1)
    bottom = jnp.concatenate([jnp.zeros_like(rotation), rotation], axis=-1)
    return jnp.concatenate([top, bottom], axis=-2)


def inverse_adjoint(g: Float[ArrayLike, "*batch 4 4"]) -> Float[Array, "*batch 6 6"]:
    """``Ad_g⁻¹ = Ad_{g⁻¹} = [[Rᵀ, −Rᵀ p̂], [0, Rᵀ]]``, without inverting a 6×6 matrix."""
    g = jnp.asarray(g)
    rt = jnp.swapaxes(g[..., :3, :3], -1, -2)
    top = jnp.concatenate([rt, -rt @ hat(g[..., :3, 3])], axis=-1)
    bottom = jnp.concatenate([jnp.zeros_like(rt), rt], axis=-1)
    return jnp.concatenate([top, bottom], axis=-2)
