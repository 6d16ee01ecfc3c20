"""Gradient-safe elementary functions shared by both physics halves.

Every function here has a finite derivative everywhere it is evaluated by the package, including the
points where the naive formula is singular (a zero vector, parallel or antiparallel unit vectors). They
follow the "double where" pattern: the unsafe branch is fed a harmless value so that its derivative,
although discarded by ``jnp.where``, is never NaN.
"""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float


def safe_norm(x: Float[ArrayLike, "*batch d"], *, eps: float = 0.0) -> Float[Array, "*batch"]:
    """Euclidean norm over the last axis whose gradient at ``x = 0`` is 0 instead of NaN.

    **Arguments:**
    - `x`: vectors, shape `(*batch, d)`.
    - `eps`: value returned (and derivative 0) where the norm is exactly zero.

    **Returns:** the norms, shape `(*batch,)`.
    """
    x = jnp.asarray(x)
    squared = jnp.sum(x * x, axis=-1)
    is_zero = squared == 0
    safe_squared = jnp.where(is_zero, 1.0, squared)
    return jnp.where(is_zero, eps, jnp.sqrt(safe_squared))


def normalise(x: Float[ArrayLike, "*batch d"]) -> Float[Array, "*batch d"]:
    """Unit vectors along ``x`` (last axis). A zero vector maps to zero, with a finite derivative."""
    x = jnp.asarray(x)
    norm = safe_norm(x)
    return x / jnp.where(norm == 0, 1.0, norm)[..., None]


def geodesic_angle(
    a: Float[ArrayLike, "*batch 3"], b: Float[ArrayLike, "*batch 3"]
) -> Float[Array, "*batch"]:
    """Angle between 3-vectors in ``[0, π]``, computed as ``atan2(|a × b|, a · b)``.

    For unit vectors this is the geodesic (great-circle) distance on the unit sphere. Unlike
    ``arccos(a · b)`` it keeps full precision near 0 and π. Its derivative is finite except exactly at
    0 and π, where the distance itself has a corner; there ``safe_norm`` makes it finite (0).
    """
    a = jnp.asarray(a)
    b = jnp.asarray(b)
    return jnp.arctan2(safe_norm(jnp.cross(a, b)), jnp.sum(a * b, axis=-1))


def safe_divide(numerator: ArrayLike, denominator: ArrayLike, *, fill: float = 0.0) -> Array:
    """``numerator / denominator`` with ``fill`` (and a zero derivative) where the denominator is 0."""
    numerator = jnp.asarray(numerator)
    denominator = jnp.asarray(denominator)
    is_zero = denominator == 0
    return jnp.where(is_zero, fill, numerator / jnp.where(is_zero, 1.0, denominator))
