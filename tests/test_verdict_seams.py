"""Seams closed by contact: the verdict counts a seam as closed when its gap is below the seam
tolerance or its two panels touch (`fold_outcome`, `SeamGaps.bodies`, `PanelContact.report`'s
`touching`).

The judged foldings are synthetic: the cube net `cube_net_01` held with every crease at 90° except
crease 3 (between panels 2 and 3), turned past it. That swings panels 3 and 4 inward, so the seam
between panels 0 and 4 (seam 3) opens at its far end by about ``L δθ`` while panel 0's rim meets
panel 4's face near the seam. The preconditions (seam gap above the tolerance; how far panel 0's
rim points over panel 4's face are from it) are checked by computations independent of the verdict:
the host's rigid folding of the flat pattern (`Net.seam_gaps`) and the panels' poses and outlines."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.net import SeamGaps, load_net
from origami_jax.system import KOH_SOLUTION, HingeDesign

from .trajectories import held_trajectory

KOH = HingeDesign.literature(fluid=KOH_SOLUTION)
SEAM = 3  # cube_net_01's seam between panels 0 and 4
FOLDED, MISFOLDED = sim.VERDICT_CODES["folded"], sim.VERDICT_CODES["misfolded"]
# The rule for touching seams is seen where a seam's gap is above its tolerance: the seams here
# open by 4–12 µm, above the fixed 1 % of the panel (2 µm), the default before the derived one
# (10–20 µm per seam on this cube, which would call them closed by their gaps alone).
FIXED = sim.VerdictTolerances(seam=sim.LEGACY_SEAM_FRACTION)


@pytest.fixture(scope="module")
def cube():
    net = load_net("cube_net_01")
    return net, net.system(KOH, contact="sampled")


def _angles(past_deg: float) -> np.ndarray:
    """Every crease at 90°, crease 3 turned `past_deg` further (rad, `(5,)`)."""
    return np.radians(90.0 + np.array([0.0, 0.0, 0.0, past_deg, 0.0]))


def _rest_gap(system, angles, a: int, b: int, margin: float) -> float:
    """The smallest clearance (µm) between the surfaces of panel `a` at its contact sample points and
    panel `b`, over the points that lie over `b` more than `margin` inside its outline (`inf` if
    none): from the bodies' poses and outlines and the films' thickness, not the contact kernel."""
    mechanism = system.mechanism
    poses = np.asarray(mechanism.body_poses(jnp.asarray(angles)))
    points = system.contact.tables.points[a] @ poses[a, :3, :3].T + poses[a, :3, 3]
    local = (points - poses[b, :3, 3]) @ poses[b, :3, :3]  # in b's frame: its face is z = 0
    polygon = np.asarray(mechanism.outlines()[b])[:, :2]
    edges = np.roll(polygon, -1, axis=0) - polygon
    turn = np.sign(
        np.sum(
            polygon[:, 0] * np.roll(polygon[:, 1], -1) - np.roll(polygon[:, 0], -1) * polygon[:, 1]
        )
    )
    inward = turn * np.stack([-edges[:, 1], edges[:, 0]], axis=1)
    inward /= np.linalg.norm(inward, axis=1)[:, None]
    inside = np.min(np.einsum("pkj,kj->pk", local[:, None, :2] - polygon[None], inward), axis=1)
    clearance = np.abs(local[:, 2]) - KOH.t_structural  # two plates of thickness t
    return float(np.min(np.where(inside > margin, clearance, np.inf)))


def _one_seam(net, system) -> SeamGaps:
    """The net's seam 3 alone (a device whose only seam is the one between panels 0 and 4)."""
    seams = net.seam_gap_function(system)
    return SeamGaps(lambda q: seams(q)[SEAM : SEAM + 1], seams.bodies[SEAM : SEAM + 1])


def _judge(net, system, trajectory, seam_gaps, traced=False):
    """`assess` (or `fold_outcome`) of the net's folding with the given seams, as `Net.assess`
    judges it (the pattern's angles, its panel size)."""
    judge = sim.fold_outcome if traced else sim.assess
    intended = jnp.asarray(net.intended_angles) if traced else net.intended_angles
    return judge(
        system,
        trajectory,
        intended_angles=intended,
        seam_gaps=seam_gaps,
        panel_size=net.panel_size(system),
        tolerances=FIXED,
    )


def test_seam_bodies_are_the_faces_that_meet_there(cube):
    """`SeamGaps.bodies` names, for every seam, two bodies (the base as `n_bodies`, as in the
    contact tables) that each have a corner at both ends of the seam in the folded cube."""
    net, system = cube
    seams = net.seam_gap_function(system)
    mechanism = system.mechanism
    n = mechanism.n_bodies
    assert system.contact.tables.n_bodies == n and system.contact.tables.has_base
    assert seams.bodies.shape == (len(net.seams), 2) and seams.bodies.dtype == np.int64
    poses = np.asarray(mechanism.body_poses(jnp.asarray(net.intended_angles)))
    corners = [o @ p[:3, :3].T + p[:3, 3] for o, p in zip(mechanism.outlines(), poses, strict=True)]
    corners.append(np.asarray(mechanism.base_outline()))  # world coordinates
    parents = np.asarray(mechanism.hinge_layout().parent)
    children = np.asarray(mechanism.hinge_layout().child)
    hinged = {frozenset((int(p) % (n + 1), int(c))) for p, c in zip(parents, children, strict=True)}
    for a, b in seams.bodies:
        assert a != b and 0 <= min(a, b) and max(a, b) <= n
        assert frozenset((int(a), int(b))) not in hinged  # a seam is not a crease
        shared = np.min(np.linalg.norm(corners[a][:, None] - corners[b][None], axis=-1), axis=1)
        assert np.sum(shared < 1e-6) == 2, (a, b, shared)  # the seam's two ends


@pytest.mark.parametrize(
    ("past_deg", "touching"),
    [
        (0.8, True),  # panel 0's rim 0.57 µm from panel 4's face: the barrier is on
        (1.4, False),  # turned further: 2.6 µm from it, over the face but apart
        (-0.8, False),  # turned back: the seam opens outward, neither panel over the other
    ],
)
def test_a_seam_is_closed_when_its_panels_touch(cube, past_deg, touching):
    """Crease 3 past 90° by up to 1.4° (within the 3° tolerance) opens seam 3 by 4–7 µm, above the
    default 2 µm: closed only while panels 0 and 4 touch (a rim point of one over the other's face
    within 1.1 ĝ; ĝ = 1 µm), open once they are more than ĝ apart or beside each other."""
    net, system = cube
    angles = _angles(past_deg)
    activation = float(system.contact.activation)
    gap = float(net.seam_gaps(angles)[SEAM])  # host geometry of the rigidly folded pattern
    assert net.panel_size(system) * FIXED.seam == pytest.approx(2.0)
    assert gap > 3.9  # µm, about 200 µm × δθ: above the 2 µm tolerance
    if touching:  # well over the face (0.5 µm inside its edge), well inside the contact layer
        clearance = min(_rest_gap(system, angles, 0, 4, 0.5), _rest_gap(system, angles, 4, 0, 0.5))
        assert 0.0 < clearance < 0.6 * activation
    else:  # anywhere over the face, far outside the layer
        clearance = min(_rest_gap(system, angles, 0, 4, 0.0), _rest_gap(system, angles, 4, 0, 0.0))
        assert clearance > 2 * activation
    trajectory = held_trajectory(system, angles)
    one = _one_seam(net, system)

    report = _judge(net, system, trajectory, one)
    assert report.seam_gaps == pytest.approx([gap], rel=1e-9)
    assert report.seams_touching.tolist() == [touching]
    if touching:
        assert report.verdict == "folded", report.summary()
        assert report.seams_closed_by_contact.tolist() == [0]
        assert "seam 0 by contact" in report.reason
        assert "closed by contact (panels touching): seam 0" in report.summary()
        assert report.time_to_fold == 0.0
    else:
        assert report.verdict == "misfolded", report.summary()
        assert report.reason == "creases at their angles but seams open"
        assert report.time_to_fold is None
    if not touching:
        return
    # A plain function of q (no bodies) keeps the gap-only rule.
    plain = _judge(net, system, trajectory, lambda q: one(q))
    assert plain.verdict == "misfolded" and not plain.seams_touching.any()
    # With all seven seams: panels 3 and 4, swung inward, push their rims 2 µm into the base's and
    # the top's rounded rims (seams 0, 2, 5, 6, open 2.8–4 µm): edge on edge, the contact a folding
    # is stopped by (this held state penetrates; a simulation cannot reach it). Those seams count
    # as touching too; seams 1 and 4 are shut (gap 0) without contact.
    full = net.assess(system, trajectory, tolerances=FIXED)
    assert full.verdict == "folded", full.summary()
    assert full.seams_touching.tolist() == [i not in (1, 4) for i in range(7)]
    assert full.max_penetration > 0
    assert full.to_dict()["seams_touching"] == full.seams_touching.tolist()


def test_seams_closed_by_contact_under_vmap(cube):
    """`fold_outcome` under `jit` and `vmap` (as sweeps and yield estimates run it) applies the
    same rule."""
    net, system = cube
    one = _one_seam(net, system)
    batch = jax.tree.map(
        lambda *x: jnp.stack(x),
        *(held_trajectory(system, _angles(d), n=3) for d in (0.8, -0.8)),
    )
    outcome = jax.jit(jax.vmap(lambda t: _judge(net, system, t, one, traced=True)))(batch)
    assert outcome.code.tolist() == [FOLDED, MISFOLDED]
    assert outcome.seams_touching.tolist() == [[True], [False]]
    # The gap the rule judges: none left open where the panels touch, the seam's own where not.
    gaps = [float(net.seam_gaps(_angles(d))[SEAM]) for d in (0.8, -0.8)]
    np.testing.assert_allclose(outcome.max_seam_gap, gaps, rtol=1e-9)
    np.testing.assert_allclose(outcome.max_open_seam_gap, [0.0, gaps[1]], rtol=1e-9)


def test_a_second_verdict_on_the_same_net_compiles_nothing(cube):
    """`assess` runs the verdict as one compiled program, keyed on the model's structure: another
    folding of the same net, judged with other tolerances, reuses it (and reads its own states: its
    seam gaps are the host's rigid folding at its angles)."""
    from origami_jax.simulation import _verdict

    net, system = cube
    net.assess(system, held_trajectory(system, _angles(0.8)))
    compiled = _verdict._outcome_compiled.jitted._cached._cache_size()
    # The derived seam tolerances too: each `assess` asks the net for a new `SeamGaps` (a plain
    # object, static by identity), whose gap function is data to their program.
    tolerance_programs = _verdict._derived_seam_tolerances.jitted._cached._cache_size()
    tolerances = sim.VerdictTolerances.from_degrees(2.0, 0.02)
    report = net.assess(system, held_trajectory(system, _angles(-0.8)), tolerances=tolerances)
    assert _verdict._outcome_compiled.jitted._cached._cache_size() == compiled
    # Runs continued segment by segment (the fold command's 501 samples, then 1001; segments of
    # 201, then 401) are judged by the 11-sample run's program too (all padded to 1024 samples).
    for n in (201, 401, 501, 1001):
        net.assess(system, held_trajectory(system, _angles(0.8), n=n))
    assert _verdict._outcome_compiled.jitted._cached._cache_size() == compiled
    assert _verdict._derived_seam_tolerances.jitted._cached._cache_size() == tolerance_programs
    # `Net.outcome` (and `fold_outcome`) on a concrete run take the same program, the tolerances
    # as its data: another run, another angle tolerance or seam fraction compile nothing.
    net.outcome(system, held_trajectory(system, _angles(0.8)))
    cases = [
        (held_trajectory(system, _angles(past)), tolerances)
        for past, tolerances in ((-0.8, FIXED), (0.5, sim.VerdictTolerances.from_degrees(4.0)))
    ]
    verdicts = [net.assess(system, run, tolerances=tolerances).verdict for run, tolerances in cases]
    traces = []

    def count(event, duration, **kwargs):
        traces.append(event == "/jax/core/compile/jaxpr_trace_duration")

    jax.monitoring.register_event_duration_secs_listener(count)
    try:
        for (run, tolerances), verdict in zip(cases, verdicts, strict=True):
            outcome = net.outcome(system, run, tolerances=tolerances)
            assert int(outcome.code) == sim.VERDICT_CODES[verdict]
    finally:
        jax.monitoring.unregister_event_duration_listener(count)
    assert not any(traces)  # nothing traced again, let alone compiled
    assert _verdict._outcome_compiled.jitted._cached._cache_size() == compiled
    assert _verdict._derived_seam_tolerances.jitted._cached._cache_size() == tolerance_programs
    np.testing.assert_allclose(report.seam_gaps, net.seam_gaps(_angles(-0.8)), atol=1e-9)
    assert report.angle_tolerance == pytest.approx(np.radians(2.0))


def test_seam_bodies_of_the_wrong_shape_are_refused(cube):
    net, system = cube
    one = _one_seam(net, system)
    bad = SeamGaps(one, np.array([[0, 4], [1, 2]]))
    with pytest.raises(ValueError, match="seam_gaps.bodies must be 1 pairs"):
        _judge(net, system, held_trajectory(system, _angles(0.8)), bad, traced=True)


@pytest.mark.slow  # a corner cube with contact: compiles and folds in about a minute on 2 cores
def test_a_flap_held_on_its_neighbours_edge_closes_the_seam():
    """The corner cube with both hinges aiming 2° past 90° (within the 3° tolerance), flap 0
    released first: it folds to 92°, leaning in past the seam, and flap 1, released 200 µs later,
    lands on flap 0's rim although its hinge pushes on towards 92°: flap 0's rim points stand
    ``t + ĝ`` off flap 1's inner face, the one 50 µm from the seam's corner holding flap 1 out at
    about 90° − (1.2 µm / 50 µm) = 88.6°. The seam is open by ~12 µm at its far end, above the 2 µm
    tolerance, but the flaps touch: folded, by contact. The gap-only rule calls the same run
    misfolded."""
    net = load_net("corner_cube")
    # The closed form above is the sampled model's (its rim points stand t + ĝ off the face); the
    # plate model, now the default, holds flap 1 by the plates' exact geometry, nearer 90°.
    system = net.system(
        KOH,
        targets=jnp.radians(jnp.full(2, 92.0)),
        release_times=jnp.array([0.0, 200.0]),
        contact="sampled",
        added_mass=False,  # the paper's dynamics: released at once
        viscous=False,
    )
    trajectory = sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(saveat=sim.SaveAt(n=301), solver=diffrax.Tsit5(), max_steps=200_000),
        t1=1500.0,
    )
    report = net.assess(system, trajectory, tolerances=FIXED)
    assert report.verdict == "folded", report.summary()
    final = np.degrees(report.final_angles)
    assert final[0] == pytest.approx(92.0, abs=0.1)  # free: at its hinge's target
    assert 88.4 < final[1] < 89.0  # held out by flap 0's rim, 3.4° short of its hinge's target
    gap = float(net.seam_gaps(report.final_angles)[0])  # host geometry of the rigid folding
    assert gap > 6.0 and report.seam_gaps[0] == pytest.approx(gap, rel=1e-9)
    assert report.seams_touching.tolist() == [True]
    assert "seam 0 by contact" in report.reason
    assert report.settled and report.max_penetration == 0.0 and report.time_to_fold is not None
    plain = _judge(net, system, trajectory, lambda q: net.seam_gap_function(system)(q))
    assert plain.verdict == "misfolded" and plain.reason == "creases at their angles but seams open"


def test_jammed_needs_contact_holding_a_crease_away_from_its_hinge(cube):
    """The same held state (panel 0's rim on panel 4's face: contact engaged) judged against
    creases intended at 100°, every one of them ~10° short: jammed when the hinges aim at 100°
    (contact holds them 10° from where they would rest), misfolded when they aim at 90°, where
    they are (a hinge drawn or bent short, nothing holding it: the panels touch by the way)."""
    net, system = cube
    angles = _angles(0.8)
    intended = np.radians(np.full(5, 100.0))

    def judge(targets_deg, intended=intended):
        aimed = eqx.tree_at(lambda s: s.hinges.target, system, jnp.radians(targets_deg))
        return sim.assess(
            aimed,
            held_trajectory(aimed, angles),
            intended_angles=intended,
            seam_gaps=_one_seam(net, aimed),
            panel_size=net.panel_size(aimed),
            tolerances=FIXED,
        )

    held = judge(np.full(5, 100.0))
    assert held.verdict == "jammed" and held.contacts > 0, held.summary()
    resting = judge(np.full(5, 90.0))
    assert resting.verdict == "misfolded" and resting.contacts > 0, resting.summary()
    assert resting.reason == "crease 0 at 90.0° instead of 100.0°, where its hinge rests (90.0°)"
    # One crease held 5° from its hinge's aim is enough (the others resting short where they aim).
    one = judge(np.array([90.0, 90.0, 90.0, 90.0, 95.0]))
    assert one.verdict == "jammed", one.summary()
    assert one.reason == "contact stops crease(s) 4 short"
    # Contact holding a crease that would fold past its angle (aimed at 95°) at it is no jam of the
    # crease that is short where its own hinge puts it (crease 1, intended at 100°, aimed at 90°).
    crease_1_short = np.radians([90.0, 100.0, 90.0, 90.0, 90.0])
    other = judge(np.array([95.0, 90.0, 90.0, 90.0, 90.0]), crease_1_short)
    assert other.verdict == "misfolded", other.summary()
