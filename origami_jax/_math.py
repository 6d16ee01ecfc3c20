"""Gradient-safe elementary functions shared by both physics halves.

Every function here has a finite derivative everywhere it is evaluated by the package, including the
points where the naive formula is singular (a zero vector, parallel or antiparallel unit vectors). They
follow the "double where" pattern: the unsafe branch is fed a harmless value so that its derivative,
although discarded by ``jnp.where``, is never NaN.
"""

import equinox.internal as eqxi
import jax
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


# Cody–Waite split of π/2 (fdlibm's pio2_1, pio2_2, pio2_3 + pio2_3t): the first two have 33
# significant bits, so k·part is exact for |k| < 2²⁰ and the reduced argument keeps full precision.
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_3 = 2.02226624871116645580e-21 + 8.47842766036889956997e-32
# Beyond this |x| the split above is no longer exact; callers of `sin_cos_reduced` use jnp.sin/cos.
SIN_COS_REDUCTION_LIMIT = 1.0e6
# fdlibm's minimax polynomials for sin and cos on [−π/4, π/4] (k_sin.c, k_cos.c).
_SIN = (
    -1.66666666666666324348e-01,
    8.33333333332248946124e-03,
    -1.98412698298579493134e-04,
    2.75573137070700676789e-06,
    -2.50507602534068634195e-08,
    1.58969099521155010221e-10,
)
_COS = (
    4.16666666666666019037e-02,
    -1.38888888888741095749e-03,
    2.48015872894767294178e-05,
    -2.75573143513906633035e-07,
    2.08757232129817482790e-09,
    -1.13596475577881948265e-11,
)


def _horner(coefficients: tuple[float, ...], z: Array) -> Array:
    result = jnp.full_like(z, coefficients[-1])
    for c in reversed(coefficients[:-1]):
        result = result * z + c
    return result


def sin_cos_reduced(x: Float[ArrayLike, "..."]) -> tuple[Array, Array]:
    """``(sin x, cos x)`` by Cody–Waite reduction to ``[−π/4, π/4]`` and fdlibm's polynomials.

    Plain multiply-adds, which XLA vectorises: on the CPU ``jnp.sin`` and ``jnp.cos`` in float64 cost
    ~10 ns per element each, these ~1 ns. Within 2 ulp of NumPy for ``|x| ≤ SIN_COS_REDUCTION_LIMIT``
    (tests); wrong beyond it, where callers must use ``jnp.sin``/``jnp.cos`` (see the scalar dynamics).
    Not for differentiation (derivatives would go through `round`); the package uses it on values only.
    """
    x = jnp.asarray(x)
    k = jnp.round(x * (2.0 / jnp.pi))
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    sine = r + r * z * _horner(_SIN, z)
    cosine = 1.0 - 0.5 * z + z * z * _horner(_COS, z)
    quadrant = jnp.mod(k, 4.0)  # x = k π/2 + r: rotate (sin r, cos r) by k quarter turns
    swap = (quadrant == 1.0) | (quadrant == 3.0)
    s = jnp.where(swap, cosine, sine)
    c = jnp.where(swap, sine, cosine)
    s = jnp.where(quadrant >= 2.0, -s, s)
    c = jnp.where((quadrant == 1.0) | (quadrant == 2.0), -c, c)
    return jnp.where(x == 0, x, s), c  # sin(±0) = ±0, which the reduction loses


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
