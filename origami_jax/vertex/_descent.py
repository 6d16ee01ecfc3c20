"""The descent kernel: small constrained steps down the charge energy, as one `lax.while_loop`.

Each iteration (docs/physics.md, "Unfolding by constrained descent"):
1. gradient `g = ∇U(x)` by autodiff;
2. projection onto the tangent space of the constraints `G(x) = 0` *and* orthogonal to the three
   rigid rotations (the gauge freedom: `U` and `G` are rotation invariant, so removing rotations
   changes nothing physical and keeps the path from drifting);
3. a step of bounded node displacement `h` along `−P g`, then Newton restoration of `G(x) = 0`
   (minimum-norm Gauss–Newton with an eigenvalue-cut pseudo-inverse, robust at the singular flat
   state);
4. acceptance tests — energy decrease (Armijo), constraints, no crossing of non-adjacent arcs, the
   step bound re-checked on the displacement actually taken, fold angles kept off ±π — else the
   step is halved and retried from the same state.

**Why the step bound rules out crossings between two checked states.** Let `c` be the smallest
geodesic clearance between non-adjacent arcs at either end of a step, and `δ` the largest node
displacement `max_i |x'_i − x_i|` (chord). Between the two states the chain moves along the
manifold path obtained by restoring the straight segment `x + s (x' − x)` onto `G = 0`; its nodes
stay within `δ + O(δ²)` of both ends. A point of the arc `x_i x_{i+1}` of length `α` is the slerp
`(sin((1−t)α) x_i + sin(tα) x_{i+1}) / sin α`, so it moves by at most `δ / cos(α/2)`. Two
non-adjacent arcs therefore approach each other by at most `2 δ / cos(α_max/2)`; requiring
`4 δ / cos(α_max/2) < c` (a factor 2 spare for the `O(δ²)` restoration term, `δ ≤ 0.05`) keeps them
apart all along the step. The same holds for fold angles: each step changes every fold angle by at
most `fold_step`, and `|ρ| + |Δρ| < π` is required, so no crease passes through ±180° (adjacent
flaps through each other). Contacts present in the input (touching pairs, `contact_mask`) have
clearance 0 and cannot be bounded this way; for them only the discrete crossing test applies, and
the result warns about it.
"""

import math
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, Bool, Float, Int

from ._energy import energy as charge_energy
from ._geometry import (
    arc_pair_clearances,
    constraints,
    fold_angles_of,
    planarity,
    rotation_generators,
    topology,
)

RUNNING, FLAT_UNFOLDED, FLAT_FOLDED, STALLED, MAX_STEPS, INVALID, CONTACT = 0, 1, 2, 3, 4, 5, 6
"""Status codes of the kernel (`UnfoldResult` turns them into a `Verdict`)."""

CERT_MARGIN = 4.0
"""`CERT_MARGIN · δ / cos(α_max/2) < clearance` is the per-step certificate condition."""


class DescentSettings(eqx.Module):
    """Numerical settings of the descent (all dynamic: changing them does not recompile).

    - `max_step`: largest node displacement per step (chord, radians on the unit sphere).
    - `clearance_fraction`: step ≤ this × clearance × cos(α_max/2); must be < 1/`CERT_MARGIN`.
    - `flat_fraction`: step ≤ this × planarity (distance to flat), so steps cannot overshoot flat.
    - `fold_step`: largest fold-angle change per step (radians).
    - `planar_tol`, `fold_tol`: verdict thresholds (1e-4 and 1°).
    - `min_step`: a trust step below this means the energy no longer decreases: stalled.
    - `contact_tol`: clearance or `π − |fold angle|` (radians) below which the descent is running
      into a self-contact (the energy is no collision barrier): stop, stalled.
    - `stationary_tol`: projected gradient norm relative to `1 + |∇U|` below which the state is a
      critical point on the constraint manifold: stalled (if not flat).
    """

    max_step: float | Float[Array, ""] = 0.05
    clearance_fraction: float | Float[Array, ""] = 0.2
    flat_fraction: float | Float[Array, ""] = 0.5
    fold_step: float | Float[Array, ""] = 0.1
    planar_tol: float | Float[Array, ""] = 1e-4
    fold_tol: float | Float[Array, ""] = math.radians(1.0)
    min_step: float | Float[Array, ""] = 1e-11
    stationary_tol: float | Float[Array, ""] = 1e-10
    contact_tol: float | Float[Array, ""] = 1e-3


class DescentOutput(eqx.Module):
    """What one run of the kernel returns (arrays; batched under `vmap`)."""

    x: Float[Array, "n 3"]
    status: Int[Array, ""]
    n_accepted: Int[Array, ""]
    n_iterations: Int[Array, ""]
    energy: Float[Array, ""]
    projected_gradient: Float[Array, ""]
    path: Float[Array, "l n 3"]
    path_energy: Float[Array, " l"]
    path_folds: Float[Array, "l m"]
    min_clearance: Float[Array, ""]
    max_abs_fold: Float[Array, ""]
    max_residual: Float[Array, ""]
    certified: Bool[Array, ""]
    sign_changes: Int[Array, " m"]
    reversals: Int[Array, " m"]
    opening_steps: Int[Array, " m"]


def _pinv_solve(matrix: Float[Array, "k k"], rhs: Float[Array, " k"]) -> Float[Array, " k"]:
    # Eigenvalue-cut pseudo-inverse: the constraint Jacobian loses rank at the flat state of a
    # closed chain (folding branches cross there), where a plain solve would blow up.
    w, v = jnp.linalg.eigh(matrix)
    cut = 1e-13 * jnp.max(jnp.abs(w))
    w_inv = jnp.where(w > cut, 1.0 / jnp.where(w > cut, w, 1.0), 0.0)
    return v @ (w_inv * (v.T @ rhs))


def _jacobian(x, sectors, closed):
    # Written out rather than by `jax.jacfwd`: a handful of scatters compile far faster.
    n = x.shape[0]
    arcs = topology(n, closed).arcs
    n_arcs = arcs.shape[0]
    unit = jnp.zeros((n, n, 3), x.dtype).at[jnp.arange(n), jnp.arange(n)].set(2 * x)
    arc = (
        jnp.zeros((n_arcs, n, 3), x.dtype)
        .at[jnp.arange(n_arcs), arcs[:, 0]]
        .set(x[arcs[:, 1]])
        .at[jnp.arange(n_arcs), arcs[:, 1]]
        .set(x[arcs[:, 0]])
    )
    return jnp.concatenate([unit, arc]).reshape(-1, x.size)


def project(
    x: Float[Array, "n 3"], g: Float[Array, "n 3"], sectors, closed: bool
) -> Float[Array, "n 3"]:
    """`g` projected onto the constraints' tangent space with rigid rotations removed."""
    b = jnp.concatenate([_jacobian(x, sectors, closed), rotation_generators(x)])
    gf = g.reshape(-1)
    mu = _pinv_solve(b @ b.T, b @ gf)
    return (gf - b.T @ mu).reshape(x.shape)


def restore(
    x: Float[Array, "n 3"], sectors, closed: bool, iterations: int = 4
) -> Float[Array, "n 3"]:
    """Newton (minimum-norm Gauss–Newton) restoration of `G(x) = 0`; quadratic convergence from
    a step of size ≤ 0.05, so a fixed small number of iterations reaches rounding level."""

    def body(_, y):
        a = _jacobian(y, sectors, closed)
        r = constraints(y, sectors, closed)
        return y - (a.T @ _pinv_solve(a @ a.T, r)).reshape(y.shape)

    return lax.fori_loop(0, iterations, body, x)


def multipliers(
    x: Float[Array, "n 3"], sectors, closed: bool, kind: str, p
) -> tuple[Float[Array, " c"], Float[Array, ""]]:
    """KKT multipliers `λ` of `∇U + Σ λ_i ∇G_i = 0` (least squares) and the residual norm."""
    g = jax.grad(charge_energy)(x, closed=closed, kind=kind, p=p).reshape(-1)
    a = _jacobian(x, sectors, closed)
    lam = -_pinv_solve(a @ a.T, a @ g)
    return lam, jnp.linalg.norm(g + a.T @ lam)


def _masked_min(values, mask, empty):
    return jnp.min(jnp.where(mask, values, empty), initial=empty)


def _wrap(angle):
    return jnp.arctan2(jnp.sin(angle), jnp.cos(angle))


def descend(
    x0: Float[Array, "n 3"],
    sectors: Float[Array, " a"],
    p: Float[Array, ""] | float,
    contact_mask: Bool[Array, " r"],
    settings: DescentSettings,
    *,
    closed: bool,
    kind: Literal["separable", "nonseparable"],
    max_steps: int,
    record: bool,
) -> DescentOutput:
    """Run the descent from `x0` until a verdict, a stall, or `max_steps` accepted steps.

    **Arguments:**
    - `x0`: `(n, 3)` valid folded state; `sectors` its sector angles (radians).
    - `p`: energy exponent; `kind`: `"separable"` or `"nonseparable"` (static).
    - `contact_mask`: `(r,)` over `Topology.arc_pairs`, `True` for pairs to bound the step with
      (pairs touching in the input are `False`, see the module docstring).
    - `max_steps`: accepted steps at most (static; the path buffer has `max_steps + 1` states).
    - `record`: keep the path (`False` for large batches: the path fields then hold one state).
    """
    n = x0.shape[0]
    dtype = x0.dtype
    p = jnp.asarray(p, dtype)
    energy_fn = lambda y: charge_energy(y, closed=closed, kind=kind, p=p)
    arc_factor = 1.0 / jnp.cos(jnp.max(sectors) / 2)
    big = jnp.asarray(jnp.pi, dtype)

    def clear_min(y):
        clearance, crossing = arc_pair_clearances(y, closed)
        return _masked_min(clearance, contact_mask, big), jnp.any(crossing)

    def verdict(y, folds):
        flat = planarity(y) < settings.planar_tol
        max_fold = jnp.max(jnp.abs(folds), initial=0.0)
        return jnp.where(
            flat & (max_fold < settings.fold_tol),
            FLAT_UNFOLDED,
            jnp.where(flat & (max_fold > jnp.pi / 2), FLAT_FOLDED, RUNNING),
        )

    folds0 = fold_angles_of(x0, closed)
    m = folds0.shape[0]
    length = max_steps + 1 if record else 1
    u0 = energy_fn(x0)
    clear0, cross0 = clear_min(x0)
    residual0 = jnp.max(jnp.abs(constraints(x0, sectors, closed)))
    path = jnp.zeros((length, n, 3), dtype).at[0].set(x0)
    path_energy = jnp.full((length,), jnp.nan, dtype).at[0].set(u0)
    path_folds = jnp.full((length, m), jnp.nan, dtype).at[0].set(folds0)
    zeros_m = jnp.zeros((m,), jnp.int32)
    init = dict(
        x=x0,
        u=u0,
        folds=folds0,
        clear=clear0,
        trust=jnp.asarray(settings.max_step, dtype),
        status=jnp.where(
            cross0 | (residual0 > 1e-8) | ~jnp.all(jnp.isfinite(x0)), INVALID, verdict(x0, folds0)
        ).astype(jnp.int32),
        n_acc=jnp.asarray(0, jnp.int32),
        n_iter=jnp.asarray(0, jnp.int32),
        pg=jnp.asarray(jnp.inf, dtype),
        path=path,
        path_energy=path_energy,
        path_folds=path_folds,
        min_clear=clear0,
        max_fold=jnp.max(jnp.abs(folds0), initial=0.0),
        max_res=residual0,
        certified=~cross0,
        sign_changes=zeros_m,
        reversals=zeros_m,
        opening=zeros_m,
        prev_dfold=jnp.zeros((m,), dtype),
        last_sign=jnp.sign(folds0) * (jnp.abs(folds0) > settings.fold_tol),
    )
    max_iter = 8 * max_steps

    def cond(c):
        return (c["status"] == RUNNING) & (c["n_iter"] < max_iter) & (c["n_acc"] < max_steps)

    def body(c):
        x, u, folds = c["x"], c["u"], c["folds"]
        g = jax.grad(energy_fn)(x)
        pg = project(x, g, sectors, closed)
        pg_norm = jnp.linalg.norm(pg)
        stationary = pg_norm <= settings.stationary_tol * (1.0 + jnp.linalg.norm(g))
        d_max = jnp.max(jnp.linalg.norm(pg, axis=-1))
        h = jnp.minimum(
            jnp.minimum(c["trust"], settings.max_step),
            jnp.minimum(
                settings.clearance_fraction * c["clear"] / arc_factor,
                settings.flat_fraction * jnp.maximum(planarity(x), settings.planar_tol),
            ),
        )
        scale = h / jnp.where(d_max > 0, d_max, 1.0)
        x_t = restore(x - scale * pg, sectors, closed)
        u_t = energy_fn(x_t)
        folds_t = fold_angles_of(x_t, closed)
        clear_t, cross_t = clear_min(x_t)
        residual = jnp.max(jnp.abs(constraints(x_t, sectors, closed)))
        disp = jnp.max(jnp.linalg.norm(x_t - x, axis=-1))
        dfold = _wrap(folds_t - folds)
        was_flat_folded = jnp.abs(folds) > jnp.pi - 1e-7  # a contact of the input (pinched crease)
        fold_ok = jnp.all(
            (jnp.abs(dfold) <= settings.fold_step)
            & ((jnp.abs(folds) + jnp.abs(dfold) < jnp.pi) | was_flat_folded)
            & (jnp.abs(folds_t) < jnp.pi)
        )
        decrease = u_t <= u - 1e-4 * scale * pg_norm**2
        safe = CERT_MARGIN * disp * arc_factor < jnp.minimum(c["clear"], clear_t)
        accept = (
            jnp.isfinite(u_t)
            & decrease
            & (residual < 1e-10)
            & ~cross_t
            & safe
            & fold_ok
            & ~stationary
        )
        n_acc = c["n_acc"] + accept.astype(jnp.int32)
        idx = jnp.minimum(n_acc, length - 1) if record else 0
        new_x = jnp.where(accept, x_t, x)
        new_folds = jnp.where(accept, folds_t, folds)
        new_u = jnp.where(accept, u_t, u)
        new_clear = jnp.where(accept, clear_t, c["clear"])
        trust = jnp.where(accept, jnp.minimum(2 * c["trust"], settings.max_step), 0.5 * h)
        status = jnp.where(accept, verdict(x_t, folds_t), RUNNING)
        status = jnp.where(stationary | (trust < settings.min_step), STALLED, status)
        # Steps shrink geometrically with the clearance, so a descent heading into a contact would
        # crawl forever without crossing: stop it and let the escapes try.
        closing = (clear_t < settings.contact_tol) | jnp.any(
            (jnp.abs(folds_t) > jnp.pi - settings.contact_tol) & ~was_flat_folded
        )
        status = jnp.where(accept & closing & (status == RUNNING), CONTACT, status)
        # A sign change counts when a crease, last clearly folded one way (|ρ| > fold_tol), is
        # clearly folded the other way: chatter of size < 1° around 0 near the goal is not counted.
        sign_t = jnp.sign(folds_t) * (jnp.abs(folds_t) > settings.fold_tol)
        flipped = accept & (sign_t != 0) & (c["last_sign"] != 0) & (sign_t != c["last_sign"])
        last_sign = jnp.where(accept & (sign_t != 0), sign_t, c["last_sign"])
        moving = jnp.abs(dfold) > 1e-12
        reversed_ = accept & moving & (jnp.sign(dfold) * jnp.sign(c["prev_dfold"]) < 0)
        opening = accept & (jnp.abs(folds_t) > jnp.abs(folds) + 1e-12)

        def put(buffer, value):
            return buffer.at[idx].set(jnp.where(accept, value, buffer[idx])) if record else buffer

        return dict(
            x=new_x,
            u=new_u,
            folds=new_folds,
            clear=new_clear,
            trust=trust,
            status=status.astype(jnp.int32),
            n_acc=n_acc,
            n_iter=c["n_iter"] + 1,
            pg=pg_norm,
            path=put(c["path"], x_t),
            path_energy=put(c["path_energy"], u_t),
            path_folds=put(c["path_folds"], folds_t),
            min_clear=jnp.where(accept, jnp.minimum(c["min_clear"], clear_t), c["min_clear"]),
            max_fold=jnp.where(
                accept,
                jnp.maximum(c["max_fold"], jnp.max(jnp.abs(folds_t), initial=0.0)),
                c["max_fold"],
            ),
            max_res=jnp.where(accept, jnp.maximum(c["max_res"], residual), c["max_res"]),
            certified=c["certified"],
            sign_changes=c["sign_changes"] + flipped.astype(jnp.int32),
            reversals=c["reversals"] + reversed_.astype(jnp.int32),
            opening=c["opening"] + opening.astype(jnp.int32),
            prev_dfold=jnp.where(accept & moving, dfold, c["prev_dfold"]),
            last_sign=last_sign,
        )

    c = lax.while_loop(cond, body, init)
    status = jnp.where(c["status"] == RUNNING, MAX_STEPS, c["status"])
    if not record:
        c["path"] = c["x"][None]
        c["path_energy"] = c["u"][None]
        c["path_folds"] = c["folds"][None]
    return DescentOutput(
        x=c["x"],
        status=status.astype(jnp.int32),
        n_accepted=c["n_acc"],
        n_iterations=c["n_iter"],
        energy=c["u"],
        projected_gradient=c["pg"],
        path=c["path"],
        path_energy=c["path_energy"],
        path_folds=c["path_folds"],
        min_clearance=c["min_clear"],
        max_abs_fold=c["max_fold"],
        max_residual=c["max_res"],
        certified=c["certified"],
        sign_changes=c["sign_changes"],
        reversals=c["reversals"],
        opening_steps=c["opening"],
    )
