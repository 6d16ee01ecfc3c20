"""Input checks shared by the chain builders: Python errors when values are known, `eqx.error_if` when traced.

Tier 1 (STYLE.md "Errors"): a value known before tracing is checked in Python and a wrong one raises a
`ValueError` that says what is wrong and how to fix it. Tier 2: a value that is a tracer (a builder called
under `jit` or `vmap`) cannot be inspected, so the same condition is attached with `eqx.error_if` and fires
when the compiled function runs.
"""

import equinox as eqx
import jax
import jax.core  # noqa: F401  (explicit for the type checker; jax imports it anyway)
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike


def is_traced(*values) -> bool:
    """True when any leaf is a JAX tracer (its value is only known inside a transformation)."""
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(values))


def as_float_array(value: ArrayLike, name: str) -> Array:
    """``jnp.asarray`` with a float dtype, rejecting complex, boolean and object input by name."""
    if is_traced(value):
        array = jnp.asarray(value)
    else:
        host = np.asarray(value)
        if host.dtype.kind not in "fiu":
            raise ValueError(f"{name} must be real numbers, got dtype {host.dtype}.")
        array = jnp.asarray(host)
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
