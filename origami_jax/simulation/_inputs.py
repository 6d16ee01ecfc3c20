"""Open-loop inputs of a folding simulation (paper Eqs. 12–13): step, etch-rate ramp, user torque.

An input is an `equinox.Module` (a pytree: it can be batched with `vmap` and differentiated) with a
method `torque(t, theta, theta_dot, system)` giving the hinge torques, `target(system)` (the final
angles the response is measured against) and `jump_times(system)` (corners of the input, handed to the
step-size controller so that it steps onto them instead of through them). Inputs read what they need
(stiffness, fold targets, release times, bending radii) from the
[`origami_jax.system.FoldingSystem`][] they drive.

All quantities are in the system's unit system (default `MICRO`: µm, µs, ng, torque pN·m).
"""

import abc
from collections.abc import Callable, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validate import is_traced
from ..system import FoldingSystem

# β of the paper: the KOH front advances along the hinge at 1.5 µm/min (paper, "Ramp Input").
KOH_ETCH_RATE_SI = 1.5e-6 / 60.0
"""Etch rate of the KOH release, m/s (1.5 µm/min, paper section "Ramp Input")."""

FAST_RAMP_DURATION_SI = 0.1
"""Duration of the paper's fast ramp, s (θ_des = 10π t per joint, paper Fig. 10)."""


class AbstractInput(eqx.Module):
    """An open-loop hinge-torque input ``τ(t, θ, θ̇)`` that sees the folding system it drives.

    Subclass it for your own law: the fields of a subclass are pytree leaves, so a new value (a new
    gain, a new target) reuses the compiled simulation; a new Python function each time does not (see
    `UserTorque`).
    """

    @abc.abstractmethod
    def torque(
        self,
        t: Float[ArrayLike, ""],
        theta: Float[Array, " h"],
        theta_dot: Float[Array, " h"],
        system: FoldingSystem,
    ) -> Float[Array, " h"]:
        """Hinge torques at time `t` (torque units of the system), shape `(h,)`."""

    def target(self, system: FoldingSystem) -> Float[Array, " h"] | None:
        """Final angles the response is measured against (rad), or `None` for the last sample.
        Default: the system's hinge targets."""
        return system.hinges.target

    def jump_times(self, system: FoldingSystem) -> Float[Array, " k"] | None:
        """Times where the input has a corner or a jump (time units), or `None`."""
        del system
        return None


class Step(AbstractInput):
    """The etch releases the hinges (paper Eq. 12): ``τ = K θ_des`` from each hinge's release on, at
    once or (with `ramp`) growing over a release time.

    **Fields:**
    - `theta_des`: target angles, rad, shape `(h,)`, or `None` (default) for the system's hinge
      targets (`system.hinges.target`, e.g. the accordion's ``(θ_final, −θ_final, …)``).
    - `ramp`: the time over which each hinge's torque grows linearly from 0 to ``K θ_des`` after
      its release (time units; MICRO: µs), a scalar, or `None` (default): the whole torque at
      once, the paper's step. A real etch frees a stressed hinge as it undercuts it, over minutes;
      any ramp long against the hinges' own periods (`quasi_static_ramp`: milliseconds in the
      bath once the fluid's inertia is modelled, a fraction of one without) releases them
      quasi-statically, which a step does not: with the fluid's inertia its impulse flings the
      panels past their targets.

    Hinges with a release time (`Hinges.release_time`) feel the torque from that time on (every
    hinge from ``t = 0`` without); the releases, and the ramps' ends, are handed to the step-size
    controller as jumps.

    **Raises:** `ValueError` for a `theta_des` not of shape `(h,)` or a `ramp` that is not a
    positive finite scalar.
    """

    theta_des: Float[Array, " h"] | None = None
    ramp: Float[Array, ""] | None = None

    def __init__(
        self,
        theta_des: Float[ArrayLike, " h"] | Sequence[float] | None = None,
        *,
        ramp: Float[ArrayLike, ""] | None = None,
    ):
        self.theta_des = None if theta_des is None else jnp.asarray(theta_des, dtype=float)
        if ramp is not None:
            if not is_traced(ramp):
                value = np.asarray(ramp, dtype=float)
                if value.ndim != 0 or not (np.isfinite(value) and value > 0):
                    raise ValueError(
                        f"Step.ramp must be a positive finite time (time units, e.g. µs), got "
                        f"{ramp!r}; leave it out (None) for the paper's step."
                    )
                # Put, not converted: `jnp.asarray` compiles a program per new shape and dtype.
                ramp = jax.device_put(value.astype(jnp.result_type(float)))
            else:
                ramp = jnp.asarray(ramp, dtype=float)
        self.ramp = ramp

    def __check_init__(self):
        if self.theta_des is not None and self.theta_des.ndim != 1:
            raise ValueError(f"Step.theta_des must have shape (h,), got {self.theta_des.shape}.")

    def target(self, system):
        return system.hinges.target if self.theta_des is None else self.theta_des

    def released(self, t, system) -> Float[Array, " h"]:
        """The fraction of each hinge's torque acting at time `t`, in ``[0, 1]``, shape `(h,)`."""
        hinges = system.hinges
        if self.ramp is None:
            if hinges.release_time is None:
                return jnp.ones_like(hinges.target)
            return hinges.released(t)
        start = 0.0 if hinges.release_time is None else hinges.release_time
        return jnp.broadcast_to(
            jnp.clip((jnp.asarray(t) - start) / self.ramp, 0.0, 1.0), hinges.target.shape
        )

    def torque(self, t, theta, theta_dot, system):
        del theta, theta_dot
        torque = system.hinges.stiffness * self.target(system)
        if self.ramp is None and system.hinges.release_time is None:
            return torque
        return torque * self.released(t, system)

    def jump_times(self, system):
        starts = system.hinges.release_time
        if self.ramp is None:
            return starts
        if starts is None:
            return jnp.reshape(self.ramp, (1,))
        return jnp.concatenate([starts, starts + self.ramp])


class EtchRamp(AbstractInput):
    """The etch front advances along each hinge at rate β (paper Eq. 13).

    The hinge of joint ``i`` bends at constant curvature ``1/ρ_i``, so its desired angle grows at
    ``β/ρ_i`` from its release until ``θ_final_i``, reached ``T_i = ρ_i |θ_final_i| / β = l_i / β``
    later. The open-loop torque is the computed torque along the desired trajectory,
    ``τ = M(θ_des) θ̈_des + C(θ_des, θ̇_des) θ̇_des + K θ_des + B θ̇_des |θ̇_des|`` (the drag term is the
    system's drag model at the desired motion), with ``θ̈_des = 0`` between the corners (the
    impulses at the corners are not applied: the paper's law has none either). The corners are handed
    to the step controller. Needs a mechanism whose coordinates are its hinge angles (chains, trees).

    **Fields:**
    - `etch_rate`: β, length/time (MICRO: µm/µs; 1.5 µm/min = 2.5e-8 µm/µs), scalar.
    - `radius`: ρ per hinge (length), or `None` for the system's (`system.hinges.radius`).
    - `theta_final`: signed final angles (rad), or `None` for the system's hinge targets.
    """

    etch_rate: Float[Array, ""]
    radius: Float[Array, " h"] | None
    theta_final: Float[Array, " h"] | None

    def __init__(
        self,
        etch_rate: Float[ArrayLike, ""],
        radius: Float[ArrayLike, "..."] | None = None,
        theta_final: Float[ArrayLike, " h"] | Sequence[float] | None = None,
    ):
        self.etch_rate = jnp.asarray(etch_rate, dtype=float)
        self.theta_final = None if theta_final is None else jnp.asarray(theta_final, dtype=float)
        if radius is None:
            self.radius = None
        else:
            radius = jnp.asarray(radius, dtype=float)
            self.radius = (
                radius
                if self.theta_final is None
                else jnp.broadcast_to(radius, self.theta_final.shape)
            )

    def __check_init__(self):
        if self.theta_final is not None and self.theta_final.ndim != 1:
            raise ValueError(
                f"EtchRamp.theta_final must have shape (h,), got {self.theta_final.shape}."
            )
        if self.etch_rate.ndim != 0:
            raise ValueError(f"EtchRamp.etch_rate must be a scalar, got {self.etch_rate.shape}.")

    def _final(self, system) -> Float[Array, " h"]:
        return system.hinges.target if self.theta_final is None else self.theta_final

    def rate(self, system) -> Float[Array, " h"]:
        """``β/ρ``, rad per time unit, shape `(h,)`."""
        radius = system.hinges.radius if self.radius is None else self.radius
        return jnp.broadcast_to(self.etch_rate / radius, self._final(system).shape)

    def durations(self, system) -> Float[Array, " h"]:
        """``T_i = ρ_i |θ_final_i| / β``, time units, shape `(h,)`: each hinge's ramp, from its release."""
        return jnp.abs(self._final(system)) / self.rate(system)

    def duration(self, system) -> Float[Array, ""]:
        """When the last hinge reaches its final angle (time units), release times included."""
        end = self.durations(system)
        if system.hinges.release_time is not None:
            end = end + system.hinges.release_time
        return jnp.max(end)

    def desired(
        self, t: Float[ArrayLike, ""], system
    ) -> tuple[Float[Array, " h"], Float[Array, " h"]]:
        """Desired angles (rad) and rates (rad/time) at time `t`, each shape `(h,)`."""
        t = jnp.asarray(t, dtype=float)
        if system.hinges.release_time is not None:
            t = t - system.hinges.release_time
            started = t >= 0
        else:
            started = True
        t = jnp.maximum(t, 0.0)
        final = self._final(system)
        sign = jnp.sign(final)
        rate = self.rate(system)
        theta_des = sign * jnp.minimum(rate * t, jnp.abs(final))
        theta_dot_des = jnp.where(started & (t < self.durations(system)), sign * rate, 0.0)
        return theta_des, theta_dot_des

    def torque(self, t, theta, theta_dot, system):
        del theta, theta_dot
        theta_des, theta_dot_des = self.desired(t, system)
        mechanism = system.mechanism
        return (
            mechanism.bias_force(theta_des, theta_dot_des)
            + system.hinges.stiffness * theta_des
            - system.drag.force(mechanism, theta_des, theta_dot_des)
        )

    def target(self, system):
        return self._final(system)

    def jump_times(self, system):
        corners = self.durations(system)
        if system.hinges.release_time is not None:
            return jnp.concatenate(
                [system.hinges.release_time, corners + system.hinges.release_time]
            )
        return corners


def fast_ramp(theta_final: Float[ArrayLike, " h"], *, duration: float) -> EtchRamp:
    """The paper's fast ramp (Fig. 10): ``θ_des = sign(θ_final) (π/duration) t`` until ``θ_final``.

    The paper uses `duration = 0.1 s` (``θ_des = 10π t``); pass it in the system's time units
    (`MICRO.time(0.1)` = 1e5 µs). β and ρ enter only through their ratio: this sets ``ρ = 1`` length
    unit and ``β = max|θ_final| / duration``.
    """
    theta_final = jnp.asarray(theta_final, dtype=float)
    if not duration > 0:
        raise ValueError(f"fast_ramp: duration must be positive, got {duration}.")
    return EtchRamp(jnp.max(jnp.abs(theta_final)) / duration, 1.0, theta_final)


class UserTorque(AbstractInput):
    """Any user torque law ``τ = fn(t, θ, θ̇)``, torque units of the system, shape `(h,)`.

    **Fields:**
    - `fn`: the law; a JAX-traceable function of `(t, theta, theta_dot)`. A new function object
      compiles a new simulation (tens of seconds); to change only numbers, pass an `equinox.Module`
      as `fn` with the numbers as JAX array fields (`jnp.asarray(2.0)`: a plain Python number is
      part of the structure and compiles anew for each value), or subclass `AbstractInput` the same
      way. Then the simulation compiles once per structure and a new gain reruns in milliseconds.
    - `theta_target`: angles the response is measured against (rad, `(h,)`), or `None` for the last
      sample.
    - `jumps`: times of corners or jumps in `fn`, or `None`.
    """

    fn: Callable
    theta_target: Float[Array, " h"] | None = None
    jumps: Float[Array, " k"] | None = None

    def torque(self, t, theta, theta_dot, system):
        del system
        return jnp.asarray(self.fn(t, theta, theta_dot))

    def target(self, system):
        del system
        return self.theta_target

    def jump_times(self, system):
        del system
        return self.jumps


def quasi_static_ramp(
    system: FoldingSystem,
    *,
    periods: float = 3.0,
    about: tuple[Float[ArrayLike, " n"], Float[ArrayLike, "n d"]] | None = None,
) -> Float[Array, ""]:
    """A release ramp long enough to release `system`'s hinges quasi-statically (`Step(ramp=...)`,
    a pattern's `release_ramp`): `periods` (default 3) times the longest period of its hinges'
    small oscillations about the flat state (or `about`), time units.

    The period is that of the slowest mode of ``M q̈ + K q = 0`` at ``q = 0``: ``M`` the mass
    matrix (the fluid's added inertia included where the system has it, as it should: it is what
    makes the bath slow), ``K`` the hinge springs' stiffness, drag left out. For a cube net of
    200 µm squares in KOH it is 13 ms with the fluid's inertia (0.55 ms without), so 3 periods
    are 40 ms, past the 30 ms that already releases it quasi-statically (the same verdicts as
    60 ms on 198 of 200 scattered samples; docs: "Released as an etch releases").

    Panels that close loops (a crease pattern) move only along their loops' branches, and the
    flat state, where the branches meet, allows more motions than any branch does. `about`
    `= (q, basis)` linearises about a state `q` on a branch, `(n,)`, in the motions it allows
    there, the columns of `basis`, `(n, d)` (the closure's null space: ``Nᵀ M N`` and
    ``Nᵀ K N``; `origami_jax.loops.CreasePattern.oscillation_state` gives both). Without it,
    such panels get the slowest mode of their spanning tree with its own hinges
    (`AbstractMechanism.without_loops`): the loops' constraints and the cut creases' springs
    can only make the pattern's slowest mode faster, so that ramp errs long (1.3–4 times the
    branch's on the catalogue's crease patterns).

    **Raises:** `ValueError` for a mechanism with no mechanism of hinge angles to bound it, or a
    `periods` that is not positive.
    """
    if not (isinstance(periods, int | float) and periods > 0):
        raise ValueError(f"periods must be a positive number, got {periods!r}.")
    if about is None:
        mechanism, hinge_stiffness = system.mechanism.without_loops(system.hinges.stiffness)
        state = jnp.zeros(mechanism.n_hinges, dtype=float)
        basis = None
    else:
        mechanism, hinge_stiffness = system.mechanism, system.hinges.stiffness
        state, basis = (jnp.asarray(x, dtype=float) for x in about)

    def spring_force(q):
        return mechanism.hinge_force(q, -hinge_stiffness * mechanism.hinge_angles(q))

    stiffness = -jax.jacfwd(spring_force)(state)
    mass = mechanism.mass_matrix(state)
    if basis is not None:
        stiffness, mass = (basis.T @ x @ basis for x in (stiffness, mass))
    lower = jnp.linalg.cholesky(mass)
    # M⁻½ K M⁻ᵀᐟ² through the Cholesky factor: its eigenvalues are the modes' ω².
    scaled = jax.scipy.linalg.solve_triangular(
        lower, jax.scipy.linalg.solve_triangular(lower, stiffness, lower=True).T, lower=True
    )
    slowest = jnp.min(jnp.linalg.eigvalsh(0.5 * (scaled + scaled.T)))
    return periods * 2 * jnp.pi / jnp.sqrt(slowest)
