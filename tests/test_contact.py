"""Panel contact: the barrier, forces from the energy, stacking, rebound, no energy gain, gradients.

The folding cases share one compiled solve per structure (Tsit5, fixed `n_save`, the accordion with
contact; a single flap for the rebound), run under the contact guard that `simulate` adds.
"""

import functools

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.chain import accordion, accordion_system
from origami_jax.contact import PanelContact, barrier
from origami_jax.system import KOH_SOLUTION, FoldingSystem, HingeDesign, HingeDrag, Hinges

from .trajectories import held_trajectory

N_SAVE = 601
# Energy may rise by no more than the integrator's error between samples (relative to the energy
# the hinges release): rtol 1e-8 local errors over ~1e3 steps.
ENERGY_RTOL = 1e-6
# Forward-mode sensitivities through contact against central differences (relative): the finite
# differences carry the solver's tolerance-level noise divided by the step.
GRADIENT_RTOL = 1e-4


def _solve(system, t1, theta0=None, theta_dot0=None, inputs=None):
    return sim.simulate(
        system,
        sim.Step() if inputs is None else inputs,
        sim.SolveOptions(
            saveat=sim.SaveAt(n=N_SAVE),
            solver=diffrax.Tsit5(),
            rtol=1e-8,
            atol=1e-10,
            max_steps=200_000,
        ),
        t1=t1,
        theta0=theta0,
        theta_dot0=theta_dot0,
    )


@functools.cache
def _accordion(fluid: str):
    design = HingeDesign.literature(**({"fluid": KOH_SOLUTION} if fluid == "koh" else {}))
    system = accordion_system(design, 3, contact=True)
    return system, _solve(system, 1500.0)


@eqx.filter_jit  # one compiled call per system structure (op by op, seconds per trajectory)
def _step_energy(system, trajectory):
    """Mechanical energy with the step's potential ``−Σ k θ_target θ``: conserved without drag and
    contact damping, so it may only fall."""
    k, target = system.hinges.stiffness, system.hinges.target
    energy = jax.vmap(system.energy)(trajectory.theta, trajectory.theta_dot)
    return energy - trajectory.theta @ (k * target)


@eqx.filter_jit
def _accelerations(system, trajectory):
    """``M⁻¹(τ_total − bias)`` at every sample, all samples in one batched call."""
    q, v = trajectory.theta, trajectory.theta_dot
    force = jax.vmap(system.generalized_force)(q, v, trajectory.tau)
    return jax.vmap(system.mechanism.forward_dynamics)(q, v, force)


@eqx.filter_jit
def _reports(contact, mechanism, theta):
    """The contact's `report` at every state `theta` `(t, n)`."""
    return jax.vmap(lambda q: contact.report(mechanism, q))(theta)


def test_barrier_is_smooth_and_finite():
    @jax.jit  # the barrier and its two derivatives at many points in one compiled call
    def curves(x):
        return tuple(
            jax.vmap(f)(x) for f in (barrier, jax.grad(barrier), jax.grad(jax.grad(barrier)))
        )

    values, first, second = curves(jnp.linspace(-2.0, 1.5, 7001))
    assert bool(jnp.all(jnp.isfinite(values) & jnp.isfinite(first) & jnp.isfinite(second)))
    assert bool(jnp.all(values >= 0)) and bool(jnp.all(first <= 1e-12))
    assert float(barrier(1.0)) == 0.0 and float(barrier(2.0)) == 0.0
    # C² at the activation gap (x = 1) and where the Taylor continuation starts (x = 0.1).
    for x0 in (1.0, 0.1):
        below, above = curves(jnp.array([x0 - 1e-9])), curves(jnp.array([x0 + 1e-9]))
        for left, right in zip(below, above, strict=True):
            np.testing.assert_allclose(left, right, rtol=1e-6, atol=1e-6)
    # The IPC barrier itself in between.
    np.testing.assert_allclose(barrier(0.5), -(0.25) * np.log(0.5), rtol=1e-14)


@pytest.mark.parametrize("sampling", [(4, 2), (8, 3)], ids=["default", "denser"])
def test_elastic_force_is_minus_the_energy_gradient_and_damping_dissipates(sampling):
    # Denser sampling: points weighted 1/2 (inner ring) and 2/3 (rim), which the hand-written
    # force must carry as the energy does.
    from origami_jax.chain._system import _base_rectangle

    system = accordion_system(HingeDesign.literature(), 3, contact=True)
    chain = system.mechanism
    contact = PanelContact.for_system(
        chain,
        system.hinges.stiffness,
        system.hinges.target,
        thickness=HingeDesign.literature().t_structural,
        base_outline=_base_rectangle(chain),  # as `accordion_system` builds it
        points_per_edge=sampling[0],
        rim_points_per_edge=sampling[1],
    )
    if sampling == (4, 2):
        assert contact.tables == system.contact.tables
    weights = contact.tables.weights[contact.tables.pairs.any(axis=1)]
    assert set(np.unique(weights)) == ({1.0} if sampling == (4, 2) else {0.5, 2 / 3, 1.0})
    q = jnp.array([np.pi - 0.005, -np.pi + 0.01, np.pi - 0.01])  # flaps pressed onto each other
    v = jnp.array([0.01, -0.02, 0.03])

    @jax.jit  # one compiled call: op by op, the gradient alone took 20 s
    def forces(q, v):
        return {
            "elastic": contact.force(chain, q, jnp.zeros(3)),
            "reference": -jax.grad(lambda q: contact.potential(chain, q))(q),
            "moving": contact.force(chain, q, v),
        }

    got = forces(q, v)
    elastic = got["elastic"]
    assert float(jnp.max(jnp.abs(elastic))) > 0  # in contact
    np.testing.assert_allclose(elastic, got["reference"], rtol=1e-10)
    assert float(v @ (got["moving"] - elastic)) < 0
    # Flat, every flap beside the others: no contact at all.
    np.testing.assert_array_equal(forces(jnp.zeros(3), jnp.zeros(3))["moving"], 0.0)


def test_crossing_counts_through_a_face_not_beside_it():
    # Flap 2 of the accordion folded onto flap 1 (θ₂ near π): its points lie over flap 1's face.
    # Turning past π carries them through flap 1's mid-plane inside the face: a crossing. Turning
    # the same amount short of π, or with flap 1 swung away so that flap 2's points pass the plane
    # beside flap 1's face, is none.
    system = accordion_system(HingeDesign.literature(), 3, contact=True)
    contact, chain = system.contact, system.mechanism
    crossed = jax.jit(lambda q0, q1: contact.crossed(chain, q0, q1))
    assert bool(crossed(jnp.array([0.0, np.pi - 0.02, 0.0]), jnp.array([0.0, np.pi + 0.02, 0.0])))
    assert not bool(
        crossed(jnp.array([0.0, np.pi - 0.04, 0.0]), jnp.array([0.0, np.pi - 0.02, 0.0]))
    )
    # Flap 3 swept through the plane of flap 1 far from it (flap 2 upright): nothing over a face.
    assert not bool(
        crossed(
            jnp.array([0.0, np.pi / 2, np.pi / 2 - 0.02]),
            jnp.array([0.0, np.pi / 2, np.pi / 2 + 0.02]),
        )
    )


@pytest.mark.slow  # a cube net with contact (about a minute to compile)
def test_guard_lets_a_seam_close_where_a_point_passes_a_face_edge():
    """A cube net with scattered hinges (the first member of the MuJoCo benchmark's batch) whose
    seams close with rim points passing other panels' planes in those panels' edge ramps: when the
    guard counted any crossing with coverage > 0, it refused every step there (200,000 steps, 99 %
    rejected, unfinished at 1335 µs); counting crossings over the face (coverage > ½) it folds in
    the usual number of steps."""
    from origami_jax.net import load_net

    net = load_net("cube_net_01")
    system = net.system(
        HingeDesign.literature(fluid=KOH_SOLUTION), contact="sampled", added_mass=False,
        viscous=False,
    )  # fmt: skip
    factor = jnp.array([1.0273923374642908, 0.9539573427527741, 0.908194704787239,
                        0.9033055271057058, 1.0626540478400546])  # fmt: skip
    release = jnp.array([2.342128161031858, 4.946824408097116, 16.127206391499524,
                         9.020949289321841, 17.53635473199218])  # fmt: skip
    h = system.hinges
    hinges = type(h)(h.stiffness * factor, h.target, h.radius, release)
    system = eqx.tree_at(lambda s: s.hinges, system, hinges)
    trajectory = sim.simulate(system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=301), solver=diffrax.Tsit5(), max_steps=20_000, throw=False), t1=1500.0)  # fmt: skip
    assert int(trajectory.stats["num_steps"]) < 5_000
    report = net.assess(system, trajectory)
    assert report.verdict == "folded", report.summary()
    # The plates' exact overlap: 0.22 µm (just over the film) where the sampled points leave the
    # rims unchecked; the plate model's own run is in tests/test_plate_contact.py.
    assert report.max_penetration < 0.3


@pytest.mark.parametrize("name", ["cube_net_01", "octahedron", "corner_cube"])
def test_blocks_hold_every_checked_pair_once(name):
    # The hot kernels run over `ContactTables.blocks`; the dense `pairs` mask is the reference.
    from origami_jax.net import load_net

    tables = load_net(name).contact_tables()
    seen = np.zeros(tables.pairs.shape[:2], dtype=int)
    for block in tables.blocks:
        k, m = block.points.shape[:2]
        assert block.point_body.shape == block.face_body.shape == (k,) and m > 0
        for j, (a, b) in enumerate(zip(block.point_body, block.face_body, strict=True)):
            assert a != b and tables.pairs[a, b].sum() == m
            np.testing.assert_array_equal(block.points[j], tables.points[a][tables.pairs[a, b]])
            np.testing.assert_array_equal(block.face_edges[j], tables.face_edges[b])
            np.testing.assert_array_equal(block.weights[j], tables.weights[a][tables.pairs[a, b]])
            seen[a, b] += m
    np.testing.assert_array_equal(seen, tables.pairs.sum(axis=-1))
    assert sum(b.points.shape[0] * b.points.shape[1] for b in tables.blocks) == tables.n_pairs


def test_denser_sampling_shares_the_same_weight_per_length_of_ring_and_rim():
    """The default points weigh 1 each; a denser ring or rim spreads the same total weight over
    more points (the contact refined, not stiffened): per square panel of the corner cube, 1 (the
    centre) + 16 (the inner ring) + 8 (the rim) whatever the sampling."""
    from origami_jax.net import load_net

    net = load_net("corner_cube")
    default = net.contact_tables()
    np.testing.assert_array_equal(default.weights, 1.0)
    for sampling in ((8, 6), (16, 1), (3, 5)):
        tables = net.contact_tables(sampling=sampling)
        np.testing.assert_allclose(tables.weights.sum(axis=1), 1 + 16 + 8, rtol=1e-14)
        assert sorted(set(tables.weights.ravel().round(12))) == sorted(
            {1.0, round(4 / sampling[0], 12), round(2 / sampling[1], 12)}
        )


def test_contact_sampling_sets_every_panels_points():
    """`Net.system(contact_sampling=(n, r))`: each square panel of the corner cube (two flaps and
    the base) gets its centre, ``n`` points per edge on its inner ring (a corner included) and
    ``r`` per edge on its rim: ``1 + 4 (n + r)`` points. Bad sampling is refused in one line."""
    from origami_jax.net import load_net

    net = load_net("corner_cube")
    for sampling in ((4, 2), (4, 0), (8, 6)):
        tables = net.contact_tables(sampling=sampling)
        counts = [len(np.unique(p, axis=0)) for p in tables.points]
        assert counts == [1 + 4 * sum(sampling)] * 3, (sampling, counts)
    system = net.system(contact="sampled", contact_sampling=(8, 6))
    assert system.contact.tables is net.contact_tables(sampling=(8, 6))
    assert system.contact.tables.n_pairs > net.contact_tables().n_pairs
    for bad, message in (
        ((4,), "must be a pair"),
        ((0, 2), "points_per_edge must be a whole number >= 1"),
        ((4, -1), "rim_points_per_edge must be a whole number >= 0"),
        ((4.5, 2), "points_per_edge must be a whole number"),
    ):
        with pytest.raises(ValueError, match=message):
            net.system(contact="sampled", contact_sampling=bad)


def test_closed_loop_patterns_and_the_command_line_take_the_sampling(tmp_path, capsys):
    from origami_jax.cli import main
    from origami_jax.loops import load_pattern

    pattern = load_pattern("vertex_degree4")
    default, dense = (
        pattern.system(contact="sampled", contact_sampling=sampling).contact.tables
        for sampling in ((4, 2), (8, 6))
    )
    assert dense.n_pairs > default.n_pairs
    np.testing.assert_allclose(dense.weights.sum(axis=1), default.weights.sum(axis=1), rtol=1e-12)
    for command in ("fold", "yield"):
        for value in ("8", "0,2", "4,-1", "x,2"):
            argv = [command, "corner_cube", "--contact-sampling", value, "--out", str(tmp_path)]
            assert main(argv) == 2, (command, value)
            assert "--contact-sampling expects RING,RIM" in capsys.readouterr().err


def test_sweeps_and_yield_estimates_take_the_sampling():
    """The net kernel names a sampling only when it is not the default (stores written before it
    existed stay resumable); `yield_estimate` refuses a bad one before compiling."""
    from origami_jax.fab_yield import yield_estimate
    from origami_jax.net import load_net
    from origami_jax.sweep import get_model

    assert "contact_sampling" not in get_model("net-fold", net="corner_cube").settings
    dense = get_model("net-fold", net="corner_cube", contact="sampled", contact_sampling=(8, 6))
    assert dense.settings["contact_sampling"] == [8, 6]
    with pytest.raises(ValueError, match="rim_points_per_edge must be a whole number >= 0"):
        yield_estimate(
            load_net("corner_cube").with_model(contact="sampled", contact_sampling=(4, -1)),
            n_samples=2,
        )
    with pytest.raises(ValueError, match="applies to contact='sampled' only"):
        get_model("net-fold", net="corner_cube", contact_sampling=(8, 6))


@pytest.mark.slow  # a whole program of its own to compile; the default run stays under 10 min
def test_net_contact_force_against_a_point_by_point_world_sum():
    # The kernel works per body pair in the face's frame with the gap's gradient by hand; the
    # reference goes point by point in the world frame (NumPy): the elastic part from the energy's
    # autodiff gradient, the damping −c a(g) ġ ∇g with ġ the gap's rate along the motion (autodiff
    # through the mechanism's kinematics) and ∇g the gap's autodiff gradient at the point. States:
    # the closed cube perturbed, so that many pairs are in contact (faces and rims). Tolerance:
    # rounding of sums of barrier forces that grow steeply as the gap closes (1e-10 relative).
    from origami_jax.contact import smoothstep
    from origami_jax.net import load_net

    system = load_net("cube_net_01").system(
        HingeDesign.literature(fluid=KOH_SOLUTION), contact="sampled"
    )
    contact, tree = system.contact, system.mechanism
    tables = contact.tables
    points = tables.points
    target = np.asarray(system.hinges.target)
    rng = np.random.default_rng(3)

    def local_gap_sum(local):
        return jnp.sum(contact._gap(local)[0])

    @jax.jit
    def pieces(q, v):
        # One compiled call for every piece of the reference and the kernel under test.
        gap = contact.gaps(tree, q)[0]
        return {
            "force": contact.force(tree, q, v),
            "elastic": jax.grad(lambda q: -contact.potential(tree, q))(q),
            "rate": jax.jvp(lambda q: contact.gaps(tree, q)[0], (q,), (v,))[1],
            "gradient": jax.grad(local_gap_sum)(contact._local(tree, q)[2]),
            "engaged": smoothstep(1 - gap / contact.activation),
            "poses": tree.body_poses(q),
        }

    apply_wrenches = jax.jit(lambda q, w: tree.apply_wrenches(q, w))  # one program, not one per op
    pressed = 0
    for _ in range(4):
        q = jnp.asarray(target * rng.uniform(0.97, 1.06, target.shape))
        v = jnp.asarray(rng.normal(0.0, 0.05, target.shape))
        got = jax.device_get(pieces(q, v))
        poses = np.concatenate([got["poses"], tables.base_pose[None]])
        engaged, rate = got["engaged"], got["rate"]
        gradient = np.stack(got["gradient"], axis=-1)  # (a, b, i, 3)
        damping_coefficient = float(contact.damping)
        wrenches = np.zeros((len(poses), 6))
        for a, b, i in zip(*np.nonzero(tables.pairs), strict=True):
            x = poses[a, :3, :3] @ points[a, i] + poses[a, :3, 3]
            normal = poses[b, :3, :3] @ gradient[a, b, i]
            f = -damping_coefficient * engaged[a, b, i] * rate[a, b, i] * normal
            wrenches[a] += np.concatenate([f, np.cross(x, f)])
            wrenches[b] -= np.concatenate([f, np.cross(x, f)])
        damping = np.asarray(apply_wrenches(q, jnp.asarray(wrenches[: tables.n_bodies])))
        reference = got["elastic"] + damping
        ours = got["force"]
        pressed += int(np.max(np.abs(reference)) > 0)
        np.testing.assert_allclose(ours, reference, rtol=1e-10, atol=1e-10 * np.max(np.abs(ours)))
    assert pressed >= 3  # the states are in contact


def _dragless_cube():
    """`cube_net_01` in KOH with its hinges' drag switched off (energy is conserved but for the
    contact's damping), in the paper's dynamics (no fluid inertia: the launch speeds and depths
    below are for the panels' own inertia)."""
    from origami_jax.net import load_net

    net = load_net("cube_net_01").with_model(added_mass=False, viscous=False)
    system = net.system(HingeDesign.literature(fluid=KOH_SOLUTION), drag="hinge", contact="sampled")
    return eqx.tree_at(lambda s: s.drag, system, HingeDrag(jnp.zeros(system.n_hinges)))


def test_closed_cube_is_free_and_an_edge_pushed_past_its_neighbours_is_held():
    # The cube closed exactly (every crease at 90°: the seams' rims coincide) feels no contact; its
    # lid (panel 1) turned 0.5° further in slides its rim 1.7 µm past the rims of the three side
    # panels it shares seams with, into their rounded plates: the contact's energy rises and its
    # force turns the lid back out. (Without edge contact the lid's points stay 2 µm off the side
    # panels' mid-planes and nothing holds it.)
    system = _dragless_cube()
    contact, tree = system.contact, system.mechanism
    # One compiled program for every quantity below (op by op: ~300 small compilations, ~16 s).
    probe = jax.jit(
        lambda q: (
            contact.force(tree, q, jnp.zeros(5)),
            contact.potential(tree, q),
            contact.report(tree, q),
        )
    )
    closed = jnp.asarray(system.hinges.target)
    force, energy, report = probe(closed)
    np.testing.assert_array_equal(force, 0.0)
    assert float(energy) == 0.0
    assert float(report["min_gap"]) > contact.activation
    pushed = closed.at[1].add(np.radians(0.5))
    force, energy, report = probe(pushed)
    assert float(energy) > 0.0
    assert float(force[1]) < 0.0  # back out
    touching = np.asarray(report["touching"])
    assert touching[1, 2] and touching[1, 3] and touching[1, 4]


@pytest.mark.slow  # a cube net with contact (about a minute to compile)
def test_lid_launched_into_the_cube_stops_at_the_side_panels_edges_without_gaining_energy():
    # The closed cube, no drag, its lid launched inward at 0.01 rad/µs: without edge contact it
    # swings 8.2° into the cube (its hinge alone turns it back); with it, the side panels' rims stop
    # it within 0.3° (0.08° seen: its rim 0.3 µm past theirs) and it rebounds, and the energy never
    # rises by more than the integrator's error.
    system = _dragless_cube()
    closed = jnp.asarray(system.hinges.target)
    trajectory = sim.simulate(system, sim.Step(), sim.SolveOptions(saveat=sim.SaveAt(n=201), solver=diffrax.Tsit5(), rtol=1e-8, atol=1e-10, max_steps=100_000), t1=100.0, theta0=closed, theta_dot0=jnp.array([0.0, 0.01, 0.0, 0.0, 0.0]))  # fmt: skip
    past = np.degrees(np.asarray(trajectory.theta[:, 1] - closed[1]))
    assert past.max() < 0.3
    assert past.min() < -1.0  # it came back out
    energy = np.asarray(_step_energy(system, trajectory))
    assert np.max(np.diff(energy)) <= ENERGY_RTOL * abs(energy[0])
    assert energy[-1] < energy[0]  # the contact's damping took some out
    report = _reports(system.contact, system.mechanism, trajectory.theta)
    # The report is the plates' exact overlap: the closed cube's rims overlap by half the film (two
    # perpendicular plates meeting edge on edge), and at the lid's impact its plate goes 0.46 µm
    # (2.3 films) into the walls between the sampled points, which stop its rim only where they
    # are; the plate model holds it within the film (tests/test_plate_contact.py).
    assert 0.1 <= float(jnp.max(report["penetration"])) < 0.6


@pytest.mark.slow  # energy balance through contact is also checked by the accordion stack below
def test_flap_rebounds_from_the_base_without_gaining_energy():
    # One flap, no drag, a weak hinge holding it at 90°, launched towards the base (θ → π).
    chain = accordion(1)
    design = HingeDesign.literature()
    hinges = Hinges(10.0, jnp.array([np.pi / 2]), design.radius())
    free = FoldingSystem(chain, hinges, HingeDrag(jnp.zeros(1)))
    base = _mirror(chain)
    contact = PanelContact.for_system(
        chain, jnp.array([1e4]), jnp.array([np.pi]), thickness=0.2, base_outline=base
    )
    system = eqx.tree_at(lambda s: s.contact, free, contact, is_leaf=lambda x: x is None)
    trajectory = _solve(system, 60.0, theta0=jnp.array([np.pi / 2]), theta_dot0=jnp.array([0.1]))
    theta, rate = np.asarray(trajectory.theta[:, 0]), np.asarray(trajectory.theta_dot[:, 0])
    assert theta.max() < np.pi  # stopped by the base, never through it
    assert rate[0] > 0 and rate.min() < -0.05  # it came back, at half its speed or more
    energy = np.asarray(_step_energy(system, trajectory))
    scale = abs(energy[0])
    assert np.max(np.diff(energy)) <= ENERGY_RTOL * scale
    assert energy[-1] < energy[0]  # the contact's damping took some out
    report = _reports(contact, chain, trajectory.theta)
    assert float(jnp.max(report["penetration"])) < 0.01 * 0.2  # the plates' exact overlap


def _mirror(chain):
    """The base: the first flap mirrored across its hinge (what `accordion_system` uses)."""
    from origami_jax.chain._system import _base_rectangle

    return _base_rectangle(chain)


# Both in the slow cases (20 s in air, 16 s in the bath): the default suite's contact stops and
# energy checks are the flap on the base and the lid on the cube above.
@pytest.mark.parametrize(
    "fluid",
    [pytest.param("air", marks=pytest.mark.slow), pytest.param("koh", marks=pytest.mark.slow)],
)
def test_accordion_with_contact_stacks_without_penetration_or_energy_gain(fluid):
    system, trajectory = _accordion(fluid)
    assert bool(trajectory.succeeded)
    theta = np.asarray(trajectory.theta)
    # No hinge passes π: each flap stops on the one below (the paper's model overshoots to 1.8π).
    assert np.all(np.abs(theta) < np.pi)
    report = _reports(system.contact, system.mechanism, trajectory.theta)
    # The exact overlap of the plates (the sampled model's report measures it on the panels'
    # polygons): the barrier holds the sampled points off, and the plates overlap nowhere by more
    # than 1 % of the film's thickness (5e-5 µm seen in air, where the points leave gaps).
    assert float(jnp.max(report["penetration"])) < 0.01 * 0.2
    energy = np.asarray(_step_energy(system, trajectory))
    released = float(jnp.sum(0.5 * system.hinges.stiffness * system.hinges.target**2))
    assert np.max(np.diff(energy)) <= ENERGY_RTOL * released
    # The samples' accelerations (computed one sample at a time with contact) are the equations
    # of motion at the samples, evaluated here for all of them at once (round-off apart).
    np.testing.assert_allclose(
        trajectory.theta_ddot,
        _accelerations(system, trajectory),
        rtol=1e-9,
        atol=1e-12 * float(jnp.max(jnp.abs(trajectory.theta_ddot))),
    )
    if fluid == "koh":
        # Overdamped: the stack settles where the barrier, which rises from zero at the activation
        # gap ĝ, holds the hinges' last few pN·m: a standoff of about ĝ (0.5 % of the flap length),
        # a fraction of a degree per hinge.
        final_gap = float(report["min_gap"][-1])
        assert 0.0 < final_gap < 1.05 * float(system.contact.activation)
        np.testing.assert_allclose(np.abs(theta[-1]), np.pi, atol=0.02)


@pytest.mark.slow  # a gradient through a folding with contact
def test_metric_gradients_through_contact_match_finite_differences():
    """Response metrics of the accordion in KOH with contact (the peaks are the stack's standoff,
    set by the barrier), differentiated in forward mode through the contact solve, against central
    differences. Overdamped, so the metrics are away from contact onset: every peak is a contact."""
    base, _ = _accordion("koh")

    def metrics(log_k, adjoint=None):
        system = eqx.tree_at(
            lambda s: s.hinges.stiffness, base, base.hinges.stiffness * jnp.exp(log_k)
        )
        trajectory = sim.simulate(
            system,
            sim.Step(),
            sim.SolveOptions(
                saveat=sim.SaveAt(n=401),
                solver=diffrax.Tsit5(),
                rtol=1e-8,
                atol=1e-10,
                max_steps=200_000,
                adjoint=adjoint,
            ),
            t1=600.0,
        )
        m = sim.response_metrics(trajectory)
        return jnp.stack([m.rise_time[0], m.peak_value[0], m.peak_value[1]])

    derivative = jax.jit(jax.jacfwd(lambda x: metrics(x, diffrax.ForwardMode())))(0.0)
    f = jax.jit(metrics)
    h = 1e-4
    fd = (f(h) - f(-h)) / (2 * h)
    assert float(jnp.min(jnp.abs(fd[1:]))) > 1e-3  # the standoff depends on the stiffness
    np.testing.assert_allclose(derivative, fd, rtol=GRADIENT_RTOL)


def _held(system, theta, result=None):
    return held_trajectory(system, theta, result)


@pytest.mark.slow  # the yield tests judge folded and misfolded nets by default
def test_verdicts():
    system, koh = _accordion("koh")
    folded = sim.assess(system, koh)
    assert folded.verdict == "folded" and folded.settled and folded.time_to_fold is not None
    assert folded.max_penetration < 0.01 * 0.2 and folded.contacts > 0  # exact, < 1 % of the film
    assert "folded" in folded.summary() and folded.to_dict()["verdict"] == "folded"
    _, air = _accordion("air")
    assert sim.assess(system, air).verdict == "unfinished"  # still rattling after 1.5 ms in air
    stacked = jnp.array([np.pi - 0.005, -np.pi + 0.01, np.pi - 0.01])
    # Held in contact short of where it should be and of where its hinges aim: jammed. Short of
    # the intended angles but where its hinges rest (drawn for 180°): misfolded, the panels'
    # contact notwithstanding. The same angles without contact to explain them (wrong sign on one
    # crease): misfolded.
    intended = jnp.array([3.3, -3.3, 3.3])
    aimed = eqx.tree_at(lambda s: s.hinges.target, system, intended)
    jammed = sim.assess(aimed, _held(aimed, stacked), intended_angles=intended)
    assert jammed.verdict == "jammed", jammed.reason
    resting = sim.assess(system, _held(system, stacked), intended_angles=intended)
    assert resting.verdict == "misfolded" and resting.contacts > 0, resting.reason
    assert "where its hinge rests" in resting.reason
    wrong = sim.assess(system, _held(system, jnp.array([1.0, 1.0, 1.0])))
    assert wrong.verdict == "misfolded" and "crease 1" in wrong.reason
    moving = _held(system, jnp.zeros(3))
    moving = eqx.tree_at(lambda t: t.theta, moving, moving.theta.at[-1].set(1.0))
    assert sim.assess(system, moving).verdict == "unfinished"
    failed = _held(system, jnp.zeros(3), result=sim.RESULTS.nonfinite_state)
    assert sim.assess(system, failed).verdict == "invalid"
    # Seams: angles right but a seam open is not folded.
    # Constant gaps: no geometry to derive a seam tolerance from (the default; it would be the
    # gap itself), so a fixed one (1 % of the contact model's panel size).
    fixed = sim.VerdictTolerances(seam=0.01)
    closed = sim.assess(system, koh, seam_gaps=lambda q: jnp.zeros(1), tolerances=fixed)
    opened = sim.assess(system, koh, seam_gaps=lambda q: jnp.full(1, 50.0), tolerances=fixed)
    assert closed.verdict == "folded" and opened.verdict == "misfolded"
