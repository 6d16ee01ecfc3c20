"""Random panel trees and their Pinocchio twins, for the tests of `origami_jax.net` (and its benchmark)."""

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from origami_jax.net import PanelTree

# A branching tree numbered out of topological order (body 0's parent is body 2): bodies 1 and 5 hang
# from the base, 1 has three children (2, 3, 6), 2 has two (0, 4); depths up to 3.
BRANCHING = (2, -1, 1, 1, 2, -1, 1)


def random_parents(n: int, seed: int, *, reach: int = 4) -> tuple[int, ...]:
    """A random tree in topological numbering: body ``i``'s parent is one of the ``reach`` before it
    (the first body hangs from the base)."""
    rng = np.random.default_rng(seed)
    return tuple([-1] + [int(rng.integers(max(0, i - reach), i)) for i in range(1, n)])


def random_tree(parents, seed: int, *, gravity: bool = True, added: str | None = None) -> PanelTree:
    """A tree with random unit axes (not parallel), crease points, body frames, CG offsets and
    inertias, lengths O(100) and masses O(1) (µm- and ng-like). `added`: `None`, `"isotropic"`
    (``diag(m_a I, J_a I)`` per body, which a rigid body at the frame origin can represent) or
    `"anisotropic"` (a random symmetric positive semi-definite 6×6 per body)."""
    rng = np.random.default_rng(seed)
    n = len(parents)
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    points = rng.uniform(-150, 150, size=(n, 3))
    frames = np.zeros((n, 4, 4))
    frames[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    frames[:, :3, 3] = points + rng.uniform(-100, 100, (n, 3))
    frames[:, 3, 3] = 1.0
    masses = rng.uniform(1, 5, n)
    cgs = rng.uniform(-30, 30, (n, 3))
    a = rng.normal(size=(n, 3, 3))
    inertias = (a @ a.transpose(0, 2, 1) + np.eye(3)) * 1e3
    g = rng.normal(size=3) * 9.8e-6
    added_inertias = None
    if added == "isotropic":
        m_a, j_a = rng.uniform(0.5, 3, n), rng.uniform(1e3, 5e3, n)
        added_inertias = np.zeros((n, 6, 6))
        added_inertias[:, :3, :3] = m_a[:, None, None] * np.eye(3)
        added_inertias[:, 3:, 3:] = j_a[:, None, None] * np.eye(3)
    elif added == "anisotropic":
        # Rank 4 of 6 (semi-definite, like a thin plate's), columns scaled to the units' sizes.
        b = rng.normal(size=(n, 6, 4)) * np.array([1.0, 1.0, 1.0, 30.0, 30.0, 30.0])[:, None]
        added_inertias = b @ b.transpose(0, 2, 1)
    return PanelTree(
        parents,
        axes,
        points,
        frames,
        masses,
        cgs,
        inertias,
        added_inertias=added_inertias,
        gravity=g if gravity else None,
    )


def depth_first(parents) -> list[int]:
    """Bodies in depth-first preorder (Pinocchio's CRBA needs every subtree numbered contiguously)."""
    children = {i: [j for j, p in enumerate(parents) if p == i] for i in range(-1, len(parents))}
    order, stack = [], list(reversed(children[-1]))
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed(children[i]))
    return order


def to_pinocchio(tree: PanelTree, *, fold_isotropic_added: bool = False):
    """The same tree as a Pinocchio model, and the permutation ``order`` (Pinocchio's joint ``k`` is
    our body ``order[k]``, so ``q_pin = q[order]``).

    Joints are `JointModelRevoluteUnaligned` about the rest axes, each joint frame world-aligned at its
    crease point (placement: the translation between crease points); each panel's inertia is given
    in that frame (CG lever, world-rotated inertia). `fold_isotropic_added`: add an isotropic added
    inertia ``diag(m_a I, J_a I)`` as the rigid body it is (mass ``m_a`` at the body frame's origin,
    rotational inertia ``J_a I`` about it).
    """
    order = depth_first(tree.parents)
    model = pin.Model()
    model.gravity = pin.Motion(np.asarray(tree.gravity), np.zeros(3))
    axes, points = np.asarray(tree.axes), np.asarray(tree.points)
    frames, cgs = np.asarray(tree.frames), np.asarray(tree.cgs)
    ids = {}
    for i in order:
        p = tree.parents[i]
        parent_id = 0 if p == -1 else ids[p]
        previous = np.zeros(3) if p == -1 else points[p]
        ids[i] = model.addJoint(
            parent_id,
            pin.JointModelRevoluteUnaligned(axes[i]),
            pin.SE3(np.eye(3), points[i] - previous),
            f"hinge_{i}",
        )
        rotation, origin = frames[i, :3, :3], frames[i, :3, 3]
        inertia = pin.Inertia(
            float(tree.masses[i]),
            origin + rotation @ cgs[i] - points[i],
            rotation @ np.asarray(tree.inertias[i]) @ rotation.T,
        )
        if fold_isotropic_added:
            added = np.asarray(tree.added_inertias[i])
            inertia = inertia + pin.Inertia(
                float(added[0, 0]), origin - points[i], float(added[3, 3]) * np.eye(3)
            )
        model.appendBodyToJoint(ids[i], inertia, pin.SE3.Identity())
    return model, np.array(order)


def pinocchio_dynamics(model, order, q, v, tau):
    """Pinocchio's ``M`` (CRBA, symmetrised), bias (RNEA at zero acceleration) and ABA, in our order."""
    data = model.createData()
    back = np.argsort(order)
    mass = pin.crba(model, data, q[order])
    mass = np.triu(mass) + np.triu(mass, 1).T
    bias = pin.rnea(model, data, q[order], v[order], np.zeros(len(q)))
    acc = pin.aba(model, data, q[order], v[order], tau[order])
    return mass[np.ix_(back, back)], bias[back], acc[back]


def random_states(n: int, count: int, seed: int):
    """Random (q, v, τ): angles over the full circle, rates O(0.05 rad/µs), torques O(1e3)."""
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-np.pi, np.pi, size=(count, n)),
        rng.normal(scale=0.05, size=(count, n)),
        rng.normal(scale=1e3, size=(count, n)),
    )
