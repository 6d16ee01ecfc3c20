"""Rows of an array picked by index tables, as dense products where they are small.

The plate contact picks each primitive pair's points and bodies from per-vertex and per-body arrays,
and sums the pairs' wrenches back onto the bodies. For the nets it is made for (tens of bodies) a
constant one-hot matrix times the array does both: a gather's derivative is a scatter-add, which
runs element by element on a CPU and does not vectorise over a batch, while a small dense product
does both. The one-hot matrix has one entry per pair and per row picked from, so it grows as the
square of a pattern's size (a 500-panel strip: 1e6 pairs × 2,000 vertices, 16 GB): past
`DENSE_PICK_LIMIT` entries the same rows are gathered and scattered instead.

Rows known only at run time (a working set's, the broad phase's) are always gathered: their
one-hot matrix is not a constant but a comparison of every row with every index, built at each
call, and on the 2-core CPU that costs more than the gather and the scatter-add together, alone
and under `vmap` (2-36× at 7e3-7e6 entries; 25 ms of a 100-panel strip's 40 ms contact force).
"""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

# One-hot matrices up to this many entries (32 MB in float64); larger picks gather.
DENSE_PICK_LIMIT = 1 << 22


def dense_pick(rows: np.ndarray | Array, size: int) -> bool:
    """Whether picking `rows` out of `size` rows uses a one-hot product: host rows whose one-hot
    matrix is small (module docstring)."""
    if not isinstance(rows, np.ndarray):
        return False
    return int(rows.shape[0]) * int(size) <= DENSE_PICK_LIMIT


def pick(rows: np.ndarray | Array, size: int, flat: Array, *, transpose: bool = False) -> Array:
    """``flat[rows]`` (`flat` `(size, c)`, result `(len(rows), c)`); with `transpose`, the sum of
    the rows of `flat` `(len(rows), c)` into `size` rows (the adjoint: a scatter-add). A product with
    a one-hot matrix where that is small (`dense_pick`), else a gather or a scatter-add."""
    if not dense_pick(rows, size):
        if transpose:
            return jnp.zeros((size,) + flat.shape[1:], flat.dtype).at[rows].add(flat)
        return flat[rows]
    one_hot = one_hot_rows(rows, size, flat.dtype)
    return one_hot.T @ flat if transpose else one_hot @ flat


def one_hot_rows(rows: np.ndarray | Array, size: int, dtype) -> Array:
    """The one-hot matrix `(len(rows), size)` of `rows`: a constant built on the host for host
    `rows`, a comparison for traced ones."""
    if isinstance(rows, np.ndarray):
        return jnp.asarray(np.eye(size)[rows], dtype)
    return (rows[:, None] == jnp.arange(size)).astype(dtype)
