"""The fixed-step engine's working set of contact pairs (`PlateContact.select_pairs`,
`ImplicitStep.active_pairs`): it keeps the pairs of least gap, gives every pair's force while the
pairs left out stay beyond the activation gap, says when one did not, and its collision check
bounds the left-out pairs from below.

Independent references: the full contact's own gaps, forces and times of impact (every pair).
Tolerances: forces and derivatives to 1e-12 relative (the same sums over a few more zero terms);
trajectories to 1e-9 rad (the same steps; rounding of sums in another order).
"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.contact._plates import _computed_where
from origami_jax.net import load_net
from origami_jax.simulation._implicit import _pair_counts

from .test_contact_jacobians import _engaged_state


@eqx.filter_jit
def _forces(contact, mechanism, q, v):
    return contact.force_jacobians(mechanism, q, v)


@functools.cache
def _selected(counts):
    system, q, v = _engaged_state()
    # Compiled (op by op, the selection's full gap evaluation costs seconds).
    select = eqx.filter_jit(
        lambda contact, mechanism, q: contact.select_pairs(mechanism, q, counts)
    )
    return select(system.contact, system.mechanism, q)


def test_the_default_budget_and_its_checks():
    system, _, _ = _engaged_state()
    contact = system.contact
    n_vf, n_ee = len(contact.tables.vertex_face), len(contact.tables.edge_edge)
    # 16 per body (five panels and the base), split in proportion to the two kinds of pairs.
    k_vf, k_ee = _pair_counts(contact, sim.ImplicitStep(dt=1.0))
    assert k_vf + k_ee == 16 * 6
    assert k_vf / (k_vf + k_ee) == pytest.approx(n_vf / (n_vf + n_ee), abs=0.01)
    # A budget of every pair, or a contact without a working set: every pair, as before.
    assert _pair_counts(contact, sim.ImplicitStep(dt=1.0, active_pairs=n_vf + n_ee)) is None
    assert _pair_counts(None, sim.ImplicitStep(dt=1.0)) is None  # no contact (or no working set)
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="active_pairs must be a positive integer"):
            sim.ImplicitStep(dt=1.0, active_pairs=bad)


def test_a_working_set_keeps_the_least_gaps_and_every_force():
    system, q, v = _engaged_state()
    contact, mechanism = system.contact, system.mechanism
    counts = _pair_counts(contact, sim.ImplicitStep(dt=1.0))
    working = _selected(counts)
    gap = np.asarray(contact._gaps(contact.vertices(mechanism, q))[0])
    n_vf = len(contact.tables.vertex_face)
    kept_vf, kept_ee = (
        np.asarray(working.selection.vertex_face),
        np.asarray(working.selection.edge_edge),
    )
    # The least gaps of each kind, and the cut: the least gap left out.
    for part, kept, count in ((gap[:n_vf], kept_vf, counts[0]), (gap[n_vf:], kept_ee, counts[1])):
        assert len(set(kept.tolist())) == count
        np.testing.assert_allclose(np.sort(part[kept]), np.sort(part)[:count], rtol=0, atol=0)
    left_out = np.delete(gap, np.concatenate([kept_vf, n_vf + kept_ee]))
    assert float(working.selection.cut) == left_out.min()
    # Every engaged pair kept: the same force and derivatives as every pair's.
    assert float(working.selection.cut) > float(contact.activation)
    assert (gap < float(contact.activation)).sum() > 0
    full = _forces(contact, mechanism, q, v)
    part = _forces(working, mechanism, q, v)
    for a, b in zip(full, part, strict=True):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * float(np.abs(a).max()))
    assert not bool(working.left_out_engaged(mechanism, q))
    # Too few kept: engaged pairs are left out, and it is said.
    assert bool(_selected((1, 1)).left_out_engaged(mechanism, q))


def test_computed_where_computes_only_for_the_members_that_need_it():
    """The conditional behind the shortcuts below: each member of a vmapped batch gets its own
    value (computed where it needs it, its own `otherwise` elsewhere), and a batch where no member
    needs it computes nothing (a callback in the computation counts its runs)."""
    runs = []

    def doubled(x):
        jax.debug.callback(lambda: runs.append(1))
        return 2 * x

    @jax.jit
    @jax.vmap
    def where(needed, x):
        return _computed_where(needed, lambda: doubled(x), -x)

    x = jnp.asarray([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(where(jnp.asarray([True, False, True]), x), [2.0, -2.0, 6.0])
    assert len(runs) == 1
    runs.clear()
    np.testing.assert_array_equal(where(jnp.zeros(3, bool), x), -x)
    assert runs == []


@functools.cache
def _far_state():
    """The engaged state's system, halfway folded: every non-adjacent pair far apart."""
    system, q, v = _engaged_state()
    return system, 0.5 * q, v


def test_far_from_contact_no_pair_is_evaluated_and_the_results_are_every_pairs():
    """Half folded (the least gap ~15× the activation gap): the working set chosen there says every
    pair is apart at a nearby state, where its force and derivatives are exactly zero as every
    pair's, and its collision check is every pair's (clear). Vmapped with a member in contact, each
    member gets its own values (the engaged one every pair's, as unbatched)."""
    system, q, v = _far_state()
    contact, mechanism = system.contact, system.mechanism
    counts = _pair_counts(contact, sim.ImplicitStep(dt=1.0))
    select = eqx.filter_jit(lambda c, m, q: c.select_pairs(m, q, counts))
    working = select(contact, mechanism, q)
    assert float(working.selection.least) > 10 * float(contact.activation)
    nearby = q + 1e-3
    assert bool(working._apart(contact.vertices(mechanism, nearby)))
    # What the fixed steps' predictor asks (free flight: it extrapolates the acceleration).
    assert bool(working.surely_apart(mechanism, nearby))
    assert bool(contact.surely_apart(mechanism, nearby))  # every pair's gap
    full, kept = _forces(contact, mechanism, nearby, v), _forces(working, mechanism, nearby, v)
    for a, b in zip(full, kept, strict=True):
        np.testing.assert_array_equal(a, 0.0)
        np.testing.assert_array_equal(b, 0.0)
    assert float(working.time_of_impact(mechanism, q, nearby)) == 1.0
    assert float(contact.time_of_impact(mechanism, q, nearby)) == 1.0
    # A batch of the far state and the engaged one, each with its own working set.
    _, engaged, _ = _engaged_state()
    near = select(contact, mechanism, engaged)
    assert not bool(near._apart(contact.vertices(mechanism, engaged)))
    assert not bool(near.surely_apart(mechanism, engaged))
    both = jax.tree.map(lambda a, b: jnp.stack([a, b]), working, near)
    batched = eqx.filter_jit(eqx.filter_vmap(lambda c, q: c.force_jacobians(mechanism, q, v)))(
        both, jnp.stack([nearby, engaged])
    )
    alone = _forces(near, mechanism, engaged, v)
    for part, single in zip(batched, alone, strict=True):
        np.testing.assert_array_equal(part[0], 0.0)
        np.testing.assert_allclose(
            part[1], single, rtol=1e-12, atol=1e-12 * float(np.abs(single).max())
        )
    assert np.abs(alone[1]).max() > 0


def test_a_working_set_is_kept_while_it_has_room():
    """`next_working_set` keeps the previous working set while the vertices drift by less than a
    quarter of its least gap's margin over the activation gap, and chooses again beyond."""
    system, q, _ = _far_state()
    contact, mechanism = system.contact, system.mechanism
    counts = _pair_counts(contact, sim.ImplicitStep(dt=1.0))
    working = eqx.filter_jit(lambda c, m, q: c.select_pairs(m, q, counts))(contact, mechanism, q)
    again = eqx.filter_jit(lambda c, m, q: c.next_working_set(m, q, counts)[0])
    first = working.selection
    np.testing.assert_array_equal(first.at, contact.vertices(mechanism, q))
    margin = float(first.least) - 1.01 * float(contact.activation)
    for shift, kept in ((1e-4, True), (0.4, False)):
        moved = q + shift
        drift = float(
            np.max(np.linalg.norm(contact.vertices(mechanism, moved) - first.at, axis=-1))
        )
        assert (4 * drift < margin) == kept
        chosen = again(working, mechanism, moved)
        where = first.at if kept else contact.vertices(mechanism, moved)
        np.testing.assert_array_equal(chosen.at, where)


@pytest.mark.slow  # a cube net's collision check compiled twice: ~10 s
def test_the_collision_check_bounds_the_pairs_left_out():
    """From the engaged state, straight steps to random nearby states (some into contact): with a
    working set, the time of impact is at most every pair's (conservative), and with every engaged
    pair kept it is the same where the left-out pairs are clear."""
    system, q, _ = _engaged_state()
    contact, mechanism = system.contact, system.mechanism
    rng = np.random.default_rng(7)
    scales = np.geomspace(1e-4, 2e-2, 24)[:, None]
    ends = q + jnp.asarray(rng.normal(size=(24, q.shape[0])) * scales)

    @eqx.filter_jit
    def impacts(contact, ends):
        return jax.vmap(lambda end: contact.time_of_impact(mechanism, q, end))(ends)

    every = np.asarray(impacts(contact, ends))
    assert 0 < (every < 1).sum() < len(every)  # some steps meet, others are clear
    default = np.asarray(impacts(_selected(_pair_counts(contact, sim.ImplicitStep(dt=1.0))), ends))
    assert np.all(default <= every * (1 + 1e-12))
    assert np.mean(default == every) > 0.5  # the bound is not what decides most steps
    # The bound alone (a working set of one pair of each kind, most engaged pairs left out): still
    # never above every pair's time of impact. Evaluated without compiling a second program.
    few = _selected((1, 1))
    x0 = contact.vertices(mechanism, q)
    for end, truth in zip(ends, every, strict=True):
        bound = float(few._left_out_impact(x0, contact.vertices(mechanism, end)))
        assert min(bound, 1.0) <= truth * (1 + 1e-12)


@pytest.mark.slow  # two fixed-step folds of a cube net to compile: ~50 s
def test_a_fold_on_the_working_set_is_the_fold_on_every_pair():
    """`cube_net_01` in KOH to 1500 µs in steps of 2.5 µs: the default working set (96 of 253
    pairs) and every pair give the same trajectory, and no contact was left out."""
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    # The paper's dynamics in the bath: no fluid inertia, released at once.
    net = load_net("cube_net_01").with_model(added_mass=False, viscous=False)
    system = net.system(HingeDesign.literature(fluid=KOH_SOLUTION), contact="plate")
    runs = {}
    for budget in (None, 10_000):
        options = sim.SolveOptions(
            saveat=sim.SaveAt(n=61), solver=sim.ImplicitStep(dt=2.5, active_pairs=budget)
        )
        trajectory = eqx.filter_jit(sim.simulate)(system, sim.Step(), options, t1=1500.0)
        assert net.assess(system, trajectory).verdict == "folded"
        assert int(trajectory.stats["contacts_left_out"]) == 0
        runs[budget] = np.asarray(trajectory.theta)
    np.testing.assert_allclose(runs[None], runs[10_000], rtol=0, atol=1e-9)


@pytest.mark.slow  # a fixed-step fold of an octahedron net to compile: ~40 s
def test_an_octahedron_net_folds_with_its_newton_iterations_converging():
    """`octahedron_net_01` in KOH to 1500 µs in steps of 2.5 µs: where a Newton direction runs into
    a barrier it did not see (a pair just beyond the activation gap at the iteration's start), the
    line search finds a decrease within its halvings (2⁻⁷ of the longest step was needed), so no
    step is left unmoved, and the default iterations converge the steps of the closing net: the
    largest Newton update left is below 0.1 rad (2 rad with 5 halvings; 3.6 rad with 6 Newton
    iterations, the default until 2026-12-06, whose steps of the closing net ended with their
    residual only ~40× down; 9e-3 with 10) and the net folds with every contact pair of its
    working set."""
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    net = load_net("octahedron_net_01")
    system = net.system(  # the paper's dynamics: released at once
        HingeDesign.literature(fluid=KOH_SOLUTION), added_mass=False, viscous=False
    )
    options = sim.SolveOptions(saveat=sim.SaveAt(n=31), solver=sim.ImplicitStep(dt=2.5))
    trajectory = eqx.filter_jit(sim.simulate)(system, sim.Step(), options, t1=1500.0)
    assert net.assess(system, trajectory).verdict == "folded"
    assert float(trajectory.stats["newton_error"]) < 0.1
    assert int(trajectory.stats["contacts_left_out"]) == 0


def test_the_next_working_set_is_chosen_where_a_step_ends_and_says_what_was_left_out():
    """`next_working_set` at a step's end: near contact, the working set `select_pairs` chooses
    there and whether the step's own set left an engaged pair out (`left_out_engaged`); far from
    contact, the step's own set kept, nothing left out."""
    system, q, _ = _engaged_state()
    contact, mechanism = system.contact, system.mechanism
    counts = _pair_counts(contact, sim.ImplicitStep(dt=1.0))
    following = eqx.filter_jit(lambda c, m, q, counts: c.next_working_set(m, q, counts))
    # A working set of one pair of each kind, chosen at this state: engaged pairs left out.
    few = _selected((1, 1))
    chosen, left_out = following(few, mechanism, q, (1, 1))
    assert bool(left_out) and bool(few.left_out_engaged(mechanism, q))
    for a, b in zip(jax.tree.leaves(chosen), jax.tree.leaves(few.selection), strict=True):
        np.testing.assert_array_equal(a, b)  # chosen again at the same state: the same
    _, left_out = following(_selected(counts), mechanism, q, counts)
    assert not bool(left_out)
    far_system, far, _ = _far_state()
    working = eqx.filter_jit(lambda c, m, q: c.select_pairs(m, q, counts))(
        far_system.contact, mechanism, far
    )
    kept, left_out = following(working, mechanism, far + 1e-4, counts)
    np.testing.assert_array_equal(kept.at, working.selection.at)
    assert not bool(left_out)
