"""Equations of motion ``M(q) q̈ + C(q, q̇) q̇ + G(q) = f`` of a panel tree: the algorithms.

Featherstone's tree algorithms (*Rigid Body Dynamics Algorithms*, Springer 2008: CRBA §6.2, RNEA §5.3,
the sparse ``LᵀL`` factorization §6.5), written in the world frame with every spatial vector taken
about the world origin and ordered ``(linear, angular)`` (as in `origami_jax.chain`). In that frame no
vector has to be moved between bodies, so the recursions over the tree become sums over subtrees or
over paths to the base. With the static ancestor matrix ``A[j, i] = 1`` when body ``j`` is an ancestor
of body ``i`` or ``i`` itself (`_topology.Topology.ancestors`):

- *Kinematics*: the displacement of body ``i`` is ``G_i = G_λ(i) J_i(q_i)`` (``λ`` the parent,
  ``J_i`` its hinge's displacement in the rest frame, `_joints`), composed level by level from the
  base; its hinge's world motion subspace is ``S_i = Ad_{G_λ(i)} S_J,i(q_i)``.
- *Spatial inertias* ``𝕀_i`` about the origin: the rigid panel's (mass ``m``, first moment ``h = m c``,
  rotational inertia ``I_o``) plus an optional general symmetric 6×6 inertia given in the body frame
  (fluid added mass), moved to the world by ``X* 𝕀 X*ᵀ``.
- *Mass matrix* (CRBA): composite inertias ``𝕀^C = A 𝕀`` (subtree sums), then
  ``M_jk = S_j · (𝕀^C_k S_k)`` for ``j`` an ancestor-or-self of ``k`` (and symmetric; zero between
  bodies on different branches).
- *Bias and inverse dynamics* (RNEA): velocities ``V = Aᵀ (S q̇)``, accelerations
  ``a = Aᵀ (S q̈ + Ṡ q̇)`` with ``Ṡ_i q̇_i = V_i × S_i q̇_i + Ad_{G_λ(i)} (dS_J/dq) q̇_i²`` (the second
  term only for joints whose ``S_J`` depends on ``q``), net body forces
  ``f_i = 𝕀_i a_i + V_i ×* 𝕀_i V_i − f_g,i`` and hinge torques ``τ = S · (A f)``. Gravity is the force
  ``f_g = (m g, h × g)`` on the rigid mass only: added fluid inertia has no weight (buoyancy is the
  fluid model's business).
- *Forward dynamics*: ``q̈ = M⁻¹ (f − C q̇ − G)`` by the tree-sparse ``M = Lᵀ L`` factorization (no
  fill-in: ``L_ij ≠ 0`` only for ``j`` an ancestor of ``i``; ``Σ depth²`` operations, unrolled on scalars)
  for trees up to `_UNROLL_MAX_WORK`, LAPACK's Cholesky beyond.

**Layout.** Bodies are processed in the tree's topological order (`Topology.order`, parents first),
so that ``λ(i) < i`` as in Featherstone; inputs are permuted into it and results back. Every 3-vector
is stored by component (`origami_jax._vec3`), one array per component with the bodies along the first axis and
any states along the trailing ones, `(n, *batch)`: the algorithms are elementwise arithmetic plus
products with constant matrices (``A``, parent selections), and vectorise over the states, which are
contiguous. Many states of one tree (`forward_dynamics_rows`, and `jax.vmap` of the single-state
forward dynamics, see `origami_jax.net._tree`) run in this layout rather than `vmap`'s states-first
one, where every operation works on short rows of bodies.

Everything is a pure function of the tree's arrays: `jit`, `vmap`, `grad` and `jvp` apply unchanged.
Units are the tree's (any consistent system).
"""

from typing import NamedTuple

import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .. import _vec3 as vec3
from .._vec3 import Mat, Vec
from ._joints import AbstractJoints
from ._topology import Topology, topology

# The unrolled sparse factorization costs Σ_i depth_i² scalar operations in the graph (a 20-panel
# serial chain: 2870); above this LAPACK's dense Cholesky is cheaper to compile.
_UNROLL_MAX_WORK = 4000
# Trees of at least this many levels compose their kinematics by pointer jumping, ⌈log₂ levels⌉
# rounds over the whole tree (`_frames_by_doubling`), rather than level by level: fewer operations
# to compile from 5 levels on (3 rounds and the parents' lookup against 4 compositions, and the
# level loop's per-level slicing and joining gone). Each round works on every body,
# so shallow trees (the nets) keep the level loop. Measured on a 10×10 Miura-ori sheet's tree (18
# levels): its body poses compiled to 11,300 optimized operations level by level, 1,700 by jumping.
_DOUBLING_MIN_LEVELS = 5


class _Ordered(NamedTuple):
    """The tree's constant data in topological order, per-body components expanded by `extra`
    trailing axes (the number of batch axes of the states)."""

    topo: Topology
    identity: bool  # the tree is already numbered in topological order
    extra: int
    ancestors: Array  # (n, n): A[j, i] = 1 if j is an ancestor-or-self of i
    joints: AbstractJoints
    frames: Array
    masses: Array
    cgs: Array
    inertias: Array
    added: Array | None


def _ordered(tree, extra: int = 0) -> _Ordered:
    topo = topology(tree.parents)
    identity = topo.order == tuple(range(len(topo.order)))
    order = np.asarray(topo.order)

    def take(x: Array) -> Array:
        return x if identity else x[order]

    a = np.asarray(topo.ancestors)[np.ix_(order, order)]
    return _Ordered(
        topo,
        identity,
        extra,
        jnp.asarray(a, tree.masses.dtype),
        tree.joints if identity else tree.joints.take(order),
        take(tree.frames),
        vec3.expand(take(tree.masses), extra),
        take(tree.cgs),
        take(tree.inertias),
        None if tree.added_inertias is None else take(tree.added_inertias),
    )


def _to_order(data: _Ordered, x: Array) -> Array:
    """Per-hinge values `(n, *batch)` into topological order."""
    return x if data.identity else x[np.asarray(data.topo.order)]


def _from_order(data: _Ordered, x: Array) -> Array:
    """Per-body values `(n, *batch)` in topological order back into the tree's order."""
    return x if data.identity else x[data.topo.position]


def _path_sum(data: _Ordered, x: Array) -> Array:
    """``Σ_{j ancestor-or-self of i} x_j`` for every body ``i`` (a sum down the tree)."""
    return jnp.tensordot(data.ancestors.T, x, axes=1)


def _subtree_sum(data: _Ordered, x: Array) -> Array:
    """``Σ_{i in subtree(k)} x_i`` for every body ``k`` (a sum up the tree)."""
    return jnp.tensordot(data.ancestors, x, axes=1)


def materialize(tree):
    """The same values, computed once into memory: a fusion boundary on the CPU.

    XLA:CPU fuses an elementwise producer into every consumer and recomputes it there (it has no
    multi-output fusion), so a value read by many later kernels, such as the motion subspaces read
    by every pivot of the factorization, is recomputed in each with everything upstream of it.
    Operands of a conditional are computed once; this one's predicate is never true (an absolute
    value below −1), so the identity branch always runs. Elsewhere (GPU, TPU) it is the identity:
    a conditional would cost a device-to-host transfer of the predicate there.
    """

    def on_cpu(tree):
        leaves = jax.tree_util.tree_leaves(tree)
        never = eqxi.unvmap_any(jnp.abs(jnp.ravel(leaves[0])[0]) < -1.0)
        return jax.lax.cond(
            never, lambda t: jax.tree_util.tree_map(jnp.zeros_like, t), lambda t: t, tree
        )

    if not jax.tree_util.tree_leaves(tree):
        return tree
    return jax.lax.platform_dependent(tree, cpu=on_cpu, default=lambda t: t)


class Frames(NamedTuple):
    """World kinematics of every body at ``q``, by component `(n, *batch)`, in topological order.

    - `rotation`, `translation`: the displacement ``G_i`` of body ``i`` (rest frame → world).
    - `s_lin`, `s_ang`: world motion subspace ``S_i`` of hinge ``i`` about the origin.
    - `ds_lin`, `ds_ang`: ``Ad_{G_λ(i)} dS_J,i/dq``, or `None` for joints with constant ``S_J``.
    """

    rotation: Mat
    translation: Vec
    s_lin: Vec
    s_ang: Vec
    ds_lin: Vec | None
    ds_ang: Vec | None


def _selection(topo: Topology, d: int, dtype) -> Array:
    """``P[m, k] = 1`` when body ``k`` of level ``d − 1`` is the parent of body ``m`` of level ``d``:
    ``P @ x`` gathers the parents' values. A product rather than a gather on purpose: XLA:CPU fuses
    a gather into each of its consumers and recomputes everything upstream of it in each, while a
    product's operands are computed once."""
    where = topo.level_parents[d - 1]
    out = np.zeros((len(where), len(topo.levels[d - 1])))
    out[np.arange(len(where)), where] = 1.0
    return jnp.asarray(out, dtype)


def _adjoint(rotation: Mat, translation: Vec, lin: Vec, ang: Vec) -> tuple[Vec, Vec]:
    # Ad_G (v, ω) = (R v + t × R ω, R ω)
    rotated = vec3.matvec(rotation, ang)
    return vec3.add(vec3.matvec(rotation, lin), vec3.cross(translation, rotated)), rotated


def _compose(first: tuple[Mat, Vec], second: tuple[Mat, Vec]) -> tuple[Mat, Vec]:
    """The displacement ``first ∘ second``: ``(R₁ R₂, R₁ t₂ + t₁)``."""
    (r1, t1), (r2, t2) = first, second
    return vec3.matmul(r1, r2), vec3.add(vec3.matvec(r1, t2), t1)


def _gathered(rotation: Mat, translation: Vec, up: np.ndarray) -> tuple[Mat, Vec]:
    """The displacement of body ``up[i]`` for every body ``i``, the identity where ``up[i] = −1``;
    components `(n, *batch)`. One product with a constant selection matrix for all twelve
    components (a product rather than a gather: see `_selection`). Its ``n²`` cost per component is
    small beside the loops' dense solve: a gather behind an optimization barrier made a 10×10
    Miura-ori sheet's right-hand side 0.1 ms (~15 %) faster and a 20×20 one's 0.7 ms (~7 %),
    measured on one core."""
    n = len(up)
    has = up >= 0
    select = np.zeros((n, n))
    select[np.flatnonzero(has), up[has]] = 1.0
    parts = [x for row in rotation for x in row] + list(translation)
    picked = jnp.tensordot(jnp.asarray(select, parts[0].dtype), jnp.stack(parts, axis=1), axes=1)
    identity = vec3.expand(jnp.asarray(~has, parts[0].dtype), parts[0].ndim - 1)
    r = tuple(
        tuple(picked[:, 3 * a + b] + (identity if a == b else 0.0) for b in range(3))
        for a in range(3)
    )
    return r, (picked[:, 9], picked[:, 10], picked[:, 11])  # type: ignore[return-value]


def _frames_by_doubling(
    data: _Ordered, joint: tuple[Mat, Vec], shape: tuple[int, ...]
) -> tuple[tuple[Mat, Vec], tuple[Mat, Vec]]:
    """Every body's displacement ``G_i = J_r ⋯ J_λ(i) J_i`` (``r`` its root) by pointer jumping
    (Wyllie's list ranking, on the tree's paths): each round composes every body's partial product
    with the one ``2ᵏ`` bodies up its path, so ``⌈log₂ levels⌉`` rounds of whole-tree arithmetic
    replace one composition per level, and the compiled program grows with the logarithm of the
    depth instead of the depth (a 10×10 Miura-ori sheet's spanning tree: 18 levels, 5 rounds).
    Returns ``G`` and the parents' ``G_λ(i)`` (the identity for roots), components `shape`."""
    rotation = vec3.map_mat(lambda x: jnp.broadcast_to(x, shape), joint[0])
    displacement = (rotation, vec3.map_vec(lambda x: jnp.broadcast_to(x, shape), joint[1]))
    parents = np.asarray(_ordered_parents(data.topo), dtype=np.int64)
    up = parents.copy()
    while np.any(up >= 0):
        displacement = _compose(_gathered(*displacement, up), displacement)
        up = np.where(up >= 0, up[np.maximum(up, 0)], -1)
    return displacement, _gathered(*displacement, parents)


def frames(data: _Ordered, q: Float[Array, " n *batch"]) -> Frames:
    """Compose the hinge displacements from the base outwards (`q` in the tree's order): one tree
    level at a time, or by pointer jumping (`_frames_by_doubling`) for trees of at least
    `_DOUBLING_MIN_LEVELS` levels."""
    joints = data.joints
    q = _to_order(data, q)
    batch = q.shape[1:]
    rj, tj = joints.transform(q)
    sl, sa = joints.motion(q)
    moving = not joints.constant_motion
    dsl, dsa = joints.motion_derivative(q) if moving else (None, None)
    if len(data.topo.levels) >= _DOUBLING_MIN_LEVELS:
        (rotation, translation), (r_p, t_p) = _frames_by_doubling(data, (rj, tj), q.shape)

        def full(x: Array) -> Array:
            return jnp.broadcast_to(x, q.shape)

        def moved(lin: Vec, ang: Vec) -> tuple[Vec, Vec]:
            lin, ang = _adjoint(r_p, t_p, lin, ang)
            return vec3.map_vec(full, lin), vec3.map_vec(full, ang)

        s_lin, s_ang = moved(sl, sa)
        ds_lin, ds_ang = moved(dsl, dsa) if moving else (None, None)
        return Frames(rotation, translation, s_lin, s_ang, ds_lin, ds_ang)
    pieces: list[tuple] = []
    start = 0
    for d, level in enumerate(data.topo.levels):
        cut = slice(start, start + len(level))
        start += len(level)

        size = len(level)

        def part(values, cut=cut, size=size):
            return jax.tree_util.tree_map(
                lambda x: jnp.broadcast_to(x[cut], (size, *batch)), values
            )

        r_j, t_j, s_j = part(rj), part(tj), part((sl, sa))
        ds_j = part((dsl, dsa)) if moving else None
        if d == 0:
            pieces.append((r_j, t_j, s_j, ds_j))
            continue
        select = _selection(data.topo, d, q.dtype)
        r_p, t_p = jax.tree_util.tree_map(
            lambda x, s=select: jnp.tensordot(s, x, axes=1), pieces[-1][:2]
        )
        rotation = vec3.matmul(r_p, r_j)
        translation = vec3.add(vec3.matvec(r_p, t_j), t_p)
        s_w = _adjoint(r_p, t_p, *s_j)
        ds_w = None if ds_j is None else _adjoint(r_p, t_p, *ds_j)
        pieces.append((rotation, translation, s_w, ds_w))
    if len(pieces) == 1:
        rotation, translation, (s_lin, s_ang), ds = pieces[0]
    else:
        joined = jax.tree_util.tree_map(lambda *xs: jnp.concatenate(xs, axis=0), *pieces)
        rotation, translation, (s_lin, s_ang), ds = joined
    ds_lin, ds_ang = ds if moving else (None, None)
    return Frames(rotation, translation, s_lin, s_ang, ds_lin, ds_ang)


def _body_frames(data: _Ordered, kin: Frames) -> tuple[Mat, Vec]:
    rest_rotation = vec3.mat(data.frames[:, :3, :3], data.extra)
    rest_position = vec3.vec(data.frames[:, :3, 3], data.extra)
    rotation = vec3.matmul(kin.rotation, rest_rotation)
    position = vec3.add(vec3.matvec(kin.rotation, rest_position), kin.translation)
    return rotation, position


def body_poses(tree, q: Float[Array, " n"]) -> Float[Array, "n 4 4"]:
    """World pose ``G_i(q) B_i`` of every body frame (``B_i`` its pose at rest), `(n, 4, 4)`."""
    data = _ordered(tree)
    rotation, position = _body_frames(data, frames(data, q))
    rotation = jax.tree_util.tree_map(lambda x: _from_order(data, x), rotation)
    position = jax.tree_util.tree_map(lambda x: _from_order(data, x), position)
    top = jnp.concatenate([vec3.stack_mat(rotation), vec3.stack_vec(position)[..., None]], axis=-1)
    bottom = jnp.broadcast_to(jnp.array([0.0, 0.0, 0.0, 1.0], top.dtype), top.shape[:-2] + (1, 4))
    return jnp.concatenate([top, bottom], axis=-2)


class Inertias(NamedTuple):
    """Spatial inertias about the world origin: a rigid part by component and an optional general one.

    Rigid: `mass`, first moment `moment` ``h = m c``, rotational inertia about the origin `inertia`
    (a `Mat`); general: `added`, an array `(n, 6, 6, *batch)` acting on ``(linear, angular)`` motion
    vectors, or `None`.
    """

    mass: Array
    moment: Vec
    inertia: Mat
    added: Array | None

    def apply(self, lin: Vec, ang: Vec) -> tuple[Vec, Vec]:
        """``𝕀 (lin, ang)``: rigid ``(m a − h × α, h × a + I_o α)`` plus the general part."""
        force = vec3.sub(vec3.scale(self.mass, lin), vec3.cross(self.moment, ang))
        torque = vec3.add(vec3.cross(self.moment, lin), vec3.matvec(self.inertia, ang))
        if self.added is not None:
            motion = jnp.stack([*lin, *ang], axis=1)  # (n, 6, *batch)
            extra = jnp.sum(self.added * motion[:, None], axis=2)
            force = vec3.add(force, (extra[:, 0], extra[:, 1], extra[:, 2]))
            torque = vec3.add(torque, (extra[:, 3], extra[:, 4], extra[:, 5]))
        return force, torque

    def map(self, f) -> "Inertias":
        """`f` applied to every component array (and to the general part as one array)."""
        return Inertias(
            f(self.mass),
            vec3.map_vec(f, self.moment),
            vec3.map_mat(f, self.inertia),
            None if self.added is None else f(self.added),
        )


def _matmul_stacked(a: Array, b: Array) -> Array:
    """``a @ b`` for stacks `(n, i, j, *batch)` and `(n, j, k, *batch)` (one multiply-and-sum)."""
    return jnp.sum(a[:, :, :, None] * b[:, None], axis=2)


def _stack_mat(m: Mat) -> Array:
    """A `Mat` of `(n, *batch)` components as one array `(n, 3, 3, *batch)`."""
    return jnp.stack([jnp.stack(row, axis=1) for row in m], axis=1)


def _spatial_to_world(added: Array, rotation: Mat, position: Vec, extra: int) -> Array:
    """A body-frame 6×6 inertia `(n, 6, 6)` moved to the world about the origin, ``X* 𝕀 X*ᵀ`` with
    ``X* = [[R, 0], [p̂ R, R]]`` on ``(force, torque)``; `(n, 6, 6, *batch)`. Stacked arrays rather
    than components: 36 entries by component would be ~700 operations to compile."""
    shape = jnp.broadcast_shapes(*(x.shape for row in rotation for x in row), position[0].shape)
    rotation = vec3.map_mat(lambda x: jnp.broadcast_to(x, shape), rotation)
    r = _stack_mat(rotation)
    p_r = _stack_mat(vec3.matmul(vec3.hat(position), rotation))
    x_star = jnp.concatenate(
        [jnp.concatenate([r, jnp.zeros_like(r)], axis=2), jnp.concatenate([p_r, r], axis=2)],
        axis=1,
    )
    body = vec3.expand(added, extra)
    return _matmul_stacked(_matmul_stacked(x_star, body), jnp.swapaxes(x_star, 1, 2))


def inertias(data: _Ordered, kin: Frames) -> tuple[Inertias, Vec]:
    """World spatial inertia of every body about the origin, and the world CG of each."""
    rotation, position = _body_frames(data, kin)
    cg = vec3.add(position, vec3.matvec(rotation, vec3.vec(data.cgs, data.extra)))
    mass = data.masses
    rest_inertia = vec3.mat(data.inertias, data.extra)
    rotated = vec3.matmul(vec3.matmul(rotation, rest_inertia), vec3.transpose(rotation))
    # Parallel axes to the origin: I_o = I_c + m (|c|² I − c cᵀ).
    c2 = vec3.dot(cg, cg)
    inertia = tuple(
        tuple(rotated[a][b] + mass * ((c2 if a == b else 0.0) - cg[a] * cg[b]) for b in range(3))
        for a in range(3)
    )
    added = (
        None
        if data.added is None
        else _spatial_to_world(data.added, rotation, position, data.extra)
    )
    return Inertias(mass, vec3.scale(mass, cg), inertia, added), cg  # type: ignore[arg-type]


def _motion_cross(v_lin: Vec, v_ang: Vec, x_lin: Vec, x_ang: Vec) -> tuple[Vec, Vec]:
    # V ×m X = (ω × x_l + v × x_a, ω × x_a)
    return vec3.add(vec3.cross(v_ang, x_lin), vec3.cross(v_lin, x_ang)), vec3.cross(v_ang, x_ang)


def _composite_forces(data: _Ordered, kin: Frames, body: Inertias) -> tuple[Vec, Vec]:
    """``F_k = 𝕀^C_k S_k``, the composite inertia of each subtree applied to its hinge's motion."""
    composite = body.map(lambda x: _subtree_sum(data, x))
    return composite.apply(kin.s_lin, kin.s_ang)


def mass_matrix(tree, q: Float[Array, " n"]) -> Float[Array, "n n"]:
    """Composite-rigid-body ``M(q)`` (module docstring), `(n, n)`, mass·length², tree order."""
    data = _ordered(tree)
    kin = frames(data, q)
    body, _ = inertias(data, kin)
    return _mass_matrix(data, kin, body)


def mass_matrix_and_bias(tree, q: Float[Array, " n"], v: Float[Array, " n"]) -> tuple[Array, Array]:
    """``(M(q), C(q, v) v + G(q))`` from one evaluation of the kinematics and inertias, tree order."""
    data = _ordered(tree)
    kin = frames(data, q)
    body, _ = inertias(data, kin)
    bias = _newton_euler(tree, data, kin, body, _to_order(data, v), None)
    return _mass_matrix(data, kin, body), _from_order(data, bias)


def _mass_matrix(data: _Ordered, kin: Frames, body: Inertias) -> Array:
    force, torque = _composite_forces(data, kin, body)
    # P[j, k] = S_j · F_k, the entry for j an ancestor-or-self of k.
    p = _outer_sum(kin.s_lin + kin.s_ang, force + torque)
    a = data.ancestors > 0
    m = jnp.where(a, p, jnp.where(a.T, p.T, 0.0))
    if data.identity:
        return m
    position = data.topo.position
    return m[position][:, position]


def _outer_sum(s: tuple, f: tuple) -> Array:
    """``P[j, k] = Σ_c s_c[j] f_c[k]``, `(n, n, *batch)`."""
    out = s[0][:, None] * f[0][None, :]
    for a, b in zip(s[1:], f[1:], strict=True):
        out = out + a[:, None] * b[None, :]
    return out


def _newton_euler(tree, data: _Ordered, kin: Frames, body: Inertias, v, a) -> Array:
    """``M a + C v + G`` by the world-frame RNEA (module docstring), topological order; `v`, `a`
    in topological order, `a` may be `None` (zero)."""
    s_lin_v, s_ang_v = vec3.scale(v, kin.s_lin), vec3.scale(v, kin.s_ang)
    vel_lin = vec3.map_vec(lambda x: _path_sum(data, x), s_lin_v)
    vel_ang = vec3.map_vec(lambda x: _path_sum(data, x), s_ang_v)
    # Ṡ_i q̇_i = V_i × S_i q̇_i (+ Ad (dS_J/dq) q̇_i² for joints that bend).
    acc_lin, acc_ang = _motion_cross(vel_lin, vel_ang, s_lin_v, s_ang_v)
    if kin.ds_lin is not None and kin.ds_ang is not None:
        v2 = v * v
        acc_lin = vec3.add(acc_lin, vec3.scale(v2, kin.ds_lin))
        acc_ang = vec3.add(acc_ang, vec3.scale(v2, kin.ds_ang))
    if a is not None:
        acc_lin = vec3.add(acc_lin, vec3.scale(a, kin.s_lin))
        acc_ang = vec3.add(acc_ang, vec3.scale(a, kin.s_ang))
    acc_lin = vec3.map_vec(lambda x: _path_sum(data, x), acc_lin)
    acc_ang = vec3.map_vec(lambda x: _path_sum(data, x), acc_ang)
    f_acc, n_acc = body.apply(acc_lin, acc_ang)
    f_mom, n_mom = body.apply(vel_lin, vel_ang)
    # V ×* F = (ω × f, ω × n + v × f); gravity's force (m g, h × g) on the rigid mass.
    g = vec3.vec(tree.gravity)
    force = vec3.sub(vec3.add(f_acc, vec3.cross(vel_ang, f_mom)), vec3.scale(body.mass, g))
    torque = vec3.sub(
        vec3.add(n_acc, vec3.add(vec3.cross(vel_ang, n_mom), vec3.cross(vel_lin, f_mom))),
        vec3.cross(body.moment, g),
    )
    force = vec3.map_vec(lambda x: _subtree_sum(data, x), force)
    torque = vec3.map_vec(lambda x: _subtree_sum(data, x), torque)
    return vec3.dot(kin.s_lin, force) + vec3.dot(kin.s_ang, torque)


def inverse_dynamics(tree, q, v, a) -> Float[Array, " n"]:
    """``M(q) a + C(q, v) v + G(q)`` (hinge torques, mass·length²/time²) by RNEA; `a` may be `None`."""
    data = _ordered(tree)
    kin = frames(data, q)
    body, _ = inertias(data, kin)
    a = None if a is None else _to_order(data, a)
    return _from_order(data, _newton_euler(tree, data, kin, body, _to_order(data, v), a))


def bias_force(tree, q, v) -> Float[Array, " n"]:
    """``C(q, v) v + G(q)`` by RNEA with zero acceleration."""
    return inverse_dynamics(tree, q, v, None)


def potential_energy(tree, q) -> Float[Array, ""]:
    """Gravitational potential ``−Σ m_i g · c_i(q)`` (energy units; zero without gravity)."""
    data = _ordered(tree)
    _, cg = inertias(data, frames(data, q))
    return -jnp.sum(data.masses * vec3.dot(cg, vec3.vec(tree.gravity)))


def _ordered_parents(topo: Topology) -> tuple[int, ...]:
    """Parents in topological numbering (``λ(i) < i``; −1 for the base)."""
    return tuple(
        -1 if not topo.path[b] else int(topo.position[topo.path[b][0]]) for b in topo.order
    )


def _path(parents: tuple[int, ...], i: int) -> tuple[int, ...]:
    out = []
    j = parents[i]
    while j != -1:
        out.append(j)
        j = parents[j]
    return tuple(out)


def tree_factor(entries: dict, parents: tuple[int, ...]) -> tuple[dict, list]:
    """Featherstone's ``M = Lᵀ L`` factorization (Table 6.3) on the tree's sparsity, as scalars.

    `entries`: ``{(i, j): M_ij}`` for ``j`` an ancestor-or-self of ``i``, with `parents` in
    topological numbering (``λ(i) < i``). ``L`` is lower triangular and ``L_ij ≠ 0`` only for ``j``
    an ancestor of ``i`` (the sparsity of ``M``'s lower triangle: no fill-in). Returns the strict
    entries ``{(i, j): L_ij}`` and the inverse diagonal ``1 / L_ii`` as a list.
    """
    entries = dict(entries)
    n = len(parents)
    inverse_diagonal: list = [None] * n
    for k in reversed(range(n)):  # descendants before ancestors
        inverse_diagonal[k] = 1 / jnp.sqrt(entries[k, k])
        path = _path(parents, k)
        for i in path:
            entries[k, i] = entries[k, i] * inverse_diagonal[k]
        for i in path:
            for j in (i, *_path(parents, i)):
                entries[i, j] = entries[i, j] - entries[k, i] * entries[k, j]
    low = {key: value for key, value in entries.items() if key[0] != key[1]}
    return low, inverse_diagonal


def tree_solve(factor: tuple[dict, list], parents: tuple[int, ...], rhs: list) -> list:
    """Solve ``Lᵀ L x = rhs`` with a `tree_factor` (lists of scalars, topological numbering)."""
    low, inverse_diagonal = factor
    n = len(parents)
    b = list(rhs)
    y: list = [None] * n
    for k in reversed(range(n)):  # Lᵀ y = b: leaves first
        y[k] = b[k] * inverse_diagonal[k]
        for j in _path(parents, k):
            b[j] = b[j] - low[k, j] * y[k]
    x: list = [None] * n
    for i in range(n):  # L x = y: root first
        entry = y[i]
        for j in _path(parents, i):
            entry = entry - low[i, j] * x[j]
        x[i] = entry * inverse_diagonal[i]
    return x


def forward_dynamics(tree, q, v, force) -> Float[Array, " n *batch"]:
    """``q̈ = M(q)⁻¹ (force − C(q, v) v − G(q))``, kinematics shared by both terms.

    `q`, `v`, `force`: `(n, *batch)` (hinges first, any states trailing), in the tree's order.
    """
    acc, _ = forward_dynamics_and_solve(tree, q, v, force)
    return acc


def forward_dynamics_and_solve(tree, q, v, force):
    """`forward_dynamics`, and a function ``r ↦ M(q)⁻¹ r`` (`(n, *batch)`, the tree's order) on the
    same factorization."""
    data = _ordered(tree, q.ndim - 1)
    topo = data.topo
    kin = frames(data, q)
    body, _ = inertias(data, kin)
    rhs = _to_order(data, force) - _newton_euler(tree, data, kin, body, _to_order(data, v), None)
    f_lin, f_ang = _composite_forces(data, kin, body)
    s, f = kin.s_lin + kin.s_ang, f_lin + f_ang
    if sum(d * d for d in topo.depth) > _UNROLL_MAX_WORK:
        p = _outer_sum(s, f)
        a = (data.ancestors > 0).reshape(data.ancestors.shape + (1,) * data.extra)
        m = jnp.moveaxis(
            jnp.where(a, p, jnp.where(jnp.swapaxes(a, 0, 1), jnp.swapaxes(p, 0, 1), 0.0)),
            (0, 1),
            (-2, -1),
        )
        factor = jax.scipy.linalg.cho_factor(m)

        def solve_dense(r):
            x = jax.scipy.linalg.cho_solve(factor, jnp.moveaxis(_to_order(data, r), 0, -1))
            return _from_order(data, jnp.moveaxis(x, -1, 0))

        acc = jax.scipy.linalg.cho_solve(factor, jnp.moveaxis(rhs, 0, -1))
        return _from_order(data, jnp.moveaxis(acc, -1, 0)), solve_dense
    # Every entry of the factorization reads these: computed once (see `materialize`).
    s, f, rhs = materialize((s, f, rhs))
    parents = _ordered_parents(topo)
    n = len(parents)
    entries = {}
    for i in range(n):
        for j in (i, *_path(parents, i)):
            entries[i, j] = sum(a[j] * b[i] for a, b in zip(s, f, strict=True))  # S_j · F_i
    factor = tree_factor(entries, parents)

    def solve(r):
        r = _to_order(data, r)
        return _from_order(data, jnp.stack(tree_solve(factor, parents, [r[i] for i in range(n)])))

    x = tree_solve(factor, parents, [rhs[i] for i in range(n)])
    return _from_order(data, jnp.stack(x)), solve
