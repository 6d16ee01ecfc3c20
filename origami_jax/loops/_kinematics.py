"""Rigid folding of a closed-loop crease pattern without dynamics: projection onto the closure, rigid
foldability along a path towards target angles, the folding branch a state is on.

These run once per pattern on the host (eager JAX, small dense least squares), before any simulation:
to check input (do the target angles close? can the pattern reach them with rigid panels?), and to
place the start of a simulation on the branch its inputs choose.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from . import _closure

# A loop closes when its rotation residual is below this (rad); input angles are checked against it.
CLOSURE_TOL = 1e-6
# A pattern folds rigidly towards its targets when every loop stays closed to this along the way.
RIGID_TOL = 1e-8


def _padded(directions: tuple[np.ndarray, ...], creases: tuple[tuple[int, ...], ...]):
    """`(n_v, D, 3)` directions and `(n_v, D)` indices padded to the largest degree (see
    `origami_jax.loops._closure`)."""
    m_pad = max((max(c) for c in creases), default=-1) + 1
    depth = max((len(c) for c in creases), default=1)
    dirs = np.zeros((len(creases), depth, 3))
    dirs[..., 0] = 1.0
    index = np.full((len(creases), depth), m_pad, dtype=np.int32)
    for v, (d, c) in enumerate(zip(directions, creases, strict=True)):
        dirs[v, : len(c)] = d
        index[v, : len(c)] = c
    return dirs, index


def _with_count(index: np.ndarray, m: int) -> np.ndarray:
    """The padding index set to `m` (the appended zero angle)."""
    out = index.copy()
    out[out >= m] = m
    return out


def _full_residual(directions, index, theta):
    """``P − I`` around every vertex, flattened `(9 n_v,)`: zero only where the loop closes (the
    dynamics' ``vee(P − Pᵀ)`` also vanishes at half-turns, which a far-off guess can reach)."""
    product, _ = _closure.loop_products(directions, _closure.gather_angles(theta, index))
    return (product - jnp.eye(3, dtype=product.dtype)).reshape(-1)


@jax.jit
def _gauss_newton(directions, index, theta, weight, progress_dir, progress, signs):
    """Minimum-norm Gauss–Newton on ``[P − I; weight (dirᵀθ − progress)] = 0`` from `theta`, each
    step projected so that crease ``j`` keeps the side of flat ``signs[j]`` (0: either side)."""

    def keep(theta):
        return jnp.where(signs != 0, signs * jnp.maximum(signs * theta, 0.0), theta)

    def body(_, theta):
        residual = _full_residual(directions, index, theta)
        jac = jax.jacfwd(_full_residual, argnums=2)(directions, index, theta)
        matrix = jnp.concatenate([jac, weight * progress_dir[None, :]], axis=0)
        rhs = jnp.concatenate([residual, weight * (progress_dir @ theta - progress)[None]])
        step = jnp.linalg.lstsq(matrix, rhs, rcond=1e-13)[0]
        return keep(theta - step)

    return jax.lax.fori_loop(0, 40, body, keep(theta))


def project(directions, index, theta, m: int, signs=None) -> np.ndarray:
    """The closed state nearest `theta` along minimum-norm Gauss–Newton steps (rad, `(m,)`), keeping
    the crease signs `signs` (default: none kept)."""
    theta = jnp.asarray(theta, dtype=float)
    zero = jnp.zeros((m,), theta.dtype)
    signs = zero if signs is None else jnp.asarray(signs, dtype=theta.dtype)
    out = _gauss_newton(
        jnp.asarray(directions), index, theta, jnp.zeros(()), zero, jnp.zeros(()), signs
    )
    return np.asarray(out)


@jax.jit
def _residual_and_jacobian(directions, index, theta):
    return _full_residual(directions, index, theta), jax.jacfwd(_full_residual, argnums=2)(
        directions, index, theta
    )


def close_nearby(directions, index, theta, *, rcond: float = 1e-4, steps: int = 8) -> np.ndarray:
    """`theta` (rad, `(m,)`) moved onto closed loops by Gauss–Newton steps truncated to the
    well-conditioned directions (singular values above `rcond` of the largest): a state that closes
    to rounding moves by about its residual, even where the loops are nearly singular (a rigid
    square twist), where the minimum-norm steps of `project` leap along the soft direction."""
    directions = jnp.asarray(directions)
    theta = np.asarray(theta, dtype=float)
    for _ in range(steps):
        residual, jac = _residual_and_jacobian(directions, index, jnp.asarray(theta))
        theta = theta - np.linalg.lstsq(np.asarray(jac), np.asarray(residual), rcond=rcond)[0]
    return theta


def motion_basis(directions, index, theta, *, rcond: float = 1e-6) -> np.ndarray:
    """An orthonormal basis `(m, d)` of the crease rates that keep every loop closed at `theta`
    (rad, `(m,)`): the null space of the closure's Jacobian, its singular values below `rcond`
    of the largest counted as zero (the loops of a Miura-ori are dependent: some are exactly
    zero; at a state 0.01 rad along a branch the smallest that are not are ~1e-4)."""
    _, jac = _residual_and_jacobian(jnp.asarray(directions), index, jnp.asarray(theta, float))
    _, singular, vh = np.linalg.svd(np.asarray(jac))
    rank = int(np.sum(singular > rcond * singular[0])) if singular.size else 0
    return vh[rank:].T


def max_residual(directions, index, theta) -> float:
    """Largest closure residual over the loops (the rotation angle, rad)."""
    residual = _closure.closure(jnp.asarray(directions), index, jnp.asarray(theta, dtype=float))
    sines = jnp.linalg.norm(residual, axis=-1)
    return float(jnp.max(jnp.arcsin(jnp.clip(sines, 0.0, 1.0)))) if residual.shape[0] else 0.0


@dataclasses.dataclass(frozen=True)
class RigidFoldability:
    """Can rigid panels fold the pattern from flat to its targets? (`CreasePattern.rigid_foldability`)

    **Fields:** `rigid` (every loop stays closed to `RIGID_TOL` along the way); `residual`: the
    largest closure residual on the way (rad: how far the panels around some vertex would have to
    twist apart, i.e. bend, to follow it); `progress` `(k,)`: the fractions of the way to the targets
    checked; `residuals` `(k,)`: the closure residual at each; `path` `(k, m)`: the closest rigid
    (or least-open) states (rad).
    """

    rigid: bool
    residual: float
    progress: np.ndarray
    residuals: np.ndarray
    path: np.ndarray

    def summary(self) -> str:
        if self.rigid:
            return (
                f"rigidly foldable to its targets (closure residual ≤ {self.residual:.1e} rad "
                "along the way)"
            )
        k = int(np.argmax(self.residuals > RIGID_TOL))
        return (
            f"not rigidly foldable: {100 * self.progress[k]:.0f} % of the way to the targets the "
            f"loops already open by {np.degrees(self.residuals[k]):.3g}°, up to "
            f"{np.degrees(self.residual):.3g}° (rigid panels cannot follow; facets must bend)"
        )


def rigid_path(directions, index, targets, m: int, steps: int = 20) -> RigidFoldability:
    """Continuation from flat towards `targets`: at progress `s`, the state that comes closest to
    closing every loop with ``t̂ · θ = s |θ_target|`` (``t̂`` the targets' direction) and every crease
    on its target's side of flat (the targets' mountain–valley assignment: the branch they are on),
    from the previous one. Rigid panels can fold there when that closest state closes."""
    targets = np.asarray(targets, dtype=float)
    norm = float(np.linalg.norm(targets))
    if norm == 0:
        zero = np.zeros((1, m))
        return RigidFoldability(True, 0.0, np.zeros(1), np.zeros(1), zero)
    unit = jnp.asarray(targets / norm)
    signs = jnp.asarray(np.sign(np.where(np.abs(targets) < 1e-12, 0.0, targets)))
    directions = jnp.asarray(directions)
    theta = jnp.asarray(targets / steps)
    progress, residuals, path = [], [], []
    for k in range(1, steps + 1):
        s = k / steps
        theta = _gauss_newton(
            directions, index, theta, jnp.asarray(1e2), unit, jnp.asarray(s * norm), signs
        )
        progress.append(s)
        residuals.append(max_residual(directions, index, theta))
        path.append(np.asarray(theta))
        theta = theta + jnp.asarray(targets / steps)
    residuals_ = np.asarray(residuals)
    worst = float(np.max(residuals_))
    return RigidFoldability(
        worst <= RIGID_TOL, worst, np.asarray(progress), residuals_, np.stack(path)
    )
