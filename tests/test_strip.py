"""Bending-arc hinges with mass (`origami_jax.net.StripTree`): the strip against a fine chain of short
rigid links (evaluated by Pinocchio), the quadrature, the point-hinge limit against the chain engine,
and contact at the folded arc's offset."""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from origami_jax.chain import accordion_system
from origami_jax.net import PanelTree, StripTree, panel_tree, strip_tree
from origami_jax.system import HingeDesign

from .chain_cases import FAST_COMPILE
from .helpers import max_relative_error
from .tree_cases import pinocchio_dynamics, to_pinocchio

quick_jit = functools.partial(jax.jit, compiler_options=FAST_COMPILE)

STRIP = 60.0  # µm, the arc hinge's strip length
WIDTH = 80.0  # µm, the strip's width (along its crease)
THICKNESS = 0.3  # µm, membrane + film
AREAL = 1.34e-3  # ng/µm², 200 nm SiNx + 100 nm Cr
SQUARE = np.array([[0.0, -40.0, 0], [80, -40, 0], [80, 40, 0], [0, 40, 0]])


def _panels():
    """Panel 0 turns about −y (a point crease at x = 0); panel 1 hangs from panel 0's edge y = 40
    on a bending strip along x. The two hinges are perpendicular, so the strip moves in 3-D (its
    rotary inertia about every axis counts) and gravity pulls it sideways."""
    return panel_tree(
        (-1, 0),
        np.array([[0.0, -1, 0], [1, 0, 0]]),
        np.array([[0.0, 0, 0], [0, 40, 0]]),
        [SQUARE, SQUARE + [0, 80 + STRIP, 0]],
        thickness=0.2,
        density=3.1e-3,
        hinge_lengths=np.array([0.0, STRIP]),
        gravity=np.array([2e-6, 3e-6, -9.8e-6]),
    )


def _strip(nodes: int) -> StripTree:
    return strip_tree(_panels(), areal_density=AREAL, width=WIDTH, thickness=THICKNESS, nodes=nodes)


def _combine(mass, cg, inertia, extra_mass, at, extra_inertia):
    """Two rigid bodies as one: mass, CG and inertia about the new CG (parallel axes)."""
    total = mass + extra_mass
    centre = (mass * cg + extra_mass * at) / total

    def shift(m, d):
        return m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))

    return (
        total,
        centre,
        inertia + shift(mass, cg - centre) + extra_inertia + shift(extra_mass, at - centre),
    )


def _fine_chain(panels: PanelTree, n: int) -> PanelTree:
    """The strip as ``n`` straight links with point hinges at ``s = (k + ½) l/n``, each turning
    ``q/n``, the panel on one more hinge at the strip's end (never turned). The strip's mass is
    lumped by the trapezoid rule at ``s = k l/n`` (``k = 0 … n``), with the cross-section's rotary
    inertia: node ``k ≥ 1`` rides on link ``k − 1`` at ``½ l/n`` from its hinge (where its
    orientation ``k q/n`` is the arc's at ``s``), node 0 on panel 0 (it never moves relative to it).
    Both the positions and the lumping are second-order accurate in ``1/n``."""
    start, direction = np.array([40.0, 40.0, 0.0]), np.array([0.0, 1.0, 0.0])
    hinge_points = [start + (k + 0.5) * STRIP / n * direction for k in range(n)]
    strip_mass = AREAL * WIDTH * STRIP
    weights = np.full(n + 1, 1.0 / n)
    weights[[0, -1]] = 0.5 / n
    unit = np.diag([THICKNESS**2, WIDTH**2 + THICKNESS**2, WIDTH**2]) / 12
    frames = np.asarray(panels.frames)
    masses, cgs = np.asarray(panels.masses).copy(), np.zeros((2, 3))
    inertias = np.asarray(panels.inertias).copy()
    # Node 0 (at the crease, s = 0) on panel 0, in panel 0's body frame.
    node0 = frames[0, :3, :3].T @ (start - frames[0, :3, 3])
    m0, c0, i0 = _combine(
        masses[0],
        cgs[0],
        inertias[0],
        weights[0] * strip_mass,
        node0,
        frames[0, :3, :3].T @ (weights[0] * strip_mass * unit) @ frames[0, :3, :3],
    )
    link_frames = np.tile(np.eye(4), (n, 1, 1))
    link_frames[:, :3, 3] = hinge_points
    link_masses = weights[1:] * strip_mass
    return PanelTree(
        tuple(range(-1, n + 1)),
        np.array([[0.0, -1, 0]] + [[1.0, 0, 0]] * (n + 1)),
        np.array([[0.0, 0, 0]] + hinge_points + [start + STRIP * direction]),
        np.concatenate([frames[:1], link_frames, frames[1:]]),
        np.concatenate([[m0], link_masses, masses[1:]]),
        np.concatenate([[c0], np.tile([0, 0.5 * STRIP / n, 0], (n, 1)), cgs[1:]]),
        np.concatenate([[i0], link_masses[:, None, None] * unit, inertias[1:]]),
        gravity=panels.gravity,
    )


def test_strip_is_the_limit_of_short_rigid_links():
    """The massive strip against ``n`` short massive links (``θ_k = q/n``, a holonomic constraint
    with Jacobian ``J``), evaluated by Pinocchio: ``M`` (vs ``Jᵀ M J``) and the bias (vs ``Jᵀ b``)
    converge as ``1/n²`` (n = 4 … 32); Richardson extrapolation of the two finest chains meets the
    strip model to 5e-6 (what is left is O(1/n⁴), ~2e-6 here, plus the strip quadrature, 1e-9)."""
    tree = _strip(8)
    q, v = jnp.array([0.7, 2.3]), jnp.array([0.3, -0.8])
    mass, bias = quick_jit(lambda t, q, v: (t.mass_matrix(q), t.bias_force(q, v)))(tree, q, v)
    massless = quick_jit(lambda t, q: t.mass_matrix(q))(tree.panels, q)
    # The strip is not negligible here: it changes M by a fifth or more.
    assert max_relative_error(mass, massless) > 0.2
    values, errors = [], []
    for n in (4, 8, 16, 32):
        chain = _fine_chain(tree.panels, n)
        model, order = to_pinocchio(chain)
        jac = np.zeros((n + 2, 2))
        jac[0, 0] = 1.0
        jac[1 : n + 1, 1] = 1.0 / n
        theta, theta_dot = jac @ np.asarray(q), jac @ np.asarray(v)
        m_chain, b_chain, _ = pinocchio_dynamics(model, order, theta, theta_dot, np.zeros(n + 2))
        values.append((jac.T @ m_chain @ jac, jac.T @ b_chain))
        errors.append(
            [max_relative_error(a, b) for a, b in zip((mass, bias), values[-1], strict=True)]
        )
    errors = np.array(errors)
    assert np.all(errors[-1] < 1.5e-3), errors
    assert np.all(errors[:-1] / errors[1:] > 3.5), errors  # second order
    for ours, coarse, fine in zip((mass, bias), values[-2], values[-1], strict=True):
        assert max_relative_error(ours, (4 * fine - coarse) / 3) < 5e-6


@pytest.mark.slow
def test_strip_quadrature_and_forward_dynamics():
    """Six nodes per strip (the default) against sixteen: the strip's part of ``M`` agrees to 1e-7
    relative at ``q = π`` and 1e-4 at ``2π`` (Gauss–Legendre on an analytic integrand; measured 4e-8
    and 3e-5); forward dynamics is
    ``M⁻¹ (f − bias)`` and inverse dynamics its inverse (round-off)."""
    coarse, fine = _strip(6), _strip(16)
    evaluate = quick_jit(lambda t, q: t.mass_matrix(q) - t.panels.mass_matrix(q))
    for angle, tolerance in ((np.pi, 1e-7), (2 * np.pi, 1e-4)):
        q = jnp.array([0.4, angle])
        assert max_relative_error(evaluate(coarse, q), evaluate(fine, q)) < tolerance
    q, v, f = jnp.array([0.4, 1.9]), jnp.array([0.2, -0.5]), jnp.array([30.0, -20.0])
    acc, mass, bias, back = quick_jit(
        lambda t, q, v, f: (
            t.forward_dynamics(q, v, f),
            t.mass_matrix(q),
            t.bias_force(q, v),
            t.inverse_dynamics(q, v, t.forward_dynamics(q, v, f)),
        )
    )(coarse, q, v, f)
    np.testing.assert_allclose(acc, np.linalg.solve(mass, f - bias), rtol=1e-12)
    np.testing.assert_allclose(back, f, rtol=1e-10)
    rows = quick_jit(lambda t, q, v, f: t.forward_dynamics(q, v, f))(
        coarse, jnp.stack([q, q]), jnp.stack([v, v]), jnp.stack([f, f])
    )
    np.testing.assert_allclose(rows, jnp.stack([acc, acc]), rtol=1e-12)


@pytest.mark.parametrize("bad", [dict(nodes=0), dict(width=-1.0), dict(areal_density=np.ones(3))])
def test_strip_tree_rejects_bad_input(bad):
    arguments = dict(areal_density=AREAL, width=WIDTH, thickness=THICKNESS) | bad
    with pytest.raises(ValueError, match="nodes|width|areal_density"):
        strip_tree(_panels(), **arguments)
    with pytest.raises(ValueError, match="arc hinges"):
        strip_tree(_fine_chain(_panels(), 2), areal_density=AREAL, width=WIDTH, thickness=0.3)


# ---- the accordion: point-hinge limit, geometry, contact ------------------------------------------


def _accordion_at(radius_um: float):
    """The literature accordion with arc hinges of radius ``ρ`` (strain scaled to get it) and the
    paper's stiffness and drag held at the point-hinge values: ``ρ → 0`` at fixed ``k``."""
    point = accordion_system(HingeDesign.literature(), 3)
    base = HingeDesign.literature()
    design = HingeDesign.literature(
        misfit_strain=base.misfit_strain * float(base.radius()) / radius_um
    )
    arc = accordion_system(design, 3, hinges="arc")
    arc = eqx.tree_at(
        lambda s: (s.hinges.stiffness, s.drag.coefficient),
        arc,
        (point.hinges.stiffness, point.drag.coefficient),
    )
    return point, arc


def test_point_hinge_limit_reproduces_the_chain_engine():
    """As the arc's radius shrinks at fixed ``k`` and ``b``, the arc accordion's accelerations tend
    to the chain engine's (the paper's model) linearly in ``ρ``: the strip's length and mass both
    vanish. Checked at random states, folded past π included."""
    rng = np.random.default_rng(3)
    q = jnp.asarray(rng.uniform(-4, 4, (4, 3)))
    v = jnp.asarray(rng.normal(scale=0.05, size=(4, 3)))
    rhs = quick_jit(
        lambda s, q, v: jax.vmap(lambda a, b: s.accelerations(a, b, s.hinges.stiffness * 3.0))(q, v)
    )
    errors = []
    for radius in (1.0, 0.1, 0.01):
        point, arc = _accordion_at(radius)
        assert isinstance(arc.mechanism, StripTree)
        errors.append(max_relative_error(rhs(arc, q, v), rhs(point, q, v)))
    errors = np.array(errors)
    assert errors[-1] < 5e-4, errors  # ρ = 10 nm: the strip is 30 nm long, 1.5e-4 of a flap
    np.testing.assert_allclose(errors[:-1] / errors[1:], 10.0, rtol=0.2)  # first order in ρ


@pytest.mark.slow  # a folding with arc hinges
def test_folded_arc_accordion_stacks_at_twice_the_radius():
    """At the targets ``(π, −π, π)`` each flap lies parallel to the one before, reversed, ``2ρ``
    above it (the strip a semicircle), over the base's membrane; contact sees that gap (the flap
    lands at the arc's offset). A point hinge puts them at zero, in contact."""
    design = HingeDesign.literature()
    system = accordion_system(design, 3, hinges="arc", contact=True)
    radius = float(design.radius())
    q = jnp.array([np.pi, -np.pi, np.pi])
    poses = np.asarray(system.mechanism.body_poses(q))
    np.testing.assert_allclose(poses[:, 2, 3], 2 * radius * np.arange(1, 4), rtol=1e-12)
    normals = poses[:, :3, 2]
    np.testing.assert_allclose(normals, [[0, 0, -1], [0, 0, 1], [0, 0, -1]], atol=1e-12)
    np.testing.assert_allclose(poses[:, 1, 3], -0.5 * 200.0, rtol=1e-12)  # the 200 µm flaps
    gap, coverage = system.contact.gaps(system.mechanism, q)
    thickness = float(design.t_structural)
    flap1_on_base = np.asarray(gap[0, 3])[np.asarray(coverage[0, 3]) > 0.5]
    # (the contact model smooths |z| at 1e-6 of its activation gap, ~1e-6 µm here)
    np.testing.assert_allclose(flap1_on_base, 2 * radius - thickness, atol=2e-6)
    # Folded to π the arc's flaps do not touch: no contact energy. With point hinges they would lie
    # inside each other's activation layer.
    assert float(system.contact.potential(system.mechanism, q)) == 0.0
    point = accordion_system(design, 3, contact=True)
    assert float(point.contact.potential(point.mechanism, q)) > 0.0
