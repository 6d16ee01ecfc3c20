"""`PanelContact`: smooth, frictionless, energy-consistent contact between thin panels.

**Model.** Every panel is a plate of thickness ``t`` around its mid-plane, its face the convex hull of its
outline. Points sampled on each panel's rim (`ContactTables`) are checked against the faces of the other
panels and of the fixed base. For a point ``p`` and a face ``F`` (frame ``(R, o)``, ``p_F = Rᵀ (p − o)``):

- *gap* ``g = |p_F,z| − (t_p + t_F)/2``: the clearance between the two plates' surfaces along the face's
  normal (``|·|`` smoothed at 0 so its gradient stays finite deep inside);
- *coverage* ``w = Π_e s(e(p_F)/δ)``: 1 when the point's projection lies inside the face by more than
  ``δ``, 0 outside it, with ``s`` the C² smoothstep ``x³(10 − 15x + 6x²)`` on each edge's inward
  distance ``e``; a rim point meets a face only over that face.

The contact energy is ``E = κ Σ w B(g/ĝ)`` with the barrier of Incremental Potential Contact (Li et al.,
SIGGRAPH 2020), ``B(x) = −(x − 1)² ln x`` for ``x < 1`` and 0 beyond: it switches on at the activation
gap ``ĝ``, is C² there, and grows without bound as the gap closes. Below ``x = 0.1`` it continues as its
own second-order Taylor polynomial, so that an integrator step that lands past contact sees a finite,
steep, restoring force instead of a NaN (penetration is then possible, and reported). The force is
``−∂E/∂q`` (autodiff through the mechanism's kinematics) plus a dissipative part
``−c Σ w a(g) ġ ∂g/∂q`` (``a`` a C² ramp from 0 at ``ĝ`` to 1 at contact), so contact never adds energy:
``v · f = −dE/dt − c Σ w a ġ² ≤ −dE/dt``.

Shared creases: two panels joined by a hinge touch along it by construction; their rim points near the
crease are not paired (the hinge keeps them apart, the barrier would fight it). Edges that meet edge
on edge (a seam closing exactly) feel no force: the model resolves plate-through-plate penetration of
faces, which is what stops folded flaps on each other and panels passing through panels.

Defaults (`PanelContact.for_system`): ``ĝ`` = the panel thickness, ``δ`` = ``ĝ``, ``κ`` = the energy the
hinges can release (``Σ ½ k θ_target²``), so a single rim point stops the whole fold's energy at about a
fifth of ``ĝ`` (``B(0.2) ≈ 1``); ``c`` from a damping ratio of the contact's stiffness at ``g = ĝ/2``
and the lightest panel's mass.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..system import AbstractContact, AbstractMechanism
from ._tables import ContactTables, build_tables

_X_MIN = 0.1  # below this fraction of the activation gap the barrier continues as a quadratic
_LOG_X_MIN = float(np.log(_X_MIN))
_B_MIN = -((_X_MIN - 1) ** 2) * _LOG_X_MIN
_DB_MIN = -2 * (_X_MIN - 1) * _LOG_X_MIN - (_X_MIN - 1) ** 2 / _X_MIN
_D2B_MIN = -2 * _LOG_X_MIN - 4 * (_X_MIN - 1) / _X_MIN + (_X_MIN - 1) ** 2 / _X_MIN**2


def barrier(x: Array) -> Array:
    """IPC barrier ``B(x) = −(x − 1)² ln x`` for ``x_min ≤ x < 1``, 0 for ``x ≥ 1``, its second-order
    Taylor polynomial below ``x_min = 0.1`` (finite for any ``x``, C² everywhere)."""
    inside = (x > _X_MIN) & (x < 1)
    safe = jnp.where(inside, x, 0.5)
    log_barrier = -((safe - 1) ** 2) * jnp.log(safe)
    dx = x - _X_MIN
    taylor = _B_MIN + _DB_MIN * dx + 0.5 * _D2B_MIN * dx**2
    return jnp.where(x >= 1, 0.0, jnp.where(inside, log_barrier, taylor))


def smoothstep(x: Array) -> Array:
    """C² step from 0 (``x ≤ 0``) to 1 (``x ≥ 1``): ``x³(10 − 15x + 6x²)``."""
    x = jnp.clip(x, 0.0, 1.0)
    return x**3 * (10 - 15 * x + 6 * x**2)


class PanelContact(AbstractContact):
    """Contact between the panels of a mechanism and its fixed base (module docstring: the model).

    **Fields:**
    - `tables` (static): the [`origami_jax.contact.ContactTables`][] geometry.
    - `stiffness`: ``κ``, energy units (µN·µm = pJ in `MICRO`).
    - `activation`: ``ĝ``, the gap at which contact switches on, length.
    - `damping`: ``c``, force·time/length, per (point, face) pair in contact.
    - `edge_width`: ``δ``, the width of the coverage ramp at a face's edge, length.

    Build it with [`origami_jax.contact.PanelContact.for_system`][] (defaults from the hinges and
    panels) or `PanelContact.from_mechanism`.
    """

    tables: ContactTables = eqx.field(static=True)
    stiffness: Float[Array, ""]
    activation: Float[Array, ""]
    damping: Float[Array, ""]
    edge_width: Float[Array, ""]

    @classmethod
    def from_mechanism(
        cls,
        mechanism: AbstractMechanism,
        *,
        thickness: float | np.ndarray,
        stiffness: float,
        damping: float,
        activation: float | None = None,
        edge_width: float | None = None,
        base_outline: np.ndarray | None = None,
        base_thickness: float | None = None,
        points_per_edge: int = 8,
    ) -> "PanelContact":
        """Contact of `mechanism`'s panels (their `outlines()`) with each other and with its base.

        **Arguments** (the mechanism's units): `thickness` per panel (scalar or `(b,)`), `stiffness`
        ``κ``, `damping` ``c``, `activation` ``ĝ`` (default: the largest thickness), `edge_width`
        ``δ`` (default ``ĝ``), `base_outline` (world polygon; default the mechanism's
        `base_outline()`), `base_thickness` (default the largest panel thickness), `points_per_edge`.

        **Raises:** `ValueError` for non-positive values or degenerate outlines.
        """
        n = mechanism.n_bodies
        thickness = np.broadcast_to(np.asarray(thickness, dtype=float), (n,))
        if not np.all(np.isfinite(thickness)) or np.any(thickness <= 0):
            raise ValueError(f"contact thickness must be positive, got {thickness}.")
        for name, value in (("stiffness", stiffness), ("damping", damping)):
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"contact {name} must be finite and >= 0, got {value}.")
        activation = float(np.max(thickness)) if activation is None else float(activation)
        edge_width = activation if edge_width is None else float(edge_width)
        if not (activation > 0 and edge_width > 0):
            raise ValueError("contact activation and edge_width must be positive lengths.")
        base = mechanism.base_outline() if base_outline is None else base_outline
        rest = np.asarray(mechanism.body_poses(mechanism.rest_state()[0]))
        layout = mechanism.hinge_layout()
        tables = build_tables(
            mechanism.outlines(),
            rest,
            base,
            thickness,
            float(np.max(thickness)) if base_thickness is None else float(base_thickness),
            layout.parent,
            layout.child,
            layout.ends,
            points_per_edge=points_per_edge,
        )
        dtype = jnp.result_type(float)
        return cls(
            tables=tables,
            stiffness=jnp.asarray(stiffness, dtype),
            activation=jnp.asarray(activation, dtype),
            damping=jnp.asarray(damping, dtype),
            edge_width=jnp.asarray(edge_width, dtype),
        )

    @classmethod
    def for_system(
        cls,
        mechanism: AbstractMechanism,
        hinge_stiffness: Float[Array, " h"],
        hinge_target: Float[Array, " h"],
        *,
        thickness: float | np.ndarray,
        damping_ratio: float = 0.5,
        **kwargs,
    ) -> "PanelContact":
        """Contact with defaults from the hinges and panels (module docstring, "Defaults").

        ``κ = Σ ½ k θ_target²``; ``c = 2 ζ sqrt(k_c m)`` with ``k_c = κ B''(½)/ĝ²`` the contact's
        stiffness half-way into the activation gap, ``m`` the lightest panel's mass (the smallest
        diagonal entry of ``M(0)``, divided by its squared lever arm, the panel size) and ``ζ`` =
        `damping_ratio`. Other keyword arguments go to `from_mechanism`.
        """
        k = np.asarray(hinge_stiffness, dtype=float)
        target = np.asarray(hinge_target, dtype=float)
        energy = float(np.sum(0.5 * k * target**2))
        probe = cls.from_mechanism(
            mechanism, thickness=thickness, stiffness=energy, damping=0.0, **kwargs
        )
        gap = float(probe.activation)
        curvature = float(jax.grad(jax.grad(barrier))(0.5))
        contact_stiffness = energy * curvature / gap**2
        inertia = np.diag(np.asarray(mechanism.mass_matrix(mechanism.rest_state()[0])))
        mass = float(np.min(inertia)) / probe.tables.scale**2
        damping = 2 * damping_ratio * np.sqrt(contact_stiffness * mass)
        return eqx.tree_at(lambda c: c.damping, probe, jnp.asarray(damping, probe.damping.dtype))

    # ---- kernels ----

    def gaps(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"]
    ) -> tuple[Float[Array, " k"], Float[Array, " k"]]:
        """Gap ``g`` (length) and coverage ``w`` (0–1) of every (point, face) pair at ``q``."""
        t = self.tables
        poses = mechanism.body_poses(q)
        base = jnp.asarray(t.base_pose, poses.dtype)[None]
        poses = jnp.concatenate([poses, base], axis=0)
        rotations, origins = poses[:, :3, :3], poses[:, :3, 3]
        owner = t.point_body[t.pair_point]
        face = t.face_body[t.pair_face]
        local = jnp.asarray(t.points[t.pair_point], poses.dtype)
        world = jnp.einsum("kij,kj->ki", rotations[owner], local) + origins[owner]
        in_face = jnp.einsum("kji,kj->ki", rotations[face], world - origins[face])
        edges = jnp.asarray(t.face_edges[t.pair_face], poses.dtype)
        inward = edges[..., 0] * in_face[:, None, 0] + edges[..., 1] * in_face[:, None, 1]
        inward = inward + edges[..., 2]
        coverage = jnp.prod(smoothstep(inward / self.edge_width), axis=-1)
        normal = in_face[:, 2]
        tiny = 1e-6 * self.activation
        half = jnp.asarray(t.half_thickness, poses.dtype)
        gap = jnp.sqrt(normal**2 + tiny**2) - tiny - (half[owner] + half[face])
        return gap, coverage

    def potential(self, mechanism, q):
        gap, coverage = self.gaps(mechanism, q)
        return self.stiffness * jnp.sum(coverage * barrier(gap / self.activation))

    def force(self, mechanism, q, v):
        elastic = -jax.grad(self.potential, argnums=1)(mechanism, q)

        def gap_of(q):
            return self.gaps(mechanism, q)

        (gap, coverage), vjp, (gap_rate, _) = _value_vjp_jvp(gap_of, q, v)
        engaged = coverage * smoothstep(1 - gap / self.activation)
        (dissipative,) = vjp((-self.damping * engaged * gap_rate, jnp.zeros_like(coverage)))
        return elastic + dissipative

    def report(self, mechanism, q) -> dict[str, Array]:
        """Contact state at ``q``: the smallest gap over pairs in contact range (length, `inf` if
        none), how many (point, face) pairs are engaged (``g < ĝ`` with coverage > 0), and the
        penetration ``max(0, −g)`` (length)."""
        gap, coverage = self.gaps(mechanism, q)
        covered = coverage > 0
        smallest = jnp.min(jnp.where(covered, gap, jnp.inf))
        return {
            "min_gap": smallest,
            "engaged": jnp.sum(covered & (gap < self.activation)),
            "penetration": jnp.maximum(-smallest, 0.0),
        }


def _value_vjp_jvp(fn, q, v):
    """``fn(q)``, its VJP function and its JVP along ``v``, tracing `fn` once for the VJP."""
    value, vjp = jax.vjp(fn, q)
    _, tangent = jax.jvp(fn, (q,), (v,))
    return value, vjp, tangent
