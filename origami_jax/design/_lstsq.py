"""Multi-start, bounded, gradient-based least squares over any residual function (optimistix inside).

`fit_batch(fn, z0s, args)` runs one optimistix solve per row of `z0s`, vmapped into a single compiled
program, with `throw=False`, and returns every start's answer and result code. The residual function
`fn(z, args) -> (r, extra, aux)` gives the residual rows `r`, further outputs `extra` whose Jacobian is
wanted as well (a design's metrics) and anything else as `aux`.

**Why a custom JVP.** Levenberg–Marquardt asks for `jax.linearize(fn)`. Through an ODE solve's
`while_loop` that linear function re-runs the whole solve at every product the QR factorisation needs.
Here the Jacobian is computed once per point with `jax.jacfwd` (p forward-mode tangents, vmapped into
one solve) and attached to `r` by a `custom_jvp`, so the linear map the optimiser sees is a small matrix
product and the Jacobian it uses is exactly the one reported (and tested against finite differences).

**Non-finite residuals** (a failed simulation, a level never crossed) are replaced by a large constant
with a zero Jacobian row: the optimiser rejects steps into such regions instead of propagating NaN, and
the start is reported with `RESULTS.nonfinite_residual` if it ends there.
"""

from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Bool, Float, Int

from ..simulation._results import promote

# Residual value standing in for a non-finite one (residual rows are O(1) when targets are met).
NONFINITE_PENALTY = 1e3


class RESULTS(optx.RESULTS):  # pyright: ignore[reportGeneralTypeIssues]
    """Outcome of a design / calibration start: optimistix's codes plus our own."""

    nonfinite_residual = (
        "The residual was NaN or infinite at the returned point: the simulation failed or a metric was "
        "undefined there (e.g. the response never reached 90 % within the run)."
    )


@jax.custom_jvp
def _attach_jacobian(z, r, jac):
    del z, jac
    return r


@_attach_jacobian.defjvp
def _attach_jacobian_jvp(primals, tangents):
    z, r, jac = primals
    dz, _, _ = tangents
    return r, jac @ dz


def _with_jacobian(fn: Callable) -> Callable:
    """`fn` → `(z, args) -> (r, (aux, r, J_r, extra, J_extra, bad))` with `J_r` attached to `r`."""

    def wrapped(z, args):
        z_frozen = jax.lax.stop_gradient(z)

        def outputs(zz):
            r, extra, aux = fn(zz, args)
            return jnp.concatenate([r, extra]), (r, extra, aux)

        jac_all, (r, extra, aux) = jax.jacfwd(outputs, has_aux=True)(z_frozen)
        n_r = r.shape[0]
        jac_r, jac_extra = jac_all[:n_r], jac_all[n_r:]
        bad_rows = ~jnp.isfinite(r) | ~jnp.all(jnp.isfinite(jac_r), axis=-1)
        r_safe = jnp.where(bad_rows, NONFINITE_PENALTY, r)
        jac_safe = jnp.where(bad_rows[:, None], 0.0, jac_r)
        r_out = _attach_jacobian(z, r_safe, jac_safe)
        return r_out, (aux, r, jac_safe, extra, jac_extra, jnp.any(bad_rows))

    return wrapped


def evaluate_with_jacobian(fn: Callable, z: Float[Array, " p"], args: Any):
    """`fn` and its Jacobians at `z`, the same way the optimiser sees them (not jitted: compose it).

    **Returns:** `(r, J_r, extra, J_extra, aux)`; `J_r` has non-finite rows zeroed.
    """
    _, (aux, r, jac, extra, jac_extra, _) = _with_jacobian(fn)(z, args)
    return r, jac, extra, jac_extra, aux


class FitBatch(eqx.Module):
    """Every start of a multi-start fit (leading axis: start).

    **Fields:**
    - `z`: unconstrained solution per start, `(s, p)`.
    - `residual`, `jacobian`: residual rows and `∂r/∂z` at the solution, `(s, r)` and `(s, r, p)`.
    - `extra`, `extra_jacobian`: the extra outputs and `∂extra/∂z`, `(s, e)` and `(s, e, p)`.
    - `aux`: the residual function's aux at the solution, batched.
    - `loss`: ``½‖r‖²`` (non-finite rows counted as the penalty), `(s,)`.
    - `result`: a [`origami_jax.design.RESULTS`][] code per start.
    - `num_steps`: optimiser steps per start, `(s,)`.
    """

    z: Float[Array, "*s p"]
    residual: Float[Array, "*s r"]
    jacobian: Float[Array, "*s r p"]
    extra: Float[Array, "*s e"]
    extra_jacobian: Float[Array, "*s e p"]
    aux: Any
    loss: Float[Array, "*s"]
    result: RESULTS
    num_steps: Int[Array, "*s"]
    nonfinite: Bool[Array, "*s"]

    def best(self) -> int:
        """Index of the start with the smallest loss among those with finite residuals (else 0)."""
        loss = np.where(np.asarray(self.nonfinite), np.inf, np.asarray(self.loss))
        return int(np.argmin(loss)) if bool(np.any(np.isfinite(loss))) else 0


def _quiet(**kwargs: Any) -> None:
    """optimistix's per-step report (`verbose`), switched off."""
    del kwargs


class GaussNewtonStepStop(optx.AbstractGaussNewton):
    """Levenberg–Marquardt, composed as optimistix composes its own (`optx.AbstractGaussNewton` with
    a `DampedNewtonDescent` and a `ClassicalTrustRegion`), that also stops when the full
    Gauss–Newton step from the current point is below the tolerances: it would change `z` by less
    than ``atol + rtol |z|`` and, by its linear prediction, every residual row by less than
    ``atol + rtol |r|``.

    optimistix stops when the step *just taken* was that small, which costs one more evaluation once
    the iteration has converged: with an exact Jacobian the step before it already lands within
    tolerance (Gauss–Newton converges quadratically on a zero-residual problem), and at a
    non-zero-residual optimum the Gauss–Newton step vanishes with the gradient ``Jᵀr``. This is
    MINPACK's test on the computed step. The point returned is the last accepted one, whose residual
    and Jacobian the report shows. On the accordion calibration: 6 evaluations instead of 7.

    **Arguments:** `rtol`, `atol` (see above and `optx.LevenbergMarquardt`); `norm` for optimistix's
    own test on the step taken (default `optx.max_norm`). The damped step is solved by lineax's
    automatic choice, QR for the (tall) damped system, as `optx.LevenbergMarquardt` does.
    """

    rtol: float
    atol: float
    norm: Callable[..., Array]
    descent: optx.DampedNewtonDescent
    search: optx.ClassicalTrustRegion
    verbose: Callable[..., None]

    def __init__(self, rtol: float, atol: float, norm: Callable[..., Array] = optx.max_norm):
        self.rtol = rtol
        self.atol = atol
        self.norm = norm
        self.descent = optx.DampedNewtonDescent()
        self.search = optx.ClassicalTrustRegion()
        self.verbose = _quiet

    def terminate(self, fn, y, args, options, state, tags):
        done, result = super().terminate(fn, y, args, options, state, tags)
        jac = state.f_info.jac.as_matrix()
        residual = state.f_info.residual
        step = jnp.linalg.lstsq(jac, -residual)[0]
        y_scale = self.atol + self.rtol * jnp.abs(y)
        r_scale = self.atol + self.rtol * jnp.abs(residual)
        small = jnp.all(jnp.abs(step) < y_scale) & jnp.all(jnp.abs(jac @ step) < r_scale)
        converged = ~state.first_step & small & jnp.all(jnp.isfinite(step))
        return done | converged, result


def default_solver(rtol: float = 1e-6, atol: float = 1e-6) -> optx.AbstractLeastSquaresSolver:
    """`GaussNewtonStepStop(rtol, atol)`, optimistix's Levenberg–Marquardt with a stopping test on
    the next step: robust to the poor conditioning that non-identifiable parameter combinations cause
    (its damping keeps the step finite along them).

    It stops once a step changes (or the next full Gauss–Newton step would change) `z` by less than
    ``atol + rtol |z|`` and every residual row by less than ``atol + rtol |r|``. Residual rows are
    relative metric errors, so ``atol = 1e-6`` is four orders of magnitude below a 1 % measurement,
    and two above the ~1e-8 relative accuracy of the simulated metrics at the default ODE tolerance
    (rtol 1e-8): a tighter `atol` would ask the stopping test to resolve the simulation's own error.
    (1e-8, the earlier default, cost one more full step on the accordion calibration, 8 against 7,
    at the same answer to ~1e-12; the test on the next step saves one more.)
    """
    return GaussNewtonStepStop(rtol=rtol, atol=atol)


def _fit_one(fn, z0, args, solver, max_steps):
    wrapped = _with_jacobian(fn)
    if isinstance(solver, optx.AbstractMinimiser):

        def loss_fn(z, a):
            r, aux = wrapped(z, a)
            return 0.5 * jnp.sum(r**2), aux

        sol = optx.minimise(
            loss_fn, solver, z0, args, has_aux=True, max_steps=max_steps, throw=False
        )
        # A minimiser's aux may belong to the previous iterate: evaluate once more at the answer.
        _, aux = wrapped(sol.value, args)
    else:
        sol = optx.least_squares(
            wrapped, solver, z0, args, has_aux=True, max_steps=max_steps, throw=False
        )
        # The solver state's aux belongs to the last accepted point, which is `sol.value`.
        aux = sol.state.aux
    user_aux, r, jac, extra, jac_extra, bad = aux
    loss = 0.5 * jnp.sum(jnp.where(jnp.isfinite(r), r, NONFINITE_PENALTY) ** 2)
    result = promote(sol.result, RESULTS)
    result = RESULTS.where(bad, RESULTS.nonfinite_residual, result)
    return FitBatch(
        z=sol.value,
        residual=r,
        jacobian=jac,
        extra=extra,
        extra_jacobian=jac_extra,
        aux=user_aux,
        loss=loss,
        result=result,
        num_steps=jnp.asarray(sol.stats["num_steps"]),
        nonfinite=bad,
    )


@eqx.filter_jit
def fit_batch(
    fn: Callable,
    z0s: Float[Array, "s p"],
    args: Any,
    *,
    solver: optx.AbstractLeastSquaresSolver | optx.AbstractMinimiser | None = None,
    max_steps: int = 64,
) -> FitBatch:
    """Least squares from every start in `z0s` at once (vmapped), never raising.

    **Arguments:**
    - `fn`: `(z, args) -> (r, extra, aux)`, residual rows `r` (shape `(r,)`), extra differentiable
      outputs `extra` (shape `(e,)`, may be empty) and any aux. It must be the same Python object between
      calls to reuse the compilation.
    - `z0s`: starting points, unconstrained, shape `(s, p)`.
    - `args`: pytree passed to `fn` (its arrays are traced: new values do not recompile).
    - `solver`: an optimistix least-squares solver (default `GaussNewtonStepStop(1e-6, 1e-6)`, a
      Levenberg–Marquardt) or a minimiser such as `optx.BFGS` (applied to ``½‖r‖²``).
    - `max_steps`: optimiser step budget per start (steps, not function evaluations).

    **Returns:** a [`origami_jax.design.FitBatch`][]; read `result` for each start.
    """
    solver = default_solver() if solver is None else solver
    return jax.vmap(lambda z0: _fit_one(fn, z0, args, solver, max_steps))(z0s)
