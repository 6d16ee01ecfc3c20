"""Charge energies of a single vertex (paper Eqs. 1–2; docs/physics.md, "Single-vertex unfolding").

Unit charges sit on every node `x_i` and every arc midpoint `m_e = normalise(x_i + x_{i+1})`. For
every node `v` and every arc `e` not incident to `v`, `d(v, e)` is the geodesic distance from `v` to
`m_e`, computed as `atan2(|a × b|, a · b)`: `arccos` loses precision and has an infinite derivative
near 0 and π.

Neither energy is a collision barrier (docs/physics.md): they see only node-to-midpoint distances, so arcs can
cross with every distance finite. Collisions are excluded by the explicit checks in `unfold`.
"""

from typing import Literal

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._math import geodesic_angle
from ._geometry import midpoints, topology

EnergyKind = Literal["separable", "nonseparable"]

DEFAULT_P: dict[str, float] = {"separable": 2.0, "nonseparable": 4.0}
"""The paper's exponents: p = 2 smoothest for Eq. 1, p = 4 for Eq. 2."""


def check_energy(energy: str) -> str:
    """`energy` if it names a known energy, else a `ValueError` listing the choices."""
    if energy not in DEFAULT_P:
        raise ValueError(f"energy must be 'separable' or 'nonseparable', got {energy!r}")
    return energy


def charge_distances(x: Float[ArrayLike, "n 3"], closed: bool) -> Float[Array, " q"]:
    """Geodesic distances `d(v, e)` (radians) over `Topology.node_arc_pairs`, shape `(q,)`."""
    x = jnp.asarray(x)
    pairs = topology(x.shape[0], closed).node_arc_pairs
    mids = midpoints(x, closed)
    return geodesic_angle(x[pairs[:, 0]], mids[pairs[:, 1]])


def separable_energy(
    x: Float[ArrayLike, "n 3"], *, closed: bool, p: float | Float[ArrayLike, ""] = 2.0
) -> Float[Array, ""]:
    """Eq. 1: `U = Σ_{e, v∉e} d(v, e)^(−p)` (dimensionless; `x` unit node directions `(n, 3)`)."""
    d = charge_distances(x, closed)
    return jnp.sum(d ** (-p))  # pyright: ignore[reportOperatorIssue] (p is real)


def nonseparable_energy(
    x: Float[ArrayLike, "n 3"], *, closed: bool, p: float | Float[ArrayLike, ""] = 4.0
) -> Float[Array, ""]:
    """Eq. 2: `U = 1 / Σ_{e, v∉e} d(v, e)^p` (dimensionless; `x` unit node directions `(n, 3)`)."""
    d = charge_distances(x, closed)
    return 1.0 / jnp.sum(d**p)


def energy(
    x: Float[ArrayLike, "n 3"],
    *,
    closed: bool,
    kind: str = "separable",
    p: float | Float[ArrayLike, ""] | None = None,
) -> Float[Array, ""]:
    """Charge energy of kind `"separable"` (Eq. 1, default p = 2) or `"nonseparable"` (Eq. 2,
    default p = 4). Differentiable in `x` and `p`."""
    check_energy(kind)
    if p is None:
        p = DEFAULT_P[kind]
    if kind == "separable":
        return separable_energy(x, closed=closed, p=p)
    return nonseparable_energy(x, closed=closed, p=p)
