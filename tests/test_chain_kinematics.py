"""SE(3) helpers and chain kinematics (issue #3 items 1 and 3)."""

import jax
import jax.numpy as jnp
import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg

import origami_jax.chain as oc

from .chain_cases import SEED, quick_jit, random_chain, random_states, to_pinocchio
from .helpers import max_relative_error

# Closed forms against scipy's Padé matrix exponential, both float64.
EXPM_RTOL = 1e-13
# Poses and Jacobians against Pinocchio (independent C++): lengths O(1e3), observed ~1e-16 relative.
PINOCCHIO_RTOL = 1e-12
# Autodiff identities (twist of a pose from its derivative): round-off only.
IDENTITY_RTOL = 1e-12


def _random_twists(rng, count):
    twists = rng.normal(size=(count, 6))
    twists[0, 3:] = 0.0  # pure translation
    twists[1, 3:] /= np.linalg.norm(twists[1, 3:])  # revolute-like unit axis
    return twists


def test_hat_vee_roundtrip():
    rng = np.random.default_rng(SEED)
    w, x = rng.normal(size=(2, 5, 3))
    np.testing.assert_allclose(oc.hat(w) @ x[..., None], np.cross(w, x)[..., None], rtol=1e-14)
    np.testing.assert_allclose(oc.vee(oc.hat(w)), w, rtol=0, atol=0)
    xi = rng.normal(size=(4, 6))
    np.testing.assert_allclose(oc.twist_vee(oc.twist_hat(xi)), xi, rtol=0, atol=0)


@pytest.mark.parametrize("theta", [0.0, 1e-9, 1e-3, 0.09, 0.11, 1.0, 3.0, -2.5])
def test_exp_twist_matches_expm(theta):
    rng = np.random.default_rng(SEED)
    for xi in _random_twists(rng, 5):
        expected = scipy.linalg.expm(np.asarray(oc.twist_hat(xi * theta)))
        assert max_relative_error(oc.exp_twist(xi, theta), expected) < EXPM_RTOL
        rotation = scipy.linalg.expm(np.asarray(oc.hat(xi[3:] * theta)))
        assert max_relative_error(oc.exp_so3(xi[3:] * theta), rotation) < EXPM_RTOL


def test_exp_twist_derivatives_finite_at_zero():
    first = jax.vmap(jax.jacfwd(oc.exp_twist, argnums=1), in_axes=(0, None))
    second = jax.vmap(jax.jacfwd(jax.jacfwd(oc.exp_twist, argnums=1), argnums=1), in_axes=(0, None))
    reverse = jax.vmap(
        jax.grad(lambda xi, t: jnp.sum(oc.exp_twist(xi, t) ** 2), argnums=1), (0, None)
    )
    xi = jnp.asarray(_random_twists(np.random.default_rng(SEED), 4))
    xi_hat = oc.twist_hat(xi)
    first, second, reverse = quick_jit(lambda x: (first(x, 0.0), second(x, 0.0), reverse(x, 0.0)))(
        xi
    )
    np.testing.assert_allclose(first, xi_hat, atol=1e-15)
    np.testing.assert_allclose(second, xi_hat @ xi_hat, atol=1e-14)
    assert np.all(np.isfinite(reverse))


def test_adjoints():
    rng = np.random.default_rng(SEED)
    for xi, eta in zip(_random_twists(rng, 3), rng.normal(size=(3, 6)), strict=True):
        g = oc.exp_twist(xi, 0.7)
        g_inv = oc.inverse_transform(g)
        np.testing.assert_allclose(g_inv, np.linalg.inv(g), atol=1e-13)
        expected = oc.twist_vee(g @ oc.twist_hat(eta) @ g_inv)
        np.testing.assert_allclose(oc.adjoint(g) @ eta, expected, atol=1e-13)
        np.testing.assert_allclose(oc.inverse_adjoint(g), np.linalg.inv(oc.adjoint(g)), atol=1e-13)


@pytest.mark.parametrize("n", [1, 3, 6])
def test_kinematics_match_pinocchio(n):
    chain = oc.accordion(n) if n != 6 else random_chain(6, SEED)
    model = to_pinocchio(chain)
    data = model.createData()
    fk = quick_jit(oc.forward_kinematics)
    body = quick_jit(oc.body_jacobians)
    for theta in random_states(n, 3, SEED)[0]:
        pin.computeJointJacobians(model, data, theta)
        pin.updateFramePlacements(model, data)
        poses, jacobians = fk(chain, theta), body(chain, theta)
        for i in range(n):
            frame = model.getFrameId(f"flap_{i}")
            assert max_relative_error(poses[i], data.oMf[frame].homogeneous) < PINOCCHIO_RTOL
            reference = pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL)
            reference = reference.reshape(6, n)  # eigenpy returns a 1-column matrix as (6,)
            assert max_relative_error(jacobians[i], reference) < PINOCCHIO_RTOL


def test_jacobians_are_pose_derivatives():
    """``(ġ g⁻¹)^∨ = J^s θ̇`` and ``(g⁻¹ ġ)^∨ = J^b θ̇`` with ġ from autodiff of the poses."""
    chain = random_chain(5, SEED + 1)
    theta, theta_dot, _ = (jnp.asarray(x[0]) for x in random_states(5, 1, SEED))
    poses, pose_dots = jax.jvp(lambda q: oc.forward_kinematics(chain, q), (theta,), (theta_dot,))
    inverse = oc.inverse_transform(poses)
    spatial = oc.twist_vee(pose_dots @ inverse)
    body = oc.twist_vee(inverse @ pose_dots)
    assert (
        max_relative_error(oc.spatial_jacobians(chain, theta) @ theta_dot, spatial) < IDENTITY_RTOL
    )
    assert max_relative_error(oc.body_jacobians(chain, theta) @ theta_dot, body) < IDENTITY_RTOL


def test_accordion_geometry():
    chain = oc.accordion(4)
    assert chain.n_joints == 4
    np.testing.assert_allclose(chain.points[:, 1], [0.0, 200.0, 400.0, 600.0])
    np.testing.assert_allclose(chain.cg_poses[:, 1, 3], [100.0, 300.0, 500.0, 700.0])
    np.testing.assert_allclose(chain.axes, np.tile([1.0, 0.0, 0.0], (4, 1)))
    # Thin plate 200 µm × 200 µm × 200 nm of SiNx (3100 kg/m³ = 3.1e-3 ng/µm³): 24.8 ng.
    np.testing.assert_allclose(chain.masses, 24.8, rtol=1e-14)
    mass = 24.8
    np.testing.assert_allclose(
        np.diag(chain.inertias[0]),
        [mass * (200**2 + 0.2**2) / 12, mass * (200**2 + 0.2**2) / 12, mass * 2 * 200**2 / 12],
        rtol=1e-14,
    )
    # Folding hinge 1 by π/2 about x stands the whole chain up along z.
    poses = quick_jit(oc.forward_kinematics)(chain, jnp.array([jnp.pi / 2, 0.0, 0.0, 0.0]))
    np.testing.assert_allclose(
        poses[:, :3, 3], [[0, 0, 100], [0, 0, 300], [0, 0, 500], [0, 0, 700]], atol=1e-12
    )
    single = oc.accordion(1)
    assert single.n_joints == 1 and single.masses.shape == (1,)
