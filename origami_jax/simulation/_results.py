"""Result codes of a folding simulation (tier 3 of the package's errors: a solver that did not succeed)."""

import diffrax
import jax.numpy as jnp
import numpy as np

from .._kernel import INVALID_INPUT


class RESULTS(diffrax.RESULTS):  # pyright: ignore[reportGeneralTypeIssues]
    """Outcome of [`origami_jax.simulation.simulate`][]: diffrax's codes plus our own.

    Extends `diffrax.RESULTS` (itself an `optimistix.RESULTS`), so a diffrax result promotes into it with
    `RESULTS.promote(solution.result)`.
    """

    nonfinite_state = (
        "The simulated joint angles or rates became NaN or infinite. The inputs or hinge parameters are "
        "probably non-physical (negative stiffness or drag, a zero mass), or the tolerances too loose."
    )
    stiff_while_differentiated = (
        "The run turned stiff, and a differentiated simulate with the default solver takes explicit "
        "steps only (the implicit ones would triple its compile time). Pass SolveOptions("
        "solver=origami_jax.simulation.StiffnessSwitching()) to differentiate through both phases."
    )


def promote(item, enumeration=RESULTS):
    """`enumeration.promote(item)` (default our `RESULTS`) for a result of an enumeration it extends
    (diffrax's, optimistix's), without a device operation when the code is a constant.

    Equinox's `promote` looks the code up under `jax.ensure_compile_time_eval`, which runs the lookup
    as eager device operations even inside a trace: half a dozen one-operation programs, each compiled
    the first time (0.15–0.3 s of a first `simulate`). Here a constant code is looked up in NumPy and a
    traced one with an indexing that stays in the traced program.
    """
    if item._enumeration is enumeration:
        return item
    offsets = enumeration._base_offsets[item._enumeration]  # raises for an unrelated enumeration
    value = item._value
    if isinstance(value, np.ndarray):
        promoted = np.asarray(offsets[value], dtype=np.int32)
    else:
        promoted = jnp.asarray(offsets)[value]
    return type(enumeration.successful)(promoted, enumeration)


def kernel_result_messages() -> dict[int, str]:
    """The `result_messages` of a sweep kernel whose result codes are `RESULTS`'s (a simulation's):
    each code's name, and `INVALID_INPUT` (−1) for a design outside the model's domain."""
    messages = {INVALID_INPUT: "invalid input"}
    messages.update({int(item._value): name for name, item in RESULTS._name_to_item.items()})
    return messages
