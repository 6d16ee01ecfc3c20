"""Closed-loop crease patterns: rigid folding against closed forms, singular places, drift, branch
verdicts, non-rigid patterns, the charge-energy path run as dynamics, bad input.

References: the flat-foldable degree-4 vertex's fold-angle relation (Huffman 1976; Evans et al.,
R. Soc. Open Sci. 2, 2015: ``tan(ρ_2/2) = k tan(ρ_1/2)`` with ``k = sin((β − α)/2) / sin((α + β)/2)``
for sectors ``α, β, π − α, π − β``, ``k = ½`` here); the Miura-ori cell's closed-form geometry
(Schenk & Guest, PNAS 110, 2013: ``H, S, L, V`` against the folding parameter ``θ``).
"""

import functools
import json
import math
import warnings

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.design import SimulationSettings
from origami_jax.fold import FoldFormatError, catalogue_path, loads_fold
from origami_jax.fold._catalogue_loops import MIURA_ALPHA_DEG, MIURA_THETA_DEG, miura_fold_angles
from origami_jax.loops import (
    CreasePattern,
    LoopedPanels,
    NotRigidlyFoldableError,
    compare_unfolding,
    load_pattern,
)
from origami_jax.net import Net, load_net
from origami_jax.system import AIR, KOH_SOLUTION, HingeDesign

from .helpers import stepped_energy_balance

KOH = HingeDesign.literature(fluid=KOH_SOLUTION)
# The paper's dynamics in the bath (no added inertia, released at once): the closed forms and
# branches below are checked on its time scale of hundreds of µs.
PAPER = {"added_mass": False, "viscous": False}
# The closed forms hold exactly on the constraint manifold; the integrated state leaves it by the
# closure drift, held near 1e-9 rad by the Baumgarte feedback at rtol 1e-10, and, within ~1e-4 rad
# of flat, by the penalty the constraint falls back to there (docs/physics.md, "Closed loops").
# Measured on the degree-4 relation: 6e-9 from a flat start; through flat 2.5e-8 at rtol 1e-10 and
# 3e-9 at rtol 1e-11 (the swing through the singular place is run at 1e-11). Checked to 1e-8.
CLOSED_FORM_TOL = 1e-8
# Stated drift bound over long runs (rad of loop rotation).
DRIFT_TOL = 1e-8
RTOL, ATOL, N_SAVE = 1e-10, 1e-12, 201


def _simulate(system, theta0=None, t1=3000.0, inputs=None, rtol=RTOL):
    return sim.simulate(
        system,
        sim.Step() if inputs is None else inputs,
        sim.SolveOptions(
            saveat=sim.SaveAt(n=N_SAVE),
            rtol=rtol,
            atol=rtol * 1e-2,
            solver=diffrax.Tsit5(),
            max_steps=200_000,
            throw=False,
        ),
        t1=t1,
        theta0=theta0,
    )


@functools.cache
def _degree4():
    pattern = load_pattern("vertex_degree4")
    return pattern, pattern.system(KOH, contact=False, **PAPER)


def _by_ray(pattern: CreasePattern, theta: np.ndarray) -> dict[int, np.ndarray]:
    """The vertex's fold angles keyed by the crease's direction in the flat sheet (degrees)."""
    g = pattern.geometry
    out = {}
    for j, line in enumerate(g.crease_edges):
        u, v = g.frame.edges_vertices[line[0]]
        centre = int(g.loop_vertices[0])
        tip = g.vertices_coords[v if u == centre else u] - g.vertices_coords[centre]
        out[round(math.degrees(math.atan2(tip[1], tip[0])) % 360)] = theta[..., j]
    return out


def _relation_error(pattern, theta) -> float:
    """Largest departure from the degree-4 closed form over the samples: majors (60°, 300°) equal,
    collinear minors (0°, 180°) opposite, tan(ρ_180/2) = k tan(ρ_60/2)."""
    r = _by_ray(pattern, theta)
    alpha, beta = math.radians(60), math.radians(120)
    k = math.sin((beta - alpha) / 2) / math.sin((alpha + beta) / 2)
    assert k == pytest.approx(0.5, rel=1e-15)
    return float(
        max(
            np.max(np.abs(r[60] - r[300])),
            np.max(np.abs(r[0] + r[180])),
            np.max(np.abs(np.tan(r[180] / 2) - k * np.tan(r[60] / 2))),
        )
    )


# --- patterns and geometry -------------------------------------------------------------------


@pytest.mark.slow  # every shipped pattern
def test_catalogue_patterns_close_and_fold_rigidly():
    for name, loops in [
        ("vertex_degree4", 1),
        ("vertex_degree6", 1),
        ("waterbomb_base", 1),
        ("miura_3x3", 4),
        ("waterbomb_2x2", 5),
    ]:
        pattern = load_pattern(name)
        assert isinstance(pattern, CreasePattern) and pattern.n_loops == loops, name
        degrees = {len(c) for c in pattern.geometry.loop_creases}
        assert degrees == {"vertex_degree6": {6}, "waterbomb_base": {8}, "waterbomb_2x2": {6}}.get(
            name, {4}
        )
        # The shipped angles close every loop (independent NumPy product of rotations).
        assert np.max(pattern.closure_residual(pattern.intended_angles)) < 1e-12, name
        report = pattern.rigid_foldability()
        assert report.rigid and report.residual < 1e-10, (name, report.summary())
    # Nets still go to the tree engine.
    assert isinstance(load_pattern("cube_net_01"), Net)


def test_origami_simulator_export_loads_as_is():
    path = catalogue_path("origami_simulator_miura")
    raw = json.loads(path.read_text())
    # The file is in Origami Simulator's export layout, not ours.
    assert raw["file_spec"] == 1.1 and raw["file_creator"].startswith("Origami Simulator")
    assert raw["frame_unit"] == "unit" and raw["frame_classes"] == ["foldedForm"]
    assert all(len(f) == 3 for f in raw["faces_vertices"]) and "F" in raw["edges_assignment"]
    assert all(abs(v[1]) == 0 for v in raw["vertices_coords"])  # the x–z plane
    with pytest.raises(ValueError, match="length_scale"):
        load_pattern(path)
    pattern = load_pattern(path, length_scale=200.0)
    assert pattern.geometry.n_faces == 4 and pattern.n_creases == 4 and pattern.n_loops == 1
    np.testing.assert_allclose(np.abs(pattern.intended_angles), np.pi)
    pattern.check_angles(pattern.intended_angles)  # Kawasaki, Maekawa, closure
    # Contact, panel drag: builds (hinges within the 150 µm creases, or it warns).
    system = pattern.system(HingeDesign.literature(hinge_width=140.0))
    assert isinstance(system.mechanism, LoopedPanels) and system.n_hinges == 4
    hinged = load_pattern(path, length_scale=200.0, flat_creases="hinge")
    assert hinged.geometry.n_faces == 8 and hinged.n_creases == 8


def test_a_net_with_its_faces_triangulated_is_the_net_of_its_panels():
    # A net whose squares are split by flat (F) diagonals (as a triangulating exporter writes
    # it) is read as the net of its squares: F joins its two faces into one rigid panel, for a
    # net as for a closed-loop pattern (it was a hinge aimed at 0°, which no stressed hinge is).
    data = json.loads(catalogue_path("cube_net_01").read_text())
    faces, edges = [], data["edges_vertices"]
    for a, b, c, d in data["faces_vertices"]:
        faces += [[a, b, c], [a, c, d]]
        edges = [*edges, [a, c]]
    n = len(data["faces_vertices"])
    data.update(
        faces_vertices=faces,
        edges_vertices=edges,
        edges_assignment=[*data["edges_assignment"], *"F" * n],
        edges_foldAngle=[*data["edges_foldAngle"], *[0] * n],
    )
    net = load_pattern(loads_fold(json.dumps(data)))
    square = load_pattern("cube_net_01")
    assert isinstance(net, Net) and net.n_creases == square.n_creases == 5
    assert net.geometry.n_faces == 6 and "F" not in net.key_frame.edges_assignment
    np.testing.assert_allclose(sorted(net.intended_angles), sorted(square.intended_angles))
    np.testing.assert_allclose(net.geometry.face_areas, square.geometry.face_areas)
    assert np.max(net.seam_gaps(net.intended_angles)) < 1e-9 * 200.0
    # The library's net loader reads it alike; a root is a face of the file (triangle 7: the
    # second triangle of square 3).
    direct = load_net(loads_fold(json.dumps(data)), root=7)
    assert direct.n_creases == 5 and direct.geometry.n_faces == 6 and direct.geometry.root == 3
    assert load_pattern(loads_fold(json.dumps(data)), root=7).geometry.root == 3
    # Read with every F edge a hinge, it is the net of triangles (which a fold refuses).
    hinged = load_pattern(loads_fold(json.dumps(data)), flat_creases="hinge")
    assert hinged.geometry.n_faces == 12 and hinged.n_creases == 11
    with pytest.raises(ValueError, match=r"crease \d+ folds to 0°.*flat_creases='hinge'"):
        hinged.system(HingeDesign.literature(hinge_width=150.0))


def test_closure_jacobian_is_the_derivative_of_the_closure():
    pattern, system = _degree4()
    mechanism = system.mechanism
    theta = jnp.asarray(pattern.intended_angles) * 0.7 + 0.01
    jac = mechanism.closure_jacobian(theta)
    reference = jax.jacfwd(lambda t: mechanism.closure(t).reshape(-1))(theta)
    np.testing.assert_allclose(jac, reference, atol=1e-13)
    # At flat the loop's rank drops to 2 (the in-plane rotations): the bifurcation.
    singular = np.linalg.svd(np.asarray(mechanism.closure_jacobian(jnp.zeros(4))), compute_uv=False)
    assert singular[1] > 0.5 and singular[2] < 1e-14


# --- dynamics against closed forms -----------------------------------------------------------


@functools.cache
def _degree4_from_flat():
    pattern, system = _degree4()
    return _simulate(system)


def test_degree4_vertex_follows_its_closed_form_from_flat():
    pattern, system = _degree4()
    trajectory = _degree4_from_flat()
    theta = np.asarray(trajectory.theta)
    assert bool(trajectory.succeeded) and np.all(theta[0] == 0)
    assert _relation_error(pattern, theta) < CLOSED_FORM_TOL
    report = pattern.assess(system, trajectory)
    assert report.verdict == "folded", report.summary()
    assert report.wrong_creases == () and report.closure_drift < DRIFT_TOL
    np.testing.assert_array_equal(report.branch, np.sign(pattern.intended_angles))


# The fixed-step engine holds loops closed by a stiff penalty (10⁴ times the step's other terms),
# so the loops open by ~1e-4 of a step's motion: measured on this vertex (paper dynamics, 3 ms)
# 1.5e-6 rad of loop rotation at dt 1 µs, 3.7e-7 at 0.5, 9.3e-8 at 0.25 (as dt²), the closed-form
# relation likewise (1.7e-6 at dt 1 µs); checked at 1e-5 for dt 1 µs. The departure from the
# adaptive trajectory: 2.1e-3, 9.9e-4, 4.8e-4 rad (first order).
FIXED_STEP_CLOSURE_TOL = 1e-5


@functools.cache
def _degree4_pre_folded():
    """The adaptive fold from the fixed steps' pre-fold (`start_bias`: they cannot leave flat)."""
    pattern, system = _degree4()
    start = pattern.start_state(system, bias=sim.FIXED_STEP_PRE_FOLD)[0]
    return start, _simulate(system, theta0=start)


@functools.cache
def _degree4_fixed_steps(dt: float):
    pattern, system = _degree4()
    start, _ = _degree4_pre_folded()
    fixed = sim.SolveOptions(saveat=sim.SaveAt(n=N_SAVE), solver=sim.ImplicitStep(dt=dt))
    return sim.simulate(system, sim.Step(), fixed, t1=3000.0, theta0=start)


@pytest.mark.slow  # the closed loop's fixed-step solve and the adaptive one compiled: ~26 s
def test_fixed_steps_hold_the_vertex_closed_and_follow_the_adaptive_fold():
    """`ImplicitStep` on a closed loop: the degree-4 vertex folds on its branch with its loop held
    closed and its closed-form relation kept, along the adaptive solver's trajectory from the same
    pre-fold within implicit Euler's first-order error (2.1e-3 rad measured, checked at 1e-2, for
    dt 1 µs over 3 ms of this underdamped swing), and folded by the same verdict. From flat at rest, where the
    fixed steps cannot choose a branch, `simulate` refuses in one line."""
    pattern, system = _degree4()
    _, adaptive = _degree4_pre_folded()
    trajectory = _degree4_fixed_steps(1.0)
    theta = np.asarray(trajectory.theta)
    assert bool(trajectory.succeeded) and float(trajectory.stats["newton_error"]) < 1e-9
    closure = jax.vmap(system.mechanism.closure)(trajectory.theta)
    assert float(jnp.max(jnp.abs(closure))) < FIXED_STEP_CLOSURE_TOL
    assert _relation_error(pattern, theta) < FIXED_STEP_CLOSURE_TOL
    assert np.max(np.abs(theta - np.asarray(adaptive.theta))) < 1e-2
    report = pattern.assess(system, trajectory, bias=sim.FIXED_STEP_PRE_FOLD)
    assert report.verdict == "folded", report.summary()
    np.testing.assert_array_equal(report.branch, np.sign(pattern.intended_angles))
    fixed = sim.SolveOptions(saveat=sim.SaveAt(n=16), solver=sim.ImplicitStep(dt=1.0))
    with pytest.raises(ValueError, match="cannot choose a closed-loop pattern's folding branch"):
        sim.simulate(system, sim.Step(), fixed, t1=2.0)
    # A fit starts flat and traces its simulations: its settings refuse it up front.
    with pytest.raises(ValueError, match="cannot choose the folding branch under a sudden"):
        SimulationSettings(100.0, layout=pattern, options=fixed)
    assert SimulationSettings(100.0, layout=pattern, inputs=sim.Step(ramp=50.0), options=fixed)


@pytest.mark.slow  # two more fixed-step compilations
def test_fixed_steps_on_a_loop_converge_at_first_order():
    """Halving the step halves the departure from the adaptive trajectory (implicit Euler's
    order), and the loop's opening falls with it."""
    _, system = _degree4()
    _, adaptive = _degree4_pre_folded()
    errors, openings = [], []
    for dt in (1.0, 0.5, 0.25):
        trajectory = _degree4_fixed_steps(dt)
        errors.append(np.max(np.abs(np.asarray(trajectory.theta) - np.asarray(adaptive.theta))))
        closure = jax.vmap(system.mechanism.closure)(trajectory.theta)
        openings.append(float(jnp.max(jnp.abs(closure))))
    for coarse, fine in zip(errors, errors[1:], strict=False):
        assert 0.35 < fine / coarse < 0.65, errors
    assert openings[2] < openings[0] / 4, openings


@pytest.mark.slow  # a forward-mode compilation through 200 fixed steps
def test_fixed_step_gradients_on_a_loop_match_central_differences():
    """The derivative of the fixed steps' fold through the closure penalty (the implicit function
    theorem at each step) against central differences: the vertex's angles at 200 µs with respect
    to a scale of every hinge's stiffness. The implicit function theorem differentiates the
    discrete map's exact roots, the differences the computed ones, which stop within the Newton
    test (1e-10 rad per step): the differences' own error, up to 1e-10 / 1e-5 rad over a step of
    1e-5, ~2e-4 relative here. Measured 1e-8 relative while free steps took two Newton updates
    (the second converging quadratically far below the test), 1.8e-6 since the predictor
    extrapolates and they take one (central differences at steps 1e-5, 1e-4 and a Richardson
    extrapolation at 1e-3 all agree on it: the computed map's own derivative); checked at 1e-5."""
    pattern, system = _degree4()
    start, _ = _degree4_pre_folded()
    fixed = sim.SolveOptions(saveat=sim.SaveAt(n=11), solver=sim.ImplicitStep(dt=1.0))

    @jax.jit
    def final(scale):
        stiffer = eqx.tree_at(lambda s: s.hinges.stiffness, system, system.hinges.stiffness * scale)
        return sim.simulate(stiffer, sim.Step(), fixed, t1=200.0, theta0=start).theta[-1]

    exact = jax.jacfwd(final)(1.0)
    step = 1e-5
    central = (final(1 + step) - final(1 - step)) / (2 * step)
    assert float(jnp.max(jnp.abs(exact - central))) < 1e-5 * float(jnp.max(jnp.abs(central)))


def test_degree4_vertex_swings_through_flat_on_its_branch():
    """Start folded, aim at the mirror image: the vertex passes through the flat bifurcation at
    speed and stays on its branch (the relation holds through flat)."""
    pattern, system = _degree4()
    start = pattern.intended_angles
    mirrored = eqx.tree_at(lambda s: s.hinges.target, system, jnp.asarray(-start))
    trajectory = _simulate(mirrored, theta0=start, t1=300.0, rtol=1e-11)
    theta = np.asarray(trajectory.theta)
    assert np.any(theta[:, 0] > 0.5) and np.any(theta[:, 0] < -0.5)
    assert _relation_error(pattern, theta) < CLOSED_FORM_TOL
    report = pattern.assess(mirrored, trajectory, intended_angles=-start)
    assert report.verdict == "folded", report.summary()


def test_degree4_vertex_folds_flat():
    """Targets at the fully folded state (every crease at ±180°): the other singular place."""
    pattern, system = _degree4()
    flat_folded = np.sign(pattern.intended_angles) * np.pi
    pattern.check_angles(flat_folded)
    folded = eqx.tree_at(lambda s: s.hinges.target, system, jnp.asarray(flat_folded))
    trajectory = _simulate(folded)
    theta = np.asarray(trajectory.theta)
    report = pattern.assess(folded, trajectory, intended_angles=flat_folded)
    assert report.verdict == "folded", report.summary()
    assert np.max(np.abs(theta[-1] - flat_folded)) < 1e-3
    assert np.max(pattern.closure_residual(theta)) < DRIFT_TOL
    # Away from the end, where tan(ρ/2) diverges, the relation holds along the way.
    away = np.abs(theta[:, 0]) < np.pi - 0.05
    assert _relation_error(pattern, theta[away]) < CLOSED_FORM_TOL


@pytest.mark.slow  # a long run
def test_constraint_drift_stays_bounded_over_a_long_run():
    """In air the vertex rings for thousands of periods; Baumgarte's feedback keeps the loop closed:
    drift bounded, no growth from the first half of the run to the second."""
    pattern, _ = _degree4()
    system = pattern.system(HingeDesign.literature(fluid=AIR), contact=False)
    start = pattern.start_state(system, bias=1e-3)[0]
    trajectory = _simulate(system, theta0=start, t1=6000.0)
    assert bool(trajectory.succeeded)
    drift = pattern.closure_residual(np.asarray(trajectory.theta))[:, 0]
    half = len(drift) // 2
    assert np.max(drift) < DRIFT_TOL
    assert np.max(drift[half:]) < 2 * np.max(drift[:half]) + 1e-12
    # Still ringing: a long run indeed (the swing at the end is over a degree).
    tail = np.asarray(trajectory.theta)[-20:, 0]
    assert np.ptp(tail) > np.radians(1.0)


@functools.cache
def _miura():
    pattern = load_pattern("miura_3x3")
    system = pattern.system(KOH, contact=False, **PAPER)
    start = pattern.start_state(system, bias=1e-3)[0]
    return pattern, system, _simulate(system, theta0=start)


@pytest.mark.slow  # a Miura cell's folding; the degree-4 closed form runs by default
def test_miura_follows_schenk_and_guest():
    pattern, system, trajectory = _miura()
    g = pattern.geometry
    theta = np.asarray(trajectory.theta)
    alpha = math.radians(MIURA_ALPHA_DEG)
    a = b = 200.0  # µm, the catalogue's sides
    straight = np.array([abs(d[1]) < 1e-12 for d in g.axes])  # straight creases run along x
    for angles in theta[1:]:
        rho_s = np.abs(angles[straight])
        rho_z = np.abs(angles[~straight])
        # Every straight crease alike and every zigzag crease alike (one degree of freedom), the
        # zigzag from the straight by the closed form.
        assert np.ptp(rho_s) < CLOSED_FORM_TOL and np.ptp(rho_z) < CLOSED_FORM_TOL
        theta_sg = (np.pi - rho_s[0]) / 2
        zigzag = miura_fold_angles(alpha, theta_sg)[1]
        assert abs(rho_z[0] - zigzag) < CLOSED_FORM_TOL
        # The cell's geometry (Schenk & Guest's H, S, L, V) at the first interior vertex, from the
        # folded vertex positions (the NumPy rigid folding of the pattern).
        corners = g.fold(angles)
        position = {}
        for f, face in enumerate(g.tree.faces):
            for k, vertex in enumerate(face):
                position.setdefault(vertex, corners[f, k])
        centre = int(g.loop_vertices[0])
        ends = {}
        for j in g.loop_creases[0]:
            u, v = g.frame.edges_vertices[g.crease_edges[j][0]]
            ends[j] = position[v if u == centre else u] - position[centre]
        sectors = np.asarray(g.loop_sectors[0])
        creases = list(g.loop_creases[0])
        straight_here = [j for j in creases if straight[j]]
        acute = next(
            j
            for j in straight_here
            if abs(sectors[creases.index(j)] - alpha) < 1e-9
            and abs(sectors[creases.index(j) - 1] - alpha) < 1e-9
        )
        obtuse = next(j for j in straight_here if j != acute)
        zig = next(j for j in creases if not straight[j])
        c_a, c_o, c_z = ends[acute], ends[obtuse], ends[zig]
        normal = np.cross(c_a, c_o)
        normal /= np.linalg.norm(normal)
        bisector = c_a / b - c_o / b
        bisector /= np.linalg.norm(bisector)
        up = np.cross(normal, bisector)
        root = np.sqrt(1 + np.cos(theta_sg) ** 2 * np.tan(alpha) ** 2)
        closed = {
            "H": a * np.sin(theta_sg) * np.sin(alpha),
            "S": b * np.cos(theta_sg) * np.tan(alpha) / root,
            "L": a * np.sqrt(1 - np.sin(theta_sg) ** 2 * np.sin(alpha) ** 2),
            "V": b / root,
        }
        measured = {
            "H": abs(c_z @ normal),
            "S": abs(c_a @ up),
            "L": abs(c_z @ bisector),
            "V": abs(c_a @ bisector),
        }
        for key in closed:
            assert abs(measured[key] - closed[key]) < CLOSED_FORM_TOL * a, key
    report = pattern.assess(system, trajectory, bias=1e-3)
    assert report.verdict == "folded", report.summary()
    assert math.isclose(
        math.degrees((np.pi - abs(theta[-1][straight][0])) / 2), MIURA_THETA_DEG, abs_tol=0.1
    )


def test_the_wrong_branch_is_misfolded():
    """Released with the pattern's major creases aimed the other way, the vertex takes the mirror
    branch: the verdict says misfolded and names the creases that went the other way."""
    pattern, system = _degree4()
    flipped = eqx.tree_at(lambda s: s.hinges.target, system, jnp.asarray(-pattern.intended_angles))
    trajectory = _simulate(flipped)
    report = pattern.assess(flipped, trajectory)
    assert report.verdict == "misfolded", report.summary()
    assert set(report.wrong_creases) == set(range(4))
    assert "another folding branch" in report.reason
    # Started flat, where the branches meet: the summary says how to start on the hinges' branch.
    assert "started flat, where the folding branches meet" in report.summary()
    assert "--bias 0.05" in report.summary()


def test_a_crease_left_flat_is_another_branch():
    """A crease the pattern folds that never leaves flat is off the pattern's branch too (a vertex
    of degree six takes such branches from flat): named in the reason and the summary, with the
    hint to start pre-folded. The vertex's folding with its crease 1 held at 0 throughout."""
    pattern, system = _degree4()
    trajectory = _degree4_from_flat()
    held = eqx.tree_at(lambda t: t.theta, trajectory, trajectory.theta.at[:, 1].set(0.0))
    report = pattern.assess(system, held)
    assert report.verdict == "misfolded", report.summary()
    assert report.stayed_flat == (1,) and report.wrong_creases == ()
    assert report.reason == "took another folding branch: crease(s) 1 stayed flat"
    summary = report.summary()
    assert "branch: not the pattern's, crease(s) 1 stayed flat (started flat, where" in summary
    assert "--bias 0.05" in summary
    # The vertex's own folding: every crease left flat on the pattern's branch.
    assert pattern.assess(system, trajectory).stayed_flat == ()


# --- single vertex: the charge-energy path as dynamics ----------------------------------------


@pytest.mark.slow
def test_corner_cube_charge_energy_path_taken_as_dynamics():
    comparison = compare_unfolding(released=False)
    assert comparison.unfolding.verdict.value == "flat-unfolded"
    driven = comparison.driven
    assert driven.verdict == "folded", driven.report.summary()
    assert not driven.certificate.crossing_states and driven.certificate.min_clearance > 0
    assert comparison.takeable
    assert driven.report.closure_drift < DRIFT_TOL
    assert 0.99 < driven.reached < 1.01


# --- non-rigid patterns and bad input --------------------------------------------------------


def test_square_twist_is_reported_not_rigidly_foldable():
    pattern = load_pattern("square_twist")
    pattern.check_angles(pattern.intended_angles)  # flat-foldable: Kawasaki and Maekawa hold
    report = pattern.rigid_foldability()
    assert not report.rigid and report.residual > np.radians(1.0)
    with pytest.raises(
        NotRigidlyFoldableError, match="not rigidly foldable.*facets must bend"
    ) as e:
        pattern.system()
    assert e.value.report.residual == report.residual
    # Asked to, it builds the rigid-panel system anyway.
    assert pattern.system(check_rigid=False, contact=False).n_hinges == pattern.n_creases


def _fold_text(fold) -> dict:
    return json.loads(catalogue_path(fold).read_text())


def test_bad_input_is_refused(tmp_path):
    # Non-manifold: a third face on an edge.
    data = _fold_text("vertex_degree4")
    data["vertices_coords"].append([300.0, 100.0])
    edge = data["edges_vertices"][0]
    new = len(data["vertices_coords"]) - 1
    data["faces_vertices"].append([edge[0], edge[1], new])
    data["edges_vertices"] += [[edge[1], new], [new, edge[0]]]
    data["edges_assignment"] += ["B", "B"]
    data["edges_foldAngle"] += [0, 0]
    with pytest.raises(FoldFormatError, match="faces 0 and 4 both run along the side 0 -> 1"):
        load_pattern(loads_fold(json.dumps(data)))
    # Fold angles that do not close the loop.
    data = _fold_text("vertex_degree4")
    data["edges_foldAngle"] = [90.0 if a != "B" else 0 for a in data["edges_assignment"]]
    data["edges_assignment"] = ["V" if a != "B" else a for a in data["edges_assignment"]]
    pattern = load_pattern(loads_fold(json.dumps(data)))
    with pytest.raises(FoldFormatError, match="do not close.*free fold angles"):
        pattern.system()
    # A flat-folded state at a vertex that is not flat-foldable (Kawasaki).
    bad = loads_fold(json.dumps(_fan_fold([0, 60, 170, 280], [-180, 180, 180, 180])))
    with pytest.raises(FoldFormatError, match="Kawasaki"):
        load_pattern(bad).system()
    # Flat-foldable sectors, but the mountains and valleys break Maekawa.
    bad = loads_fold(json.dumps(_fan_fold([0, 60, 180, 300], [180, 180, 180, 180])))
    with pytest.raises(FoldFormatError, match="Maekawa"):
        load_pattern(bad).system()
    pattern, _ = _degree4()
    with pytest.raises(ValueError, match="finite length"):
        pattern.system(hinges="arc")
    with pytest.raises(ValueError, match="drag"):
        pattern.system(drag="hinge")
    with pytest.raises(ValueError, match="one fold angle per crease"):
        pattern.system(targets=jnp.zeros(3))
    with pytest.raises(ValueError, match="bias"):
        pattern.start_state(bias=-1.0)


def test_a_pre_fold_lies_on_the_aimed_branch_at_the_asked_size():
    """`start_state(bias=...)`: a closed state of about `bias` rad with every crease on its
    target's side of flat. The waterbomb base's nearest closed state to
    the stiffness-weighted targets falls to flat (4e-9 rad for 1e-3, 4e-7 for 0.05, before
    2026-12-06); it is reached down the branch from the full fold instead."""
    waterbomb = load_pattern("waterbomb_base")
    paper = waterbomb.system(KOH, contact=False, **PAPER)
    for pattern, system in (_degree4(), (waterbomb, paper)):
        name = pattern.name
        for bias in (1e-3, 0.05):
            theta, rate = pattern.start_state(system, bias=bias)
            assert 0.2 * bias < np.linalg.norm(theta) < 1.5 * bias, (name, bias)
            assert np.all(np.sign(theta) == np.sign(pattern.intended_angles)), name
            assert float(np.max(pattern.closure_residual(theta))) < 1e-12 and not np.any(rate)


def _fan_fold(rays_deg, angles_deg) -> dict:
    """A single interior vertex in a square, creases along `rays_deg` with `angles_deg`."""
    from origami_jax.fold._catalogue_loops import _fan

    fold, rays = _fan(
        list(map(float, rays_deg)),
        (200.0, 200.0),
        [1 if a > 0 else -1 for a in angles_deg],
        title="t",
        frame_title="t",
        description="t",
    )
    key = fold.frames[0]
    out = key.to_dict()
    tips = []
    for u, v in key.edges_vertices.tolist():
        tip = np.asarray(key.vertices_coords)[v if u == 0 else u]
        tips.append(round(math.degrees(math.atan2(tip[1], tip[0])) % 360))
    out["edges_foldAngle"] = [
        float(angles_deg[rays_deg.index(t)]) if a != "B" and t in rays_deg else 0.0
        for t, a in zip(tips, key.edges_assignment, strict=True)
    ]
    out["file_spec"] = 1.2
    return out


# --- one physics: CLI, design layout, sweep ---------------------------------------------------


def test_fold_cli_lists_and_refuses(tmp_path, capsys):
    from origami_jax.cli import main

    assert main(["fold", "--list"]) == 0
    listed = capsys.readouterr().out.split()
    for name in (
        "vertex_degree4",
        "vertex_degree6",
        "miura_3x3",
        "waterbomb_base",
        "waterbomb_2x2",
    ):
        assert name in listed
    code = main(["fold", "square_twist", "--no-figures", "--out", str(tmp_path / "twist")])
    assert code == 2 and "not rigidly foldable" in capsys.readouterr().err
    code = main(["fold", "origami_simulator_miura", "--no-figures", "--out", str(tmp_path / "os")])
    assert code == 2 and "give --length-scale, µm per FOLD unit" in capsys.readouterr().err
    # A misspelt name: neither a file nor a shipped net, and the message says where the names are.
    code = main(["fold", "cube_net_1", "--no-figures", "--out", str(tmp_path / "typo")])
    err = capsys.readouterr().err
    assert code == 2 and "no shipped net of that name" in err and "fold --list" in err, err
    with pytest.raises(FileNotFoundError, match="catalogue_names"):
        load_pattern(tmp_path / "missing.fold")


def test_layout_and_sweep_kernel_build_closed_loop_systems():
    from origami_jax.sweep import get_model

    pattern, system = _degree4()
    layout = pattern.with_model(contact=False, **PAPER)
    built = layout(KOH)
    assert layout.n_hinges == 4 and isinstance(built.mechanism, LoopedPanels)
    np.testing.assert_allclose(built.hinges.stiffness, system.hinges.stiffness, rtol=1e-15)
    kernel = get_model("net-fold", net="vertex_degree4", contact=False, bias=1e-3)
    assert kernel.settings["closed_loops"] == 1 and "release[3]" in kernel.parameters


@pytest.mark.slow  # the yield tests sweep a closed-loop pattern with contact by default
def test_a_sweep_folds_a_closed_loop_pattern_with_contact_as_its_own_system_does():
    # The kernel builds the system inside a trace: the pattern's checks and its contact tables
    # must still be computed on the host (both once failed there), and each member must fold as
    # the pattern's own system with that design does. Default hinges: no wider than the creases.
    from origami_jax.net import hinges_within_creases
    from origami_jax.sweep import Table, get_model, sweep

    pattern = load_pattern("vertex_degree4").with_model(**PAPER)
    strains = [0.004, 0.006]
    settings = dict(t_end=150.0, n_save=11, bias=1e-3, **PAPER)
    kernel = get_model("net-fold", net="vertex_degree4", **settings)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        swept = sweep(kernel, Table({"misfit_strain": strains}), progress=False)
    assert list(swept["result"].values) == [0, 0]
    base = hinges_within_creases(KOH, pattern.crease_lengths)
    theta0 = pattern.start_state(bias=settings["bias"])[0]
    for strain, final in zip(strains, swept["final_angle"].values, strict=True):
        system = pattern.system(eqx.tree_at(lambda d: d.misfit_strain, base, strain))
        trajectory = sim.simulate(
            system,
            sim.Step(),
            sim.SolveOptions(saveat=sim.SaveAt(n=settings["n_save"]), solver=diffrax.Tsit5()),
            theta0=theta0,
            t1=settings["t_end"],
        )
        # The same equations and solver, one member of a vmap against one call: round-off.
        np.testing.assert_allclose(final, trajectory.theta[-1], atol=1e-9)


@pytest.mark.slow
def test_fold_cli_folds_a_closed_loop_pattern_in_the_bath(tmp_path, capsys):
    """The command's defaults in the etch bath: the panels carry the fluid's inertia and are
    released over the branch's quasi-static ramp (4000 µs), and the vertex folds on its branch."""
    from origami_jax.cli import main

    out = tmp_path / "vertex"
    argv = ["fold", "vertex_degree4", "--fluid", "koh", "--no-contact"]
    code = main(argv + ["--no-figures", "--n-save", "201", "--bias", "0.001", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    result = json.loads((out / "result.json").read_text())
    assert result["verdict"] == "folded" and result["closed_loops"] == 1
    # The closure's stabilisation runs at the wet hinges' rate, 20 times slower than the dry
    # ones' (DRIFT_TOL's): its drift, ~6e-8 rad over the 5000 µs, is still 1e-6 of the verdict's
    # angle tolerance.
    assert result["wrong_creases"] == [] and result["closure_drift"] < 1e-6
    assert result["added_mass"] is True and result["viscous"] is True
    assert result["release_ramp_us"] == 4000.0
    assert (out / "trajectory.fold").is_file()


@pytest.mark.slow  # one tight-tolerance folding of a vertex carrying the bath's inertia (~15 s)
def test_closed_loops_in_the_bath_lose_exactly_the_fluids_dissipation():
    """A degree-4 vertex whose panels carry the fluid's added inertia and viscous drag (the bath's
    default), stepped to its angles: kinetic (panels and fluid) + spring energy − the step's work
    ``Σ k θ_target θ`` falls by the work the drags take out, ``∫ Σ_parts (−θ̇ᵀ f) dt`` (Simpson on
    1501 samples), to 1e-7 of the released energy (measured 2e-9: the closure's constraint force
    does no work beyond its drift, 1e-10 rad); each part dissipates, and half the energy is gone
    by 6 ms."""
    pattern = load_pattern("vertex_degree4").with_model(contact=False)
    system = pattern.system(KOH)
    assert system.mechanism.carries_added_inertia and len(system.drag.parts) == 2
    trajectory = sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(
            saveat=sim.SaveAt(n=1501),
            rtol=RTOL,
            atol=ATOL,
            solver=diffrax.Tsit5(),
            max_steps=200_000,
        ),
        t1=6000.0,
        theta0=pattern.start_state(system, bias=1e-3)[0],
    )
    balance, lost, scale, rates = stepped_energy_balance(system, trajectory)
    assert all(r.min() >= -1e-12 * np.abs(r).max() for r in rates)
    assert lost[-1] > 0.3 * scale
    np.testing.assert_allclose(balance, balance[0], atol=1e-7 * scale)


def test_a_hinge_wider_than_its_crease_is_warned_about():
    # The literature hinge is 200 µm wide; four creases of the degree-6 vertex are 141 µm long.
    # The system models such a hinge that wide all the same, and says so; per-crease widths
    # within the creases are taken silently.
    from origami_jax.cli._common import _one_line_warning

    pattern = load_pattern("vertex_degree6")
    lengths = pattern.geometry.lengths * pattern.length_scale
    assert np.sum(lengths < 200.0) == 4
    with pytest.warns(UserWarning, match=r"hinges wider than their creases.*crease 0 \(200 on 141"):
        pattern.system(HingeDesign.literature(), contact=False, check_rigid=False)
    within = HingeDesign.literature(hinge_width=0.9 * lengths)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pattern.system(within, contact=False, check_rigid=False)
        # Without a design: the literature hinge, each no wider than its crease.
        default = pattern.system(contact=False, check_rigid=False)
    clipped = HingeDesign.literature(hinge_width=np.minimum(lengths, 200.0))
    expected = pattern.system(clipped, contact=False, check_rigid=False)
    np.testing.assert_allclose(default.hinges.stiffness, expected.hinges.stiffness, rtol=1e-15)
    with pytest.warns(UserWarning, match="hinges wider"):
        wide = pattern.system(HingeDesign.literature(), contact=False, check_rigid=False)
    ratio = np.asarray(default.hinges.stiffness) / np.asarray(wide.hinges.stiffness)
    np.testing.assert_allclose(ratio, np.minimum(lengths, 200.0) / 200.0, rtol=1e-12)
    line = _one_line_warning("hinges wider", UserWarning, "x.py", 1)
    assert line == "origami-jax: warning: hinges wider\n"  # the command line's form
