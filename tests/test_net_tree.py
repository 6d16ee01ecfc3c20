"""Panel trees (`origami_jax.net`): Pinocchio, the serial-chain engine, added inertia, gradients,
rows of states, energy, the flat-pattern builder, the bending-arc hinge and the input checks."""

import functools

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pinocchio as pin
import pytest

import origami_jax.chain as oc
from origami_jax.net import ArcJoints, PanelTree, _batching, panel_tree
from origami_jax.net import _dynamics as net_dynamics
from origami_jax.net._joints import arc_functions
from origami_jax.simulation import SaveAt, SolveOptions, Step, simulate
from origami_jax.system import FoldingSystem, HingeDrag, Hinges

from .chain_cases import FAST_COMPILE, random_chain
from .helpers import max_relative_error
from .tree_cases import (
    BRANCHING,
    pinocchio_dynamics,
    random_states,
    random_tree,
    to_pinocchio,
)

# Pinocchio is an independent C++ implementation (CRBA, RNEA, ABA) in float64; we see ~1e-14
# (forward dynamics: cond(M)·eps), and 1e-10 relative to the largest entry is the target.
PINOCCHIO_RTOL = 1e-10
# The serial chain's engine runs the same algebra in another order (cumulative sums, its planar path
# for the accordion): round-off only.
CHAIN_RTOL = 1e-12
# M from body Jacobians by autodiff: the same model by different algebra, all float64.
REFERENCE_RTOL = 1e-10
# The bias from the Christoffel symbols of that M, its derivatives by central differences (seen:
# 3e-10).
CHRISTOFFEL_RTOL = 1e-8
# Central differences of the poses at step 1e-6 rad: truncation ~1e-12, round-off ~eps·|p|/h ~ 1e-8
# of the position scale.
FD_RTOL = 1e-7
# Energy with zero drag along a solve at rtol 1e-9: the drift stays ~1e-8 of the energy scale.
ENERGY_RTOL = 1e-6

quick_jit = functools.partial(jax.jit, compiler_options=FAST_COMPILE)


@quick_jit
def _dynamics(tree, q, v, tau):
    """M, bias and forward dynamics for rows of states: one compilation per tree shape."""
    return dict(
        mass=jax.vmap(tree.mass_matrix)(q),
        bias=jax.vmap(tree.bias_force)(q, v),
        acceleration=tree.forward_dynamics(q, v, tau),
    )


_inverse_dynamics = quick_jit(lambda tree, q, v, a: jax.vmap(tree.inverse_dynamics)(q, v, a))
_accelerations = quick_jit(lambda tree, q, v, tau: tree.forward_dynamics(q, v, tau))  # (n,), (t, n)


def _compare_with_pinocchio(tree, model, order, *, inverse=False, n_states=3, seed=3):
    q, v, tau = random_states(tree.n_hinges, n_states, seed)
    ours = _dynamics(tree, *(jnp.asarray(x) for x in (q, v, tau)))
    a = np.random.default_rng(seed + 1).normal(scale=1e-3, size=q.shape)
    if inverse:
        ours["inverse"] = _inverse_dynamics(tree, *(jnp.asarray(x) for x in (q, v, a)))
    for k in range(n_states):
        mass, bias, acceleration = pinocchio_dynamics(model, order, q[k], v[k], tau[k])
        assert max_relative_error(ours["mass"][k], mass) < PINOCCHIO_RTOL
        assert max_relative_error(ours["bias"][k], bias) < PINOCCHIO_RTOL
        assert max_relative_error(ours["acceleration"][k], acceleration) < PINOCCHIO_RTOL
        if inverse:
            data = model.createData()
            expected = pin.rnea(model, data, q[k][order], v[k][order], a[k][order])
            assert (
                max_relative_error(ours["inverse"][k], expected[np.argsort(order)]) < PINOCCHIO_RTOL
            )


SMALL = (-1, 0, 0, 1)
TINY = (-1, 0, 0)  # a root with two children


@pytest.fixture(scope="module")
def small_tree():
    """Four panels with anisotropic added inertia and gravity."""
    return random_tree(SMALL, seed=7, added="anisotropic")


@pytest.fixture(scope="module")
def tiny_tree():
    return random_tree(TINY, seed=8)


# ---- Pinocchio ------------------------------------------------------------------------------------


def test_branching_tree_matches_pinocchio():
    """7 panels numbered out of topological order, three children on one panel, tilted axes,
    gravity: M (CRBA), bias (RNEA at zero acceleration), ABA and RNEA."""
    tree = random_tree(BRANCHING, seed=1)
    assert max(sum(1 for p in BRANCHING if p == i) for i in range(len(BRANCHING))) == 3
    _compare_with_pinocchio(tree, *to_pinocchio(tree), inverse=True)


@pytest.mark.slow
def test_isotropic_added_inertia_matches_pinocchio_folded():
    """An added inertia diag(m_a I, J_a I) is a rigid body (mass m_a at the frame origin, inertia
    J_a I): without gravity, Pinocchio with it added to each panel's inertia is the same model.
    With gravity, the added inertia has no weight: the gravity torques are the rigid panels'."""
    tree = random_tree(SMALL, seed=2, added="isotropic", gravity=False)
    _compare_with_pinocchio(tree, *to_pinocchio(tree, fold_isotropic_added=True))
    heavy = random_tree(SMALL, seed=2, added="isotropic")
    light = eqx.tree_at(lambda t: t.added_inertias, heavy, jnp.zeros_like(heavy.added_inertias))
    q = jnp.asarray(random_states(len(SMALL), 1, seed=6)[0])
    zero = jnp.zeros_like(q)
    with_added = _dynamics(heavy, q, zero, zero)["bias"]
    without = _dynamics(light, q, zero, zero)["bias"]
    assert max_relative_error(with_added, without) < 1e-13


@pytest.mark.slow
def test_twenty_panel_tree_matches_pinocchio():
    from .tree_cases import random_parents

    tree = random_tree(random_parents(20, seed=5), seed=6)
    _compare_with_pinocchio(tree, *to_pinocchio(tree))


# The default run keeps the pointer-jumping kinematics equal to the level-by-level ones (below) and
# those against Pinocchio (the branching tree above); this joins the two directly (~20 s).
@pytest.mark.slow
def test_deep_tree_matches_pinocchio():
    """A tree of 7 levels, whose kinematics are composed by pointer jumping
    (`_frames_by_doubling`), against Pinocchio."""
    from .tree_cases import random_parents

    parents = random_parents(12, seed=21, reach=2)
    tree = random_tree(parents, seed=22)
    levels = len(net_dynamics.topology(parents).levels)
    assert levels >= net_dynamics._DOUBLING_MIN_LEVELS
    _compare_with_pinocchio(tree, *to_pinocchio(tree), inverse=True, n_states=2)


@pytest.mark.slow  # a whole program of its own to compile; the default run stays under 10 min
def test_doubling_frames_equal_level_by_level(monkeypatch):
    """Pointer jumping and the level-by-level composition give the same kinematics (displacements,
    world motion subspaces and their derivatives) to round-off, for bending-arc hinges (whose
    subspaces move) on a deep branching tree numbered out of topological order, one state and a
    batch of states."""
    from .tree_cases import random_parents

    parents = random_parents(14, seed=23, reach=3)
    order = np.random.default_rng(24).permutation(14)  # renumber: body order[i] was body i
    renumbered = tuple(-1 if parents[i] < 0 else int(order[parents[i]]) for i in np.argsort(order))
    tree = random_tree(renumbered, seed=25)
    directions = jnp.cross(tree.frames[:, :3, 2], tree.axes)
    lengths = jnp.asarray(np.random.default_rng(26).uniform(0, 40, 14))
    tree = eqx.tree_at(
        lambda t: t.joints, tree, ArcJoints(tree.axes, tree.points, directions, lengths)
    )
    assert len(net_dynamics.topology(renumbered).levels) >= net_dynamics._DOUBLING_MIN_LEVELS
    q = jnp.asarray(np.random.default_rng(27).uniform(-2, 2, (14, 5)))
    for state in (q[:, 0], q):
        data = net_dynamics._ordered(tree, state.ndim - 1)
        # One program each (op by op, every operation would compile its own); the threshold is
        # read when the function is traced, so each wrapper is a fresh trace.
        doubled = jax.jit(lambda x, d=data: net_dynamics.frames(d, x))(state)
        with monkeypatch.context() as patch:
            patch.setattr(net_dynamics, "_DOUBLING_MIN_LEVELS", 10**6)
            levelled = jax.jit(lambda x, d=data: net_dynamics.frames(d, x))(state)
        assert doubled.ds_lin is not None
        for a, b in zip(jax.tree.leaves(doubled), jax.tree.leaves(levelled), strict=True):
            assert a.shape == b.shape
            assert max_relative_error(a, b) < CHAIN_RTOL


# ---- the serial chain -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "make",
    [
        pytest.param(lambda: oc.accordion(3), id="accordion3"),
        pytest.param(
            lambda: random_chain(5, 11, gravity=True), id="random5", marks=pytest.mark.slow
        ),
    ],
)
def test_serial_chain_equals_chain_engine(make):
    """The tree (−1, 0, 1, …) is the serial chain: M, bias and forward dynamics equal the chain
    engine's (its planar path for the accordion)."""
    chain = make()
    tree = PanelTree.from_chain(chain)
    q, v, tau = random_states(chain.n_hinges, 3, seed=4)
    ours = _dynamics(tree, *(jnp.asarray(x) for x in (q, v, tau)))
    reference = quick_jit(
        lambda c, q, v, t: dict(
            mass=jax.vmap(c.mass_matrix)(q),
            bias=jax.vmap(c.bias_force)(q, v),
            acceleration=c.forward_dynamics(q, v, t),
        )
    )(chain, *(jnp.asarray(x) for x in (q, v, tau)))
    for key in ("mass", "bias", "acceleration"):
        assert max_relative_error(ours[key], reference[key]) < CHAIN_RTOL, key


# ---- anisotropic added inertia: an independent formula -------------------------------------------


def _body_frame_inertia(tree, i):
    """Rigid 6×6 inertia of body i about its frame's origin, in its axes, on (v, ω) twists, plus the
    added one."""
    m, c, inertia = tree.masses[i], tree.cgs[i], tree.inertias[i]
    c_hat = jnp.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    rigid = jnp.block([[m * jnp.eye(3), -m * c_hat], [m * c_hat, inertia - m * c_hat @ c_hat]])
    return rigid + tree.added_inertias[i]


def _jacobian_mass_matrix(tree, q):
    """M = Σ J_iᵀ 𝕀_i J_i with body Jacobians J_i from autodiff of the body poses."""
    poses = tree.body_poses(q)
    d_poses = jax.jacfwd(tree.body_poses)(q)  # (b, 4, 4, n)
    total = 0.0
    for i in range(tree.n_bodies):
        rotation = poses[i, :3, :3]
        lin = rotation.T @ d_poses[i, :3, 3, :]
        w_hat = jnp.einsum("ji,jkn->ikn", rotation, d_poses[i, :3, :3, :])  # Rᵀ dR
        ang = jnp.stack([w_hat[2, 1], w_hat[0, 2], w_hat[1, 0]])
        jac = jnp.concatenate([lin, ang])  # (6, n)
        total = total + jac.T @ _body_frame_inertia(tree, i) @ jac
    return total


def _gravity_potential(tree, q):
    poses = tree.body_poses(q)
    cg = poses[:, :3, 3] + jnp.einsum("bij,bj->bi", poses[:, :3, :3], tree.cgs)
    return -jnp.sum(tree.masses * (cg @ tree.gravity))


@quick_jit
def _jacobian_terms(tree, q):
    """M by body Jacobians, and the gravity torque ``∂V/∂q`` from the poses."""
    return _jacobian_mass_matrix(tree, q), jax.grad(lambda x: _gravity_potential(tree, x))(q)


def _reference_dynamics(tree, q, v, h=1e-5):
    """M by Jacobians and the bias from its Christoffel symbols plus the gravity torque,
    ``b = Ṁ v − ½ ∂_q (vᵀ M v) + ∂_q V``, with ``∂M/∂q`` by central differences (step `h` rad:
    truncation ~h², round-off ~eps/h, ~1e-10 relative)."""
    mass, gravity = _jacobian_terms(tree, q)
    d_mass = np.stack(
        [
            (_jacobian_terms(tree, q + h * e)[0] - _jacobian_terms(tree, q - h * e)[0]) / (2 * h)
            for e in np.eye(len(q))
        ],
        axis=-1,
    )  # [i, j, k] = ∂M_ij/∂q_k
    v = np.asarray(v)
    coriolis = np.einsum("ijk,k,j->i", d_mass, v, v) - 0.5 * np.einsum("ijk,i,j->k", d_mass, v, v)
    return mass, coriolis + np.asarray(gravity)


@pytest.mark.slow  # the isotropic case against Pinocchio runs by default
def test_anisotropic_added_inertia_matches_jacobian_formula(small_tree):
    """A general positive semi-definite 6×6 per body (rank 4): M against Σ Jᵢᵀ 𝕀ᵢ Jᵢ with body
    Jacobians by autodiff of `body_poses`, the bias against the Christoffel symbols of that M."""
    tree = small_tree
    q, v, tau = random_states(tree.n_hinges, 2, seed=5)
    ours = _dynamics(tree, *(jnp.asarray(x) for x in (q, v, tau)))
    for k in range(2):
        mass, bias = _reference_dynamics(tree, jnp.asarray(q[k]), jnp.asarray(v[k]))
        assert max_relative_error(ours["mass"][k], mass) < REFERENCE_RTOL
        assert max_relative_error(ours["bias"][k], bias) < CHRISTOFFEL_RTOL


# ---- a tiny tree: gradients, rows of states, poses ------------------------------------------------


@pytest.mark.slow  # ~18 s of compilation; the trees' dynamics are checked in value by default
def test_forward_dynamics_gradients(tiny_tree):
    """Forward and reverse mode against central finite differences, in the states and the forces,
    through `jax.vmap` (its batching rule and the custom derivative rule underneath): the JVP along
    a random direction against the difference quotient (step 1e-6, error O(1e-12) relative to the
    O(1) entries, so 1e-6 leaves room for rounding), and the VJP against the JVP by the adjoint
    identity ``<c, J d> = <Jᵀ c, d>``. The rule (from the inverse dynamics) against plain autodiff
    of the whole algorithm along a direction in the tree's own numbers too (axes, points, masses,
    inertias: what a design gradient moves), to rounding (1e-10). One compiled program
    (`jax.test_util.check_grads` compiled one per mode and evaluation, ~20 s)."""
    q, v, tau = (jnp.asarray(x) for x in random_states(3, 2, seed=8))
    v = v * 10  # make the velocity terms matter
    rng = np.random.default_rng(18)
    direction = tuple(jnp.asarray(rng.normal(size=x.shape)) for x in (q, v, tau))
    cotangent = jnp.asarray(rng.normal(size=q.shape))
    eps = 1e-6
    numbers, rest = eqx.partition(tiny_tree, eqx.is_inexact_array)
    tree_direction = jax.tree_util.tree_map(
        lambda x: jnp.asarray(rng.normal(size=x.shape)), numbers
    )
    # Inertia tensors move symmetrically (a non-symmetric one is no body's: the mass matrix and the
    # inverse dynamics read different halves of it).
    tree_direction = eqx.tree_at(
        lambda t: t.inertias, tree_direction, replace_fn=lambda i: i + jnp.swapaxes(i, -1, -2)
    )

    def accel(q, v, tau):
        return jax.vmap(tiny_tree.forward_dynamics)(q, v, tau)

    def by_rule(numbers):
        return jax.vmap(eqx.combine(numbers, rest).forward_dynamics)(q, v, tau)

    def by_autodiff(numbers):
        return net_dynamics.forward_dynamics(eqx.combine(numbers, rest), q.T, v.T, tau.T).T

    @quick_jit
    def probe(args, direction, cotangent, numbers, tree_direction):
        _, tangent = jax.jvp(accel, args, direction)
        _, pullback = jax.vjp(accel, *args)
        shifted = [
            tuple(x + s * eps * d for x, d in zip(args, direction, strict=True)) for s in (1, -1)
        ]
        quotient = (accel(*shifted[0]) - accel(*shifted[1])) / (2 * eps)
        in_tree = [jax.jvp(f, (numbers,), (tree_direction,))[1] for f in (by_rule, by_autodiff)]
        return tangent, pullback(cotangent), quotient, in_tree

    tangent, back, quotient, in_tree = probe(
        (q, v, tau), direction, cotangent, numbers, tree_direction
    )
    assert max_relative_error(tangent, quotient) < 1e-6
    forward = jnp.sum(cotangent * tangent)
    reverse = sum(jnp.sum(b * d) for b, d in zip(back, direction, strict=True))
    assert abs(float(reverse - forward)) < 1e-12 * max(1.0, abs(float(forward)))
    assert float(jnp.max(jnp.abs(in_tree[1]))) > 0
    assert max_relative_error(*in_tree) < 1e-10


@pytest.mark.slow
def test_rows_vmap_and_single_states_agree(tiny_tree, monkeypatch):
    """`(t, n)` rows (chunked, the last chunk padded), `jax.vmap` of the single-state call (its
    batching rule) and the single states are the same numbers."""
    monkeypatch.setattr(_batching, "CHUNK", 3)  # 7 states: two full chunks and a padded one
    q, v, tau = (jnp.asarray(x) for x in random_states(3, 7, seed=9))
    rows = _accelerations(tiny_tree, q, v, tau)
    mapped = quick_jit(jax.vmap(tiny_tree.forward_dynamics))(q, v, tau)
    single = jnp.stack([_accelerations(tiny_tree, q[k], v[k], tau[k]) for k in range(7)])
    assert max_relative_error(rows, single) < 1e-13
    assert max_relative_error(mapped, single) < 1e-13


@pytest.mark.slow
def test_dense_solve_for_large_trees(tiny_tree, monkeypatch):
    """Trees whose sparse factorization would unroll too far solve with LAPACK's Cholesky: the same
    accelerations, for one state and for rows."""
    q, v, tau = (jnp.asarray(x) for x in random_states(3, 2, seed=16))
    sparse = _accelerations(tiny_tree, q, v, tau)
    monkeypatch.setattr(net_dynamics, "_UNROLL_MAX_WORK", 0)
    dense = quick_jit(
        lambda t, q, v, f: (t.forward_dynamics(q, v, f), t.forward_dynamics(q[0], v[0], f[0]))
    )
    rows, one = dense(tiny_tree, q, v, tau)
    assert max_relative_error(rows, sparse) < 1e-13
    assert max_relative_error(one, sparse[0]) < 1e-13


def test_vmap_over_trees_falls_back(tiny_tree):
    """A batch of trees (here: masses) goes through plain vmap and still gives each tree's answer."""
    q, v, tau = (jnp.asarray(x[0]) for x in random_states(3, 1, seed=10))

    def scaled(s):
        return eqx.tree_at(lambda t: t.masses, tiny_tree, tiny_tree.masses * s)

    trees = jax.vmap(scaled)(jnp.array([1.0, 2.0]))
    batched = quick_jit(jax.vmap(lambda t: t.forward_dynamics(q, v, tau)))(trees)
    for k, s in enumerate((1.0, 2.0)):
        assert max_relative_error(batched[k], _accelerations(scaled(s), q, v, tau)) < 1e-13


def test_kinetic_energy_from_body_velocities(small_tree):
    """½ vᵀ M v equals Σ over bodies of ½ m |v_cg|² + ½ ωᵀ I ω + ½ νᵀ 𝕀_added ν from
    `body_velocities` (ν the body-frame twist)."""
    q, v, _ = (jnp.asarray(x[0]) for x in random_states(4, 1, seed=11))

    @quick_jit
    def both(tree, q, v):
        poses = tree.body_poses(q)
        lin, ang = tree.body_velocities(q, v)
        total = 0.0
        for i in range(tree.n_bodies):
            rotation = poses[i, :3, :3]
            v_cg = lin[i] + jnp.cross(ang[i], rotation @ tree.cgs[i])
            w_body = rotation.T @ ang[i]
            twist = jnp.concatenate([rotation.T @ lin[i], w_body])
            total = total + 0.5 * (
                tree.masses[i] * v_cg @ v_cg
                + w_body @ tree.inertias[i] @ w_body
                + twist @ tree.added_inertias[i] @ twist
            )
        return tree.kinetic_energy(q, v), total

    ours, reference = both(small_tree, q, v)
    assert abs(ours - reference) < 1e-12 * abs(reference)


def test_body_poses_derivative_matches_finite_differences(tiny_tree):
    q = jnp.asarray(random_states(3, 1, seed=12)[0][0])
    poses = jax.jit(lambda q: tiny_tree.body_poses(q))
    jac = jax.jit(jax.jacfwd(tiny_tree.body_poses))(q)
    h = 1e-6
    for k in range(3):
        step = jnp.zeros(3).at[k].set(h)
        central = (poses(q + step) - poses(q - step)) / (2 * h)
        assert max_relative_error(jac[..., k], central) < FD_RTOL


def test_inverse_of_forward_dynamics(tiny_tree):
    q, v, tau = (jnp.asarray(x[0]) for x in random_states(3, 1, seed=13))
    a = _accelerations(tiny_tree, q, v, tau)
    back = quick_jit(lambda t, q, v, a: t.inverse_dynamics(q, v, a))(tiny_tree, q, v, a)
    assert max_relative_error(back, tau) < 1e-10


# ---- the flat-pattern builder: a cube net ---------------------------------------------------------

L = 100.0  # µm
SQUARE = np.array([[0.0, 0.0, 0.0], [L, 0.0, 0.0], [L, L, 0.0], [0.0, L, 0.0]])


def cube_net(**kwargs):
    """The cross-shaped cube net: the base square [0, L]² fixed, four sides hinged to it (south,
    east, north, west) and the lid hinged to the north side. Each hinge axis runs along its crease
    the way the child's counter-clockwise outline does (valley positive)."""
    shift = np.array
    outlines = [
        SQUARE + shift([0, -L, 0]),  # south
        SQUARE + shift([L, 0, 0]),  # east
        SQUARE + shift([0, L, 0]),  # north
        SQUARE + shift([-L, 0, 0]),  # west
        SQUARE + shift([0, 2 * L, 0]),  # lid
    ]
    axes = np.array([[-1, 0, 0], [0, -1, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0]], dtype=float)
    points = np.array([[0, 0, 0], [L, 0, 0], [0, L, 0], [0, 0, 0], [0, 2 * L, 0]])
    return panel_tree(
        (-1, -1, -1, -1, 2),
        axes,
        points,
        outlines,
        thickness=0.2,
        density=3.1e-3,
        base_outline=SQUARE,
        **kwargs,
    )


def test_cube_net_folds_into_a_cube():
    """Every crease at +90° (valley) closes the net into the cube [0, L]³: every panel corner lands
    on a cube corner, and the lid covers the top."""
    tree = cube_net()
    polygons = tree.panel_polygons(np.full(5, np.pi / 2))
    corners = np.concatenate(polygons)
    assert np.allclose(np.round(corners / L) * L, corners, atol=1e-9 * L)
    assert set(map(tuple, np.round(corners / L).astype(int))) == {
        (x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)
    }
    assert np.allclose(polygons[4][:, 2], L)  # the lid


def test_builder_frames_masses_and_valley_sign():
    """Body frames at the CG with z the panel normal; outlines come back in body frames; mass ρ t A;
    a small positive (valley) angle lifts every child towards +z."""
    tree = cube_net()
    rest = tree.panel_polygons(np.zeros(5))
    np.testing.assert_allclose(rest[2], SQUARE + [0, L, 0], atol=1e-12 * L)
    np.testing.assert_allclose(tree.masses, 3.1e-3 * 0.2 * L * L, rtol=1e-14)
    np.testing.assert_allclose(np.asarray(tree.frames[:, :3, 2]), np.tile([0, 0, 1.0], (5, 1)))
    lifted = np.asarray(tree.body_poses(jnp.full(5, 0.1)))[:, 2, 3]
    assert np.all(lifted > 0)
    np.testing.assert_allclose(tree.base_outline(), SQUARE)


def test_builder_rejects_a_mountain_axis():
    with pytest.raises(ValueError, match=r"hinge_axes\[1\] turns panel 1 down"):
        panel_tree(
            (-1, -1),
            np.array([[-1.0, 0, 0], [0, 1, 0]]),
            np.array([[0.0, 0, 0], [L, 0, 0]]),
            [SQUARE + [0, -L, 0], SQUARE + [L, 0, 0]],
            thickness=0.2,
            density=3.1e-3,
        )


# ---- energy: a folding simulation ----------------------------------------------------------------


@pytest.fixture(scope="module")
def cube_trajectory():
    tree = cube_net()
    stiffness = 2e4  # ng·µm²/µs² per rad: a ~1 rad/µs panel oscillation
    target = jnp.array([1.0, 1.2, 0.8, 1.1, 0.9])
    hinges = Hinges(stiffness, target, radius=50.0)
    system = FoldingSystem(tree, hinges, HingeDrag(jnp.zeros(5)))
    # An explicit controller: `simulate`'s default one is annotated for Python floats, which
    # run-time type checking rejects for the array tolerances it passes.
    solution = simulate(
        system,
        Step(),
        SolveOptions(
            saveat=SaveAt(n=81),
            solver=diffrax.Tsit5(),
            stepsize_controller=diffrax.PIDController(rtol=1e-9, atol=1e-12),
        ),
        t1=8.0,
    )
    return system, solution


@pytest.mark.slow  # energy balance is checked on the chain engine and through contact by default
def test_simulation_conserves_energy_without_drag(cube_trajectory):
    """With zero drag, kinetic + spring energy minus the step input's work ``Σ k θ_target θ`` is
    conserved; the folding swings every hinge past its target."""
    system, solution = cube_trajectory
    energy = jax.vmap(system.energy)(solution.theta, solution.theta_dot)
    work = solution.theta @ (system.hinges.stiffness * system.hinges.target)
    total = np.asarray(energy - work)
    scale = float(
        np.max(
            np.asarray(
                jax.vmap(system.mechanism.kinetic_energy)(solution.theta, solution.theta_dot)
            )
        )
    )
    assert scale > 0
    assert np.max(np.abs(total - total[0])) < ENERGY_RTOL * scale
    assert np.all(np.max(solution.theta, axis=0) > np.asarray(system.hinges.target))


# ---- the bending-arc hinge ------------------------------------------------------------------------


def test_arc_functions_series_and_closed_forms_agree():
    """Series (|q| < 1) and closed forms meet at |q| = 1; values and derivatives at 0 are the
    limits (1, 0, ½) and (0, 1/6, 0)."""
    below, above = jnp.array([0.999999999, -0.999999999]), jnp.array([1.000000001, -1.000000001])
    for a, b in zip(arc_functions(below), arc_functions(above), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-8)
    q = jnp.array([0.3, 0.9])
    exact = (np.sin(q) / q, (q - np.sin(q)) / q**2, (1 - np.cos(q)) / q**2)
    for ours, reference in zip(arc_functions(q), exact, strict=True):
        np.testing.assert_allclose(ours, reference, rtol=1e-14)
    values = arc_functions(jnp.zeros(1))
    np.testing.assert_allclose([float(x[0]) for x in values], [1.0, 0.0, 0.5], atol=0)
    slopes = [jax.grad(lambda q, k=k: arc_functions(q)[k])(0.0) for k in range(3)]
    np.testing.assert_allclose(slopes, [0.0, 1 / 6, 0.0], atol=1e-17)
    curvature = jax.grad(jax.grad(lambda q: arc_functions(q)[2]))(0.0)
    np.testing.assert_allclose(curvature, -1 / 12, rtol=1e-15)


STRIP = 40.0  # µm


def _arc_tree():
    """A panel on a point crease (strip length 0) carrying a second panel on a bending strip."""
    square = SQUARE * 0.8
    return panel_tree(
        (-1, 0),
        np.array([[1.0, 0, 0], [1, 0, 0]]),
        np.array([[0.0, 0, 0], [0, 80, 0]]),
        [square, square + [0, 80.0 + STRIP, 0]],
        thickness=0.2,
        density=3.1e-3,
        hinge_lengths=np.array([0.0, STRIP]),
        gravity=np.array([0.0, 3e-6, -9.8e-6]),
    )


def _fine_chain(arc, n_links):
    """The arc's strip as n_links short rigid links (hinges at the midpoints of n equal pieces,
    tiny masses), the panels as in `arc`, all point creases."""
    axes = [np.asarray(arc.axes[0])] + [np.asarray(arc.axes[1])] * n_links
    start, direction = np.asarray(arc.points[1]), np.array([0.0, 1.0, 0.0])
    points = [np.asarray(arc.points[0])] + [
        start + (k + 0.5) * STRIP / n_links * direction for k in range(n_links)
    ]
    frames = np.asarray(arc.frames)
    link_frames = np.tile(np.eye(4), (n_links, 1, 1))
    link_frames[:, :3, 3] = np.array(points[1:])
    tiny = 1e-10 * float(arc.masses[1])
    return PanelTree(
        tuple(range(-1, n_links + 1)),
        np.array(axes + [np.asarray(arc.axes[1])])[: n_links + 2],
        np.array(points + [start + STRIP * direction])[: n_links + 2],
        np.concatenate([frames[:1], link_frames, frames[1:]]),
        np.concatenate(
            [np.asarray(arc.masses[:1]), np.full(n_links, tiny), np.asarray(arc.masses[1:])]
        ),
        None,
        np.concatenate(
            [
                np.asarray(arc.inertias[:1]),
                np.tile(tiny * np.eye(3), (n_links, 1, 1)),
                np.asarray(arc.inertias[1:]),
            ]
        ),
        gravity=arc.gravity,
    )


@pytest.mark.slow  # the strip's limit runs by default (test_strip.py)
def test_arc_hinge_is_the_limit_of_short_rigid_links():
    """The bending strip against n short rigid links folding together (θ_k = q/n, a holonomic
    constraint with Jacobian J): the panel's pose, ``M`` (vs ``Jᵀ M J``) and the bias (vs
    ``Jᵀ b``, which holds the Ṡ q̇ terms) converge as 1/n² (midpoint rule), the extra last link
    of the chain being rigidly attached (its hinge never turns)."""
    arc = _arc_tree()
    q = jnp.array([0.7, 2.1])
    v = jnp.array([0.3, -0.8])
    mass, bias = quick_jit(lambda t, q, v: (t.mass_matrix(q), t.bias_force(q, v)))(arc, q, v)
    pose = np.asarray(jax.jit(lambda q: arc.body_poses(q))(q))[1]
    values, errors = [], []
    for n in (4, 8, 16):
        chain = _fine_chain(arc, n)
        model, order = to_pinocchio(chain)
        jac = np.zeros((n + 2, 2))
        jac[0, 0] = 1.0
        jac[1 : n + 1, 1] = 1.0 / n  # the last hinge (strip end to panel) stays at 0
        theta, theta_dot = jac @ np.asarray(q), jac @ np.asarray(v)
        m_chain, b_chain, _ = pinocchio_dynamics(model, order, theta, theta_dot, np.zeros(n + 2))
        data = model.createData()
        pin.forwardKinematics(model, data, theta[order])
        placement = data.oMi[int(np.argsort(order)[n + 1]) + 1]
        rest_joint = pin.SE3(np.eye(3), np.asarray(chain.points[n + 1])).homogeneous
        chain_pose = (
            placement.homogeneous @ np.linalg.inv(rest_joint) @ np.asarray(chain.frames[n + 1])
        )
        value = (chain_pose, jac.T @ m_chain @ jac, jac.T @ b_chain)
        values.append(value)
        errors.append(
            [max_relative_error(a, b) for a, b in zip((pose, mass, bias), value, strict=True)]
        )
    errors = np.array(errors)
    assert np.all(errors[-1] < 1e-3), errors
    assert np.all(errors[:-1] / errors[1:] > 3.5), errors  # second order
    # Richardson extrapolation of the last two removes the 1/n² term: what is left is O(1/n⁴)
    # (~1e-6 here) plus the links' tiny masses (1e-10): the limit is the arc hinge.
    for ours, coarse, fine in zip((pose, mass, bias), values[1], values[2], strict=True):
        assert max_relative_error(ours, (4 * fine - coarse) / 3) < 2e-5


# ---- input checks ---------------------------------------------------------------------------------


def _tree_arguments(n=3):
    tree = random_tree(tuple(range(-1, n - 1)), seed=0)
    return dict(
        parents=tree.parents,
        axes=np.asarray(tree.axes),
        points=np.asarray(tree.points),
        frames=np.asarray(tree.frames),
        masses=np.asarray(tree.masses),
        cgs=np.asarray(tree.cgs),
        inertias=np.asarray(tree.inertias),
    )


def _build(**changes):
    arguments = _tree_arguments()
    keywords = {
        k: changes.pop(k) for k in ("added_inertias", "gravity", "arc_lengths") if k in changes
    }
    arguments.update(changes)
    return PanelTree(*arguments.values(), **keywords)


@pytest.mark.parametrize(
    "changes, message",
    [
        (dict(parents=(-1, 2, 1)), r"cycle \(1 → 2 → 1\)"),
        (dict(parents=(-1, 1, 0)), r"parents\[1\] = 1: a panel cannot be its own parent"),
        (dict(parents=(-1, 0, 3)), r"parents\[2\] = 3 is out of range"),
        (dict(parents=(-1, 0.0, 1)), r"parents\[1\] must be an integer"),
        (dict(parents=()), "parents is empty"),
        (dict(axes=np.ones((2, 3))), r"axes must have shape \(3, 3\)"),
        (dict(axes=np.array([[2.0, 0, 0], [0, 1, 0], [0, 0, 1]])), r"axes\[0\] has norm 2"),
        (dict(masses=np.array([1.0, -1.0, 1.0])), "masses must be positive"),
        (dict(inertias=np.tile(np.diag([1.0, 1.0, -1.0]), (3, 1, 1))), "not positive definite"),
        (dict(added_inertias=-np.tile(np.eye(6), (3, 1, 1))), "not positive semi-definite"),
        (dict(added_inertias=np.tile(np.triu(np.ones((6, 6))), (3, 1, 1))), "not symmetric"),
        (dict(frames=np.tile(np.diag([1.0, 1.0, -1.0, 1.0]), (3, 1, 1))), "rigid transforms"),
        (dict(arc_lengths=np.ones(3)), "is not in the plane of panel"),
    ],
)
def test_bad_trees_are_rejected(changes, message):
    with pytest.raises(ValueError, match=message):
        _build(**changes)


def test_bad_states_are_rejected(tiny_tree):
    with pytest.raises(ValueError, match=r"shape \(3,\) or \(t, 3\)"):
        tiny_tree.forward_dynamics(jnp.zeros(4), jnp.zeros(4), jnp.zeros(4))


def test_arc_joints_match_revolute_at_zero_length():
    """A strip of length 0 is the point crease."""
    tree = random_tree(SMALL, seed=14)
    zero = ArcJoints(
        tree.axes, tree.points, jnp.cross(tree.frames[:, :3, 2], tree.axes), jnp.zeros(4)
    )
    q = jnp.asarray(random_states(4, 1, seed=15)[0][0])
    for a, b in zip(
        jax.tree_util.tree_leaves((zero.transform(q), zero.motion(q))),
        jax.tree_util.tree_leaves((tree.joints.transform(q), tree.joints.motion(q))),
        strict=True,
    ):
        np.testing.assert_allclose(a, jnp.broadcast_to(b, a.shape), rtol=1e-15, atol=1e-13)
