"""Keys of values by their contents, for what is kept per pattern and settings across the objects
that hold them (patterns and settings compare by identity)."""

import jax
import numpy as np


def value_key(value) -> tuple:
    """A hashable key of `value` by its contents: its tree structure (static fields included) and
    each leaf's bytes, shape and dtype (arrays, numbers) or representation (anything else: a
    function's names its object, so two distinct functions never share a key)."""
    leaves, structure = jax.tree_util.tree_flatten(value)
    parts = []
    for leaf in leaves:
        if isinstance(leaf, (np.ndarray, np.generic, jax.Array, bool, int, float, complex)):
            array = np.asarray(leaf)
            parts.append((array.tobytes(), array.shape, str(array.dtype)))
        else:
            parts.append(repr(leaf))
    return (str(structure), *parts)
