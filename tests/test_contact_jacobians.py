"""The plate contact's closest points, its Gauss–Newton force derivatives, the collision check that
iterates a few pairs, and the fixed-step engine's Gauss–Newton Newton matrix.

Independent references: the squared distances of `point_polygon_sq` (a separate formula), the
gaps' gradient by automatic differentiation of `_gaps` (the distance functions, not the closest
points), and `additive_ccd_groups` iterating every pair. Tolerances: distances and derivatives to
1e-9 relative (rounding of sums of a few hundred pairs); times of impact to 1e-12 (the same
arithmetic on a subset).
"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.contact._barrier import _barrier_curvature, smoothstep, smoothstep_slope
from origami_jax.contact._primitives import (
    additive_ccd_groups,
    closest_on_polygon,
    earliest_impact,
    point_polygon_sq,
    polygon_normal,
)
from origami_jax.net import load_net

from .test_plate_contact import random_ccd_groups

SCALE = 0.5  # the catalogue's cube net at half scale: 100 µm panels


def test_closest_point_on_a_polygon_gives_its_distance_and_lies_on_it():
    rng = np.random.default_rng(0)
    # A tilted pentagon (convex, counter-clockwise) and points above, beside and in its plane.
    angles = np.sort(rng.uniform(0, 2 * np.pi, 5))
    flat = np.stack([np.cos(angles), np.sin(angles), np.zeros(5)], axis=1)
    c, s = np.cos(0.4), np.sin(0.4)
    rotation = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    polygon = jnp.asarray(np.broadcast_to(flat @ rotation.T + [0.3, -0.2, 0.5], (200, 5, 3)))
    points = jnp.asarray(rng.uniform(-2, 2, (200, 3)))
    normal = polygon_normal(polygon)
    closest = closest_on_polygon(points, polygon, normal)
    np.testing.assert_allclose(
        np.sum((points - closest) ** 2, axis=-1),
        point_polygon_sq(points, polygon, normal),
        rtol=1e-10,
        atol=1e-14,
    )
    # On the polygon: in its plane, and on the inner side of every edge.
    local = (np.asarray(closest) - [0.3, -0.2, 0.5]) @ rotation
    assert np.abs(local[:, 2]).max() < 1e-12
    for a, b in zip(flat, np.roll(flat, -1, axis=0), strict=True):
        inward = np.cross([0, 0, 1], b - a)
        assert np.min((local - a) @ inward) > -1e-12
    # Some points project inside, others onto edges or corners.
    inside = np.isclose(np.asarray(point_polygon_sq(points, polygon, normal)), 0) | (
        np.abs(np.asarray(jnp.sum((points - closest) * normal, -1)) ** 2)
        > np.asarray(point_polygon_sq(points, polygon, normal)) * (1 - 1e-9)
    )
    assert 10 < inside.sum() < 190


def test_iterating_a_few_pairs_bounds_the_earliest_impact_from_below():
    groups = random_ccd_groups()
    arrays = [(start, motion, sep) for _, start, motion, sep in groups]
    kinds = [g[0] for g in groups]

    @jax.jit
    def answers(arrays):
        groups = [(d, *a) for d, a in zip(kinds, arrays, strict=True)]
        still = [(d, s, tuple(0 * m for m in motion), sep) for d, s, motion, sep in groups]
        return (
            additive_ccd_groups(groups),
            earliest_impact(groups, limit=40),
            earliest_impact(groups, limit=1),
            earliest_impact(still, limit=4),
        )

    every, enough, few, none = (np.asarray(x) for x in answers(arrays))
    truth = np.min(np.where(every > 0, every, np.inf))
    assert 0 < truth < 1
    # Enough pairs iterated: the same earliest impact.
    assert float(enough) == pytest.approx(truth, rel=1e-12)
    # One pair of each kind: a lower bound (the others' first advances), still positive.
    assert 0 < float(few) <= truth
    # Nothing moving: no impact.
    assert float(none) == np.inf


@functools.cache
def _engaged_state():
    """The half-scale cube net 0.5 % short of closed (creases off by up to 0.06°), a velocity, and
    its system: rims within the activation gap of each other."""
    net = load_net("cube_net_01", length_scale=SCALE)
    system = net.system()
    rng = np.random.default_rng(3)
    q = jnp.asarray(net.intended_angles) * 0.995 + jnp.asarray(rng.uniform(-1e-3, 1e-3, 5))
    v = jnp.asarray(rng.normal(size=5)) * 0.01
    return system, q, v


@eqx.filter_jit
def _derivatives(contact, mechanism, q, v):
    force, d_dq, d_dv = contact.force_jacobians(mechanism, q, v)
    gaps = lambda q: contact._gaps(contact.vertices(mechanism, q))[0]  # noqa: E731
    gap, gradient = gaps(q), jax.jacfwd(gaps)(q)
    return force, d_dq, d_dv, gap, gradient, contact.force(mechanism, q, v)


def test_gauss_newton_derivatives_from_the_gaps_gradient():
    system, q, v = _engaged_state()
    contact = system.contact
    force, d_dq, d_dv, gap, gradient, plain = _derivatives(contact, system.mechanism, q, v)
    np.testing.assert_allclose(force, plain, rtol=1e-12, atol=0)
    ratio = gap / contact.activation
    engaged = np.asarray(ratio < 1)
    assert engaged.sum() > 0
    # ∂f/∂v is exact (the force is linear in v through the damping): −Gᵀ diag(c a) G, with G the
    # gaps' gradient by automatic differentiation of the distances.
    damping = contact.damping * smoothstep(1 - ratio)
    expected_dv = -gradient.T @ (damping[:, None] * gradient)
    scale = np.abs(expected_dv).max()
    assert scale > 0
    np.testing.assert_allclose(d_dv, expected_dv, rtol=1e-9, atol=1e-9 * scale)
    # ∂f/∂q: the barrier's curvature and the damping's ramp along the same gradient (the
    # mollifier, 1 on these pairs but near-parallel seams, taken from the gaps' own output).
    _, mollifier = contact._gaps(contact.vertices(system.mechanism, q))
    n_vf = len(contact.tables.vertex_face)
    weight = jnp.concatenate([jnp.ones(n_vf), mollifier])
    rate = gradient @ v
    stiffness = (
        contact.stiffness * weight * _barrier_curvature(ratio) / contact.activation**2
        - contact.damping * smoothstep_slope(1 - ratio) * rate / contact.activation
    )
    expected_dq = -gradient.T @ (jnp.maximum(stiffness, 0.0)[:, None] * gradient)
    np.testing.assert_allclose(d_dq, expected_dq, rtol=1e-9, atol=1e-9 * np.abs(expected_dq).max())
    # Symmetric, negative semi-definite (a restoring stiffness).
    np.testing.assert_allclose(d_dq, np.asarray(d_dq).T, rtol=0, atol=1e-9 * scale)
    assert np.linalg.eigvalsh(np.asarray(d_dq)).max() < 1e-9 * np.abs(np.asarray(d_dq)).max()


def test_the_newton_matrix_is_chosen_by_name():
    with pytest.raises(ValueError, match="jacobian"):
        sim.ImplicitStep(dt=1.0, jacobian="newton")
    system, _, _ = _engaged_state()
    from origami_jax.simulation._implicit import _gauss_newton_applies

    assert _gauss_newton_applies(system, sim.ImplicitStep(dt=1.0))
    assert not _gauss_newton_applies(system, sim.ImplicitStep(dt=1.0, jacobian="exact"))
    sampled = load_net("cube_net_01", length_scale=SCALE).system(contact="sampled")
    assert not _gauss_newton_applies(sampled, sim.ImplicitStep(dt=1.0))


@pytest.mark.slow  # two fixed-step folds of a cube net to compile and run: ~60 s
def test_gauss_newton_and_exact_newton_matrices_fold_a_cube_net_alike():
    """`cube_net_01` in KOH to 1500 µs in steps of 2.5 µs: both Newton matrices close the cube,
    their final crease angles within 1e-3 rad (one step at the walls' meeting converges less
    tightly with the Gauss–Newton matrix, 8e-4 rad against 1e-5, and the fold carries that on;
    the mid-fold difference stays below 0.02 rad)."""
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    # The paper's dynamics in the bath: no fluid inertia, released at once.
    net = load_net("cube_net_01").with_model(added_mass=False, viscous=False)
    system = net.system(HingeDesign.literature(fluid=KOH_SOLUTION), contact="plate")
    runs = {}
    for name in ("gauss-newton", "exact"):
        options = sim.SolveOptions(
            saveat=sim.SaveAt(n=31), solver=sim.ImplicitStep(dt=2.5, jacobian=name)
        )
        trajectory = eqx.filter_jit(sim.simulate)(system, sim.Step(), options, t1=1500.0)
        assert net.assess(system, trajectory).verdict == "folded"
        runs[name] = np.asarray(trajectory.theta)
        assert float(trajectory.stats["newton_error"]) < 2e-3
    assert np.abs(runs["gauss-newton"][-1] - runs["exact"][-1]).max() < 1e-3
    assert np.abs(runs["gauss-newton"] - runs["exact"]).max() < 0.02


@pytest.mark.parametrize("kind", ["net", "closed loops"])
def test_unit_twists_are_the_wrench_maps_transpose(kind):
    """The contact's twists per unit generalized velocity, read off the mechanism's wrench map
    (`_unit_twists`, no second evaluation of the kinematics), equal forward-mode differentiation of
    the bodies' twists, for a net's tree and for a crease pattern's loops (whose cut creases move
    no body), to round-off."""
    from origami_jax.contact._plates import _unit_twists
    from origami_jax.loops import load_pattern

    if kind == "net":
        mechanism = load_net("cube_net_01", length_scale=SCALE).system().mechanism
    else:
        mechanism = load_pattern("miura_3x3").system().mechanism
    rng = np.random.default_rng(5)
    q = jnp.asarray(rng.uniform(-0.5, 0.5, mechanism.n_hinges))
    v = jnp.asarray(rng.normal(size=mechanism.n_hinges))

    @jax.jit
    def both(q, v):
        _, twists, wrench_force = mechanism.body_motion(q, v)
        by_map = _unit_twists(wrench_force, twists.shape[0], v.dtype)
        return by_map, jax.jacfwd(lambda v: mechanism.spatial_velocities(q, v))(v)

    by_map, differentiated = both(q, v)
    assert by_map.shape == differentiated.shape
    scale = float(np.abs(differentiated).max())
    np.testing.assert_allclose(by_map, differentiated, rtol=0, atol=1e-13 * scale)
