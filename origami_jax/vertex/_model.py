"""The `SingleVertex` model, its constructors and its validation (docs/physics.md, "Single-vertex geometry").

A folded state is stored as unit crease directions in R³ (the robust internal representation);
sector angles are stored alongside because they are the rigid data of the paper the constraints
keep fixed. Spherical coordinates (Eq. 3, corrected) and fold angles are conversions in and out.
"""

import dataclasses
import functools
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._geometry import (
    arc_lengths,
    arc_pair_clearances,
    chain_from_fold_angles,
    fold_angles_of,
    planarity,
    topology,
)

PLANAR_TOL = 1e-4
"""Smallest singular value of the node matrix below which the nodes count as one great circle."""
FLAT_FOLD_TOL = float(np.deg2rad(1.0))
"""|fold angle| below which a crease counts as unfolded (1° separates chatter from folding)."""
LENGTH_TOL = 1e-7
"""Tolerance (radians, and on |x| − 1) for arc lengths matching sector angles."""
CLOSURE_TOL = 1e-8
"""Tolerance on the loop-closure residual of fold angles of a closed chain."""
CONTACT_TOL = 1e-9
"""Clearance (radians) below which two non-adjacent arcs touch."""


class InvalidVertexError(ValueError):
    """A single-vertex input that is not a valid folded state (see `validate_vertex`)."""


class SingleVertex(eqx.Module):
    """A single-vertex origami in a folded state.

    **Fields:**
    - `directions`: `(n, 3)` unit crease directions ("nodes" on the unit sphere), in cyclic order.
      The front side of the paper is the one seen with the nodes running counter-clockwise.
    - `sector_angles`: radians, `(n,)` for a closed chain (sector `i` between creases `i` and
      `i + 1 mod n`, summing to 2π) or `(n − 1,)` for an open chain (boundary vertex, sum < 2π).
    - `closed`: static; `True` for a vertex interior to the paper.

    Build one with `SingleVertex.from_fold_angles`, `.from_directions` or `.from_spherical`, which
    validate the input; the bare constructor checks shapes only (so that batched vertices and
    `jax.tree_util` reconstruction work).
    """

    directions: Float[Array, "n 3"]
    sector_angles: Float[Array, " a"]
    closed: bool = eqx.field(static=True)

    def __check_init__(self):
        shape = jnp.shape(self.directions)
        if len(shape) < 2 or shape[-1] != 3:
            raise ValueError(f"directions must have shape (n, 3), got {shape}")
        n = shape[-2]
        if n < 3:
            raise ValueError(f"a single vertex needs at least 3 creases, got n={n}")
        expected = n if self.closed else n - 1
        if jnp.shape(self.sector_angles)[-1] != expected:
            kind = "closed" if self.closed else "open"
            raise ValueError(
                f"a {kind} chain of {n} creases has {expected} sector angles, "
                f"got {jnp.shape(self.sector_angles)[-1]}"
            )

    @property
    def n(self) -> int:
        """Number of creases (nodes), including an open chain's two boundary rays."""
        return self.directions.shape[-2]

    @property
    def n_fold_angles(self) -> int:
        """Number of creases that carry a fold angle: `n` closed, `n − 2` open."""
        return self.n if self.closed else self.n - 2

    @classmethod
    def from_fold_angles(
        cls,
        sector_angles: Float[ArrayLike, " a"] | Sequence[float],
        fold_angles: Float[ArrayLike, " m"] | Sequence[float],
        *,
        closed: bool,
        validate: bool = True,
    ) -> "SingleVertex":
        """Build a folded state by rotating the flaps about the creases in turn.

        **Arguments:**
        - `sector_angles`: radians, `(n,)` closed (sum 2π) or `(n − 1,)` open.
        - `fold_angles`: radians, valley +, mountain − (FOLD convention): `(n,)` for a closed
          chain (crease `i` between sectors `i − 1` and `i`), `(n − 2,)` for an open chain (its
          interior creases `1 … n − 2`).
        - `closed`: interior (`True`) or boundary (`False`) vertex.
        - `validate`: run `validate_vertex` (default).

        Flap 0 lies in the xy-plane, from `x_0 = (1, 0, 0)` towards `+y`.

        **Raises:** `InvalidVertexError` if the counts disagree, if a fold angle is not finite or
        lies outside [−π, π] (a fold of 190° is no fold: it would put a flap through its
        neighbour, and its geometry is that of −170°), if a closed chain's fold angles do
        not close the loop (closure residual above `CLOSURE_TOL`; a closed vertex has only
        `n − 3` free fold angles), or if the state fails `validate_vertex`.
        """
        sectors = np.asarray(sector_angles, dtype=np.float64)
        folds = np.asarray(fold_angles, dtype=np.float64)
        if sectors.ndim != 1 or folds.ndim != 1:
            raise InvalidVertexError("sector_angles and fold_angles must be 1-D arrays")
        n = len(sectors) if closed else len(sectors) + 1
        m = n if closed else n - 2
        if len(folds) != m:
            kind = "closed" if closed else "open"
            raise InvalidVertexError(
                f"a {kind} chain with {len(sectors)} sectors has {m} fold angles, got {len(folds)}"
            )
        _check_sectors(sectors, closed)
        _check_folds(folds)
        padded = folds if closed else np.concatenate([[0.0], folds, [0.0]])
        nodes, closure = _chain(jnp.asarray(sectors), jnp.asarray(padded), closed)
        nodes, closure = np.asarray(nodes, np.float64), np.asarray(closure, np.float64)
        if closed:
            residual = float(np.max(np.abs(closure)))
            if not residual <= CLOSURE_TOL:  # NaN fails too
                raise InvalidVertexError(
                    f"the fold angles do not close the loop (closure residual {residual:.2e} > "
                    f"{CLOSURE_TOL:g}): a closed vertex of {n} creases has only {n - 3} free fold "
                    "angles; solve the others with `close_loop`."
                )
            nodes = nodes[:n]
        vertex = cls(jnp.asarray(nodes), jnp.asarray(sectors), closed)
        if validate:
            validate_vertex(vertex)
        return vertex

    @classmethod
    def from_directions(
        cls,
        directions: Float[ArrayLike, "n 3"] | Sequence[Sequence[float]],
        sector_angles: Float[ArrayLike, " a"] | Sequence[float] | None = None,
        *,
        closed: bool,
        validate: bool = True,
        normalise: bool = False,
    ) -> "SingleVertex":
        """A folded state from its crease directions.

        **Arguments:**
        - `directions`: `(n, 3)` crease directions in cyclic order; unit vectors unless
          `normalise=True`.
        - `sector_angles`: radians; if given, the arcs must have these lengths (to `LENGTH_TOL`);
          if `None`, they are measured from `directions` (a closed chain must then sum to 2π).
        - `closed`, `validate`: as in `from_fold_angles`.

        **Raises:** `InvalidVertexError` (see `validate_vertex`).
        """
        x = np.asarray(directions, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != 3 or x.shape[0] < 3:
            raise InvalidVertexError(f"directions must have shape (n >= 3, 3), got {x.shape}")
        if normalise:
            x = x / np.linalg.norm(x, axis=1, keepdims=True)
        if sector_angles is None:
            sectors = np.asarray(_measure(jnp.asarray(x), closed)[0], np.float64)
        else:
            sectors = np.asarray(sector_angles, dtype=np.float64)
        expected = len(x) if closed else len(x) - 1
        if sectors.shape != (expected,):
            raise InvalidVertexError(
                f"{'closed' if closed else 'open'} chain of {len(x)} creases needs {expected} "
                f"sector angles, got shape {sectors.shape}"
            )
        vertex = cls(jnp.asarray(x), jnp.asarray(sectors), closed)
        if validate:
            validate_vertex(vertex)
        return vertex

    @classmethod
    def from_spherical(
        cls,
        psi: Float[ArrayLike, " n"] | Sequence[float],
        phi: Float[ArrayLike, " n"] | Sequence[float],
        sector_angles: Float[ArrayLike, " a"] | Sequence[float] | None = None,
        *,
        closed: bool,
        validate: bool = True,
    ) -> "SingleVertex":
        """A folded state from spherical coordinates of its nodes (paper Fig. 2, Eq. 3).

        **Arguments:**
        - `psi`: azimuths `ψ_i`, radians, `(n,)`.
        - `phi`: zeniths (colatitudes) `φ_i` from `+z`, radians, `(n,)`.
        - others as in `from_directions`.
        """
        psi = np.asarray(psi, dtype=np.float64)
        phi = np.asarray(phi, dtype=np.float64)
        x = np.stack([np.sin(phi) * np.cos(psi), np.sin(phi) * np.sin(psi), np.cos(phi)], axis=-1)
        return cls.from_directions(x, sector_angles, closed=closed, validate=validate)


def fold_angles(vertex: SingleVertex) -> Float[Array, " m"]:
    """Signed fold angles (radians; valley +, mountain −, 0 flat) of `vertex`: `(n,)` for a closed
    chain, `(n − 2,)` (the interior creases) for an open one."""
    return fold_angles_of(vertex.directions, vertex.closed)


def to_spherical(vertex: SingleVertex) -> tuple[Float[Array, " n"], Float[Array, " n"]]:
    """Azimuths `ψ ∈ (−π, π]` and zeniths `φ ∈ [0, π]` (radians) of the nodes.

    Use for input/output only: the parametrisation is singular at the poles.
    """
    x = vertex.directions
    psi = jnp.arctan2(x[:, 1], x[:, 0])
    phi = jnp.arctan2(jnp.hypot(x[:, 0], x[:, 1]), x[:, 2])
    return psi, phi


def spherical_arc_lengths(
    psi: Float[ArrayLike, " n"] | Sequence[float],
    phi: Float[ArrayLike, " n"] | Sequence[float],
    *,
    closed: bool,
) -> Float[Array, " a"]:
    """Arc lengths `γ_i` (radians) between consecutive nodes by Eq. 3, corrected:
    `cos γ_i = cos φ_i cos φ_{i+1} + sin φ_i sin φ_{i+1} cos(ψ_{i+1} − ψ_i)` (the paper prints
    `sin φ_i` twice). For reference only; the package measures arcs with unit vectors."""
    psi = jnp.asarray(psi)
    phi = jnp.asarray(phi)
    j = jnp.roll(jnp.arange(psi.shape[0]), -1)
    if not closed:
        j = j[:-1]
    i = jnp.arange(j.shape[0])
    cos_gamma = jnp.cos(phi[i]) * jnp.cos(phi[j]) + jnp.sin(phi[i]) * jnp.sin(phi[j]) * jnp.cos(
        psi[j] - psi[i]
    )
    return jnp.arccos(jnp.clip(cos_gamma, -1.0, 1.0))


@dataclasses.dataclass(frozen=True)
class ValidationReport:
    """What `validate_vertex` found in a valid input.

    - `contacts`: warnings about touching (but not crossing) flaps, e.g. the corner cube's pinched
      gusset; an empty tuple when none.
    - `min_clearance`: smallest geodesic distance between non-adjacent arcs (radians).
    - `planarity`: smallest singular value of the node matrix (0 = flat).
    - `max_abs_fold_angle`: radians.
    - `contact_mask`: `(r,)` boolean over `Topology.arc_pairs`, the pairs that touch.
    """

    contacts: tuple[str, ...]
    min_clearance: float
    planarity: float
    max_abs_fold_angle: float
    contact_mask: np.ndarray


def _check_folds(folds: np.ndarray) -> None:
    if not np.all(np.isfinite(folds)):
        bad = np.flatnonzero(~np.isfinite(folds)).tolist()
        raise InvalidVertexError(f"fold angles must be finite; entries {bad[:8]} are not")
    bad = np.flatnonzero(np.abs(folds) > np.pi)
    if len(bad):
        raise InvalidVertexError(
            f"fold angles must lie in [−180°, 180°] (radians in [−π, π]; valley +, mountain −): "
            f"entries {bad[:8].tolist()} are {np.round(np.rad2deg(folds[bad[:8]]), 6).tolist()}°. "
            "A fold beyond 180° would carry a flap through its neighbour; angles are in radians."
        )


def _check_sectors(sectors: np.ndarray, closed: bool) -> None:
    if not np.all(np.isfinite(sectors)):
        raise InvalidVertexError("sector angles must be finite")
    bad = np.flatnonzero((sectors <= 0) | (sectors >= np.pi))
    if len(bad):
        raise InvalidVertexError(
            f"sector angles must lie strictly between 0 and π (at π an arc's midpoint is "
            f"undefined); sectors {bad.tolist()} are {np.round(np.rad2deg(sectors[bad]), 6).tolist()}°"
        )
    total = float(np.sum(sectors))
    if closed and abs(total - 2 * np.pi) > LENGTH_TOL * len(sectors):
        raise InvalidVertexError(
            f"a closed chain's sector angles must sum to 2π (360°), got {np.rad2deg(total):.9g}°"
        )
    if not closed and total >= 2 * np.pi:
        raise InvalidVertexError(
            f"an open chain's sector angles must sum to less than 2π, got {np.rad2deg(total):.9g}°"
        )


_chain = jax.jit(chain_from_fold_angles, static_argnums=2)


@functools.partial(jax.jit, static_argnames="closed")
def _measure(x, closed):
    # One compiled call instead of dozens of eagerly dispatched small operations.
    clearance, crossing = arc_pair_clearances(x, closed)
    return arc_lengths(x, closed), clearance, crossing, fold_angles_of(x, closed), planarity(x)


def validate_vertex(vertex: SingleVertex) -> ValidationReport:
    """Check that `vertex` is a valid folded state of a single-vertex origami.

    **Raises:** `InvalidVertexError` when
    - a value is not finite, a sector angle is not strictly between 0 and π, a closed chain's
      sector angles do not sum to 2π, or an open chain's reach 2π;
    - a direction is not a unit vector, or an arc's length differs from its sector angle by more
      than `LENGTH_TOL`;
    - two non-adjacent arcs cross or overlap along a stretch (the flaps would intersect);
    - the state is fully flat-folded: all nodes on one great circle (planarity < `PLANAR_TOL`) but
      some flaps lying on each other. The charge model's energy is infinite there; open such a
      state slightly (fold angles a little below ±180°) and unfold that.

    Touching without crossing (a contact, clearance below `CONTACT_TOL`, or a fold angle of ±180°
    at one crease) is accepted and reported in `ValidationReport.contacts`.
    """
    x = np.asarray(vertex.directions, dtype=np.float64)
    sectors = np.asarray(vertex.sector_angles, dtype=np.float64)
    closed = vertex.closed
    if x.ndim != 2:
        raise InvalidVertexError("validate one vertex at a time (got a batch)")
    if not np.all(np.isfinite(x)):
        raise InvalidVertexError("directions must be finite")
    _check_sectors(sectors, closed)
    norms = np.linalg.norm(x, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1) > LENGTH_TOL)
    if len(bad):
        raise InvalidVertexError(
            f"directions must be unit vectors; |x_i| = {norms[bad].tolist()} at creases "
            f"{bad.tolist()} (pass normalise=True to from_directions to rescale)"
        )
    lengths, clearance, crossing, folds, flatness = (
        np.asarray(a) for a in _measure(jnp.asarray(x), closed)
    )
    flatness = float(flatness)
    bad = np.flatnonzero(np.abs(lengths - sectors) > LENGTH_TOL)
    if len(bad):
        raise InvalidVertexError(
            "arc lengths do not match the sector angles (flaps are rigid): "
            + ", ".join(
                f"arc {i}: {np.rad2deg(lengths[i]):.9g}° vs {np.rad2deg(sectors[i]):.9g}°"
                for i in bad[:5]
            )
        )
    top = topology(len(x), closed)
    if np.any(crossing):
        pairs = top.arc_pairs[crossing]
        raise InvalidVertexError(
            "non-adjacent flaps intersect: arcs "
            + ", ".join(f"{e}–{f}" for e, f in pairs[:5].tolist())
            + " cross on the unit sphere"
        )
    touching = clearance < CONTACT_TOL
    contacts: list[str] = []
    for e, f in top.arc_pairs[touching].tolist():
        if _overlap(x, top.arcs[e], top.arcs[f]):
            raise InvalidVertexError(
                f"non-adjacent flaps {e} and {f} overlap along a stretch (they lie in each other)"
            )
        contacts.append(f"flaps {e} and {f} touch (clearance < {CONTACT_TOL:g} rad)")
    max_fold = float(np.max(np.abs(folds))) if len(folds) else 0.0
    if flatness < PLANAR_TOL and max_fold > np.pi / 2:
        raise InvalidVertexError(
            "the state is fully flat-folded (all creases in one plane, some flaps lying on each "
            "other): the charge model's energy is infinite there. Open it slightly (fold angles a "
            "little below ±180°, e.g. 179°) and unfold that state."
        )
    creases = top.creases
    for k in np.flatnonzero(np.abs(folds) > np.pi - 1e-7).tolist():
        contacts.append(
            f"crease {int(creases[k])} is folded flat (±180°): its two flaps lie on each other"
        )
    return ValidationReport(
        contacts=tuple(contacts),
        min_clearance=float(np.min(clearance)) if len(clearance) else float(np.pi),
        planarity=flatness,
        max_abs_fold_angle=max_fold,
        contact_mask=touching,
    )


def _overlap(x: np.ndarray, arc_a: np.ndarray, arc_b: np.ndarray) -> bool:
    """Whether two touching arcs share a stretch of positive length (same great circle)."""
    a1, a2 = x[arc_a[0]], x[arc_a[1]]
    b1, b2 = x[arc_b[0]], x[arc_b[1]]
    na, nb = np.cross(a1, a2), np.cross(b1, b2)
    na, nb = na / np.linalg.norm(na), nb / np.linalg.norm(nb)
    if np.linalg.norm(np.cross(na, nb)) > 1e-7:
        return False  # different great circles meet in single points only

    def inside(p, q1, q2, normal):
        # strictly inside minor arc q1 q2 (angular coordinates along its great circle)
        return np.dot(np.cross(q1, p), normal) > 1e-9 and np.dot(np.cross(p, q2), normal) > 1e-9

    mid_a = (a1 + a2) / np.linalg.norm(a1 + a2)
    mid_b = (b1 + b2) / np.linalg.norm(b1 + b2)
    return bool(
        inside(b1, a1, a2, na)
        or inside(b2, a1, a2, na)
        or inside(a1, b1, b2, nb)
        or inside(a2, b1, b2, nb)
        or inside(mid_a, b1, b2, nb)
        or inside(mid_b, a1, a2, na)
    )
