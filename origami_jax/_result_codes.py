"""Result codes (equinox enumerations: the solvers', the fits', the unfoldings') in words."""

import jax
import numpy as np


def message(item, enumeration) -> str:
    """The words of `item`, a result code of `enumeration`, wherever its value lives.

    Equinox words a code held in an array; one fetched to the host (`jax.device_get`) holds a NumPy
    scalar, which it words as "unknown"."""
    return str(enumeration[jax.tree.map(np.asarray, item)])
