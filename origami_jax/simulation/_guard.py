"""`ContactGuard`: a step-size controller that refuses steps in which a panel passes through another.

Contact forces act over a thin layer (the activation gap on either side of a panel), and a step that
carries a point across that whole layer sees no force at either end: the panel would tunnel through.
The guard checks every accepted candidate step the way continuous collision detection does in
Incremental Potential Contact (Li et al., 2020), with the step's end points in place of a line search:
if a sample point crosses a face's mid-plane between the step's ends where it lies over the face
(`PanelContact.crossed`), the step is rejected and retried at half the size. Accepted steps are
those of the wrapped controller, so accuracy control is unchanged; only tunnelling steps are refused.
"""

import equinox as eqx
import jax.numpy as jnp
from diffrax import AbstractAdaptiveStepSizeController


class AbstractWrappedController(AbstractAdaptiveStepSizeController):
    """An adaptive controller that wraps another and takes its tolerances, norm and direction from
    it; its final subclasses say what happens at a step (`init`, `adapt_step_size`: abstract in
    diffrax's base) and what the state holds."""

    controller: AbstractAdaptiveStepSizeController

    @property
    def rtol(self):
        return self.controller.rtol

    @property
    def atol(self):
        return self.controller.atol

    @property
    def norm(self):  # pyright: ignore[reportIncompatibleMethodOverride]
        return self.controller.norm

    def wrap(self, direction):
        return eqx.tree_at(lambda c: c.controller, self, self.controller.wrap(direction))


class ContactGuard(AbstractWrappedController):
    """Wraps an adaptive controller; rejects steps across which a panel crosses another (module
    docstring). `simulate` adds it when the system has a contact model.

    **Fields:** `controller`, the wrapped controller; `shrink`, the factor of a rejected step's retry.
    """

    shrink: float = eqx.field(static=True, default=0.5)

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        return self.controller.init(terms, t0, t1, y0, dt0, args, func, error_order)

    def adapt_step_size(
        self, t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state
    ):
        keep, next_t0, next_t1, made_jump, state, result = self.controller.adapt_step_size(
            t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state
        )
        system = args[0]
        crossed = system.contact.crossed(system.mechanism, y0[0], y1_candidate[0])
        retry = keep & crossed
        next_t0 = jnp.where(retry, t0, next_t0)
        next_t1 = jnp.where(retry, t0 + self.shrink * (t1 - t0), next_t1)
        return keep & ~crossed, next_t0, next_t1, made_jump & ~retry, state, result
