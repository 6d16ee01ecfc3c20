"""Geometry out of FOLD: single vertices (closed, open, picked from several), accordions, faces."""

import json
from pathlib import Path

import numpy as np
import pytest

from origami_jax.fold import (
    FoldFormatError,
    chain_geometry,
    dumps_fold,
    fold_angles_from_coords,
    fold_from_dict,
    list_vertices,
    loads_fold,
    paper_plane,
    planar_faces,
    read_fold,
    single_vertex_fold,
    single_vertex_geometry,
    vertex_fold_angles,
)

DATA = Path(__file__).parent / "data" / "fold"
DEG = np.pi / 180


def folded_directions(sectors, folds, *, closed):
    """Crease directions from sector and fold angles (radians), flap by flap (independent of vertex).

    Flap 0 lies in the xy plane from e_x counter-clockwise (front +z); at each crease the running
    flap normal turns about the crease by its fold angle. `folds` has one entry per crease: `n` for a
    closed chain (entry 0 at ray 0, used only for closure), `n - 2` for an open chain.
    """
    n = len(sectors) if closed else len(sectors) + 1
    at_ray = np.zeros(n)
    if closed:
        at_ray[:] = folds
    else:
        at_ray[1:-1] = folds
    x = [np.array([1.0, 0.0, 0.0])]
    normal = np.array([0.0, 0.0, 1.0])
    for i, alpha in enumerate(sectors):
        u = x[-1]
        x.append(np.cos(alpha) * u + np.sin(alpha) * np.cross(normal, u))
        axis = x[-1]
        angle = at_ray[(i + 1) % n]
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        normal = (np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k) @ normal
    x = np.array(x)
    if closed:
        np.testing.assert_allclose(x[-1], x[0], atol=1e-9)  # the fold angles close the loop
        return x[:-1]
    return x


@pytest.mark.parametrize(
    "name, closed, sectors_deg, folds_deg",
    [
        ("degree4", True, [60, 120, 120, 60], [60, -98.21321070173823, -60, -98.21321070173823]),
        (
            "corner_cube",
            True,
            [90, 90, 90, 45, 45],
            [-44.64751963037503, 89.49999988362131, 89.50000011637873, -44.647546302748815, 179],
        ),
        ("waterbomb", True, [45] * 8, [-60, 25.332938613028517] * 4),
        ("boundary_vertex", False, [45] * 4, [30, -40, 50]),
        ("legacy_fold_angles", False, [45] * 4, [30, -40, 50]),
        ("frames", True, [60, 120, 120, 60], [60, -98.21321070173823, -60, -98.21321070173823]),
    ],
)
def test_single_vertex_fixtures(name, closed, sectors_deg, folds_deg):
    geometry = single_vertex_geometry(DATA / f"{name}.fold")
    assert geometry.vertex_index == 0
    assert geometry.closed is closed
    assert geometry.flat
    np.testing.assert_allclose(geometry.sector_angles, np.array(sectors_deg) * DEG, atol=1e-12)
    np.testing.assert_allclose(geometry.fold_angles, np.array(folds_deg) * DEG, atol=1e-12)
    n = len(sectors_deg) if closed else len(sectors_deg) + 1
    assert geometry.n_rays == n and geometry.directions.shape == (n, 3)
    np.testing.assert_allclose(np.linalg.norm(geometry.directions, axis=1), 1.0)
    if closed:
        assert np.sum(geometry.sector_angles) == pytest.approx(2 * np.pi)
        assert geometry.boundary_rays is None
        # The fold angles close the loop: the flap-by-flap construction returns to its start.
        x = folded_directions(geometry.sector_angles, geometry.fold_angles, closed=True)
        np.testing.assert_allclose(
            vertex_fold_angles(x, closed=True), geometry.fold_angles, atol=1e-9
        )
    else:
        assert geometry.boundary_rays.shape == (2, 3)
        assert geometry.assignments == ("V", "M", "V")


def test_closed_vertex_starts_at_lowest_edge_and_runs_counter_clockwise():
    geometry = single_vertex_geometry(DATA / "degree4.fold")
    assert geometry.ray_edges == (0, 1, 2, 3)
    angles = np.arctan2(geometry.directions[:, 1], geometry.directions[:, 0])
    assert np.all(np.diff(np.unwrap(angles)) > 0)


def test_boundary_vertex_rays_run_over_the_paper():
    geometry = single_vertex_geometry(DATA / "boundary_vertex.fold")
    assert geometry.ray_edges == (0, 6, 7, 8, 5)  # boundary, three creases, boundary
    np.testing.assert_allclose(geometry.boundary_rays, [[1, 0, 0], [-1, 0, 0]], atol=1e-15)
    assert np.sum(geometry.sector_angles) == pytest.approx(np.pi)  # a straight edge


def test_convex_corner_vertex_without_faces():
    # A vertex at the corner of the paper (90°), two creases, no faces: the paper side is the one
    # holding the creases.
    data = {
        "vertices_coords": [[0, 0], [1, 0], [1, 1], [0, 1], [1, 0.5], [0.5, 1]],
        "edges_vertices": [[0, 1], [0, 3], [1, 4], [4, 2], [2, 5], [5, 3], [0, 4], [0, 5]],
        "edges_assignment": ["B", "B", "B", "B", "B", "B", "M", "V"],
        "edges_foldAngle": [0, 0, 0, 0, 0, 0, -20, 30],
    }
    geometry = single_vertex_geometry(fold_from_dict(data))
    assert not geometry.closed
    assert geometry.ray_edges == (0, 6, 7, 1)
    assert np.sum(geometry.sector_angles) == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(geometry.fold_angles, np.array([-20, 30]) * DEG)


def test_two_vertex_pattern_lists_vertices_and_lets_the_user_pick():
    fold = read_fold(DATA / "two_vertex.fold")
    with pytest.raises(FoldFormatError) as excinfo:
        single_vertex_geometry(fold)
    message = str(excinfo.value)
    assert "2 vertices where creases meet" in message and "vertex_index=" in message
    assert "vertex   0  (-0.5, 0, 0)  degree 4, 4 crease(s), interior" in message
    assert "vertex   1  (0.5, 0, 0)" in message
    listing = list_vertices(fold)
    assert len(listing) == 12
    assert [v.index for v in listing if not v.boundary] == [0, 1]
    assert listing[2].kind == "boundary" and listing[2].n_creases == 1
    left = single_vertex_geometry(fold, vertex_index=0)
    right = single_vertex_geometry(fold, vertex_index=1)
    assert left.closed and right.closed
    assert left.ray_edges == (0, 5, 4, 6) and right.ray_edges == (0, 3, 1, 2)
    # Vertex 0 at (-0.5, 0): creases to (0.5, 0), (-1, 1), (-2, 0), (-1, -1).
    a = np.arctan2(1.0, -0.5)
    np.testing.assert_allclose(left.sector_angles, [a, np.pi - a, np.pi - a, a])
    assert np.isnan(left.fold_angles[0])  # the U crease between the two vertices is free
    np.testing.assert_allclose(left.fold_angles[1:], np.array([180, -180, 180]) * DEG)


def test_vertex_index_errors():
    fold = read_fold(DATA / "two_vertex.fold")
    with pytest.raises(FoldFormatError, match="vertex_index 40 does not exist"):
        single_vertex_geometry(fold, vertex_index=40)
    with pytest.raises(FoldFormatError, match="vertex 3 has no creases"):
        single_vertex_geometry(fold, vertex_index=3)
    with pytest.raises(FoldFormatError, match="no vertex where creases meet"):
        single_vertex_geometry(DATA / "accordion.fold")
    with pytest.raises(FoldFormatError, match="missing key edges_assignment"):
        single_vertex_geometry(DATA / "errors" / "missing_assignment.fold")


def test_boundary_vertex_problems():
    # Boundary edges through the vertex with creases on both sides: a slit, not one vertex.
    slit = {
        "vertices_coords": [[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]],
        "edges_vertices": [[0, 1], [0, 2], [0, 3], [0, 4]],
        "edges_assignment": ["B", "B", "M", "V"],
    }
    with pytest.raises(FoldFormatError, match="both sides"):
        single_vertex_geometry(fold_from_dict(slit), vertex_index=0)
    pinch = {
        "vertices_coords": [[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1], [1, 1]],
        "edges_vertices": [[0, 1], [0, 2], [0, 3], [0, 4], [0, 5]],
        "edges_assignment": ["B", "B", "B", "B", "V"],
    }
    with pytest.raises(FoldFormatError, match="has 4 boundary"):
        single_vertex_geometry(fold_from_dict(pinch), vertex_index=0)
    degree2 = {
        "vertices_coords": [[0, 0], [1, 0], [-1, 0]],
        "edges_vertices": [[0, 1], [0, 2]],
        "edges_assignment": ["V", "V"],
    }
    with pytest.raises(FoldFormatError, match="needs at least 3"):
        single_vertex_geometry(fold_from_dict(degree2), vertex_index=0)


def test_frame_argument_reads_that_frames_state():
    geometry = single_vertex_geometry(DATA / "frames.fold", frame=1)
    np.testing.assert_allclose(geometry.fold_angles[0], 30 * DEG)
    assert single_vertex_geometry(DATA / "frames.fold", frame=2).unit == "mm"


@pytest.mark.parametrize("name", ["degree4", "corner_cube", "waterbomb", "boundary_vertex"])
def test_folded_3d_frame_gives_back_the_same_vertex(name):
    flat = single_vertex_geometry(DATA / f"{name}.fold")
    x = folded_directions(flat.sector_angles, flat.fold_angles, closed=flat.closed)
    fold = loads_fold(dumps_fold(single_vertex_fold(x, closed=flat.closed)))
    folded = single_vertex_geometry(fold, frame=1)
    assert not folded.flat and folded.closed == flat.closed
    np.testing.assert_allclose(folded.sector_angles, flat.sector_angles, atol=1e-12)
    np.testing.assert_allclose(folded.fold_angles, flat.fold_angles, atol=1e-9)
    np.testing.assert_allclose(folded.directions, x, atol=1e-12)
    # Without edges_foldAngle a folded frame's angles come from its geometry.
    data = fold.to_dict()
    del data["file_frames"][0]["edges_foldAngle"]
    del data["edges_foldAngle"]
    for key in ("edges_assignment",):
        data[key] = ["U" if a != "B" else "B" for a in data[key]]
    data["file_frames"][0].pop("edges_assignment", None)
    geometric = single_vertex_geometry(fold_from_dict(data), frame=1)
    np.testing.assert_allclose(geometric.fold_angles, flat.fold_angles, atol=1e-9)


def test_folded_frame_needs_faces():
    x = folded_directions(np.array([60, 120, 120, 60]) * DEG, [0.3, 0, 0.3, 0], closed=True)
    data = single_vertex_fold(x, closed=True).to_dict()
    del data["faces_vertices"]
    fold = fold_from_dict(data)
    with pytest.raises(FoldFormatError, match="has no faces_vertices"):
        single_vertex_geometry(fold, frame=1)


def test_fold_angles_from_coords_agrees_with_vertex_fold_angles():
    flat = single_vertex_geometry(DATA / "waterbomb.fold")
    x = folded_directions(flat.sector_angles, flat.fold_angles, closed=True)
    fold = single_vertex_fold(x, closed=True)
    frame = fold.frame(1)
    dihedral = fold_angles_from_coords(
        frame.vertices_coords, frame.faces_vertices, frame.edges_vertices
    )
    np.testing.assert_allclose(dihedral[:8], flat.fold_angles, atol=1e-9)
    assert np.all(np.isnan(dihedral[8:]))  # boundary edges have one face
    # In the flat crease pattern every crease is at 0.
    key = fold.frame(0)
    np.testing.assert_allclose(
        fold_angles_from_coords(key.vertices_coords, key.faces_vertices, key.edges_vertices)[:8],
        0.0,
    )


def test_valley_sign_is_folds_convention():
    # Two flaps: lift the second toward the first's front normal (+z): a valley, positive.
    x = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, np.cos(0.4), np.sin(0.4)]])
    assert vertex_fold_angles(x, closed=False)[0] == pytest.approx(0.4)
    assert vertex_fold_angles(x * [1, 1, -1], closed=False)[0] == pytest.approx(-0.4)


def test_accordion_chain_geometry():
    chain = chain_geometry(DATA / "accordion.fold")
    assert chain.n_hinges == 3
    assert chain.crease_edges == ((0,), (1,), (2,))
    np.testing.assert_allclose(chain.axis, [1, 0, 0])
    np.testing.assert_allclose(chain.direction, [0, 1, 0])
    np.testing.assert_allclose(chain.hinge_offsets, [0, 200, 400])
    np.testing.assert_allclose(chain.hinge_points, [[0, 0, 0], [0, 200, 0], [0, 400, 0]])
    np.testing.assert_allclose(chain.flap_lengths, [200, 200, 200, 200])
    np.testing.assert_allclose(chain.flap_widths, 200)
    np.testing.assert_allclose(chain.crease_lengths, 200)
    np.testing.assert_allclose(chain.fold_angles, [np.pi, -np.pi, np.pi])  # the paper's step target
    assert chain.assignments == ("V", "M", "V") and chain.unit == "um"


def test_chain_with_split_crease_lines_and_reversed_axis():
    # Creases drawn right-to-left, one split into two collinear edges, uneven flaps.
    data = {
        "vertices_coords": [
            [0, 0],
            [10, 0],
            [0, 3],
            [10, 3],
            [5, 3],
            [0, 7],
            [10, 7],
            [0, 8],
            [10, 8],
        ],
        "edges_vertices": [
            [3, 4],
            [4, 2],
            [6, 5],
            [0, 1],
            [7, 8],
            [0, 2],
            [2, 5],
            [5, 7],
            [1, 3],
            [3, 6],
            [6, 8],
        ],
        "edges_assignment": ["V", "V", "M", "B", "B", "B", "B", "B", "B", "B", "B"],
        "edges_foldAngle": [90, 90, -45, 0, 0, 0, 0, 0, 0, 0, 0],
    }
    chain = chain_geometry(fold_from_dict(data))
    assert chain.crease_edges == ((0, 1), (2,))
    np.testing.assert_allclose(chain.axis, [1, 0, 0])
    np.testing.assert_allclose(chain.flap_lengths, [3, 4, 1])
    np.testing.assert_allclose(chain.fold_angles, [np.pi / 2, -np.pi / 4])
    np.testing.assert_allclose(chain.crease_lengths, [10, 10])
    data["edges_foldAngle"][1] = 80
    with pytest.raises(FoldFormatError, match="different fold angles"):
        chain_geometry(fold_from_dict(data))


def test_chain_errors():
    with pytest.raises(FoldFormatError, match="not parallel"):
        chain_geometry(DATA / "degree4.fold")
    x = folded_directions(np.array([60, 120, 120, 60]) * DEG, [0.3, 0, 0.3, 0], closed=True)
    with pytest.raises(FoldFormatError, match="folded in 3D"):
        chain_geometry(single_vertex_fold(x, closed=True), frame=1)


def test_planar_faces_of_two_vertex_pattern():
    fold = read_fold(DATA / "two_vertex.fold")
    key = fold.key_frame
    faces = planar_faces(key.coords3, key.edges_vertices)
    assert len(faces) == 6
    # Every crease borders two faces, every boundary edge one, and all faces are counter-clockwise.
    count = {}
    for face in faces:
        for u, v in zip(face, face[1:] + face[:1], strict=True):
            count[frozenset((u, v))] = count.get(frozenset((u, v)), 0) + 1
    for (u, v), a in zip(key.edges_vertices.tolist(), key.edges_assignment, strict=True):
        assert count[frozenset((u, v))] == (1 if a == "B" else 2)
    data = json.loads((DATA / "two_vertex.fold").read_text())
    data["faces_vertices"] = [list(f) for f in faces]
    fold_from_dict(data)  # passes the counter-clockwise check


def test_planar_faces_refuses_a_folded_frame():
    x = folded_directions(np.array([60, 120, 120, 60]) * DEG, [0.3, 0, 0.3, 0], closed=True)
    frame = single_vertex_fold(x, closed=True).frame(1)
    with pytest.raises(FoldFormatError, match="not a flat crease pattern"):
        planar_faces(frame.coords3, frame.edges_vertices)


@pytest.mark.parametrize("name", ["degree4", "boundary_vertex"])
def test_flat_pattern_in_another_plane(name):
    # Origami Simulator stores a flat pattern as (x, 0, y): still a crease pattern, same vertex.
    data = json.loads((DATA / f"{name}.fold").read_text())
    data["vertices_coords"] = [[x, 0, y] for x, y in data["vertices_coords"]]
    reference = single_vertex_geometry(DATA / f"{name}.fold")
    geometry = single_vertex_geometry(fold_from_dict(data))
    assert geometry.flat and geometry.closed == reference.closed
    assert geometry.ray_edges == reference.ray_edges
    np.testing.assert_allclose(geometry.sector_angles, reference.sector_angles, atol=1e-12)
    np.testing.assert_allclose(geometry.fold_angles, reference.fold_angles)


def test_accordion_in_another_plane():
    data = json.loads((DATA / "accordion.fold").read_text())
    data["vertices_coords"] = [[x, 0, y] for x, y in data["vertices_coords"]]
    chain = chain_geometry(fold_from_dict(data))
    np.testing.assert_allclose(chain.flap_lengths, 200)
    np.testing.assert_allclose(chain.direction, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(chain.fold_angles, [np.pi, -np.pi, np.pi])


def test_paper_plane():
    assert paper_plane(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 1]])) is not None  # 3 points
    assert paper_plane(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])) is None
    np.testing.assert_array_equal(
        paper_plane(np.array([[0.0, 0, 2], [1, 0, 2], [0, 1, 2]])), [[1, 0, 0], [0, 1, 0]]
    )
