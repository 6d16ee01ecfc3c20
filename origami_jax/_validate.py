"""Input checks shared by the chain builders: Python errors when values are known, `eqx.error_if` when traced.

Tier 1 (STYLE.md "Errors"): a value known before tracing is checked in Python and a wrong one raises a
`ValueError` that says what is wrong and how to fix it. Tier 2: a value that is a tracer (a builder called
under `jit` or `vmap`) cannot be inspected, so the same condition is attached with `eqx.error_if` and fires
when the compiled function runs.
"""

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.core  # noqa: F401  (explicit for the type checker; jax imports it anyway)
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike


def is_traced(*values) -> bool:
    """True when any leaf is a JAX tracer (its value is only known inside a transformation)."""
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(values))


def as_float_array(value: ArrayLike | Sequence[float], name: str) -> Array:
    """``jnp.asarray`` with a float dtype, rejecting complex, boolean and object input by name."""
    if is_traced(value):
        array = jnp.asarray(value)
    else:
        host = np.asarray(value)
        if host.dtype.kind not in "fiu":
            raise ValueError(f"{name} must be real numbers, got dtype {host.dtype}.")
        if host.dtype.kind != "f":  # converted on the host
            host = host.astype(jnp.result_type(float))
        array = jax.device_put(host)  # `jnp.asarray` would compile a program per shape
    if not jnp.issubdtype(array.dtype, jnp.floating):
        array = array.astype(jnp.result_type(float))
    return array


def check_shape(array: Array, shape: tuple, name: str, hint: str = "") -> None:
    """Raise a `ValueError` unless ``array.shape == shape`` (``None`` entries match anything)."""
    ok = array.ndim == len(shape) and all(
        want is None or want == got for want, got in zip(shape, array.shape, strict=True)
    )
    if not ok:
        wanted = str(tuple("?" if s is None else s for s in shape)).replace("'", "")
        raise ValueError(
            f"{name} must have shape {wanted}, got {tuple(array.shape)}. {hint}".strip()
        )


def check_finite(array: Array, name: str) -> Array:
    """No NaN or infinity: `ValueError` if concrete, `eqx.error_if` if traced."""
    if is_traced(array):
        return eqx.error_if(array, ~jnp.all(jnp.isfinite(array)), f"{name} contains NaN or inf.")
    host = np.asarray(array)
    if not np.all(np.isfinite(host)):
        bad = np.argwhere(~np.isfinite(host))[0]
        raise ValueError(
            f"{name} contains NaN or inf (first at index {tuple(int(i) for i in bad)}); "
            "check the values that built it."
        )
    return array


def check_positive(array: Array, name: str, unit: str = "") -> Array:
    """All entries strictly positive: `ValueError` if concrete, `eqx.error_if` if traced."""
    array = check_finite(array, name)
    if is_traced(array):
        return eqx.error_if(array, jnp.any(array <= 0), f"{name} must be positive.")
    host = np.asarray(array)
    if np.any(host <= 0):
        bad = host[host <= 0].ravel()[0]
        raise ValueError(
            f"{name} must be positive{f' ({unit})' if unit else ''}, got {float(bad):g}; "
            "thicknesses, lengths, widths, densities and masses are magnitudes."
        )
    return array


# Relative tolerance on |ω| = 1 and on RᵀR = I: inputs typed by hand or stored in float32 carry ~1e-7
# relative error; anything beyond 1e-6 is a wrong input, not round-off.
UNIT_TOLERANCE = 1e-6


def check_unit_vectors(array: Array, name: str, what: str = "vector") -> Array:
    """Rows of `array` (shape `(n, 3)`) are unit vectors: `ValueError` if concrete, `eqx.error_if`
    if traced."""
    array = check_finite(array, name)
    norms = jnp.linalg.norm(array, axis=-1)
    if is_traced(array):
        bad = jnp.any(jnp.abs(norms - 1) > UNIT_TOLERANCE)
        return eqx.error_if(array, bad, f"{name} must be unit vectors.")
    for i, norm in enumerate(np.asarray(norms)):
        if norm == 0:
            raise ValueError(f"{name}[{i}] is the zero vector; a {what} needs a direction.")
        if abs(norm - 1) > UNIT_TOLERANCE:
            raise ValueError(
                f"{name}[{i}] has norm {norm:.6g}, not 1; pass unit vectors "
                "(e.g. origami_jax._math.normalise) so that angles are in radians."
            )
    return array


def check_rigid_transforms(poses: Array, name: str) -> Array:
    """Every `poses[i]` (shape `(n, 4, 4)`) is ``[[R, p], [0, 0, 0, 1]]`` with ``R`` a rotation."""
    poses = check_finite(poses, name)
    traced = is_traced(poses)
    # Known poses are checked on the host (op by op in JAX, each new shape compiles a program).
    xp, values = (jnp, poses) if traced else (np, np.asarray(poses))
    rotation = values[..., :3, :3]
    orthogonality = xp.max(
        xp.abs(xp.swapaxes(rotation, -1, -2) @ rotation - xp.eye(3, dtype=values.dtype))
    )
    bottom = xp.max(xp.abs(values[..., 3, :] - xp.array([0.0, 0.0, 0.0, 1.0], dtype=values.dtype)))
    determinant = xp.linalg.det(rotation)
    bad = (orthogonality > UNIT_TOLERANCE) | (bottom > 0) | xp.any(determinant <= 0)
    if traced:
        return eqx.error_if(poses, bad, f"{name} must be rigid transforms [[R, p], [0, 1]].")
    if bad:
        raise ValueError(
            f"{name} must be rigid transforms [[R, p], [0, 0, 0, 1]] with R a rotation "
            f"(max |RᵀR − I| = {float(orthogonality):.3g}, max bottom-row error {float(bottom):.3g}, "
            f"min det R = {float(np.min(determinant)):.3g})."
        )
    return poses


def check_symmetric_positive(
    matrices: Array, name: str, *, definite: bool = True, hint: str = ""
) -> Array:
    """Every `matrices[i]` (shape `(n, k, k)`) is symmetric and positive definite (`definite`) or
    semi-definite, to 1e-9 of its largest entry: `ValueError` if concrete, `eqx.error_if` if traced."""
    matrices = check_finite(matrices, name)
    kind = "positive definite" if definite else "positive semi-definite"
    traced = is_traced(matrices)
    # Known matrices are checked on the host (no program compiled per shape).
    xp, values = (jnp, matrices) if traced else (np, np.asarray(matrices))
    scale = xp.max(xp.abs(values), axis=(-1, -2))
    asymmetry = xp.max(xp.abs(values - xp.swapaxes(values, -1, -2)), axis=(-1, -2))
    if traced:
        symmetric = 0.5 * (matrices + jnp.swapaxes(matrices, -1, -2))
        lowest = jnp.linalg.eigvalsh(symmetric)[..., 0]
        bad = (asymmetry > 1e-9 * scale) | ((lowest <= 0) if definite else (lowest < -1e-9 * scale))
        return eqx.error_if(matrices, jnp.any(bad), f"{name} must be symmetric {kind}.")
    for i in range(values.shape[0]):
        if float(asymmetry[i]) > 1e-9 * float(scale[i]):
            raise ValueError(f"{name}[{i}] is not symmetric; an inertia is. {hint}".strip())
        eigenvalues = np.linalg.eigvalsh(values[i])
        low = eigenvalues.min()
        if (low <= 0) if definite else (low < -1e-9 * float(scale[i])):
            raise ValueError(
                f"{name}[{i}] is not {kind} (eigenvalues {np.array2string(eigenvalues, precision=3)})."
                f" {hint}".strip()
            )
    return matrices
