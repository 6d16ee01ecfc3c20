"""Adhesion and friction at plate contacts (issue #48, parts 1 and 2), each against a closed form
written here, on a minimal mechanism: one square plate translating (three coordinates, no hinge)
over a fixed square base, under a constant body load (a tilted gravity) and a linear drag.

Tolerances, and why:
- `EXACT` (1e-10 relative): closed forms the model reproduces exactly (two equal stacked plates,
  two edges along each other), up to rounding and the gaps' ``1e-6 ĝ`` smoothing at zero.
- `DYNAMIC` (1e-4 relative): quantities read off an integrated trajectory (diffrax Tsit5 at rtol
  1e-10 after the normal transient has decayed by e⁻¹⁰ or more).
- the quadrature of a plate on a larger base: the stated cell-band bound (test's comment).
- derivatives against central differences: 1e-6 relative (a step of 1e-5 of the scale; the
  truncation error of C² functions).
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import quad

from origami_jax.contact import Adhesion, Friction, PlateContact
from origami_jax.net import load_net
from origami_jax.simulation import ImplicitStep, UserTorque
from origami_jax.simulation._implicit import integrate, steps_per_interval
from origami_jax.system import (
    MICRO,
    AbstractMechanism,
    FoldingSystem,
    HingeDrag,
    HingeLayout,
    Hinges,
)

EXACT = 1e-10
DYNAMIC = 1e-4
THICKNESS = 0.2  # µm, both plates
ACTIVATION = 0.2  # ĝ, µm


def phi(x):
    """The adhesion profile written independently: 1 − (10x³ − 15x⁴ + 6x⁵) on [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return 1 - (10 * x**3 - 15 * x**4 + 6 * x**5)


def square(side, centre=(0.0, 0.0)):
    h = side / 2
    cx, cy = centre
    return np.array(
        [[cx - h, cy - h, 0], [cx + h, cy - h, 0], [cx + h, cy + h, 0], [cx - h, cy + h, 0]]
    )


class Slider(AbstractMechanism):
    """One square plate of side `side`, parallel to a fixed square base of side `base` in the
    plane z = 0, translating: ``q = (x, y, z − height)``, the plate's centre at ``(x, y, height +
    q₂)`` (so the flat state ``q = 0`` is `height` clear of the base). Mass `mass`, a constant body
    acceleration `load` `(3,)` (a gravity: potential ``−m load · q``), a linear drag `drag` (in
    `bias_force`: only dissipates)."""

    side: float = eqx.field(static=True)
    base: float = eqx.field(static=True)
    height: float = eqx.field(static=True)
    base_centre: tuple = eqx.field(static=True, default=(0.0, 0.0))
    mass: jax.Array = eqx.field(converter=jnp.asarray, default=1.0)
    load: jax.Array = eqx.field(converter=jnp.asarray, default=(0.0, 0.0, 0.0))
    drag: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    hinged: bool = eqx.field(static=True, default=False)

    # `hinged`: one idle hinge (no angle, no force, its crease far away), for what needs a
    # `FoldingSystem` (its `Hinges` take at least one).

    @property
    def n_hinges(self):
        return int(self.hinged)

    @property
    def n_bodies(self):
        return 1

    @property
    def n_coordinates(self):
        return 3

    @property
    def n_velocities(self):
        return 3

    def hinge_angles(self, q):
        return jnp.zeros(self.n_hinges, q.dtype)

    def hinge_rates(self, q, v):
        return jnp.zeros(self.n_hinges, q.dtype)

    def hinge_force(self, q, tau):
        return jnp.zeros(3, q.dtype)

    def mass_matrix(self, q):
        return self.mass * jnp.eye(3, dtype=q.dtype)

    def bias_force(self, q, v):
        return -self.mass * self.load + self.drag * v

    def potential_energy(self, q):
        return -self.mass * self.load @ q

    def body_poses(self, q):
        pose = jnp.eye(4, dtype=q.dtype)
        return pose.at[:3, 3].set(q + jnp.array([0.0, 0.0, self.height]))[None]

    def outlines(self):
        return [square(self.side)]

    def hinge_layout(self):
        h = self.n_hinges
        far = np.array([[[1e4, 1e4, 0.0], [1e4 + 1, 1e4, 0.0]]])
        return HingeLayout(
            np.full(h, -1), np.zeros(h, int), np.tile([[1.0, 0.0, 0.0]], (h, 1)), far[:h]
        )

    def base_outline(self):
        return square(self.base, self.base_centre)


def plate_contact(mechanism, *, stiffness=1.0, damping=1.0, adhesion=None, friction=None):
    return PlateContact.from_mechanism(
        mechanism,
        thickness=THICKNESS,
        stiffness=stiffness,
        damping=damping,
        activation=ACTIVATION,
        adhesion=adhesion,
        friction=friction,
    )


def at_gap(mechanism, gap, x=0.0, y=0.0):
    """The state whose plate is `gap` above the base (mid-surfaces ``gap + t`` apart)."""
    return jnp.array([x, y, gap + THICKNESS - mechanism.height])


@eqx.filter_jit
def _potential(contact, mechanism, q):
    return contact.potential(mechanism, q)


@eqx.filter_jit
def _force(contact, mechanism, q, v):
    return contact.force(mechanism, q, v)


def adhesive_energy(contact, mechanism, q):
    bare = contact.with_surface(mechanism, friction=contact.friction)
    return float(_potential(contact, mechanism, q) - _potential(bare, mechanism, q))


def simulate(contact, mechanism, q0, t1, *, ts, rtol=1e-10):
    """Integrate ``m q̈ = f_contact − bias`` (diffrax Tsit5), states `(len(ts), 6)` at `ts`."""

    def field(t, y, args):
        q, v = y[:3], y[3:]
        force = contact.force(mechanism, q, v)
        return jnp.concatenate([v, mechanism.forward_dynamics(q, v, force)])

    solution = diffrax.diffeqsolve(
        diffrax.ODETerm(field),
        diffrax.Tsit5(),
        0.0,
        t1,
        1e-3,
        jnp.concatenate([q0, jnp.zeros(3)]),
        saveat=diffrax.SaveAt(ts=jnp.asarray(ts)),
        stepsize_controller=diffrax.PIDController(rtol=rtol, atol=rtol * 1e-2),
        max_steps=200_000,
    )
    return np.asarray(solution.ys)


# ---- adhesion ----


def test_units_of_the_work_of_adhesion():
    # MICRO's energy per area, µN·µm/µm², is 1 J/m²; its energy per length, µN, is 1e-6 J/m.
    adhesion = Adhesion.from_si(MICRO, work=0.05, range=0.4e-6, line=2e-8)
    assert float(adhesion.work) == pytest.approx(0.05, rel=1e-12)
    assert float(adhesion.range) == pytest.approx(0.4, rel=1e-12)
    assert float(adhesion.line) == pytest.approx(0.02, rel=1e-12)
    with pytest.raises(ValueError, match="range"):
        Adhesion(work=0.05, range=0.0)
    mechanism = Slider(side=20.0, base=20.0, height=5.0)
    unattached = eqx.tree_at(
        lambda c: c.adhesion, plate_contact(mechanism), Adhesion(work=1.0, range=1.0),
        is_leaf=lambda x: x is None,
    )  # fmt: skip
    with pytest.raises(ValueError, match="surface"):
        unattached.potential(mechanism, at_gap(mechanism, 0.1))


@pytest.mark.parametrize("gap", [0.0, 0.05, 0.2, 0.5, 0.79, 0.9])
def test_equal_stacked_plates_adhere_with_work_times_area(gap):
    w, delta, side = 0.05, 0.8, 20.0
    mechanism = Slider(side=side, base=side, height=5.0)
    contact = plate_contact(mechanism, adhesion=Adhesion(work=w, range=delta))
    got = adhesive_energy(contact, mechanism, at_gap(mechanism, gap))
    expected = -w * side**2 * phi(gap / delta)
    assert got == pytest.approx(expected, rel=EXACT, abs=EXACT * w * side**2)
    if gap == 0.05:  # the report carries the adhesive energy
        report = contact.report(mechanism, at_gap(mechanism, gap))
        assert float(report["adhesion"]) == pytest.approx(got, rel=1e-12)


def test_plate_on_a_larger_base_adheres_within_the_quadrature():
    # A 20 µm plate wholly over a 60 µm base, gap g: the overlap is the plate, A = 400 µm². The
    # plate's own points sum to ½ w A φ(g/δ) exactly. The base's give ½ w A φ(g/δ) plus a halo:
    # its points beside the plate, at a lateral distance ℓ from its rim, are sqrt(ℓ² + (g + t)²)
    # from it, so the model's energy converges, as the cells shrink, to
    #     −w A φ(g/δ) − ½ w (P ∫ φ_ℓ dℓ + 2π ∫ r φ_r dr)
    # (P the perimeter; φ_ℓ = φ((sqrt(ℓ² + (g + t)²) − t)/δ); the corners quarter discs), and
    # differs from it by at most ½ w × the band of base cells the rim cuts (P × a cell's side).
    w, delta, side, base, gap = 0.05, 0.8, 20.0, 60.0, 0.1
    mechanism = Slider(side=side, base=base, height=5.0, base_centre=(0.3, -0.2))
    q = at_gap(mechanism, gap, x=1.7, y=2.9)

    def profile(r):
        return phi((np.sqrt(r**2 + (gap + THICKNESS) ** 2) - THICKNESS) / delta)

    rim = quad(profile, 0, 2 * delta)[0]
    corners = quad(lambda r: r * profile(r), 0, 2 * delta)[0]
    halo = 0.5 * w * (4 * side * rim + 2 * np.pi * corners)
    expected = -w * side**2 * phi(gap / delta) - halo
    errors = []
    for samples in (4, 16):
        contact = plate_contact(mechanism, adhesion=Adhesion(work=w, range=delta, samples=samples))
        got = adhesive_energy(contact, mechanism, q)
        assert abs(got - expected) <= 0.5 * w * 4 * side * base / samples
        errors.append(abs(got / expected - 1))
    assert errors[-1] < 0.01  # 0.5 % with 16² cells per fan triangle


def test_edge_on_face_has_no_face_adhesion():
    # A 20 µm plate beside a 20 µm base, coplanar, its edge `gap` from the base's edge, sliding
    # `shift` along it: the face points sit a third of a cell inside the rims, so only the line
    # adhesion of the two parallel edges acts, −γ (L − shift) φ(g/δ).
    w, gamma, delta, side = 0.05, 0.02, 0.8, 20.0
    mechanism = Slider(side=side, base=side, height=5.0)
    for gap, shift in ((0.0, 0.0), (0.1, 3.0), (0.4, 7.5), (0.85, 1.0)):
        q = jnp.array([side + THICKNESS + gap, shift, -mechanism.height])
        faces = plate_contact(mechanism, adhesion=Adhesion(work=w, range=delta))
        assert adhesive_energy(faces, mechanism, q) == 0.0
        seams = plate_contact(mechanism, adhesion=Adhesion(work=w, range=delta, line=gamma))
        expected = -gamma * (side - shift) * phi(gap / delta)
        got = adhesive_energy(seams, mechanism, q)
        assert got == pytest.approx(expected, rel=EXACT, abs=EXACT * gamma * side)


def test_the_seams_of_a_closed_cube_bond():
    # A cube has 12 edges; its net of six 100 µm squares folds 5 of them as creases, so closing
    # it brings 7 pairs of edges together along their length: line adhesion −7 γ L at closure
    # (mid-surface edges coincide: φ = 1), 0 flat (nothing is stuck before it folds), and no
    # face adhesion between perpendicular panels (their points are far from each other's faces).
    gamma, side = 0.02, 100.0
    net = load_net("cube_net_01", length_scale=0.5)
    system = net.system()
    mechanism = system.mechanism
    contact = system.contact.with_surface(
        mechanism, adhesion=Adhesion(work=0.05, range=0.4, line=gamma)
    )
    closed = jnp.asarray(net.intended_angles)
    bare = system.contact
    energies = [
        float(_potential(contact, mechanism, q) - _potential(bare, mechanism, q))
        for q in (0 * closed, 0.5 * closed, closed)
    ]
    assert energies[0] == 0.0 and energies[1] == 0.0
    assert energies[2] == pytest.approx(-7 * gamma * side, rel=EXACT)


@pytest.mark.parametrize("fraction", [0.9, 1.1])
def test_adhesion_holds_below_its_pull_off_force_and_releases_above(fraction):
    # With δ/2 ≥ ĝ the largest force adhesion resists is where the barrier is off: the slope of
    # −w A φ(g/δ) at g = δ/2, F_max = w A max|φ'| / δ = 15 w A / (8 δ) (closer in the barrier only
    # pushes). An overdamped plate pulled by F = 0.9 F_max settles within δ/2; by 1.1 F_max it
    # leaves past δ.
    w, delta, side = 0.05, 0.8, 20.0
    pull_off = 15 * w * side**2 / (8 * delta)
    mechanism = Slider(side=side, base=side, height=5.0, drag=200.0)
    contact = plate_contact(mechanism, adhesion=Adhesion(work=w, range=delta))
    pulled = eqx.tree_at(lambda m: m.load, mechanism, jnp.array([0.0, 0.0, fraction * pull_off]))
    gap0 = 0.5 * ACTIVATION
    states = simulate(contact, pulled, at_gap(mechanism, gap0), 60.0, ts=[30.0, 60.0], rtol=1e-8)
    gaps = states[:, 2] + mechanism.height - THICKNESS
    if fraction < 1:
        assert np.all(gaps < delta / 2) and abs(states[-1, 5]) < 1e-6
    else:
        assert gaps[-1] > 2 * delta and gaps[-1] > gaps[0]


# ---- friction ----


def incline(angle, *, coefficient=0.3, slip=0.01, side=20.0, base=100.0, hinged=False):
    """A plate resting on a base tilted by `angle` (gravity 1 µm/µs² turned by it), its contact
    with friction, and the state resting at the normal load's equilibrium gap."""
    load = np.array([np.sin(angle), 0.0, -np.cos(angle)])
    mechanism = Slider(side=side, base=base, height=5.0, load=load, hinged=hinged)
    contact = plate_contact(
        mechanism,
        stiffness=0.02,
        damping=2.0,
        friction=Friction(coefficient=coefficient, slip=slip),
    )
    return mechanism, contact


def energy(contact, mechanism, state):
    q, v = jnp.asarray(state[:3]), jnp.asarray(state[3:])
    return float(
        mechanism.kinetic_energy(q, v)
        + mechanism.potential_energy(q)
        + _potential(contact, mechanism, q)
    )


def test_a_plate_slides_down_an_incline_steeper_than_the_friction_angle():
    mu = 0.3
    angle = np.arctan(1.5 * mu)
    mechanism, contact = incline(angle, coefficient=mu)
    ts = np.linspace(0.0, 10.0, 41)
    states = simulate(contact, mechanism, at_gap(mechanism, 0.07), 10.0, ts=ts)
    # After the normal transient (t ≥ 4): the plate slides faster than ε_v, friction is μ N.
    expected = np.sin(angle) - mu * np.cos(angle)
    late = ts >= 4
    slope = np.polyfit(ts[late], states[late, 3], 1)[0]
    assert slope == pytest.approx(expected, rel=DYNAMIC)
    assert np.all(states[late, 3] > 10 * float(contact.friction.slip))
    assert np.all(np.abs(states[late, 4]) < 1e-12)
    energies = [energy(contact, mechanism, s) for s in states]
    assert np.all(np.diff(energies) <= 1e-8 * abs(energies[0]))
    # And frictionless it accelerates at g sin θ.
    free = eqx.tree_at(lambda c: c.friction, contact, None, is_leaf=lambda x: x is None)
    states = simulate(free, mechanism, at_gap(mechanism, 0.07), 10.0, ts=ts)
    assert np.polyfit(ts[late], states[late, 3], 1)[0] == pytest.approx(np.sin(angle), rel=DYNAMIC)


def test_a_plate_sticks_on_an_incline_below_the_friction_angle():
    # Stuck, it creeps where the mollified friction balances the load: μ N f₁(u/ε_v) = m g sin θ,
    # f₁(y) = 2y − y² (y = u/ε_v < 1), so u = ε_v (1 − sqrt(1 − tan θ/μ)), < ε_v.
    mu, slip, t1 = 0.3, 0.01, 20.0
    angle = np.arctan(0.5 * mu)
    mechanism, contact = incline(angle, coefficient=mu, slip=slip)
    ts = np.linspace(0.0, t1, 41)
    states = simulate(contact, mechanism, at_gap(mechanism, 0.07), t1, ts=ts)
    creep = slip * (1 - np.sqrt(1 - np.tan(angle) / mu))
    assert states[-1, 3] == pytest.approx(creep, rel=DYNAMIC)
    assert np.all(np.abs(states[:, 3]) < slip) and abs(states[-1, 0]) < slip * t1
    energies = [energy(contact, mechanism, s) for s in states]
    assert np.all(np.diff(energies) <= 1e-8 * abs(energies[0]))


def _no_torque(t, theta, theta_dot):
    return jnp.zeros(1)


@eqx.filter_jit
def _implicit(system, ts, q0, solver, steps):
    inputs = UserTorque(fn=_no_torque)
    q, v, _, _ = integrate(system, inputs, solver, jnp.zeros(()), ts, q0, jnp.zeros(3), steps)
    return q, v, jax.vmap(system.energy)(q, v)


# The sticking case (0.5) integrates long enough to see the creep: ~25 s, in the slow suite.
@pytest.mark.parametrize("ratio", [pytest.param(0.5, marks=pytest.mark.slow), 1.5])
def test_the_implicit_step_takes_friction_in_its_residual(ratio):
    # `ImplicitStep` puts the full generalized force, friction included, into its implicit-Euler
    # residual at v = (q − q_n)/h. Steady motion is a fixed point of the scheme: the same closed
    # forms as the explicit integration, a velocity growing by h a per step (sliding) and the
    # creep speed (sticking); backward Euler only damps the transient.
    mu, slip, dt = 0.3, 0.01, 0.05
    angle = np.arctan(ratio * mu)
    mechanism, contact = incline(angle, coefficient=mu, slip=slip, hinged=True)
    system = FoldingSystem(
        mechanism=mechanism,
        hinges=Hinges(stiffness=[1.0], target=[0.0], radius=[1.0]),
        drag=HingeDrag([0.0]),
        contact=contact,
    )
    ts = jnp.linspace(0.25, 20.0, 80)
    solver = ImplicitStep(dt=dt)
    steps = steps_per_interval(solver, 0.0, np.asarray(ts))
    q, v, energies = map(np.asarray, _implicit(system, ts, at_gap(mechanism, 0.07), solver, steps))
    late = np.asarray(ts) >= 10
    if ratio > 1:
        slope = np.polyfit(np.asarray(ts)[late], v[late, 0], 1)[0]
        assert slope == pytest.approx(np.sin(angle) - mu * np.cos(angle), rel=DYNAMIC)
    else:
        creep = slip * (1 - np.sqrt(1 - np.tan(angle) / mu))
        assert v[-1, 0] == pytest.approx(creep, rel=DYNAMIC)
    assert np.all(np.diff(energies) <= 1e-8 * abs(energies[0]))


def _friction_force(contact, mechanism, q, v):
    free = eqx.tree_at(lambda c: c.friction, contact, None, is_leaf=lambda x: x is None)
    return _force(contact, mechanism, q, v) - _force(free, mechanism, q, v)


def test_friction_never_adds_energy_on_random_states():
    rng = np.random.default_rng(7)
    mechanism, contact = incline(0.3)
    for _ in range(20):
        q = at_gap(mechanism, rng.uniform(0.01, 0.19), *rng.uniform(-30, 30, 2))
        v = jnp.asarray(rng.normal(size=3) * 10.0 ** rng.uniform(-4, 0))
        power = float(v @ _friction_force(contact, mechanism, q, v))
        assert power <= 1e-15
    # Rotating bodies: a cube net folded near closure, its seams touching, random rates.
    net = load_net("cube_net_01", length_scale=0.5)
    system = net.system()
    closing = system.contact.with_surface(
        system.mechanism, friction=Friction(coefficient=0.5, slip=1e-3)
    )
    q = jnp.asarray(net.intended_angles) * 0.995 + jnp.asarray(rng.uniform(-1e-3, 1e-3, 5))
    for _ in range(5):
        v = jnp.asarray(rng.normal(size=5) * 1e-2)
        f = _friction_force(closing, system.mechanism, q, v)
        assert float(jnp.max(jnp.abs(f))) > 0 and float(v @ f) <= 1e-15


# ---- derivatives and defaults ----


@eqx.filter_jit
def _jacobian(contact, mechanism, state):
    """``∂f/∂(q, v)`` `(3, 6)` by forward mode (reverse mode: `_objective`'s gradient)."""
    return jax.jacfwd(lambda s: contact.force(mechanism, s[:3], s[3:]))(state)


@eqx.filter_jit
def _objective(contact, mechanism, q, v, parameters):
    """A scalar through both models' parameters: ``|f|² + E`` at ``(q, v)``."""
    work, mu = parameters
    c = eqx.tree_at(lambda c: (c.adhesion.work, c.friction.coefficient), contact, (work, mu))
    return jnp.sum(c.force(mechanism, q, v) ** 2) + c.potential(mechanism, q)


@eqx.filter_jit
def _batched(contact, mechanism, qs, v, works):
    """The force over a batch of states, and over a batch of works of adhesion."""
    over_states = jax.vmap(lambda q: contact.force(mechanism, q, v))(qs)

    def with_work(work):
        return eqx.tree_at(lambda c: c.adhesion.work, contact, work).force(mechanism, qs[0], v)

    return over_states, jax.vmap(with_work)(works)


def _central(f, x, step):
    """Central differences of `f` at `x` `(n,)` along each axis, `(n, ...)`."""
    rows = []
    for i in range(x.shape[0]):
        e = jnp.zeros_like(x).at[i].set(step)
        rows.append((np.asarray(f(x + e)) - np.asarray(f(x - e))) / (2 * step))
    return np.stack(rows)


@pytest.mark.slow  # ~55 s on 2 cores: forward and reverse derivatives compiled through both
def test_gradients_through_adhesion_and_friction_match_central_differences():
    w, mu, delta = 0.05, 0.3, 0.8
    mechanism = Slider(side=20.0, base=20.0, height=5.0)
    contact = plate_contact(
        mechanism,
        adhesion=Adhesion(work=w, range=delta, line=0.01),
        friction=Friction(coefficient=mu, slip=0.01),
    )
    step = 1e-5
    # Adhesion alone (the barrier is off beyond ĝ = 0.2; the offset plate's edges lie along the
    # base's, so line adhesion acts too): at rest the force is −∇E.
    q = at_gap(mechanism, 0.3, x=0.4, y=-0.2)
    gradient = jax.grad(lambda q: _potential(contact, mechanism, q))(q)
    force = _force(contact, mechanism, q, jnp.zeros(3))
    np.testing.assert_allclose(force, -gradient, rtol=1e-12, atol=1e-14)
    central = _central(lambda q: _potential(contact, mechanism, q), q, step)
    np.testing.assert_allclose(gradient, central, rtol=1e-6, atol=1e-9)
    # In contact and sliding (|u_t| ≫ ε_v): the force's Jacobian in q and v.
    q = at_gap(mechanism, 0.1, x=0.4, y=-0.2)
    v = jnp.array([0.3, -0.2, 0.05])
    state = jnp.concatenate([q, v])
    jacobian = _jacobian(contact, mechanism, state)
    central = _central(lambda s: _force(contact, mechanism, s[:3], s[3:]), state, step).T
    np.testing.assert_allclose(jacobian, central, rtol=1e-6, atol=1e-6 * np.max(np.abs(central)))
    # And in the parameters: work of adhesion and friction coefficient.
    parameters = jnp.array([w, mu])
    grads = jax.grad(lambda p: _objective(contact, mechanism, q, v, p))(parameters)
    central = _central(lambda p: _objective(contact, mechanism, q, v, p), parameters, 1e-6)
    assert np.all(np.isfinite(grads)) and np.all(np.abs(grads) > 0)
    np.testing.assert_allclose(grads, central, rtol=1e-6)
    # Batches: vmap over states and over parameters gives each member's own force.
    qs = jnp.stack([q, at_gap(mechanism, 0.15, x=-0.3), at_gap(mechanism, 0.5)])
    works = jnp.array([w, 2 * w, 0.0])
    over_states, over_works = _batched(contact, mechanism, qs, v, works)
    for i in range(3):
        single = eqx.tree_at(lambda c: c.adhesion.work, contact, works[i])
        np.testing.assert_allclose(over_states[i], _force(contact, mechanism, qs[i], v), rtol=1e-12)
        np.testing.assert_allclose(over_works[i], _force(single, mechanism, q, v), rtol=1e-12)


def test_surface_physics_is_off_by_default_and_zero_parameters_change_nothing():
    mechanism, contact = incline(0.2)
    plain = plate_contact(mechanism, stiffness=0.02, damping=2.0)
    assert plain.adhesion is None and plain.friction is None and plain.surface is None
    rng = np.random.default_rng(1)
    q = at_gap(mechanism, 0.05, 1.0, 2.0)
    v = jnp.asarray(rng.normal(size=3))
    base = _force(plain, mechanism, q, v)
    # Removing what was attached is the same object as never attaching it.
    stripped = contact.with_surface(mechanism)
    assert np.array_equal(np.asarray(_force(stripped, mechanism, q, v)), np.asarray(base))
    # Zero work, zero friction: the same force and energy to rounding.
    zero = plain.with_surface(
        mechanism,
        adhesion=Adhesion(work=0.0, range=0.4),
        friction=Friction(coefficient=0.0, slip=0.01),
    )
    np.testing.assert_allclose(_force(zero, mechanism, q, v), base, rtol=1e-14, atol=1e-14)
    assert float(_potential(zero, mechanism, q)) == float(_potential(plain, mechanism, q))


# ---- through the pattern ----


def test_a_pattern_records_its_adhesion_and_friction_and_hands_them_on():
    # Cheap (no compilation): the options reach the system's plate contact, with the host's
    # surface tables; stores record them only when on (a store written without them resumes).
    from origami_jax.net import fold_kernel

    adhesion, friction = Adhesion(work=0.05, range=0.4, line=0.02), Friction(0.3, 0.01)
    net = load_net("cube_net_01", length_scale=0.5)
    sticky = net.with_model(adhesion=adhesion, friction=friction)
    assert sticky.adhesion is adhesion and net.adhesion is None
    contact = sticky.system().contact
    assert contact.friction is friction and contact.adhesion is adhesion
    assert contact.surface is not None and net.system().contact.surface is None
    settings = fold_kernel(sticky).settings
    assert settings["adhesion"] == {"work": 0.05, "range": 0.4, "line": 0.02, "samples": 3}
    assert settings["friction"] == {"coefficient": 0.3, "slip": 0.01}
    assert "adhesion" not in fold_kernel(net).settings


@pytest.mark.slow  # ~10 s: the contact potential compiled for three systems
def test_a_pattern_carries_its_adhesion_and_friction_into_its_systems():
    # The pattern's options reach its systems' plate contact: the closed cube's seams bond with
    # −7 γ L, as when attached by hand (above); a traced design (a sweep's, a fit's) still gets
    # the host's surface tables; a crease pattern's options reach its contact too.
    from origami_jax.loops import load_pattern

    gamma, side = 0.02, 100.0
    adhesion, friction = Adhesion(work=0.05, range=0.4, line=gamma), Friction(0.3, 0.01)
    net = load_net("cube_net_01", length_scale=0.5)
    sticky = net.with_model(adhesion=adhesion, friction=friction)
    system, bare = sticky.system(), net.system()
    closed = jnp.asarray(net.intended_angles)
    bonded = _potential(system.contact, system.mechanism, closed)
    energy = float(bonded - _potential(bare.contact, bare.mechanism, closed))
    assert energy == pytest.approx(-7 * gamma * side, rel=EXACT)

    nominal = net.default_design()

    @jax.jit
    def traced(t_structural):
        design = eqx.tree_at(lambda d: d.t_structural, nominal, t_structural)
        traced_system = sticky.system(design)
        return traced_system.contact.potential(traced_system.mechanism, closed)

    assert float(traced(nominal.t_structural)) == pytest.approx(float(bonded), rel=1e-12)
    loops = load_pattern("vertex_degree4").with_model(friction=friction, check_rigid=False)
    assert loops.system().contact.friction is friction


@pytest.mark.parametrize(
    "options, message",
    [
        ({"adhesion": 0.05}, "must be None or an origami_jax.contact.Adhesion"),
        ({"friction": "0.3"}, "must be None or an origami_jax.contact.Friction"),
    ],
)
def test_a_pattern_refuses_what_is_not_surface_physics(options, message):
    with pytest.raises(ValueError, match=message):
        load_net("cube_net_01").with_model(**options)


@pytest.mark.parametrize("contact", [False, "sampled"])
def test_surface_physics_needs_the_plate_contact(contact):
    net = load_net("cube_net_01").with_model(contact=contact, adhesion=Adhesion(0.05, 0.4))
    with pytest.raises(ValueError, match="need the plate contact"):
        net.system()
