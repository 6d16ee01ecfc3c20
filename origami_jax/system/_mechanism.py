"""`AbstractMechanism`: the contract every folding mechanism implements (chain, panel tree, closed loops).

A *mechanism* is the rigid part of a folding device: panels (flaps) with mass and inertia, joined by
hinges, some of it fixed to the substrate. It knows its kinematics and inertia and nothing of what
drives it: hinge springs, release inputs, fluid and contact forces live in the
[`origami_jax.system.FoldingSystem`][] around it and reach the mechanism as one generalized force.

**State layout.** The state is a pair ``(q, v)``: generalized coordinates ``q`` (`n_coordinates`) and
velocities ``v`` (`n_velocities`), both flat 1-D arrays. For the open mechanisms (serial chains, panel
trees) ``q`` is the vector of hinge angles ``θ`` and ``v = θ̇``; a mechanism whose state is something
else (node positions of a bar-and-hinge model, say) maps it to hinge angles with `hinge_angles`, and
hinge torques back to generalized forces with `hinge_force`. Angles are radians, valley positive
(the FOLD convention); ``q = 0`` is the flat, as-fabricated state.

**Units.** Kernels are unit-agnostic: any consistent system (the builders use `MICRO`: µm, µs, ng),
forces and torques in mass·length²/time² per radian of the mechanism's units.

**What the simulator calls, in order** (see `origami_jax.simulation.simulate`):
1. `hinge_angles(q)`, `hinge_rates(q, v)`: the hinge state the springs, inputs and metrics see;
2. `hinge_force(q, tau)`: the generalized force of hinge torques ``τ`` (``J_hᵀ τ``);
3. `forward_dynamics(q, v, force)`: ``v̇ = M(q)⁻¹ (force − bias(q, v))``.
Fluid and contact models read the bodies through `body_poses` and `spatial_velocities`, and hand
their forces back as per-body wrenches through `apply_wrenches`.

**Derivatives.** Every method is a pure function of the module's array fields and its arguments, so
`jax.jit`, `jax.vmap` and `jax.grad` (forward and reverse) apply without change. An implementation may
give `forward_dynamics` a custom JVP for speed; it must then keep reverse mode working, except under
`forward_mode_only=True`, where only `jax.jvp`/`jax.jacfwd` are promised (what `simulate` asks for under
`diffrax.ForwardMode`).
"""

import abc
import dataclasses
from collections.abc import Callable
from functools import partial
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float


@dataclasses.dataclass(frozen=True)
class HingeLayout:
    """Where the hinges of a mechanism are, in the flat state ``q = 0`` (host NumPy arrays).

    **Fields:** `parent`, `child`: body index on either side of each hinge, shape `(h,)` (−1 is the
    fixed base); `axis`: unit crease direction, `(h, 3)`; `ends`: the crease's two end points in the
    world frame, `(h, 2, 3)` (length units).
    """

    parent: np.ndarray
    child: np.ndarray
    axis: np.ndarray
    ends: np.ndarray


class AbstractMechanism(eqx.Module):
    """Rigid panels joined by hinges: kinematics and inertia (module docstring: the contract).

    Implementations: [`origami_jax.chain.Chain`][] (a serial chain of flaps),
    [`origami_jax.net.PanelTree`][] (panels hinged in a tree). Shapes below: ``nq`` =
    `n_coordinates`, ``nv`` = `n_velocities`, ``h`` = `n_hinges`, ``b`` = `n_bodies`.
    """

    coordinates_are_hinge_angles: ClassVar[bool] = True
    """``q = θ`` and ``v = θ̇`` (chains and trees); a mechanism with other coordinates sets it `False`
    and overrides `hinge_angles`, `hinge_rates` and `hinge_force`."""

    # ---- sizes (static Python ints) ----

    @property
    @abc.abstractmethod
    def n_hinges(self) -> int:
        """Number of hinges (creases that fold)."""

    @property
    @abc.abstractmethod
    def n_bodies(self) -> int:
        """Number of moving rigid bodies (panels or flaps; the fixed base is not counted)."""

    @property
    def n_coordinates(self) -> int:
        """Length of ``q``; the hinge count for chains and trees."""
        return self.n_hinges

    @property
    def n_velocities(self) -> int:
        """Length of ``v``; the hinge count for chains and trees."""
        return self.n_hinges

    # ---- state ----

    def rest_state(self) -> tuple[Float[Array, " nq"], Float[Array, " nv"]]:
        """The flat, as-fabricated state at rest: ``(q, v)`` with every hinge angle zero."""
        dtype = jnp.result_type(float)
        return jnp.zeros(self.n_coordinates, dtype), jnp.zeros(self.n_velocities, dtype)

    def hinge_angles(self, q: Float[Array, " nq"]) -> Float[Array, " h"]:
        """Hinge angles ``θ`` (rad, valley positive) at ``q``; ``q`` itself for chains and trees."""
        return q

    def hinge_rates(self, q: Float[Array, " nq"], v: Float[Array, " nv"]) -> Float[Array, " h"]:
        """Hinge angular rates ``θ̇`` (rad/time) at ``(q, v)``; ``v`` itself for chains and trees."""
        del q
        return v

    def hinge_force(self, q: Float[Array, " nq"], tau: Float[Array, " h"]) -> Float[Array, " nv"]:
        """Generalized force of hinge torques ``τ`` (``J_hᵀ τ``, ``J_h = ∂θ̇/∂v``); ``τ`` itself for
        chains and trees."""
        del q
        return tau

    # ---- dynamics ----

    @abc.abstractmethod
    def mass_matrix(self, q: Float[Array, " nq"]) -> Float[Array, "nv nv"]:
        """Generalized mass matrix ``M(q)``, symmetric positive definite, mass·length²."""

    @abc.abstractmethod
    def bias_force(self, q: Float[Array, " nq"], v: Float[Array, " nv"]) -> Float[Array, " nv"]:
        """Velocity and gravity terms ``C(q, v) v + G(q)`` of ``M v̇ + C v + G = force``."""

    def forward_dynamics(
        self,
        q: Float[Array, "*rows nq"],
        v: Float[Array, "*rows nv"],
        force: Float[Array, "*rows nv"],
        *,
        forward_mode_only: bool = False,
    ) -> Float[Array, "*rows nv"]:
        """Accelerations ``v̇ = M(q)⁻¹ (force − C v − G)``.

        **Arguments:** `q`, `v`, `force` (generalized force, everything but inertia: hinge torques,
        drag, contact), shape `(n,)` or `(t, n)` for `t` states of the same mechanism.
        `forward_mode_only`: the caller only takes forward-mode derivatives (an implementation may
        then use a faster rule that reverse mode cannot transpose).

        The default solves with the mass matrix and bias; implementations override it with a fast path.
        """
        del forward_mode_only
        if q.ndim == 2:
            return jax.vmap(self.forward_dynamics)(q, v, force)
        return jnp.linalg.solve(self.mass_matrix(q), force - self.bias_force(q, v))

    def inverse_dynamics(
        self, q: Float[Array, " nq"], v: Float[Array, " nv"], a: Float[Array, " nv"]
    ) -> Float[Array, " nv"]:
        """Generalized force ``M(q) a + C(q, v) v + G(q)`` that produces accelerations ``a``."""
        return self.mass_matrix(q) @ a + self.bias_force(q, v)

    def kinetic_energy(self, q: Float[Array, " nq"], v: Float[Array, " nv"]) -> Float[Array, ""]:
        """``½ vᵀ M(q) v`` (mass·length²/time²)."""
        return 0.5 * v @ self.mass_matrix(q) @ v

    def potential_energy(self, q: Float[Array, " nq"]) -> Float[Array, ""]:
        """Gravitational potential energy (zero without gravity); hinge springs are the system's."""
        del q
        return jnp.zeros((), jnp.result_type(float))

    # ---- geometry (plotting, FOLD export, fluid and contact models) ----

    @abc.abstractmethod
    def body_poses(self, q: Float[Array, " nq"]) -> Float[Array, "b 4 4"]:
        """World pose of each moving body's frame at ``q``, homogeneous transforms ``[[R, p], [0, 1]]``.
        Body-frame geometry (`outlines`, inertias) is given in these frames."""

    def body_velocities(
        self, q: Float[Array, " nq"], v: Float[Array, " nv"]
    ) -> tuple[Float[Array, "b 3"], Float[Array, "b 3"]]:
        """World linear velocity of each body frame's origin and world angular velocity, each `(b, 3)`.

        Default: differentiate `body_poses` along ``q̇ = v`` (valid when ``v = q̇``, chains and trees)."""

        def positions_and_rotations(q):
            poses = self.body_poses(q)
            return poses[:, :3, 3], poses[:, :3, :3]

        (_, rotations), (velocity, rotation_rate) = jax.jvp(positions_and_rotations, (q,), (v,))
        # ω̂ = Ṙ Rᵀ
        w_hat = jnp.einsum("bij,bkj->bik", rotation_rate, rotations)
        omega = jnp.stack([w_hat[:, 2, 1], w_hat[:, 0, 2], w_hat[:, 1, 0]], axis=-1)
        return velocity, omega

    def spatial_velocities(
        self, q: Float[Array, " nq"], v: Float[Array, " nv"]
    ) -> Float[Array, "b 6"]:
        """Each moving body's spatial velocity in the world frame, taken at the world origin:
        ``(v_O, ω)`` with ``v_O`` the velocity of the body point passing through the origin (so a
        point ``x`` of the body moves at ``v_O + ω × x``), shape `(b, 6)`.

        Default: from `body_velocities`. Chains and trees override it with the recursive sum of
        hinge twists."""
        velocity, omega = self.body_velocities(q, v)
        origins = self.body_poses(q)[:, :3, 3]
        return jnp.concatenate([velocity - jnp.cross(omega, origins), omega], axis=-1)

    def apply_wrenches(
        self, q: Float[Array, " nq"], wrenches: Float[Array, "b 6"]
    ) -> Float[Array, " nv"]:
        """Generalized force of world wrenches on the bodies, ``Σ_b J_bᵀ W_b``: `wrenches[b]` is
        ``(F, M)``, a force and its moment about the world origin (``M = Σ x × F`` for forces ``F`` at
        points ``x``), the dual of `spatial_velocities` (power ``Σ_b W_b · V_b = fᵀ v``).

        Default: autodiff of that power in ``v``. Chains and trees override it with the backward
        pass of Newton–Euler."""
        v = jnp.zeros(self.n_velocities, wrenches.dtype)
        return jax.grad(lambda v: jnp.sum(wrenches * self.spatial_velocities(q, v)))(v)

    def body_motion(
        self, q: Float[Array, " nq"], v: Float[Array, " nv"]
    ) -> tuple[Float[Array, "b 4 4"], Float[Array, "b 6"], Callable[[Array], Array]]:
        """What a fluid model reads of the bodies at ``(q, v)``, in one call: `body_poses(q)`,
        `spatial_velocities(q, v)` and ``wrenches ↦ apply_wrenches(q, wrenches)``.

        Default: those three methods. Trees override it to compute their kinematics once for all
        three: XLA does not merge repeated kinematics of separate calls (their sines and cosines are
        computed in conditionals, which it never deduplicates), so each call would be compiled and run
        again."""
        return self.body_poses(q), self.spatial_velocities(q, v), partial(self.apply_wrenches, q)

    @abc.abstractmethod
    def outlines(self) -> list[np.ndarray]:
        """Each moving body's outline as a polygon in its body frame, a list of `b` host arrays of
        shape `(k_i, 3)` (length units), counter-clockwise seen from the body's +z (its normal)."""

    @abc.abstractmethod
    def hinge_layout(self) -> "HingeLayout":
        """Which bodies each hinge joins and where its crease lies in the flat state (host data), for
        contact models (panels that share a crease touch along it by construction) and plotting."""

    def base_outline(self) -> np.ndarray | None:
        """The fixed base (substrate panel) as a world-frame polygon `(k, 3)`, or `None`."""
        return None

    @property
    def carries_added_inertia(self) -> bool:
        """Whether its panels carry a fluid's added inertia (`with_added_inertias`; static)."""
        return False

    def with_added_inertias(self, added: Float[ArrayLike, "b 6 6"] | None) -> "AbstractMechanism":
        """The same mechanism with its panels' added (fluid) inertias replaced, body frames `(b, 6, 6)`
        (`None`: none), for `origami_jax.fluid.fluid_loads`. Panel trees implement it; other
        mechanisms raise `ValueError`."""
        raise ValueError(
            f"added fluid inertia needs a panel tree (PanelTree or StripTree), got "
            f"{type(self).__name__}; build the accordion with hinges='arc' or a fluid other than "
            "'paper'."
        )

    def without_loops(
        self, stiffness: Float[Array, " h"]
    ) -> tuple["AbstractMechanism", Float[Array, " k"]]:
        """A mechanism whose coordinates are its hinge angles, with its hinges' stiffness
        (`stiffness`, one per hinge of this one), whose slowest small oscillation about flat is no
        faster than this one's: itself where its coordinates are already its hinge angles; closed
        loops cut open (`origami_jax.loops.LoopedPanels`). For
        `origami_jax.simulation.quasi_static_ramp`.

        **Raises:** `ValueError` where the mechanism has no such loosening."""
        if not self.coordinates_are_hinge_angles:
            raise ValueError(
                f"{type(self).__name__}: its coordinates are not its hinge angles and it has no "
                "mechanism of hinge angles to bound its slowest oscillation."
            )
        return self, stiffness

    def panel_polygons(self, q: Float[ArrayLike, " nq"]) -> list[np.ndarray]:
        """World-frame outline of every moving body at ``q`` (host arrays), for plotting and export."""
        poses = np.asarray(self.body_poses(jnp.asarray(q)))
        return [
            outline @ pose[:3, :3].T + pose[:3, 3]
            for outline, pose in zip(self.outlines(), poses, strict=True)
        ]
