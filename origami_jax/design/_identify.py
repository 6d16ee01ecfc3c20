"""Which parameter combinations do the targets determine? The singular values of the sensitivity matrix.

Given the Jacobian ``S = ∂r/∂(log x)`` of the dimensionless residual rows with respect to the logarithms
of the free parameters (relative changes; for a linearly-scaled parameter, its change in units of its
bound range), the right singular vectors with non-negligible singular values are the combinations
``Π x_j^{v_j}`` that the targets pin down; those with (near-)zero singular values are moves along which
the targets do not change at all, and any point along them fits equally well.

docs/physics.md ("What a step response identifies"): with the hinge as wide as the flap, the
width cancels; stiffness, hinge length, moduli and stress only set the time scale; only ``b/m`` changes the
shape. So e.g. ``hinge_width`` and ``k_scale`` enter only through their product, and a design with both
free has rank 1 in that pair. The report says so rather than presenting an arbitrary point as determined.
"""

import dataclasses
from collections.abc import Sequence

import numpy as np

RANK_RTOL = 1e-6
"""A singular value below `RANK_RTOL × σ_max` counts as zero: its direction is not determined (the
residual Jacobian carries the ODE solver's relative error, ~1e-8, so exact cancellations land far
below this and genuine sensitivities far above)."""
WEAK_RTOL = 1e-3
"""Singular values between `RANK_RTOL` and `WEAK_RTOL × σ_max` mark poorly determined directions:
a residual change of 0.1 % along them moves the parameters by a factor ~e."""


def _normalised(vector: np.ndarray) -> np.ndarray:
    v = vector / np.max(np.abs(vector))
    # Sign convention: the first non-negligible component is positive (deterministic text).
    first = np.flatnonzero(np.abs(v) > 1e-3)[0]
    return v * np.sign(v[first])


def _combination(vector: np.ndarray, names: Sequence[str]) -> str:
    """A determined combination, as the product ``Π x_j^{v_j}``."""
    v = _normalised(vector)
    terms = [f"{name}^{c:+.3g}" for name, c in zip(names, v, strict=True) if abs(c) > 1e-3]
    return " · ".join(terms)


def _move(vector: np.ndarray, names: Sequence[str]) -> str:
    """An undetermined direction, as the family of moves ``x_j → x_j c^{v_j}``."""
    v = _normalised(vector)
    terms = [f"{name} × c^{c:+.3g}" for name, c in zip(names, v, strict=True) if abs(c) > 1e-3]
    return "(" + ", ".join(terms) + " for any c > 0)"


@dataclasses.dataclass(frozen=True)
class Identifiability:
    """Verdict on which free-parameter combinations the targets determine.

    **Fields:**
    - `names`: the free parameters.
    - `singular_values`: of the sensitivity matrix, descending (dimensionless residual per unit log).
    - `directions`: right singular vectors as rows, `(p, p)`, in log-parameter space, matching
      `singular_values`.
    - `rank`: number of singular values above `RANK_RTOL × σ_max`.
    - `determined`: combinations ``Π x_j^{v_j}`` the targets fix (strongly or weakly), one string each.
    - `undetermined`: families of moves ``x_j → x_j c^{v_j}`` that change nothing (the null space).
    - `weak`: the subset of `determined` that is only poorly determined (below `WEAK_RTOL`).
    - `verdict`: one sentence.
    """

    names: tuple[str, ...]
    singular_values: np.ndarray
    directions: np.ndarray
    rank: int
    determined: tuple[str, ...]
    undetermined: tuple[str, ...]
    weak: tuple[str, ...]
    verdict: str

    @property
    def identifiable(self) -> bool:
        """True when every free parameter is determined (full rank)."""
        return self.rank == len(self.names)

    def to_dict(self) -> dict:
        return {
            "names": list(self.names),
            "singular_values": self.singular_values.tolist(),
            "directions": self.directions.tolist(),
            "rank": self.rank,
            "identifiable": self.identifiable,
            "determined": list(self.determined),
            "undetermined": list(self.undetermined),
            "poorly_determined": list(self.weak),
            "verdict": self.verdict,
        }


def identifiability(
    sensitivity: np.ndarray,
    names: Sequence[str],
    *,
    rank_rtol: float = RANK_RTOL,
    weak_rtol: float = WEAK_RTOL,
) -> Identifiability:
    """Rank and (non-)determined parameter combinations of a sensitivity matrix.

    **Arguments:**
    - `sensitivity`: ``∂r/∂(log x)``, shape `(r, p)`, rows the (weighted, dimensionless) residuals.
    - `names`: the `p` parameter names.
    - `rank_rtol`, `weak_rtol`: thresholds relative to the largest singular value.

    **Returns:** an [`origami_jax.design.Identifiability`][].
    """
    names = tuple(names)
    matrix = np.nan_to_num(np.asarray(sensitivity, dtype=float))
    p = len(names)
    if matrix.ndim != 2 or matrix.shape[1] != p:
        raise ValueError(f"sensitivity must have shape (r, {p}), got {matrix.shape}.")
    if matrix.shape[0] == 0:
        matrix = np.zeros((1, p))
    _, s, vt = np.linalg.svd(matrix, full_matrices=True)
    s = np.concatenate([s, np.zeros(p - s.size)])
    s_max = s[0] if s.size else 0.0
    if s_max == 0:
        return Identifiability(
            names,
            s,
            vt,
            0,
            (),
            tuple(_move(v, names) for v in vt),
            (),
            "No target depends on any free parameter: nothing is determined.",
        )
    strong = s > weak_rtol * s_max
    nonzero = s > rank_rtol * s_max
    rank = int(np.sum(nonzero))
    determined = tuple(_combination(v, names) for v in vt[nonzero])
    weak = tuple(_combination(v, names) for v in vt[nonzero & ~strong])
    undetermined = tuple(_move(v, names) for v in vt[~nonzero])
    if rank == p and not weak:
        verdict = f"All {p} free parameters are determined by the targets (rank {rank})."
    elif rank == p:
        verdict = (
            f"Rank {rank} of {p}, but poorly determined: {'; '.join(weak)} "
            f"(singular value below {weak_rtol:g} of the largest)."
        )
    else:
        verdict = (
            f"Only {rank} of {p} parameter combinations are determined ({'; '.join(determined)}); "
            f"the targets do not change under {'; '.join(undetermined)} — any point along these directions fits equally well, "
            "and the reported values are just where the optimiser stopped (width cancels; k, l, "
            "E and stress only set the time scale; only b/m shapes the response)."
        )
    return Identifiability(names, s, vt, rank, determined, undetermined, weak, verdict)
