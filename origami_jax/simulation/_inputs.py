"""Open-loop inputs of a folding simulation (paper Eqs. 12–13): step, etch-rate ramp, user torque.

An input is an `equinox.Module` (a pytree: it can be batched with `vmap` and differentiated) with a
method `torque(t, theta, theta_dot, *, chain, stiffness, drag)` giving the joint torques, a `target`
(the final angles the response is measured against) and `jump_times` (corners of the input, handed to
the step-size controller so that it steps onto them instead of through them).

All quantities are in the chain's unit system (default `MICRO`: µm, µs, ng, torque pN·m).
"""

import abc
from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..chain import bias_torque, hinge_torque

# β of the paper: the KOH front advances along the hinge at 1.5 µm/min (paper, "Ramp Input").
KOH_ETCH_RATE_SI = 1.5e-6 / 60.0
"""Etch rate of the KOH release, m/s (1.5 µm/min, paper section "Ramp Input")."""

FAST_RAMP_DURATION_SI = 0.1
"""Duration of the paper's fast ramp, s (θ_des = 10π t per joint, paper Fig. 10)."""


def alternating_targets(n_joints: int, angle: float = float(np.pi)) -> Float[Array, " n"]:
    """The accordion's fold targets `(angle, −angle, angle, …)`, rad, shape `(n_joints,)`."""
    if n_joints < 1:
        raise ValueError(f"n_joints must be at least 1, got {n_joints}.")
    signs = np.where(np.arange(n_joints) % 2 == 0, 1.0, -1.0)
    return jnp.asarray(angle * signs)


class AbstractInput(eqx.Module):
    """An open-loop joint-torque input `τ(t, θ, θ̇)`."""

    @abc.abstractmethod
    def torque(
        self,
        t: Float[ArrayLike, ""],
        theta: Float[Array, " n"],
        theta_dot: Float[Array, " n"],
        *,
        chain,
        stiffness: Float[Array, " n"],
        drag: Float[Array, " n"],
    ) -> Float[Array, " n"]:
        """Joint torques at time `t` (torque units of the chain), shape `(n,)`."""

    @property
    @abc.abstractmethod
    def target(self) -> Float[Array, " n"] | None:
        """Final angles the response settles to (rad), or `None` when unknown (metrics then use the
        last sample)."""

    @property
    @abc.abstractmethod
    def jump_times(self) -> Float[Array, " k"] | None:
        """Times where the input has a corner or a jump (time units), or `None`."""


class Step(AbstractInput):
    """The etch releases every hinge at once (paper Eq. 12): `τ = K θ_des` for `t ≥ 0`.

    **Fields:**
    - `theta_des`: target angles, rad, shape `(n,)`; the accordion's are `(π, −π, π)`
      ([`origami_jax.simulation.alternating_targets`][]).
    """

    theta_des: Float[Array, " n"]

    def __init__(self, theta_des: Float[ArrayLike, " n"]):
        self.theta_des = jnp.asarray(theta_des, dtype=float)

    def __check_init__(self):
        if self.theta_des.ndim != 1:
            raise ValueError(f"Step.theta_des must have shape (n,), got {self.theta_des.shape}.")

    def torque(self, t, theta, theta_dot, *, chain, stiffness, drag):
        del t, theta, theta_dot, chain, drag
        return stiffness * self.theta_des

    @property
    def target(self):
        return self.theta_des

    @property
    def jump_times(self):
        return None


class EtchRamp(AbstractInput):
    """The etch front advances along each hinge at rate β (paper Eq. 13).

    The hinge of joint `i` bends at constant curvature `1/ρ_i`, so its desired angle grows at
    `β/ρ_i` until `θ_final_i`, reached at `T_i = ρ_i |θ_final_i| / β = l_i / β`. The open-loop torque is the
    computed torque along the desired trajectory,
    `τ = M(θ_des) θ̈_des + C(θ_des, θ̇_des) θ̇_des + K θ_des + B θ̇_des |θ̇_des|`,
    with `θ̈_des = 0` between the corners (the impulses at `t = 0` and `t = T_i` are not applied: the
    paper's law has none either). The corners `T_i` are handed to the step controller.

    **Fields:**
    - `etch_rate`: β, length/time (MICRO: µm/µs; 1.5 µm/min = 2.5e-8 µm/µs), scalar.
    - `radius`: ρ, bending radius of each hinge, length, shape `(n,)`.
    - `theta_final`: signed final angles, rad, shape `(n,)`.
    """

    etch_rate: Float[Array, ""]
    radius: Float[Array, " n"]
    theta_final: Float[Array, " n"]

    def __init__(
        self,
        etch_rate: Float[ArrayLike, ""],
        radius: Float[ArrayLike, "..."],
        theta_final: Float[ArrayLike, " n"],
    ):
        self.theta_final = jnp.asarray(theta_final, dtype=float)
        self.etch_rate = jnp.asarray(etch_rate, dtype=float)
        self.radius = jnp.broadcast_to(jnp.asarray(radius, dtype=float), self.theta_final.shape)

    def __check_init__(self):
        if self.theta_final.ndim != 1:
            raise ValueError(
                f"EtchRamp.theta_final must have shape (n,), got {self.theta_final.shape}."
            )
        if self.etch_rate.ndim != 0:
            raise ValueError(f"EtchRamp.etch_rate must be a scalar, got {self.etch_rate.shape}.")

    @property
    def rate(self) -> Float[Array, " n"]:
        """`β/ρ`, rad per time unit, shape `(n,)`."""
        return self.etch_rate / self.radius

    @property
    def durations(self) -> Float[Array, " n"]:
        """`T_i = ρ_i |θ_final_i| / β`, time units, shape `(n,)`."""
        return jnp.abs(self.theta_final) / self.rate

    @property
    def duration(self) -> Float[Array, ""]:
        """The longest `T_i`, time units."""
        return jnp.max(self.durations)

    def desired(self, t: Float[ArrayLike, ""]) -> tuple[Float[Array, " n"], Float[Array, " n"]]:
        """Desired angles (rad) and rates (rad/time) at time `t`, each shape `(n,)`."""
        t = jnp.maximum(jnp.asarray(t, dtype=float), 0.0)
        sign = jnp.sign(self.theta_final)
        theta_des = sign * jnp.minimum(self.rate * t, jnp.abs(self.theta_final))
        theta_dot_des = jnp.where(t < self.durations, sign * self.rate, 0.0)
        return theta_des, theta_dot_des

    def torque(self, t, theta, theta_dot, *, chain, stiffness, drag):
        del theta, theta_dot
        theta_des, theta_dot_des = self.desired(t)
        return bias_torque(chain, theta_des, theta_dot_des) + hinge_torque(
            stiffness, drag, theta_des, theta_dot_des
        )

    @property
    def target(self):
        return self.theta_final

    @property
    def jump_times(self):
        return self.durations


def fast_ramp(theta_final: Float[ArrayLike, " n"], *, duration: float) -> EtchRamp:
    """The paper's fast ramp (Fig. 10): `θ_des = sign(θ_final) (π/duration) t` until `θ_final`.

    The paper uses `duration = 0.1 s` (`θ_des = 10π t`); pass it in the chain's time units
    (`MICRO.time(0.1)` = 1e5 µs). β and ρ enter only through their ratio: this sets `ρ = 1` length unit and
    `β = max|θ_final| / duration`.
    """
    theta_final = jnp.asarray(theta_final, dtype=float)
    if duration <= 0:
        raise ValueError(f"fast_ramp: duration must be positive, got {duration}.")
    return EtchRamp(jnp.max(jnp.abs(theta_final)) / duration, 1.0, theta_final)


class UserTorque(AbstractInput):
    """Any user torque law `τ = fn(t, θ, θ̇)`, torque units of the chain, shape `(n,)`.

    **Fields:**
    - `fn`: the law; it must be a JAX-traceable function of `(t, theta, theta_dot)`.
    - `theta_target`: angles the response is measured against (rad, `(n,)`), or `None` for the last sample.
    - `jumps`: times of corners or jumps in `fn`, or `None`.
    """

    fn: Callable
    theta_target: Float[Array, " n"] | None = None
    jumps: Float[Array, " k"] | None = None

    def torque(self, t, theta, theta_dot, *, chain, stiffness, drag):
        del chain, stiffness, drag
        return jnp.asarray(self.fn(t, theta, theta_dot))

    @property
    def target(self):
        return self.theta_target

    @property
    def jump_times(self):
        return self.jumps
