"""Type aliases shared across the package (jaxtyping shape annotations).

Shapes use these names: ``n`` nodes or joints, ``t`` time samples, ``b`` batch members.
"""

from collections.abc import Sequence

from jaxtyping import Array, ArrayLike, Bool, Float, Int

Scalar = Float[Array, ""]
ScalarLike = float | Float[ArrayLike, ""]
# What the package's constructors take for per-hinge or per-parameter values: arrays, numbers and
# lists of numbers (they go through `numpy.asarray`), not only JAX's array-likes.
FloatsLike = ArrayLike | Sequence[float]
Vector3 = Float[Array, "3"]
Matrix3 = Float[Array, "3 3"]
Twist = Float[Array, "6"]
Transform = Float[Array, "4 4"]

__all__ = [
    "Array",
    "ArrayLike",
    "Bool",
    "Float",
    "FloatsLike",
    "Int",
    "Matrix3",
    "Scalar",
    "ScalarLike",
    "Transform",
    "Twist",
    "Vector3",
]
