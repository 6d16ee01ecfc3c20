"""Size limits the command line and the sweep models enforce before compiling anything, how far
a folding is continued while its panels still move, and the contact's default sampling.

Tracing and compiling a chain grow with its flap count (its dynamics are unrolled over the hinges):
past these limits a run spends minutes and gigabytes compiling before it computes anything
(300 flaps: 6 min and 9.8 GB). The Python API accepts larger sizes.
"""

MAX_FLAPS = 32
"""Most flaps of a command-line or sweep accordion. Measured on a 2-core CPU (build, compile and a
short run of the default solver): 8 and 16 flaps ~40 s, 24 flaps 56 s, 32 flaps 75 s."""

MAX_SAMPLES = 1_000_000
"""Most samples of one command-line or sweep simulation (rows of its trajectory)."""

FOLD_SEGMENT = 1000.0
"""One segment of a folding continued until it settles (`origami_jax.simulation.fold_until_settled`,
`Net.fold`, the `fold` command), time units: µs in the default units. A cube net in the etch bath
settles at ~1,400 µs (two segments); one in air rings for several milliseconds."""

AFTER_RELEASE_US = 1500.0
"""How long the fold kernel (so a sweep or a yield estimate) runs after a step release unless
told, µs: a cube net in the etch bath closes within it."""

AFTER_RAMP_FRACTION = 0.2
"""After a release ramp, runs go on for at least this fraction of it: a quasi-static release's
last increments are followed by the net's slowest modes (a third of the automatic ramp each), and
a cube net of 200 µm panels released over 40 ms is still moving 1.5 ms after it on 35 of 40
scattered samples, while over 30 ms every one of 440 was at rest 6 ms after it."""


def default_t_end(ramp: float | None, after: float = AFTER_RELEASE_US) -> float:
    """How long a fold runs unless told (µs): `after` (default `AFTER_RELEASE_US`, 1500 µs) past
    a step release (`ramp` `None`), past a ramp the longer of `after` and `AFTER_RAMP_FRACTION`
    of it (48 ms for a 40 ms ramp)."""
    if ramp is None:
        return after
    return ramp + max(after, AFTER_RAMP_FRACTION * ramp)


FOLD_MAX_STEPS = 500_000
"""The step budget of the `fold` command's adaptive solve (each segment of it)."""

KERNEL_MAX_STEPS = 200_000
"""The step budget of each sample of the fold kernel (`origami_jax.net.FOLD_KERNEL_SOLVE`): a
yield estimate's, a net sweep's."""

EXPLICIT_STABILITY = 4.0
"""An explicit solver's steps are at most this many ``1/ω_max`` long (``ω_max`` the stiffest
hinge's rest frequency, `FoldingSystem.rest_frequencies`, or its lower bound
`stiffest_rest_frequency_bound`), however smooth the motion: Tsit5 is
stable out to about 3.5 on the negative real axis and less on the imaginary one, so the steps this
bound gives are a floor. `fold` refuses a run whose floor passes its step budget (the net ran 16
minutes with `--t1 1e12` before any result) and says when it passes `SLOW_EXPLICIT_STEPS`."""

SLOW_EXPLICIT_STEPS = 50_000
"""The explicit steps past which `fold` says a run will be long and which solvers step further."""

MAX_FIXED_STEPS = 500_000
"""Most fixed steps of one command-line run of the implicit-step engine (`--t1` or the run's end
over `--dt`), the adaptive fold's own step budget: past it a run would take hours (a cube net
takes a few milliseconds a step), and `--t1 1e12 --dt 2.5` ran without end."""

MAX_FOLD_SEGMENTS = 8
"""Most segments of such a folding (8,000 µs in the default units)."""

CONTACT_SAMPLING = (4, 2)
"""Contact sample points per panel edge, ``(inner ring, rim)`` along the longest edge (`origami_jax.
contact.build_tables`): the default of every `contact_sampling` (`Net.system`, the sweep's net
kernel, `yield_estimate`, the `--contact-sampling` flag). Its points weigh 1 each."""

MAX_CONTACT_SAMPLING = 32
"""Most contact points per panel edge, on the inner ring or on the rim, of a command-line or sweep
run (`--contact-sampling`, a sweep's `contact_sampling`): 8 times the default's density. The
contact's work grows with the square of the points (each point against every face), and 100,000
per edge compiled and ran without end."""
