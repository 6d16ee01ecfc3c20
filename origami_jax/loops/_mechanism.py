"""`LoopedPanels`: rigid panels whose creases close loops around interior vertices.

A spanning tree of the faces ([`origami_jax.net.PanelTree`][], the net engine) carries the panels;
the creases left out of the tree (the *cut creases*) are kept as coordinates too, tied to the tree by
the closure of every vertex loop (`origami_jax.loops._closure`). The state is every crease's fold
angle and rate, ``q = θ`` (tree creases first, then cut creases) and ``v = θ̇``, so hinges, inputs,
drag, contact and verdicts read the same angles as for chains and nets.

**Equations of motion.** The kinetic energy is the tree's, ``½ θ̇_Tᵀ M_T(θ_T) θ̇_T``; the cut creases
carry no inertia of their own (their rates follow from the tree's). With the closure ``c(θ) = 0`` and
its Jacobian ``J``, the accelerations solve

    M θ̈ = f − C θ̇ − G + Jᵀ λ,     J θ̈ = −J̇ θ̇ − 2ω J θ̇ − ω² c,

the second line being the closure's second derivative with Baumgarte's stabilisation (critically
damped at rate ``ω``, so drift decays instead of growing). The hinge torque on a cut crease does
work through its rate like any other (``τ θ̇_C``) and reaches the panels through ``λ``.

**Singular places.** At the flat state (and at fully folded states) the closure Jacobian loses rank:
the loops' linearised constraints become dependent, and several folding branches meet. The
multipliers are then not unique and the saddle-point system is singular, so it is solved by the
augmented-Lagrangian iteration (Bayo & Ledesma, Nonlinear Dyn. 9, 1996) with each vertex's three rows
whitened, ``W_v = (J_v J_vᵀ + δ)⁻¹``:

    (M + ρ Jᵀ W J) θ̈ₖ₊₁ = f − C θ̇ − G + Jᵀ λₖ + ρ Jᵀ W b,     λₖ₊₁ = λₖ + ρ W (b − J θ̈ₖ₊₁),

one Cholesky factorisation and a few solves. The matrix is positive definite at any rank of ``J``;
redundant constraints (a Miura-ori's loops are dependent everywhere) converge in a few iterations.
The whitening matters near flat: a vertex's out-of-plane row shrinks like the fold ``r`` there, and
unwhitened it would be enforced only as a penalty of stiffness ``ρ r²`` (the path leaves its branch
for ``r`` up to ~1/√(ρ/M)); whitened it is enforced at full strength down to ``|J_v row| ~ √δ``
(``δ`` = `whitening`, 1e-8: rows within ~1e-4 rad of flat fall back to the penalty, which lets a
vertex swinging through flat keep its momentum along its branch instead of being thrown onto the
other one by accelerations that grow like 1/r). Units: ``ρ = penalty · mean(diag M_T)``.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..net import PanelTree
from ..system import AbstractMechanism, HingeLayout
from . import _closure

# Regularising inertia on the cut creases, relative to the mean diagonal of M_T: keeps M + ρJᵀJ
# positive definite when a cut crease's column of J vanishes; its effect on the accelerations is
# of this relative size.
_CUT_INERTIA = 1e-12
# Whitening floor δ of a vertex's constraint Gram matrix J_v J_vᵀ (entries O(1): the rows of J are
# combinations of unit crease directions). Rows larger than √δ are enforced at full strength, smaller
# ones (within ~1e-4 rad of a flat or fully folded vertex) fall back to the penalty. Measured on a
# flat-foldable degree-4 vertex: 1e-12 lets a vertex swinging through flat jump onto the other
# branch (the constraint demands accelerations ~ 1/r there); 1e-8 keeps it on its branch and keeps
# its fold-angle relation to 4e-9 from a flat start; 1e-4 loosens that to 2e-6.
_WHITENING = 1e-8


def _inverse3(a: Float[Array, "n 3 3"]) -> Float[Array, "n 3 3"]:
    """Inverses of 3×3 matrices by the adjugate (no LAPACK call per vertex)."""
    c0 = jnp.cross(a[:, 1], a[:, 2])
    c1 = jnp.cross(a[:, 2], a[:, 0])
    c2 = jnp.cross(a[:, 0], a[:, 1])
    det = jnp.sum(a[:, 0] * c0, axis=-1)
    return jnp.stack([c0, c1, c2], axis=-1) / det[:, None, None]


class LoopedPanels(AbstractMechanism):
    """Rigid panels hinged along creases that close loops (module docstring).

    **Fields:**
    - `tree`: the panels on a spanning tree of the faces, a `PanelTree` (hinges ``0 … m_T − 1``).
    - `cut_bodies` (static): for each cut crease, the two bodies it joins ``(a, b)`` (−1: the base);
      `cut_ends`: `(c, 2, 3)` their two end points in the flat state, world frame (host data).
    - `loop_index` (static): `(n_v, D)` crease indices around each interior vertex, counter-clockwise
      (``m`` pads); `loop_directions`: `(n_v, D, 3)` their outward unit directions in the flat state.
    - `rate`: Baumgarte rate ``ω`` (1/time); `whitening`: ``δ`` (dimensionless). `penalty` (static):
      ``ρ / mean(diag M_T)``; `iterations` (static): augmented-Lagrangian iterations.
    - `loop_points`: `(k, 3)` the interior vertices' positions (flat state), for contact tables
      (host data: a pattern of another size compiles nothing).
    """

    tree: PanelTree
    cut_bodies: tuple[tuple[int, int], ...] = eqx.field(static=True)
    cut_ends: Float[ArrayLike, "c 2 3"]
    loop_index: tuple[tuple[int, ...], ...] = eqx.field(static=True)
    loop_directions: Float[Array, "n_v D 3"]
    rate: Float[Array, ""]
    whitening: Float[Array, ""] = eqx.field(default_factory=lambda: jnp.asarray(_WHITENING))
    penalty: float = eqx.field(static=True, default=1e4)
    iterations: int = eqx.field(static=True, default=4)
    loop_points: Float[ArrayLike, "k 3"] = eqx.field(default_factory=lambda: np.zeros((0, 3)))

    # ---- sizes ----

    @property
    def n_tree(self) -> int:
        return self.tree.n_hinges

    @property
    def n_cut(self) -> int:
        return len(self.cut_bodies)

    @property
    def n_hinges(self) -> int:
        return self.tree.n_hinges + len(self.cut_bodies)

    @property
    def n_bodies(self) -> int:
        return self.tree.n_bodies

    @property
    def n_loops(self) -> int:
        return len(self.loop_index)

    def _index(self) -> np.ndarray:
        return np.asarray(self.loop_index, dtype=np.int32).reshape(self.n_loops, -1)

    # ---- closure ----

    def closure(self, q: Float[Array, " m"]) -> Float[Array, "n_v 3"]:
        """Closure residual ``vee(P − Pᵀ)/2`` of every vertex loop at ``q`` (dimensionless,
        ``sin`` of the loop's rotation angle), `(n_v, 3)`."""
        return _closure.closure(self.loop_directions, self._index(), jnp.asarray(q))

    def closure_jacobian(self, q: Float[Array, " m"]) -> Float[Array, "c m"]:
        """Dense closure Jacobian ``∂c/∂θ``, `(3 n_v, m)` (analysis and tests; the dynamics keep it
        in per-vertex blocks)."""
        q = jnp.asarray(q)
        _, jac, _ = _closure.closure_terms(
            self.loop_directions, self._index(), q, jnp.zeros_like(q)
        )
        index = self._index()
        out = jnp.zeros((self.n_loops, 3, self.n_hinges + 1), q.dtype)
        rows = jnp.arange(self.n_loops)[:, None, None]
        comps = jnp.arange(3)[None, :, None]
        out = out.at[rows, comps, index[:, None, :]].add(jac)
        return out[..., : self.n_hinges].reshape(3 * self.n_loops, self.n_hinges)

    def whitened_closure_force(self, q: Float[Array, " m"]) -> Float[Array, " m"]:
        """``Jᵀ W c`` at `q`, `(m,)`: the closure residual ``c`` pulled back to the creases through
        each vertex's whitened rows, ``W_v = (J_v J_vᵀ + δ)⁻¹`` (module docstring), so that a row
        shrinking near the flat state still counts in full. The fixed-step engine
        (`origami_jax.simulation.ImplicitStep`) holds loops closed with it as a stiff penalty; it
        vanishes exactly where the loops close."""
        q = jnp.asarray(q)
        index = self._index()
        product, carried = _closure.loop_products(
            self.loop_directions, _closure.gather_angles(q, index)
        )
        residual = _closure.residual_of(product)
        jac = _closure.jacobian_blocks(product, carried)
        pulled = jnp.einsum("vij,vj->vi", self._whitening(jac), residual)
        return _closure.apply_transpose(jac, index, pulled, self.n_hinges)

    # ---- AbstractMechanism ----

    def mass_matrix(self, q):
        """``blockdiag(M_T(θ_T), 0)``: only positive semi-definite (the cut creases carry no inertia of
        their own); the constrained dynamics are in `forward_dynamics`."""
        q = jnp.asarray(q)
        m_tree = self.tree.mass_matrix(q[: self.n_tree])
        out = jnp.zeros((self.n_hinges, self.n_hinges), m_tree.dtype)
        return out.at[: self.n_tree, : self.n_tree].set(m_tree)

    def bias_force(self, q, v):
        q, v = jnp.asarray(q), jnp.asarray(v)
        bias = self.tree.bias_force(q[: self.n_tree], v[: self.n_tree])
        return jnp.concatenate([bias, jnp.zeros((self.n_cut,), bias.dtype)])

    def forward_dynamics(self, q, v, force, *, forward_mode_only: bool = False):
        """Constrained accelerations ``θ̈`` (module docstring), `(m,)` or `(t, m)` rows."""
        del forward_mode_only
        q, v, force = jnp.asarray(q), jnp.asarray(v), jnp.asarray(force)
        m = self.n_hinges
        if q.ndim not in (1, 2) or q.shape[-1] != m or v.shape != q.shape or force.shape != q.shape:
            raise ValueError(
                f"q, v and force must have shape ({m},) or (t, {m}) for this pattern's {m} creases, "
                f"got {q.shape}, {v.shape} and {force.shape}."
            )
        if q.ndim == 2:
            return jax.vmap(self._accelerations)(q, v, force)
        return self._accelerations(q, v, force)

    def _whitening(self, jac: Float[Array, "n_v 3 D"]) -> Float[Array, "n_v 3 3"]:
        """Each vertex's weight ``W_v = (J_v J_vᵀ + δ)⁻¹``: a loop whose out-of-plane row shrinks
        near the flat state (size σ ~ the fold) is still enforced at full strength."""
        gram = jnp.einsum("vik,vjk->vij", jac, jac)
        eye = jnp.eye(3, dtype=gram.dtype)
        return _inverse3(gram + self.whitening * eye)

    def _with_cut_inertia(self, m_tree: Float[Array, "t t"]) -> tuple[Array, Array]:
        """``blockdiag(M_T, 0)`` with the cut creases' regularising inertia (`_CUT_INERTIA` of
        ``mean(diag M_T)``), `(m, m)`, and that mean."""
        n_tree, m = self.n_tree, self.n_hinges
        scale = jnp.mean(jnp.diagonal(m_tree))
        matrix = jnp.zeros((m, m), m_tree.dtype).at[:n_tree, :n_tree].set(m_tree)
        diagonal = jnp.concatenate(
            [jnp.zeros((n_tree,), m_tree.dtype), jnp.full((self.n_cut,), _CUT_INERTIA)]
        )
        return matrix + jnp.diag(diagonal * scale), scale

    def regularised_mass_matrix(self, q: Float[Array, " m"]) -> Float[Array, "m m"]:
        """`mass_matrix` with the cut creases' regularising inertia, as the constrained dynamics
        use it: positive definite, for the fixed-step engine's incremental problem."""
        q = jnp.asarray(q)
        return self._with_cut_inertia(self.tree.mass_matrix(q[: self.n_tree]))[0]

    def _accelerations(self, q, v, force):
        n_tree, m = self.n_tree, self.n_hinges
        index = self._index()
        m_tree, bias = self.tree.mass_matrix_and_bias(q[:n_tree], v[:n_tree])
        free = force - jnp.concatenate([bias, jnp.zeros((self.n_cut,), bias.dtype)])
        residual, jac, gamma = _closure.closure_terms(self.loop_directions, index, q, v)
        omega = self.rate
        rate_residual = _closure.apply_blocks(jac, index, v)
        target = -gamma - 2 * omega * rate_residual - omega**2 * residual
        weight = self._whitening(jac)
        whitened = jnp.einsum("vij,vjk->vik", weight, jac)  # W_v J_v
        matrix, scale = self._with_cut_inertia(m_tree)
        rho = self.penalty * scale
        blocks = jnp.einsum("vik,vil->vkl", jac, whitened)  # J_vᵀ W_v J_v
        normal = jnp.zeros((m + 1, m + 1), m_tree.dtype)
        normal = normal.at[index[:, :, None], index[:, None, :]].add(blocks)[:m, :m]
        matrix = matrix + rho * normal
        factor = jax.scipy.linalg.cho_factor(matrix, lower=True)
        base = free + rho * _closure.apply_transpose(
            jac, index, jnp.einsum("vij,vj->vi", weight, target), m
        )
        acceleration = jax.scipy.linalg.cho_solve(factor, base)
        multiplier = jnp.zeros_like(target)
        for _ in range(self.iterations):
            gap = target - _closure.apply_blocks(jac, index, acceleration)
            multiplier = multiplier + rho * jnp.einsum("vij,vj->vi", weight, gap)
            acceleration = jax.scipy.linalg.cho_solve(
                factor, base + _closure.apply_transpose(jac, index, multiplier, m)
            )
        return acceleration

    def kinetic_energy(self, q, v):
        q, v = jnp.asarray(q), jnp.asarray(v)
        return self.tree.kinetic_energy(q[: self.n_tree], v[: self.n_tree])

    def potential_energy(self, q):
        return self.tree.potential_energy(jnp.asarray(q)[: self.n_tree])

    def body_poses(self, q):
        return self.tree.body_poses(jnp.asarray(q)[: self.n_tree])

    def body_velocities(self, q, v):
        q, v = jnp.asarray(q), jnp.asarray(v)
        return self.tree.body_velocities(q[: self.n_tree], v[: self.n_tree])

    def spatial_velocities(self, q, v):
        q, v = jnp.asarray(q), jnp.asarray(v)
        return self.tree.spatial_velocities(q[: self.n_tree], v[: self.n_tree])

    def apply_wrenches(self, q, wrenches):
        force = self.tree.apply_wrenches(jnp.asarray(q)[: self.n_tree], wrenches)
        return jnp.concatenate([force, jnp.zeros((self.n_cut,), force.dtype)])

    def body_motion(self, q, v):
        """The tree's (one evaluation of its kinematics); cut creases get no generalized force."""
        q, v = jnp.asarray(q), jnp.asarray(v)
        poses, twists, tree_force = self.tree.body_motion(q[: self.n_tree], v[: self.n_tree])

        def wrench_force(wrenches):
            force = tree_force(wrenches)
            return jnp.concatenate([force, jnp.zeros((self.n_cut,), force.dtype)])

        return poses, twists, wrench_force

    @property
    def carries_added_inertia(self) -> bool:
        return self.tree.carries_added_inertia

    def with_added_inertias(self, added: Float[Array, "b 6 6"] | None) -> "LoopedPanels":
        """The same panels with their added (fluid) inertias replaced, body frames `(b, 6, 6)`
        (`None`: none): the spanning tree's (the cut creases carry no body)."""
        return eqx.tree_at(lambda mech: mech.tree, self, self.tree.with_added_inertias(added))

    def without_loops(self, stiffness: Float[Array, " m"]) -> tuple[PanelTree, Float[Array, " t"]]:
        """The spanning tree with its own hinges' stiffness (the cut creases, their springs and
        the closure dropped): a looser mechanism whose slowest small oscillation is slower than
        the pattern's (Rayleigh: a constraint or a spring can only raise the lowest frequency),
        for `origami_jax.simulation.quasi_static_ramp`."""
        return self.tree, jnp.asarray(stiffness)[: self.n_tree]

    def outlines(self) -> list[np.ndarray]:
        return self.tree.outlines()

    def base_outline(self) -> np.ndarray | None:
        return self.tree.base_outline()

    def hinge_layout(self) -> HingeLayout:
        """The tree's hinges, then the cut creases (their two bodies and crease ends)."""
        tree = self.tree.hinge_layout()
        if not self.n_cut:
            return tree
        ends = np.asarray(self.cut_ends, dtype=float).reshape(-1, 2, 3)
        axes = ends[:, 1] - ends[:, 0]
        axes = axes / np.linalg.norm(axes, axis=-1, keepdims=True)
        bodies = np.asarray(self.cut_bodies, dtype=np.int64).reshape(-1, 2)
        return HingeLayout(
            np.concatenate([tree.parent, bodies[:, 0]]),
            np.concatenate([tree.child, bodies[:, 1]]),
            np.concatenate([tree.axis, axes]),
            np.concatenate([tree.ends, ends]),
        )
