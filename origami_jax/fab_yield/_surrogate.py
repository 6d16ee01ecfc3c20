"""A differentiable yield surrogate: the mean over fixed scatter draws of each sample's smoothed
"folded" margin, a function of what the designer draws (hinge angles, hinge widths, release times)."""

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from ..net import FOLD_KERNEL_SOLVE
from ..simulation import VerdictTolerances
from ..system import KOH_SOLUTION
from ._estimate import _GLOBAL, _nominal, as_pattern
from ._order import front_release_times
from ._scatter import Scatter, standard_draws

DESIGN_VARIABLES = ("target", "hinge_width", "release", "front_angle", "front_speed")
"""What `SoftYield` takes: per crease `target` (rad), `hinge_width` (µm), `release` (µs); or the
release times as an etch front's path, `front_angle` (rad) and `front_speed` (µm/µs), both scalars
(`front_release_times`)."""


def _transform(spread, nominal, z):
    """`Spread.transform` in JAX (differentiable in the nominal value)."""
    w = spread.width
    if w == 0:
        return jnp.broadcast_to(nominal, z.shape)
    if spread.distribution == "normal":
        step = w * z
    elif spread.distribution == "uniform":
        step = w * (2 * jax.scipy.special.ndtr(z) - 1)
    else:
        return nominal * jnp.exp(w * z)
    return nominal * (1 + step) if spread.relative else nominal + step


@dataclasses.dataclass(frozen=True, eq=False)
class SoftYield:
    """The smoothed yield of a net over `n_samples` fixed scatter draws (common random numbers), as a
    traceable function of the design variables: call it with a dict of `(m,)` arrays,
    `{"target": rad, "hinge_width": µm, "release": µs}` (any subset; the others stay nominal), or
    with the release times as an etch front, `{"front_angle": rad, "front_speed": µm/µs}` (scalars,
    both, instead of `release`; `front_release_times`).

    Each sample's score is ``Π_j σ(m_j / τ) · σ(m_s / τ)``: ``m_j = tol − |θ_j(t_end) − θ*_j|`` the
    margin of crease ``j``'s final angle to the pattern's angle ``θ*_j``, ``m_s = (1 − r) α_s`` the
    seams' margin: ``r`` the largest gap over its seam's tolerance among the seams whose panels do
    not touch at the end (`seam_margin`; the verdict holds a touching seam closed whatever its gap;
    whether panels touch is a switch, not smoothed) and ``α_s`` the crease error the seam tolerance
    stands for (`VerdictTolerances.seam_equivalent_angle`: the angle tolerance for the default,
    derived, seam tolerance; the fraction ``seam`` for a fixed one, a gap ``δ`` being a crease off
    by about ``δ / L``), ``σ`` the logistic function and ``τ`` = `temperature_deg` (in rad). As ``τ → 0`` the score tends to the indicator of the
    folded verdict for samples that have settled (`fold_outcome` also asks the last tenth of the run
    to be still). The mean over samples is the soft yield; `jax.grad` of it goes through every
    sample's contact simulation.

    Without contact the surrogate is smooth and its gradient matches its finite differences
    (checked in the test suite). With contact it is not smooth: a panel stopped by another moves
    the final state non-smoothly with the design (on the corner cube, central differences of it
    changed fivefold between steps of 0.4° and 0.1°), so its gradient there is finite but not
    validated.

    Build it with `soft_yield`. **Fields:** `fn` (the traceable function), `nominal` (the design
    variables' nominal values), `n_samples`.
    """

    fn: Any
    nominal: dict[str, np.ndarray]
    n_samples: int

    def __call__(self, variables: dict[str, Any]) -> jax.Array:
        return self.fn(variables)


def soft_yield(
    pattern,
    scatter: Scatter | None = None,
    n_samples: int = 16,
    seed: int = 0,
    *,
    design=None,
    targets=None,
    release_times=None,
    solve=None,
    tolerances=None,
    temperature_deg: float = 0.5,
) -> SoftYield:
    """The differentiable yield surrogate of `pattern` (a net, or its name; see `SoftYield`), with
    the same samples as `yield_estimate(pattern, scatter, n_samples, seed, ...)` (same arguments,
    same meaning: the pattern's physics model, `solve` a `SolveOptions`, `tolerances` a
    `VerdictTolerances`), smoothed at `temperature_deg` (degrees).

    **Raises:** `ValueError` before anything compiles, as `yield_estimate`, and for a temperature
    that is not positive.
    """
    tolerances = VerdictTolerances() if tolerances is None else tolerances
    if not isinstance(tolerances, VerdictTolerances):
        raise ValueError(f"tolerances must be a VerdictTolerances, got {tolerances!r}.")
    solve = FOLD_KERNEL_SOLVE if solve is None else solve
    if not (isinstance(temperature_deg, int | float) and temperature_deg > 0):
        raise ValueError(f"temperature_deg must be a positive number, got {temperature_deg!r}.")
    scatter = Scatter() if scatter is None else scatter
    if isinstance(n_samples, bool) or not isinstance(n_samples, int) or n_samples < 1:
        raise ValueError(f"n_samples must be an integer >= 1, got {n_samples!r}.")
    the_net = as_pattern(pattern)
    if the_net.n_loops:
        raise ValueError(f"{the_net.name}: the yield surrogate takes nets (trees of panels).")
    if design is None:
        design = the_net.default_design(KOH_SOLUTION)  # as `yield_estimate`'s
    m = the_net.n_hinges
    intended = np.asarray(the_net.intended_angles)
    aims = intended if targets is None else np.asarray(targets, dtype=float)
    if aims.shape != (m,):
        raise ValueError(f"targets must be {m} angles (rad, one per crease).")
    nominal = _nominal(design, None if release_times is None else np.asarray(release_times), m)
    draws = {k: jnp.asarray(v) for k, v in standard_draws(seed, n_samples, m).items()}
    kernel = the_net.kernel(
        design=design,
        hinge_lengths="designed",
        solve=solve,
        tolerances=tolerances,
        bias=0.0,
    )
    tol = tolerances.angle
    tau = float(np.radians(temperature_deg))
    # The seam margin in angle units: a seam at a fraction (1 − r) of its tolerance below it is
    # (1 − r) of the tolerance's crease error (`seam_equivalent_angle`) from opening (for a fixed
    # fraction of the panel size L: (seam · L − gap) / L, a gap δ being a crease off by δ / L).
    seam_angle = tolerances.seam_equivalent_angle
    start = {"target": aims, "hinge_width": nominal["hinge_width"], "release": nominal["release"]}

    def fn(variables):
        unknown = sorted(set(variables) - set(DESIGN_VARIABLES))
        if unknown:
            raise ValueError(f"unknown design variable(s) {unknown}; use {DESIGN_VARIABLES}.")
        front = {"front_angle", "front_speed"} & set(variables)
        if front and (len(front) != 2 or "release" in variables):
            raise ValueError(
                "an etch front needs both front_angle and front_speed, and no release times."
            )
        current = {k: jnp.asarray(variables.get(k, v), dtype=float) for k, v in start.items()}
        if front:
            current["release"] = front_release_times(
                the_net, variables["front_angle"], variables["front_speed"]
            )
        params = {}
        for name, spread in scatter.items():
            z = draws[name]
            if spread.per == "net":
                z = jnp.repeat(z[:, :1], m, axis=1)
            x0 = current.get(name, jnp.asarray(nominal[name]))
            x = _transform(spread, x0[None, :], z)
            if name == "release":
                x = x - jnp.minimum(0.0, jnp.min(x, axis=1, keepdims=True))
            if name in _GLOBAL:
                params[name] = x[:, 0]
            else:
                params.update({f"{name}[{j}]": x[:, j] for j in range(m)})
        params.update({f"target[{j}]": jnp.full(n_samples, current["target"][j]) for j in range(m)})
        out = jax.vmap(kernel.fn)(params)
        margin = tol - jnp.abs(out["final_angle"] - jnp.asarray(intended))
        seam = (1.0 - out["seam_margin"]) * seam_angle
        score = jnp.prod(jax.nn.sigmoid(margin / tau), axis=-1) * jax.nn.sigmoid(seam / tau)
        return jnp.mean(jnp.where(jnp.isfinite(score), score, 0.0))

    return SoftYield(
        fn=fn, nominal={k: np.asarray(v) for k, v in start.items()}, n_samples=n_samples
    )
