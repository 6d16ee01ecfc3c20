"""Result codes of a folding simulation (tier 3 of the package's errors: a solver that did not succeed)."""

import diffrax


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
        "steps only (the implicit ones would triple its compile time). Pass "
        "solver=origami_jax.simulation.StiffnessSwitching() to differentiate through both phases."
    )
