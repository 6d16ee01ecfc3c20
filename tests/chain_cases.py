"""Shared chains and a Pinocchio twin for the tests of `origami_jax.chain`."""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

import origami_jax.chain as oc

SEED = 20051105

# Test-only compiled functions are tiny and run a handful of times: XLA's backend optimisation costs
# more than it saves there (measured: the Christoffel reference compiles ~3x faster at level 0).
# Numerics are unchanged (no fast-math at either level).
FAST_COMPILE = {"xla_backend_optimization_level": 0, "xla_llvm_disable_expensive_passes": True}
quick_jit = functools.partial(jax.jit, compiler_options=FAST_COMPILE)


def random_chain(n: int, seed: int, *, gravity: bool = False) -> oc.Chain:
    """A chain with random, non-parallel unit axes, random hinge points and random flap frames.

    Lengths are O(100) (µm-like), so numbers look like the accordion's in MICRO units.
    """
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return _random_flaps(rng, axes, gravity)


def random_planar_chain(n: int, seed: int, *, gravity: bool = False) -> oc.Chain:
    """A planar chain in general position: every axis along one random direction, with random signs
    (some hinges turn the other way), hinge points, CGs and flap frames anywhere in space (offsets along
    the axis included), asymmetric flaps with tilted frames, gravity in any direction."""
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    signs = np.where(rng.uniform(size=n) < 0.5, -1.0, 1.0)
    signs[0] = 1.0
    chain = _random_flaps(rng, signs[:, None] * direction, gravity)
    assert chain.planar
    return chain


def _random_flaps(rng, axes: np.ndarray, gravity: bool) -> oc.Chain:
    # Hinge points, CGs, flap frames, plate sizes and gravity drawn after the axes.
    n = axes.shape[0]
    points = np.cumsum(rng.uniform(-150, 150, size=(n, 3)), axis=0)
    cg = points + rng.uniform(-100, 100, size=(n, 3))
    rotations = Rotation.random(n, random_state=rng).as_matrix()
    return oc.flap_chain(
        axes,
        points,
        cg,
        flap_length=rng.uniform(100, 300, size=n),
        flap_width=rng.uniform(100, 300, size=n),
        thickness=rng.uniform(0.1, 20, size=n),
        density=rng.uniform(2e-3, 8e-3, size=n),
        flap_rotations=rotations,
        gravity=rng.normal(size=3) * 9.8e-6 if gravity else None,
    )


def to_pinocchio(chain: oc.Chain) -> pin.Model:
    """The same chain as a Pinocchio model: revolute joints about arbitrary (unaligned) axes.

    At θ = 0 every joint frame has the world's orientation and sits at its hinge point ``q_i``, so the
    placement relative to the parent joint is a pure translation ``q_i − q_{i−1}``; each flap's inertia is
    expressed in its joint frame (CG lever ``c_i − q_i``, rotated inertia ``R I Rᵀ``).
    """
    axes = np.asarray(chain.axes)
    points = np.asarray(chain.points)
    poses = np.asarray(chain.cg_poses)
    model = pin.Model()
    model.gravity = pin.Motion(np.asarray(chain.gravity), np.zeros(3))
    parent, previous = 0, np.zeros(3)
    for i in range(chain.n_joints):
        joint = pin.JointModelRevoluteUnaligned(axes[i])
        placement = pin.SE3(np.eye(3), points[i] - previous)
        joint_id = model.addJoint(parent, joint, placement, f"hinge_{i}")
        rotation = poses[i, :3, :3]
        inertia = rotation @ np.asarray(chain.inertias[i]) @ rotation.T
        lever = poses[i, :3, 3] - points[i]
        model.appendBodyToJoint(
            joint_id, pin.Inertia(float(chain.masses[i]), lever, inertia), pin.SE3.Identity()
        )
        model.addFrame(
            pin.Frame(f"flap_{i}", joint_id, pin.SE3(rotation, lever), pin.FrameType.OP_FRAME)
        )
        parent, previous = joint_id, points[i]
    return model


def random_states(n: int, count: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random (θ, θ̇, τ): angles over the full circle, rates O(0.05 rad/µs), torques O(1e3 µN·µm)."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-np.pi, np.pi, size=(count, n))
    theta_dot = rng.normal(scale=0.05, size=(count, n))
    tau = rng.normal(scale=1e3, size=(count, n))
    return theta, theta_dot, tau


def as_jax(*arrays):
    return tuple(jnp.asarray(a) for a in arrays)


def forward_dynamics(chain, theta, theta_dot, tau, *, stiffness, drag, **options):
    """The paper's Eq. 11 right-hand side: `oc.forward_dynamics` with the generalized force
    ``τ − K θ − B θ̇|θ̇|`` (what `FoldingSystem.generalized_force` assembles for a chain)."""
    applied = jnp.asarray(tau) - oc.hinge_torque(stiffness, drag, theta, theta_dot)
    applied = jnp.broadcast_to(applied, jnp.shape(theta))
    return oc.forward_dynamics(chain, theta, theta_dot, applied, **options)
