"""When a chain is planar: every hinge axis parallel to the first (`Chain.planar`, the accordion).

The checks shared by the chain's constructor and its dynamics (which take the planar path only for a
chain whose axes are still parallel).
"""

from typing import TYPE_CHECKING

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validate import is_traced

if TYPE_CHECKING:
    from ._chain import Chain

PARALLEL_TOLERANCE = 1e-12
"""A chain is planar when every ``|ω_i × ω_1| / |ω_1|`` is at most this (the sine of the angle between
axes): the spatial and planar dynamics then differ by about this much relative, below what float64
solves resolve. Axes typed as the same vector, or normalised from the same direction, pass."""


def _sines_to_first_axis(axes: ArrayLike) -> np.ndarray:
    """``|ω_i × ω_1| / |ω_1|`` per hinge (the sine of the angle to the first axis for unit axes), on
    the host (known axes only)."""
    host = np.asarray(axes, dtype=float)
    return np.linalg.norm(np.cross(host, host[0]), axis=-1) / np.linalg.norm(host[0])


def check_still_planar(chain: "Chain") -> None:
    """`ValueError` if `chain.planar` is set but its axes (when known) are no longer parallel: a chain
    whose axes were replaced after it was built (`eqx.tree_at`). Traced axes are left to the guard in
    the planar dynamics, which then returns NaN."""
    if not getattr(chain, "planar", False) or is_traced(chain.axes):
        return
    if np.any(_sines_to_first_axis(chain.axes) > PARALLEL_TOLERANCE):
        raise ValueError(
            "This chain is marked planar but its hinge axes are not parallel (were they replaced "
            "after it was built, e.g. with eqx.tree_at?). Build it again with Chain(...) or "
            "flap_chain(...), which detect planarity."
        )


def axes_parallel_error(axes: Float[Array, "n 3"]) -> Float[Array, ""]:
    """``max_i |ω_i × ω_1|² / |ω_1|²``, zero for a planar chain. Written on scalars so that, inside the
    planar dynamics' guard, it fuses with them."""
    x0, y0, z0 = axes[0, 0], axes[0, 1], axes[0, 2]
    worst = jnp.zeros((), axes.dtype)
    for i in range(1, axes.shape[0]):
        x, y, z = axes[i, 0], axes[i, 1], axes[i, 2]
        normal = (y * z0 - z * y0, z * x0 - x * z0, x * y0 - y * x0)
        worst = jnp.maximum(worst, normal[0] ** 2 + normal[1] ** 2 + normal[2] ** 2)
    return worst / (x0 * x0 + y0 * y0 + z0 * z0)
