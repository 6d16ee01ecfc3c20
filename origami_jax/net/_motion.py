"""Body twists and generalized forces of a panel tree from its hinges' world motion subspaces.

A panel's world twist (about the world origin, ``(v_O, ω)``) is the sum of the motion subspaces of
the hinges between it and the base, ``V_b = Σ_{j ⪯ b} S_j q̇_j``, and a wrench ``W_b`` on it (force and
moment about the origin) loads hinge ``j`` with ``S_j · Σ_{b ⪰ j} W_b``, the dual of the former
(Featherstone, *Rigid Body Dynamics Algorithms*, 2008, §2.9 and §5.3). Hinge ``j``'s world subspace is
its rest-frame one moved by its parent's displacement, ``S_j = Ad_{G_λ(j)} S_J,j(q_j)``, and the
displacement is read off the parent's pose, ``G = P(q) P(0)⁻¹``. One evaluation of the body poses and
of the joint models, and two products with the tree's ancestor matrix: what fluid and contact models
call at every right-hand side, without autodiff through the kinematics.
"""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._topology import topology


def world_subspaces(tree, q: Float[Array, " n"], poses: Float[Array, "n 4 4"]) -> Array:
    """``S_j`` of every hinge in the world frame about the origin, ``(linear, angular)``, `(n, 6)`.

    `poses`: the tree's `body_poses(q)` (passed in, as callers need them too)."""
    lin, ang = tree.joints.motion(q)
    lin = jnp.broadcast_to(jnp.stack(lin, axis=-1), (tree.n_hinges, 3))
    ang = jnp.broadcast_to(jnp.stack(ang, axis=-1), (tree.n_hinges, 3))
    parents = np.asarray(tree.parents)
    has_parent = parents >= 0
    index = np.where(has_parent, parents, 0)
    rest = tree.frames[index]
    pose = poses[index]
    # G = P R⁻¹: rotation P_R R_Rᵀ, translation p_P − G_R p_R.
    rotation = jnp.einsum("nij,nkj->nik", pose[:, :3, :3], rest[:, :3, :3])
    translation = pose[:, :3, 3] - jnp.einsum("nij,nj->ni", rotation, rest[:, :3, 3])
    mask = jnp.asarray(has_parent)[:, None]
    eye = jnp.eye(3, dtype=rotation.dtype)
    rotation = jnp.where(mask[:, :, None], rotation, eye)
    translation = jnp.where(mask, translation, 0.0)
    # Ad_G (v, ω) = (R v + t × R ω, R ω)
    turned = jnp.einsum("nij,nj->ni", rotation, ang)
    linear = jnp.einsum("nij,nj->ni", rotation, lin) + jnp.cross(translation, turned)
    return jnp.concatenate([linear, turned], axis=-1)


def twists(tree, subspaces: Array, v: Float[Array, " n"]) -> Float[Array, "n 6"]:
    """Every body's world twist about the origin from the world subspaces, ``V = Aᵀ (S q̇)``, `(n, 6)`."""
    ancestors = jnp.asarray(topology(tree.parents).ancestors, subspaces.dtype)
    return ancestors.T @ (subspaces * v[:, None])


def generalized_force(tree, subspaces: Array, wrenches: Float[Array, "n 6"]) -> Float[Array, " n"]:
    """Generalized force of world wrenches on the bodies from the world subspaces,
    ``f_j = S_j · (A W)_j``, `(n,)`."""
    ancestors = jnp.asarray(topology(tree.parents).ancestors, subspaces.dtype)
    return jnp.sum(subspaces * (ancestors @ wrenches), axis=-1)


def spatial_velocities(tree, q, v) -> Float[Array, "n 6"]:
    """Every body's world twist about the origin, ``V = Aᵀ (S q̇)``, `(n, 6)`."""
    return twists(tree, world_subspaces(tree, q, tree.body_poses(q)), v)


def apply_wrenches(tree, q, wrenches) -> Float[Array, " n"]:
    """Generalized force of world wrenches on the bodies, ``f_j = S_j · (A W)_j``, `(n,)`."""
    return generalized_force(tree, world_subspaces(tree, q, tree.body_poses(q)), wrenches)
