"""A folded form unfolded to its crease pattern: round trips through our own folding, fold angles
against hand-built folds, a closed cube cut into a net, and bad forms refused in one line."""

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from origami_jax.fold import (
    FoldFile,
    FoldFormatError,
    FoldFrame,
    is_folded_form,
    read_fold,
    unfold_folded_form,
)
from origami_jax.fold._pattern_file import edges_of
from origami_jax.loops import load_pattern
from origami_jax.net import load_net

# Unfolding composes one rotation per face of the tree: round-off only.
ROUND_TRIP_TOL = 1e-12
DATA = Path(__file__).parent / "data" / "fold"


def _aligned(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`b` (`(n, 2)`) moved by the rotation and translation (no reflection) that best fit it onto
    `a` (Kabsch)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((b - cb).T @ (a - ca))
    rotation = (u @ vt).T
    assert np.linalg.det(rotation) > 0, "the unfolded sheet is a mirror image"
    return (b - cb) @ rotation.T + ca


@pytest.mark.parametrize("name", ["cube_net_01", "miura_3x3"])
def test_a_folded_form_of_ours_unfolds_to_its_pattern(name):
    # Fold a shipped pattern to its angles with our own FOLD writer, keep only the folded form,
    # and read it back: the same sheet (up to a rigid motion) and the same fold angles.
    pattern = load_pattern(name)
    angles = pattern.intended_angles
    animation = pattern.to_fold(angles=np.stack([0 * angles, angles]), times=np.array([0.0, 1.0]))
    folded = animation.frame(animation.n_frames - 1)
    assert is_folded_form(folded) and not is_folded_form(animation.frame(0))
    flat = unfold_folded_form(folded)
    key = animation.frame(0)
    assert flat.n_vertices == key.n_vertices and flat.n_edges == key.n_edges
    size = np.ptp(key.vertices_coords[:, :2], axis=0).max()
    np.testing.assert_allclose(
        _aligned(key.vertices_coords[:, :2], flat.vertices_coords[:, :2]),
        key.vertices_coords[:, :2],
        atol=ROUND_TRIP_TOL * size,
    )
    again = load_pattern(FoldFile(frames=(folded,)), name=name)
    assert type(again) is type(pattern) and again.n_creases == pattern.n_creases
    np.testing.assert_allclose(again.intended_angles, angles, atol=ROUND_TRIP_TOL)


def _square_folded(angle_deg: float, assignment: str = "U", reverse: bool = False) -> FoldFrame:
    """A unit square folded along its diagonal 0–2: triangle (0, 1, 2) on the xy plane, front +z,
    triangle (0, 2, 3) turned about the diagonal by `angle_deg` towards the front (a valley)."""
    theta = np.radians(angle_deg)
    axis = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    p3 = np.array([0.0, 1.0, 0.0])
    # Rodrigues: turn p3 about the diagonal 0→2 by θ (right-handed: p3 rises towards +z).
    c, s = np.cos(theta), np.sin(theta)
    turned = p3 * c + np.cross(axis, p3) * s + axis * (axis @ p3) * (1 - c)
    coords = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], turned])
    faces = ((0, 1, 2), (0, 2, 3))
    if reverse:
        faces = tuple(f[::-1] for f in faces)
    edges = np.array([[0, 1], [1, 2], [2, 0], [2, 3], [3, 0]])
    return FoldFrame(
        vertices_coords=coords,
        edges_vertices=edges,
        edges_assignment=("B", "B", assignment, "B", "B"),
        faces_vertices=faces,
        frame_unit="um",
        frame_classes=("foldedForm",),
    )


def test_a_fold_angle_is_the_forms_dihedral_valley_positive():
    form = _square_folded(60.0)
    assert form.coords3[3, 2] > 0  # the far triangle rose to the front: a valley fold
    flat = unfold_folded_form(form)
    (crease,) = np.flatnonzero(np.asarray(flat.edges_assignment) != "B")
    assert flat.edges_assignment[crease] == "V"
    assert abs(flat.edges_fold_angle_deg[crease] - 60.0) < 1e-12
    assert flat.vertices_coords.shape == (4, 2)
    (x1, y1), (x3, y3) = flat.vertices_coords[[1, 3]] - flat.vertices_coords[0]
    area = 0.5 * abs(x1 * y3 - y1 * x3)
    assert abs(area - 0.5) < 1e-12  # the square's two triangles, side by side again
    mountain = unfold_folded_form(_square_folded(-45.0))
    assert mountain.edges_assignment[crease] == "M"
    assert abs(mountain.edges_fold_angle_deg[crease] + 45.0) < 1e-12
    # Faces wound from the other side than the assignments: every M/V crease disagrees, so the
    # faces are read reversed, and the valley stays a valley.
    for form in (_square_folded(60.0, "V", reverse=True), _square_folded(-60.0, "V")):
        reversed_ = unfold_folded_form(form)
        assert reversed_.edges_assignment[crease] == "V"
        assert abs(reversed_.edges_fold_angle_deg[crease] - 60.0) < 1e-12


def _closed_cube(outward: bool) -> FoldFrame:
    corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    # Each face counter-clockwise seen from outside the cube.
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    if not outward:
        faces = [f[::-1] for f in faces]
    return FoldFrame(
        vertices_coords=200.0 * corners,
        faces_vertices=tuple(faces),
        frame_unit="um",
        frame_classes=("foldedForm",),
    )


@pytest.mark.parametrize("outward", [True, False])
def test_a_closed_cube_is_cut_into_a_net_and_folds_back(outward, tmp_path):
    # No flat sheet keeps a cube's twelve edges: the tree of faces keeps five as creases and the
    # unfolding says where it cut. Faces seen from outside fold away from their front: mountains.
    with pytest.warns(UserWarning, match="cut along 7 of its creases"):
        flat = unfold_folded_form(_closed_cube(outward))
    creases = np.asarray(flat.edges_assignment) != "B"
    assert creases.sum() == 5 and flat.n_vertices == 14
    np.testing.assert_allclose(flat.edges_fold_angle_deg[creases], -90.0 if outward else 90.0)
    # As a mesh exporter writes it: vertices and faces only (the reader takes the faces' sides as
    # its edges, unassigned).
    path = tmp_path / "cube_folded.fold"
    path.write_text(json.dumps({"file_spec": 1.2, **_closed_cube(outward).to_dict()}))
    assert read_fold(path).key_frame.edges_assignment == ("U",) * 12
    with pytest.warns(UserWarning, match="cut along 7"):
        net = load_net(path)
    assert net.n_creases == 5 and net.name == "cube_folded"
    np.testing.assert_allclose(np.abs(net.intended_angles), np.pi / 2, atol=1e-12)
    # Folded to its angles, the net's seams close: the cube it came from.
    assert np.max(net.seam_gaps(net.intended_angles)) < 1e-9 * 200.0


def _triangulated(frame: FoldFrame) -> FoldFrame:
    """`frame` with every quadrilateral face split by a diagonal, as a mesh exporter writes it."""
    faces = []
    for a, b, c, d in frame.faces_vertices:
        faces += [(a, b, c), (a, c, d)]
    return frame.replace(faces_vertices=tuple(faces))


def test_a_triangulated_cube_is_cut_between_its_faces_and_folds_as_six_panels(tmp_path):
    # A closed mesh of triangles: the two triangles of each square are coplanar, their diagonal
    # flat (F). The sheet keeps every diagonal (the tree crosses flat sides first), so its cuts
    # are the quadrilateral cube's, and the net read from it is the six squares' (F joins).
    with pytest.warns(UserWarning, match="cut along 7"):
        quads = unfold_folded_form(_closed_cube(True))
    with pytest.warns(UserWarning, match="cut along 7"):
        triangles = unfold_folded_form(_triangulated(_closed_cube(True)))
    assignment = np.asarray(triangles.edges_assignment)
    assert (assignment == "F").sum() == 6 and (assignment == "M").sum() == 5

    def cut_corners(flat):
        boundary = np.asarray(flat.edges_vertices)[np.asarray(flat.edges_assignment) == "B"]
        coords = np.asarray(flat.vertices_coords)
        return sorted(tuple(sorted(map(tuple, np.round(coords[e], 6).tolist()))) for e in boundary)

    assert cut_corners(triangles) == cut_corners(quads)
    # Turned and written to six significant digits, the diagonals' dihedrals are round-off
    # (up to ~2e-6 rad here), not folds: still flat.
    c, s = np.cos(0.7), np.sin(0.7)
    turn = np.array([[1, 0, 0], [0, c, -s], [0, s, c]]) @ np.array(
        [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    )
    rounded = np.vectorize(lambda x: float(f"{x:.6g}"))(_closed_cube(True).coords3 @ turn.T)
    with pytest.warns(UserWarning, match="cut along 7"):
        turned = unfold_folded_form(
            _triangulated(_closed_cube(True)).replace(vertices_coords=rounded)
        )
    assignment = np.asarray(turned.edges_assignment)
    assert (assignment == "F").sum() == 6 and (assignment == "M").sum() == 5
    np.testing.assert_allclose(turned.edges_fold_angle_deg[assignment == "M"], -90.0, atol=1e-3)
    path = tmp_path / "cube_mesh.fold"
    path.write_text(json.dumps({"file_spec": 1.2, **_triangulated(_closed_cube(True)).to_dict()}))
    with pytest.warns(UserWarning, match="cut along 7"):
        net = load_pattern(path)
    assert net.n_creases == 5 and net.geometry.n_faces == 6
    np.testing.assert_allclose(net.intended_angles, -np.pi / 2, atol=1e-12)
    assert np.max(net.seam_gaps(net.intended_angles)) < 1e-9 * 200.0


def test_a_polyhedron_is_unfolded_from_a_face_whose_net_lies_flat(monkeypatch):
    # The hull of 87 random points (25 vertices, 46 triangles, written to 0.01 µm): its
    # breadth-first net from its largest face overlaps itself, as do those of other roots; the
    # unfolding goes down the faces by area to the first whose net does not.
    path = DATA / "random_hull_folded.fold"
    frame = read_fold(path).key_frame
    corners = frame.coords3[np.asarray(frame.faces_vertices)]
    areas = np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    largest = int(np.argmax(areas))
    with pytest.raises(FoldFormatError, match=rf"unfolded from face {largest} overlaps itself"):
        unfold_folded_form(frame, root=largest)
    with pytest.warns(UserWarning, match=r"cut along 24 of its creases .* from face 8;"):
        net = load_net(path)
    assert net.n_creases == 45
    # Folded to its angles, the seams close: the polyhedron it came from (to its rounding).
    size = np.ptp(frame.coords3, axis=0).max()
    assert np.max(net.seam_gaps(net.intended_angles)) < 1e-9 * size
    # Where no root of those tried lies flat, one line says so and how to choose the seams.
    monkeypatch.setattr("origami_jax.fold._unfold.ROOTS_TRIED", 1)
    with pytest.raises(
        FoldFormatError, match=r"overlaps itself unfolded from each of its 1 largest faces .* C"
    ):
        unfold_folded_form(frame)


def test_bad_folded_forms_are_refused_in_one_line():
    cube = _closed_cube(True)
    # Assignments of which some agree with the form's folds and one does not.
    edges = np.array(edges_of([list(f) for f in cube.faces_vertices])[0])
    assignment = ("M",) * 11 + ("V",)
    u, v = edges[11]
    with pytest.raises(
        FoldFormatError, match=rf"edge ({u}–{v}|{v}–{u}) is assigned V but .* by -90°"
    ):
        unfold_folded_form(cube.replace(edges_vertices=edges, edges_assignment=assignment))
    bent = np.array(cube.vertices_coords)
    bent[7, 0] += 20.0  # a corner pulled out of its three faces' planes
    with pytest.raises(FoldFormatError, match=r"face 5 \[1, 3, 7, 5\] is not planar"):
        unfold_folded_form(cube.replace(vertices_coords=bent))
    apart = cube.replace(
        faces_vertices=cube.faces_vertices + ((8, 9, 10),),
        vertices_coords=np.concatenate([cube.vertices_coords, 900.0 + np.eye(3) * 50]),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the cube's own cuts
        with pytest.raises(FoldFormatError, match=r"faces \[6\] are not joined to face 0"):
            unfold_folded_form(apart)
    twisted = cube.replace(faces_vertices=((0, 1, 3, 2),) + cube.faces_vertices[1:])
    with pytest.raises(FoldFormatError, match="the same way"):
        unfold_folded_form(twisted)


def test_a_rounded_form_of_a_closed_loop_pattern_is_closed_to_its_nearest_state():
    # A form written to a few digits closes its loops only to that precision; the loader moves its
    # angles onto the nearest closed state (by about the rounding), so that the pattern folds.
    from origami_jax.fold import flat_fold
    from origami_jax.fold._loop_geometry import loop_geometry
    from origami_jax.loops import CLOSURE_TOL, CreasePattern

    pattern = load_pattern("miura_3x3")
    angles = pattern.intended_angles
    animation = pattern.to_fold(angles=np.stack([0 * angles, angles]), times=np.array([0.0, 1.0]))
    folded = animation.frame(animation.n_frames - 1)
    rounded = FoldFile(frames=(folded.replace(vertices_coords=np.round(folded.coords3, 2)),))
    raw = loop_geometry(flat_fold(rounded))
    raw_residual = CreasePattern(raw, "raw", 1.0).closure_residual(raw.targets).max()
    assert CLOSURE_TOL < raw_residual < 1e-4, raw_residual  # 10 nm on 200 µm panels
    closed = load_pattern(rounded, name="rounded")
    # The rounded sector angles leave the overconstrained Miura-ori closable only to about the
    # rounding: the residual left is the pattern's precision, below the form's own residual.
    left = closed.closure_residual(closed.intended_angles).max()
    assert left < raw_residual and closed.precision == pytest.approx(2 * left)
    assert CreasePattern(raw, "raw", 1.0).precision == 0.0  # an exact pattern keeps 1e-6
    # Moved by about the rounding, not along the pattern's folding motion.
    assert np.max(np.abs(closed.intended_angles - angles)) < 20 * raw_residual
    closed.check_angles(closed.intended_angles)
    rigid = closed.rigid_foldability()
    assert not rigid.rigid and rigid.residual <= closed.precision  # accepted within the rounding
    closed.system(contact=False)  # the checks pass


def test_the_fold_command_folds_a_folded_form_and_says_it_unfolded_it(tmp_path, capsys):
    from origami_jax.cli import main

    path = tmp_path / "square.fold"
    form = _square_folded(60.0)  # a 200 µm square
    form = form.replace(vertices_coords=200.0 * form.vertices_coords)
    path.write_text(json.dumps({"file_spec": 1.2, **form.to_dict()}))
    out = tmp_path / "out"
    argv = ["fold", str(path), "--no-contact", "--t1", "300", "--n-save", "31"]
    argv += ["--no-fluid-inertia"]  # released at once: 300 µs is enough
    assert main(argv + ["--figures", "none", "--out", str(out)]) == 0, capsys.readouterr().err
    assert "the file holds a folded form: unfolded" in capsys.readouterr().out
    result = json.loads((out / "result.json").read_text())
    assert result["unfolded_from_folded_form"] is True and result["verdict"] == "folded"
    np.testing.assert_allclose(result["intended_angles"], [np.radians(60.0)], rtol=1e-12)


def test_the_closest_state_of_a_perturbed_miura_is_near_it():
    # A 1-DOF pattern has a nearly singular direction besides its motion: minimum-norm Gauss–Newton
    # steps leapt 20 rad from angles 0.01 rad off a closed state; the closest state is near them.
    from origami_jax.loops import CLOSURE_TOL

    pattern = load_pattern("miura_3x3")
    off = pattern.intended_angles + 0.01 * np.random.default_rng(0).standard_normal(12)
    assert pattern.closure_residual(off).max() > 1e-3
    closest = pattern.closest_state(off)
    assert pattern.closure_residual(closest).max() <= CLOSURE_TOL
    assert np.max(np.abs(closest - off)) < 0.03
