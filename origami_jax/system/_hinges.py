"""`Hinges`: what drives each hinge of a folding system: its stiffness, fold target and release.

A stressed bilayer hinge is a torsional spring that the etch releases: from its release time on it
drives its crease towards the fold angle its film stress sets (``θ_final`` with the crease's sign).
In the paper's decomposition (Eqs. 11–12) the spring ``K θ`` about the flat state is a passive force of
the system and the release is an input torque ``K θ_target`` (a step) or a computed torque along the
etch ramp; `origami_jax.simulation`'s inputs read these fields.
"""

from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._validate import as_float_array, check_finite, check_positive, is_traced


class Hinges(eqx.Module):
    """Per-hinge parameters of a folding system (units: the system's, `MICRO` by default).

    **Fields** (each shape `(h,)`, one entry per hinge):
    - `stiffness`: rotational stiffness ``k`` (torque/rad; pN·m/rad in `MICRO`).
    - `target`: the signed fold angle each released hinge drives to, rad (valley positive).
    - `radius`: free bending radius ``ρ`` of each bilayer (length): the etch ramp's rate ``β/ρ`` and the
      hinge length ``l = ρ |target|`` follow from it.
    - `release_time`: when the etch releases each hinge (time units), or `None`: every hinge at
      ``t = 0`` (the paper's step, Eq. 12).

    **Raises:** `ValueError` for mismatched shapes, non-positive stiffness or radius, non-finite values.
    """

    stiffness: Float[Array, " h"]
    target: Float[Array, " h"]
    radius: Float[Array, " h"]
    release_time: Float[Array, " h"] | None

    def __init__(
        self,
        stiffness: Float[ArrayLike, "*#h"] | Sequence[float],
        target: Float[ArrayLike, " h"] | Sequence[float],
        radius: Float[ArrayLike, "*#h"] | Sequence[float],
        release_time: Float[ArrayLike, "*#h"] | Sequence[float] | None = None,
    ):
        target = check_finite(as_float_array(target, "target"), "target")
        if target.ndim != 1 or target.shape[0] < 1:
            raise ValueError(
                f"Hinges.target must have shape (h,) with one fold angle per hinge, got "
                f"{tuple(target.shape)}."
            )
        shape = target.shape
        self.target = target
        self.stiffness = check_positive(
            _broadcast(as_float_array(stiffness, "stiffness"), shape, "stiffness"),
            "stiffness",
            "torque/rad",
        )
        self.radius = check_positive(
            _broadcast(as_float_array(radius, "radius"), shape, "radius"), "radius", "length"
        )
        if release_time is None:
            self.release_time = None
        else:
            times = _broadcast(as_float_array(release_time, "release_time"), shape, "release_time")
            times = check_finite(times, "release_time")
            if not is_traced(times) and bool(jnp.any(times < 0)):
                raise ValueError(
                    "release_time must be >= 0 (time units after the start of the simulation), "
                    f"got {times}."
                )
            self.release_time = times

    @property
    def n_hinges(self) -> int:
        return self.target.shape[0]

    def length(self) -> Float[Array, " h"]:
        """Hinge length ``l = ρ |target|`` (length): the film that bends by the target at ``1/ρ``."""
        return self.radius * jnp.abs(self.target)

    def released(self, t: Float[ArrayLike, ""]) -> Float[Array, " h"]:
        """1.0 for hinges released by time `t`, else 0.0 (every hinge from ``t = 0`` by default)."""
        if self.release_time is None:
            return jnp.ones_like(self.target)
        return jnp.where(jnp.asarray(t) >= self.release_time, 1.0, 0.0).astype(self.target.dtype)


def _broadcast(array: Array, shape: tuple[int, ...], name: str) -> Array:
    if array.ndim > 1 or (array.ndim == 1 and array.shape != shape):
        raise ValueError(
            f"Hinges.{name} must be a scalar or have shape {shape} (one per hinge), got "
            f"{tuple(array.shape)}."
        )
    return jnp.broadcast_to(array, shape)
