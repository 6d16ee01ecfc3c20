"""Keys of values by their contents, for what is kept per pattern and settings across the objects
that hold them (patterns and settings compare by identity)."""

import dataclasses

import jax
import numpy as np


def value_key(value) -> tuple:
    """A hashable key of `value` by its contents: its tree structure (static fields included) and
    each leaf's bytes, shape and dtype (arrays, numbers), a dataclass leaf's fields the same way
    (its representation would round and elide its arrays), or the representation of anything
    else (a function's names its object, so two distinct functions never share a key)."""
    leaves, structure = jax.tree_util.tree_flatten(value)
    return (str(structure), *map(_leaf_key, leaves))


def _leaf_key(leaf):
    if isinstance(leaf, (np.ndarray, np.generic, jax.Array, bool, int, float, complex)):
        array = np.asarray(leaf)
        return (array.tobytes(), array.shape, str(array.dtype))
    if dataclasses.is_dataclass(leaf) and not isinstance(leaf, type):
        fields = dataclasses.fields(leaf)
        return (type(leaf).__qualname__, *(value_key(getattr(leaf, f.name)) for f in fields))
    return repr(leaf)
