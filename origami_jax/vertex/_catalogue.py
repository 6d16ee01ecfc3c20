"""Example vertices the package ships (the paper's Fig. 3 and more) and a seeded generator of random valid ones."""

import functools
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, PRNGKeyArray

from ._geometry import chain_from_fold_angles, fold_angles_of
from ._model import InvalidVertexError, SingleVertex, validate_vertex

_DEG = np.pi / 180


@functools.partial(jax.jit, static_argnames="iterations")
def _close_loop_kernel(sectors, guess, free, iterations: int = 40):
    def residual(folds):
        return chain_from_fold_angles(sectors, folds, True)[1]

    def body(_, folds):
        r = residual(folds)
        jac = jax.jacfwd(residual)(folds) * free  # only free fold angles move
        # Minimum-norm Gauss–Newton step (lstsq): stays near the guess, the closest closing state.
        step = jnp.linalg.lstsq(jac, r, rcond=1e-12)[0]
        return folds - step

    folds = jax.lax.fori_loop(0, iterations, body, guess)
    return folds, jnp.max(jnp.abs(residual(folds)))


def close_loop(
    sector_angles: Float[ArrayLike, " n"] | Sequence[float],
    fold_guess: Float[ArrayLike, " n"] | Sequence[float],
    *,
    free: Bool[ArrayLike, " n"] | Float[ArrayLike, " n"] | Sequence[float] | None = None,
) -> tuple[Float[Array, " n"], float]:
    """Fold angles of a closed chain near `fold_guess` that close the loop.

    A closed vertex of `n` creases has `n − 3` free fold angles; this corrects the entries marked
    `free` (default all) by minimum-norm Gauss–Newton steps so that the flaps close up.

    **Returns:** `(fold_angles, residual)`, radians; check `residual` (≈1e-15 on success).
    """
    sectors = jnp.asarray(sector_angles, dtype=jnp.float64)
    guess = jnp.asarray(fold_guess, dtype=sectors.dtype)
    mask = jnp.ones_like(guess) if free is None else jnp.asarray(free, dtype=sectors.dtype)
    folds, residual = _close_loop_kernel(sectors, guess, mask)
    return folds, float(residual)


def _closed_from_guess(sectors, guess, free) -> SingleVertex:
    folds, residual = close_loop(sectors, guess, free=free)
    if not residual < 1e-12:
        raise InvalidVertexError(f"could not close the loop (residual {residual:.2e})")
    # The solver may step past ±π; a rotation by θ and by θ − 2π is the same fold.
    folds = np.remainder(np.asarray(folds) + np.pi, 2 * np.pi) - np.pi
    return SingleVertex.from_fold_angles(sectors, folds, closed=True)


def corner_cube(*, gusset_opening: float = 1.0 * _DEG) -> SingleVertex:
    """The corner cube: three mutually perpendicular 90° faces; the fourth 90° of the square of
    paper becomes a two-layer 45° + 45° gusset (paper Figs. 2, 3a).

    Creases `x_0 = e_x, x_1 = e_y, x_2 = e_z, x_3, x_4` with sectors (90°, 90°, 90°, 45°, 45°);
    `x_4` is the gusset's middle crease, outside the cube.

    **Arguments:**
    - `gusset_opening`: radians. With 0 the gusset is pinched flat (fold angle ±180° at `x_4`)
      and `x_3 = x_0`: two creases coincide, a contact the validation accepts with a warning.
      The default 1° opens the gusset slightly (the cube's faces tilt by a fraction of a degree),
      which keeps the state off the contact.
    """
    sectors = np.array([90, 90, 90, 45, 45], dtype=np.float64) * _DEG
    e = np.eye(3)
    g = np.cos(np.pi / 4) * e[0] - np.sin(np.pi / 4) * (e[1] + e[2]) / np.sqrt(2)
    ideal = np.stack([e[0], e[1], e[2], e[0], g])
    if gusset_opening == 0:
        return SingleVertex.from_directions(ideal, sectors, closed=True)
    if not 0 < gusset_opening < np.pi:
        raise ValueError(f"gusset_opening must lie in [0, π), got {gusset_opening}")
    folds = np.asarray(fold_angles_of(jnp.asarray(ideal), True))
    free = np.array([1, 1, 1, 1, 0.0])
    errors = []
    for sign in (1.0, -1.0):
        guess = folds.copy()
        guess[4] = sign * (np.pi - gusset_opening)
        try:
            return _closed_from_guess(sectors, guess, free)
        except InvalidVertexError as error:
            errors.append(str(error))
    raise InvalidVertexError("could not build the opened corner cube: " + "; ".join(errors))


def waterbomb_base(*, valley: float = 100.0 * _DEG) -> SingleVertex:
    """A partly folded waterbomb base: 8 creases at 45°, alternating valley (the diagonals, fold
    angle `valley`, radians) and mountain (the mid-lines, solved for loop closure) (paper Fig. 3b).
    """
    sectors = np.full(8, 45.0 * _DEG)
    guess = np.tile([valley, -valley], 4)
    free = np.tile([0.0, 1.0], 4)
    return _closed_from_guess(sectors, guess, free)


def degree4_vertex(*, alpha: float = 60.0 * _DEG, fold: float = 60.0 * _DEG) -> SingleVertex:
    """A degree-4 Miura-type vertex: sectors (α, π − α, π − α, α), crease 0 folded by `fold`
    (radians, valley), the other three mountains (Maekawa: |M − V| = 2), solved for closure; the
    collinear creases 0 and 2 fold in opposite senses, 1 and 3 alike."""
    sectors = np.array([alpha, np.pi - alpha, np.pi - alpha, alpha])
    guess = np.array([fold, -fold, -fold, -fold])
    free = np.array([0.0, 1.0, 1.0, 1.0])
    return _closed_from_guess(sectors, guess, free)


def open_chain_vertex(
    sector_angles: Float[ArrayLike, " a"] | Sequence[float] = (
        40 * _DEG,
        50 * _DEG,
        45 * _DEG,
        35 * _DEG,
    ),
    fold_angles: Float[ArrayLike, " m"] | Sequence[float] = (80 * _DEG, -70 * _DEG, 60 * _DEG),
) -> SingleVertex:
    """A boundary vertex (open chain): by default a convex 170° corner of paper with four flaps and
    three interior creases folded valley–mountain–valley (radians)."""
    return SingleVertex.from_fold_angles(sector_angles, fold_angles, closed=False)


def _random_candidate(
    rng: np.random.Generator, n: int, closed: bool, total: float, max_fold: float
):
    n_arcs = n if closed else n - 1
    weights = rng.uniform(0.5, 1.5, n_arcs)
    sectors = total * weights / np.sum(weights)
    folds = rng.uniform(-max_fold, max_fold, n)
    if not closed:
        folds[0] = folds[-1] = 0.0
    return sectors, folds


def random_vertex(
    key: PRNGKeyArray,
    n: int,
    *,
    closed: bool,
    total: float | None = None,
    max_fold: float = 150.0 * _DEG,
    min_sector: float = 10.0 * _DEG,
    min_clearance: float = 2.0 * _DEG,
    max_tries: int = 200,
) -> SingleVertex:
    """A random valid folded single vertex, reproducible from `key`.

    Sector angles are drawn with weights uniform in [0.5, 1.5], scaled to `total` (default 2π
    closed; for open chains uniform in [0.5π, π], a convex corner or straight edge, drawn from
    `key`). Fold angles are uniform in ±`max_fold`; a closed chain's are then corrected to the
    nearest closing state (`close_loop`). Candidates that are invalid, nearly flat, have a sector
    below `min_sector` or a clearance below `min_clearance` (radians) are redrawn.

    With the default settings, draws succeed reliably up to about 20 creases for a closed vertex
    and 10 for an open one (measured: 19 of 20 keys at n = 20 closed, 17 of 20 at n = 10 open);
    beyond, nearly every candidate has a sector below `min_sector` or flaps that cross. Each
    candidate takes milliseconds, so a failure is quick, and its message says which test rejected
    the candidates.

    **Raises:** `ValueError` up front when no candidate can pass (the average sector `total / n` is
    below `min_sector`); `RuntimeError` if `max_tries` candidates all fail.
    """
    if n < 3 or (closed and n < 4):
        raise ValueError("random vertices need n >= 4 (closed) or n >= 3 (open)")
    if max_tries < 1:
        raise ValueError(f"max_tries must be at least 1, got {max_tries}.")
    # NumPy's generator seeded from the key: drawing candidates eagerly through jax.random costs
    # milliseconds of dispatch per call, which dominated generating thousands of vertices.
    rng = np.random.default_rng(np.asarray(jax.random.key_data(key)).ravel().tolist())
    n_arcs = n if closed else n - 1
    widest = total if total is not None else (2 * np.pi if closed else np.pi)
    if widest / n_arcs < min_sector:
        raise ValueError(
            f"{'a closed' if closed else 'an open'} vertex of {n} creases has {n_arcs} sectors "
            f"averaging at most {np.degrees(widest / n_arcs):.3g}°, below min_sector = "
            f"{np.degrees(min_sector):.3g}°: no candidate can pass. Lower n or min_sector."
        )
    if total is None:
        total = 2 * np.pi if closed else rng.uniform(0.5, 1.0) * np.pi
    rejected = {"a sector outside [min_sector, π − min_sector]": 0}
    for _ in range(max_tries):
        sectors, folds = _random_candidate(rng, n, closed, total, max_fold)
        if np.min(sectors) < min_sector or np.max(sectors) > np.pi - min_sector:
            rejected["a sector outside [min_sector, π − min_sector]"] += 1
            continue
        try:
            if closed:
                vertex = _closed_from_guess(sectors, folds, None)
            else:
                vertex = SingleVertex.from_fold_angles(sectors, folds[1:-1], closed=False)
            report = validate_vertex(vertex)
        except InvalidVertexError as error:
            message = str(error)
            reason = (
                "not closing"
                if "close the loop" in message
                else "crossing or overlapping flaps"
                if "flaps" in message
                else "invalid"
            )
            rejected[reason] = rejected.get(reason, 0) + 1
            continue
        reason = None
        if report.contacts or report.min_clearance < min_clearance:
            reason = "flaps closer than min_clearance"
        elif report.planarity < 1e-2:
            reason = "nearly flat"
        elif report.max_abs_fold_angle > np.pi - min_sector:
            reason = "a fold angle near ±180°"
        if reason is not None:
            rejected[reason] = rejected.get(reason, 0) + 1
            continue
        return vertex
    counts = ", ".join(f"{count} {why}" for why, count in rejected.items() if count)
    raise RuntimeError(
        f"no valid random vertex with n={n}, closed={closed} in {max_tries} tries (rejected: "
        f"{counts}). Fewer creases, a smaller max_fold or min_sector, or more max_tries help."
    )


def random_vertices(
    key: PRNGKeyArray, count: int, n: int, *, closed: bool, **kwargs
) -> SingleVertex:
    """`count` random vertices (see `random_vertex`) stacked into one batched `SingleVertex`
    (leading axis `count`), ready for `unfold_batch`."""
    keys = jax.random.split(key, count)
    vertices = [random_vertex(k, n, closed=closed, **kwargs) for k in keys]
    return stack_vertices(vertices)


def stack_vertices(vertices: list[SingleVertex]) -> SingleVertex:
    """Stack vertices of the same size and kind into one batched `SingleVertex`."""
    if not vertices:
        raise ValueError("nothing to stack")
    kinds = {(v.n, v.closed) for v in vertices}
    if len(kinds) != 1:
        raise ValueError(f"vertices differ in size or kind: {sorted(kinds)}")
    return jax.tree.map(lambda *leaves: jnp.stack(leaves), *vertices)
