"""`StiffnessSwitching`: explicit Tsit5 until the problem turns stiff, then implicit Kvaerno5 (LSODA's idea).

Why: a folding chain in air is not stiff at the accuracy users ask for (the 3-flap accordion step takes
~740 steps with Tsit5 and with Kvaerno5 alike at rtol 1e-8), and there an implicit step costs ~10× an
explicit one (a Jacobian and chord iterations on a 6×6 system). In a viscous etchant or with very stiff
hinges the explicit solver's step is bounded by stability, not accuracy, and its gradients can have the
wrong sign at loose tolerance. This solver takes explicit steps while they are cheap and
safe, and switches for good to the L-stable implicit solver once the stiffness test has fired.

Stiffness test (Hairer & Wanner, *Solving ODEs II*, §IV.2, as in DOPRI5): Tsit5's stages 6 and 7 are
both taken at ``t₁``, so ``h ρ ≈ ‖k₇ − k₆‖ / ‖y₁ − Y₆‖`` estimates the step size times the dominant
eigenvalue of the Jacobian along the direction the step explored, from values the step computed anyway.
Past `threshold` (default 3.25, Hairer's value for DOPRI5; Tsit5's real stability interval ends at
3.51) on `patience` accepted steps (default 15; six non-stiff steps in between reset the count) the
solver turns implicit. The switch is one way: an implicit step is never wrong, only dearer, and flipping back and
forth would put explicit steps into stiff stretches, where their gradients are unreliable.

Dense output (the samples of `simulate`) carries each step's own accuracy: an explicit step is
interpolated with Tsit5's fourth-order continuous extension of its seven stages, an implicit one
with the cubic Hermite polynomial of its end values and slopes (what Kvaerno5 itself uses). Both
steps hand over the same dense information (end values and the seven stage increments) plus a flag
saying which kind of step it was, so one interpolation class serves both. A single cubic Hermite
interpolant for every step, as before, made the samples of a free chain up to ~1000× less accurate
than the steps (energy drift 1.7e-5 at the samples against 2.2e-7 at the step ends).

Under `vmap` with a batched switch flag, `lax.cond` evaluates both branches: a batch of designs pays
for an implicit and an explicit step each step. Batches should name their solver (the sweep kernels do).
"""

from typing import ClassVar, Literal

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Int

_HermiteFromK = diffrax.ThirdOrderHermitePolynomialInterpolation.from_k
_Tsit5Interpolation = diffrax.Tsit5.interpolation_cls


class SwitchingInterpolation(diffrax.AbstractLocalInterpolation):
    """Dense output of one `StiffnessSwitching` step (module docstring): Tsit5's fourth-order
    interpolant for an explicit step, cubic Hermite (Kvaerno5's) for an implicit one.

    **Fields:** `t0`, `t1` (the step), `y0`, `y1` (its end states), `k` (the seven stage increments
    ``h f``, leading axis 7, the layout both Runge–Kutta methods share), `implicit` (a boolean
    scalar, batched under `vmap`; `None` in the `"explicit"` phase, whose steps are all explicit:
    then no conditional, and no Hermite branch to trace and compile).
    """

    t0: Array
    t1: Array
    y0: object
    y1: object
    k: object
    implicit: Bool[Array, ""] | None

    def evaluate(self, t0, t1=None, left=True):
        del left
        if t1 is not None:
            return jax.tree.map(lambda a, b: a - b, self.evaluate(t1), self.evaluate(t0))
        span = dict(t0=self.t0, t1=self.t1, y0=self.y0, y1=self.y1, k=self.k)
        if self.implicit is None:
            return _Tsit5Interpolation(**span).evaluate(t0)
        return jax.lax.cond(
            self.implicit,
            lambda: _HermiteFromK(**span).evaluate(t0),
            lambda: _Tsit5Interpolation(**span).evaluate(t0),
        )


def implicit_solver() -> diffrax.Kvaerno5:
    """Kvaerno5 (L-stable ESDIRK, order 5) with diffrax's `VeryChord` root finder at fixed tolerances.

    `VeryChord` keeps the Jacobian that diffrax computes once per step for all stages, where optimistix's
    `Chord` recomputes it for every stage (counted on the accordion: 2 against 8 Jacobians per step;
    1.2× faster on one accordion trajectory, 2.2× in a vmapped sweep). The stage tolerances only
    need to sit below the step's error estimate; these fixed ones do at rtol down to 1e-8 (diffrax's
    default would take the controller's, which rejected about half the steps at rtol 1e-8).
    """
    return diffrax.Kvaerno5(root_finder=diffrax.VeryChord(rtol=1e-5, atol=1e-8))


class StiffnessSwitching(diffrax.AbstractAdaptiveSolver):
    """Tsit5 while the problem is non-stiff, Kvaerno5 from the first stiff stretch on (module docstring).

    **Arguments:**
    - `threshold`: stiffness indicator ``h ρ`` above which an explicit step counts as stiff.
    - `patience`: number of stiff accepted steps (with fewer than six non-stiff ones between) that
      trigger the switch.
    - `start_implicit`: begin with implicit steps (for problems known to be stiff from the start).
    - `phase`: `"both"` (default): the solver above. `"explicit"`: explicit steps only, ending the
      solve at the step after which the switch turns (result `TURNED_STIFF`); `"implicit"`:
      implicit steps only, continuing from that step's solver state. A top-level `simulate` runs
      the two phases as two programs, so that a run which never turns stiff never compiles the
      implicit solver (three quarters of the default solver's compile time).

    The solver state records whether the switch happened; [`origami_jax.simulation.simulate`][] reports
    the time of the switch in its statistics as `switch_time` (`inf` if it never switched).
    """

    explicit: diffrax.Tsit5 = eqx.field(default_factory=diffrax.Tsit5)
    implicit: diffrax.Kvaerno5 = eqx.field(default_factory=implicit_solver)
    threshold: float = 3.25
    patience: int = 15
    start_implicit: bool = False
    phase: Literal["both", "explicit", "implicit"] = eqx.field(default="both", static=True)

    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar = SwitchingInterpolation

    def __check_init__(self):
        if not self.threshold > 0:
            raise ValueError(f"threshold must be positive, got {self.threshold}.")
        if self.patience < 1:
            raise ValueError(f"patience must be at least 1, got {self.patience}.")
        if self.phase not in ("both", "explicit", "implicit"):
            raise ValueError(f"phase must be 'both', 'explicit' or 'implicit', got {self.phase!r}.")

    def with_scan_kind(self, kind: str | None) -> "StiffnessSwitching":
        """The same solver with its Runge–Kutta stage loops of this `scan_kind`.

        diffrax sets `scan_kind="lax"` on a Runge–Kutta solver it is given with
        `adjoint=diffrax.ForwardMode()` (forward-mode autodiff cannot pass the default checkpointed
        loop); it cannot see inside this wrapper, so do it here: `simulate` does it for you.
        """
        return eqx.tree_at(
            lambda s: (s.explicit.scan_kind, s.implicit.scan_kind),
            self,
            (kind, kind),
            is_leaf=lambda x: x is None,
        )

    def order(self, terms):
        return 5

    def error_order(self, terms):
        return 5

    def init(self, terms, t0, t1, y0, args):
        runge_kutta = self.explicit.init(terms, t0, t1, y0, args)
        stiff = jnp.asarray(self.start_implicit)
        zero = jnp.asarray(0, dtype=jnp.int32)
        switch_time = jnp.where(stiff, t0, jnp.inf)
        return runge_kutta, _Switch(stiff, zero, zero, jnp.asarray(switch_time))

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        runge_kutta, switch = solver_state

        def explicit():
            y1, error, dense, state, result = self.explicit.step(
                terms, t0, t1, y0, args, runge_kutta, made_jump
            )
            return y1, error, dense, state, result, _tsit5_stiffness(dense, self.explicit)

        def implicit():
            y1, error, dense, state, result = self.implicit.step(
                terms, t0, t1, y0, args, runge_kutta, made_jump
            )
            return y1, error, dense, state, result, jnp.zeros((), dtype=jnp.result_type(t1))

        if self.phase == "explicit":
            y1, error, dense, state, result, h_rho = explicit()
        elif self.phase == "implicit":
            y1, error, dense, state, result, h_rho = implicit()
        else:
            y1, error, dense, state, result, h_rho = jax.lax.cond(switch.stiff, implicit, explicit)
        # The explicit phase takes explicit steps only (its `switch.stiff` is False at every step's
        # start: the solve stops at the step that sets it), so its interpolant is Tsit5's.
        explicit_only = self.phase == "explicit" and self.start_implicit is False
        dense = {**dense, "implicit": None if explicit_only else switch.stiff}
        is_stiff_step = h_rho > self.threshold
        stiff_steps = jnp.where(is_stiff_step, switch.stiff_steps + 1, switch.stiff_steps)
        calm_steps = jnp.where(is_stiff_step, 0, switch.calm_steps + 1)
        stiff_steps = jnp.where(calm_steps >= 6, 0, stiff_steps)
        calm_steps = jnp.where(calm_steps >= 6, 0, calm_steps)
        turns = jnp.logical_and(~switch.stiff, stiff_steps >= self.patience)
        new_switch = _Switch(
            stiff=switch.stiff | turns,
            stiff_steps=stiff_steps,
            calm_steps=calm_steps,
            switch_time=jnp.where(turns, t1, switch.switch_time),
        )
        if self.phase == "explicit":
            # Not an "okay" result, so that diffrax keeps it (it keeps the step and stops): the
            # caller reads it back as the switch (see `TURNED_STIFF`).
            result = diffrax.RESULTS.where(turns, TURNED_STIFF, result)
        return y1, error, dense, (state, new_switch), result

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)


TURNED_STIFF = diffrax.RESULTS.internal_error
"""The result with which a `phase="explicit"` solve stops at the switch. An explicit Runge–Kutta step
never fails by itself, so this code cannot come from anything else in that solve; it has to be one
that diffrax does not treat as "okay", or the step-size controller's own result would replace it."""


class _Switch(eqx.Module):
    stiff: Bool[Array, ""]
    stiff_steps: Int[Array, ""]
    calm_steps: Int[Array, ""]
    switch_time: Array


def _tsit5_stiffness(dense, tsit5: diffrax.Tsit5) -> Array:
    """``h ρ ≈ ‖k₇ − k₆‖ / ‖y₁ − Y₆‖`` from one Tsit5 step's stage increments ``k = h f``."""
    tableau = tsit5.tableau
    # The weights on the host (in the precision JAX computes in): constants of the traced program.
    real = jax.dtypes.canonicalize_dtype(np.float64)
    a_stage6 = np.asarray(tableau.a_lower[-2], dtype=real)  # weights of k₁..k₅ in Y₆
    b = np.asarray(tableau.a_lower[-1], dtype=real)  # weights of k₁..k₆ in y₁ (FSAL: k₇ at y₁)
    weights = b.copy()
    weights[: a_stage6.shape[0]] += -a_stage6  # y₁ − Y₆ = Σⱼ (bⱼ − a₆ⱼ) kⱼ

    def leaf_sums(k):
        # Σⱼ wⱼ kⱼ written out in a dot product's order (bitwise the `tensordot` it replaces on
        # XLA:CPU): elementwise, it fuses with the squares below, where a dot is a kernel of its
        # own to compile.
        w = weights.astype(k.dtype)
        difference = w[0] * k[0]
        for j in range(1, w.shape[0]):
            difference = difference + w[j] * k[j]  # y₁ − Y₆
        return jnp.sum((k[-1] - k[-2]) ** 2), jnp.sum(difference**2)

    sums = [leaf_sums(k) for k in jax.tree.leaves(dense["k"])]
    numerator = sum(s[0] for s in sums)
    denominator = sum(s[1] for s in sums)
    safe = denominator > 0
    return jnp.where(safe, jnp.sqrt(numerator / jnp.where(safe, denominator, 1.0)), 0.0)
