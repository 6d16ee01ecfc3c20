"""Panel drag: quadrature, the strip-theory closed form for a flap about its hinge, dissipation, and
the paper's hinge drag as its special case."""

import jax
import jax.numpy as jnp
import numpy as np

from origami_jax.chain import accordion, accordion_system
from origami_jax.fluid import PanelDrag, polygon_quadrature
from origami_jax.system import HingeDesign

# The quadrature is exact for polynomials up to degree 5 (Radon's rule on every sub-triangle):
# a flap about its hinge has v_n ∝ r, so its drag torque integrand |v_n| v_n r ∝ r³ is exact.
EXACT_RTOL = 1e-12


def test_quadrature_integrates_polynomials_exactly():
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]])
    points, weights = polygon_quadrature(square, subdivisions=2)
    np.testing.assert_allclose(weights.sum(), 6.0, rtol=1e-14)
    x, y = points[:, 0], points[:, 1]
    np.testing.assert_allclose(np.sum(weights * x**3 * y**2), (2**4 / 4) * (3**3 / 3), rtol=1e-13)
    triangle = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    points, weights = polygon_quadrature(triangle, subdivisions=1)
    # ∫ x⁵ over the unit right triangle = 1/42.
    np.testing.assert_allclose(np.sum(weights * points[:, 0] ** 5), 1 / 42, rtol=1e-13)


def test_single_flap_about_its_hinge_is_the_strip_formula():
    design = HingeDesign.literature()
    chain = accordion(1, flap_length=200.0, flap_width=150.0)
    density, c_d = float(design.fluid.density), 1.17
    drag = PanelDrag.for_mechanism(chain, coefficient=c_d, density=density)
    for q, omega in ((0.3, 0.02), (2.0, -0.05)):
        torque = drag.force(chain, jnp.array([q]), jnp.array([omega]))
        length = 200.0 + 1e-4  # `Chain.outlines` reads the length from the plate inertia
        expected = -c_d * density * (length * 150.0) * length**3 * omega * abs(omega) / 8
        np.testing.assert_allclose(torque, [expected], rtol=1e-6)
    # scale=0.5 is the paper's /16.
    paper = PanelDrag.for_mechanism(chain, coefficient=c_d, density=density, scale=0.5)
    b = float(HingeDesign.literature().drag(1, 200.0, 150.0)[0])
    np.testing.assert_allclose(
        paper.force(chain, jnp.array([0.3]), jnp.array([0.1])), [-b * 0.01], rtol=1e-5
    )


def test_panel_drag_dissipates_and_sees_absolute_motion():
    system = accordion_system(HingeDesign.literature(), 3)
    chain = system.mechanism
    drag = PanelDrag.for_mechanism(
        chain, coefficient=1.17, density=system.mechanism.masses[0] * 0 + 1.2e-6
    )
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = jnp.asarray(rng.uniform(-3, 3, 3))
        v = jnp.asarray(rng.normal(scale=0.05, size=3))
        assert float(v @ drag.force(chain, q, v)) < 0
    # Hinge 2 still, hinge 1 turning: flaps 2 and 3 are dragged through the fluid too (the paper's
    # hinge drag has no torque on hinge 2 then).
    force = drag.force(chain, jnp.array([0.5, 0.0, 0.0]), jnp.array([0.05, 0.0, 0.0]))
    assert abs(float(force[1])) > 0
    # Its generalized force is the power-consistent one: f · v = Σ F_p · v_p (autodiff check).
    q, v = jnp.array([0.3, -0.4, 0.9]), jnp.array([0.02, 0.01, -0.03])
    ours = drag.force(chain, q, v)
    reference = jax.grad(lambda w: jnp.sum(_point_power(drag, chain, q, v, w)))(jnp.zeros(3))
    np.testing.assert_allclose(ours, reference, rtol=1e-10)


def test_panel_drag_of_a_net_is_the_point_by_point_power():
    # A tree with non-parallel hinges (a cube net): panels turn about their own creases and are
    # carried by their parents. The kernel works in each panel's frame; the reference sums the
    # point forces in the world frame (`_point_power`). Rounding only: 1e-10 relative.
    from origami_jax.net import load_net

    system = load_net("cube_net_01").system(HingeDesign.literature())
    tree, drag = system.mechanism, system.drag
    rng = np.random.default_rng(1)
    for _ in range(3):
        q = jnp.asarray(rng.uniform(-1.5, 1.5, tree.n_hinges))
        v = jnp.asarray(rng.normal(scale=0.05, size=tree.n_hinges))
        ours = drag.force(tree, q, v)
        reference = jax.grad(lambda w, q=q, v=v: jnp.sum(_point_power(drag, tree, q, v, w)))(
            jnp.zeros(tree.n_hinges)
        )
        np.testing.assert_allclose(ours, reference, rtol=1e-10, atol=1e-10 * np.max(np.abs(ours)))


def _point_power(drag, chain, q, v, w):
    """Σ_p F_p(q, v) · (velocity of point p under rates w), with F_p frozen at (q, v)."""
    poses = chain.body_poses(q)
    body = np.asarray(drag.quadrature.body)
    rot, org = poses[body, :3, :3], poses[body, :3, 3]
    x = jnp.einsum("pij,pj->pi", rot, drag.quadrature.points) + org
    n = jnp.einsum("pij,pj->pi", rot, drag.quadrature.normals)

    def point_velocity(rates):
        twist = chain.spatial_velocities(q, rates)[body]
        return twist[:, :3] + jnp.cross(twist[:, 3:], x)

    vn = jnp.sum(point_velocity(v) * n, axis=-1)
    coefficient = jnp.broadcast_to(drag.coefficient, (chain.n_bodies,))[body] * drag.scale
    force = (-0.5 * coefficient * drag.density * vn * jnp.abs(vn) * drag.quadrature.weights)[
        :, None
    ] * n
    return jnp.sum(jax.lax.stop_gradient(force) * point_velocity(w), axis=-1)
