"""Rows of an array picked by index tables: gathers and scatter-adds, or dense one-hot products.

The plate contact picks each primitive pair's points and bodies from per-vertex and per-body arrays,
and sums the pairs' wrenches back onto the bodies. Both can be a gather and a scatter-add, or a
product with a constant one-hot matrix (host rows; traced rows took a comparison of every row with
every index, built at each call). The one-hot products were chosen first, measured faster for tens
of bodies under `vmap` with an earlier XLA; on jaxlib 0.10 (2-core CPU, 2026-12-06) the gathers
win everywhere: one pick and its adjoint 3-10× faster alone and as fast or faster vmapped over 64
(constant one-hot, 28-101 rows picked from 64-4096), 2-36× for traced rows; a cube net's adaptive
fold 1.9× faster (a vmapped batch of 16 unchanged), a 100-panel strip's contact force 2.5×.
`DENSE_PICK_LIMIT` (entries of a one-hot matrix, default 0: always gather) keeps the products for
comparison; the one-hot matrix grows as the square of a pattern's size (a 500-panel strip: 1e6
pairs × 2,000 vertices, 16 GB), and traced rows are gathered whatever the limit.
"""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

# One-hot products for host rows up to this many entries (1 << 22: 32 MB in float64); 0: gathers.
DENSE_PICK_LIMIT = 0


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


def one_hot_rows(rows: np.ndarray, size: int, dtype) -> Array:
    """The one-hot matrix `(len(rows), size)` of host `rows`, a constant (`dense_pick` rows only:
    traced rows are always gathered)."""
    return jnp.asarray(np.eye(size)[rows], dtype)
