"""Folding order as a design variable: release schedules (per-crease delays, or an etch front's path)
and a search for the one that maximises the Monte Carlo yield.

Some nets fold only in the right order: a flap that leans over the base at its target stands in the
path of a longer one that must fold flat under it, and the long one jams on its edge unless it is
released well before (`examples/flap_under_flap.fold` in the source repository, with friction at
its contacts: frictionless, the long flap pushes the edge back and slides past it). The release time
of each crease is a design variable: per-hinge delays, or the path of the etch front that frees them
(`front_release_times`: a straight front crossing the die in a direction at a speed). `order_search`
estimates the yield of each candidate schedule on the same fabricated nets (common random numbers)
and names the best.
"""

import dataclasses
import os
from collections.abc import Mapping
from typing import Any

import jax.numpy as jnp
import numpy as np

from ..net import front_release, load_net
from ._estimate import RunOptions, YieldEstimate, as_pattern, yield_estimate
from ._until import SampleUntil


def front_release_times(net, angle, speed):
    """Release times of a straight etch front, traceable in `angle` and `speed` (for `jax.grad`).

    The front moves across the die in the direction ``(cos angle, sin angle)`` (in the pattern's
    plane basis, `NetGeometry.plane`: the FOLD file's x and y for a pattern in the xy plane) at
    `speed`; it starts at the pattern's first point along that direction at ``t = 0`` and releases
    each crease when it reaches the crease's midpoint, as `origami_jax.net.release_times_from_front`.

    **Arguments:** `net`: an `origami_jax.net.Net` (or a catalogue name or `.fold` path); `angle`:
    rad; `speed`: design length units per time unit (µm/µs in the MICRO units).

    **Returns:** release times `(m,)` (time units), one per crease.

    **Raises:** `ValueError` for a speed that is a number and not positive and finite.
    """

    if not hasattr(net, "geometry"):
        net = load_net(net)
    if isinstance(speed, int | float) and not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"the etch front's speed must be positive and finite, got {speed!r}.")
    g = net.geometry
    direction = jnp.stack([jnp.cos(angle), jnp.sin(angle)]) @ jnp.asarray(g.plane)
    return front_release(
        jnp.asarray(g.vertices_coords),
        jnp.asarray(g.crease_midpoints),
        direction,
        float(net.length_scale),
        speed,
    )


def front_candidates(net, speed: float, n_directions: int = 8) -> dict[str, np.ndarray]:
    """Candidate schedules for `order_search`: all creases at once (`"simultaneous"`) and a straight
    etch front at `speed` from each of `n_directions` equally spaced directions (`"front 0°"`,
    `"front 45°"`, ...; `front_release_times`).

    **Raises:** `ValueError` for a speed that is not positive or fewer than 1 direction.
    """
    if isinstance(n_directions, bool) or not isinstance(n_directions, int) or n_directions < 1:
        raise ValueError(f"n_directions must be an integer >= 1, got {n_directions!r}.")

    if not hasattr(net, "geometry"):
        net = load_net(net)
    out = {"simultaneous": np.zeros(net.n_creases)}
    for k in range(n_directions):
        degrees = 360.0 * k / n_directions
        times = front_release_times(net, float(np.radians(degrees)), speed)
        out[f"front {degrees:g}°"] = np.asarray(times, dtype=float)
    return out


@dataclasses.dataclass(frozen=True)
class OrderSearch:
    """The yield of each candidate release schedule, estimated on the same fabricated nets.

    **Fields:** `schedules` (name → release times `(m,)`, µs), `estimates` (name → its
    `YieldEstimate`), `best` (the name with the highest yield; the first of equals).

    The best of several noisy estimates is biased upwards (it won because its draws were kind):
    re-estimate it with another seed before quoting its yield, as the yield guide does.
    """

    schedules: dict[str, np.ndarray]
    estimates: dict[str, YieldEstimate]
    best: str

    def rows(self) -> list[dict[str, Any]]:
        """One JSON-ready row per schedule: name, release times (µs), yield, interval, counts."""
        return [
            {
                "schedule": name,
                "release_us": [float(t) for t in self.schedules[name]],
                "yield": e.fraction,
                "interval": list(e.interval),
                "counts": dict(e.counts),
            }
            for name, e in self.estimates.items()
        ]

    def summary(self) -> str:
        """A line per schedule, the best marked."""
        lines = []
        for name, e in self.estimates.items():
            low, high = e.interval
            mark = "  <- best" if name == self.best else ""
            lines.append(f"{name:>16}: yield {e.fraction:.3f} [{low:.3f}, {high:.3f}]{mark}")
        return "\n".join(lines)


def order_search(
    pattern,
    schedules: Mapping[str, Any],
    scatter=None,
    n_samples: int = 32,
    seed: int = 0,
    *,
    run: RunOptions | None = None,
    **options: Any,
) -> OrderSearch:
    """The Monte Carlo yield of `net` under each release schedule of `schedules`, and the best.

    Every schedule is estimated with `yield_estimate(net, scatter, n_samples, seed,
    release_times=schedule, **options)`: the same draws for all (common random numbers, so the
    differences between schedules are not sampling noise between different nets), the release
    scatter added to each schedule's nominal times. The compiled kernel is shared: release times are
    data, so the search costs one compilation and ``len(schedules) · n_samples`` simulations.

    **Arguments:** `pattern` (a net, or its name), `scatter`, `n_samples`, `seed` and `options`
    (`design`, `solve`, `tolerances`, ...): as `yield_estimate`; `schedules`: name → release
    times (µs, one per crease; e.g. `front_candidates`); `run`: as `yield_estimate`'s, its `out`
    a folder to store each schedule's samples in (one subfolder per schedule, numbered), or
    `None`.

    **Returns:** an `OrderSearch`.

    **Raises:** `ValueError` (before anything compiles) for an empty `schedules`, a schedule of the
    wrong length, negative or non-finite times, and what `yield_estimate` refuses.
    """
    if not isinstance(schedules, Mapping) or not schedules:
        raise ValueError("schedules must be a non-empty mapping name -> release times (µs).")
    if "release_times" in options:
        raise ValueError("give the release times as schedules, not release_times.")
    if isinstance(n_samples, SampleUntil):
        # Each schedule would stop at its own count: no longer the same samples for all.
        raise ValueError(
            "order_search compares schedules on the same samples: give n_samples as a count, not "
            "a SampleUntil."
        )
    pattern = as_pattern(pattern)
    run = RunOptions() if run is None else run
    m = pattern.n_hinges
    checked = {}
    for name, times in schedules.items():
        times = np.asarray(times, dtype=float)
        if times.shape != (m,) or not np.all(np.isfinite(times)) or np.any(times < 0):
            raise ValueError(
                f"schedule {name!r} must be {m} finite release times >= 0 (µs, one per crease), "
                f"got {times.tolist()}."
            )
        checked[str(name)] = times
    estimates = {}
    for k, (name, times) in enumerate(checked.items()):
        folder = None if run.out is None else os.path.join(os.fspath(run.out), f"schedule-{k:02d}")
        estimates[name] = yield_estimate(
            pattern,
            scatter,
            n_samples,
            seed,
            release_times=times,
            run=dataclasses.replace(run, out=folder),
            **options,
        )
    best = max(estimates, key=lambda n: estimates[n].fraction)
    return OrderSearch(schedules=checked, estimates=estimates, best=best)
