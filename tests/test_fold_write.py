"""FOLD writing: round trips, our single-vertex and chain animations, and Origami Simulator's checks."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from origami_jax.fold import (
    FoldFile,
    FoldFormatError,
    chain_fold,
    chain_geometry,
    dumps_fold,
    fold_angles_from_coords,
    fold_from_dict,
    normalise_fold,
    read_fold,
    single_vertex_fold,
    single_vertex_geometry,
    validate_schema,
    write_fold,
)

from .test_fold_geometry import folded_directions

DATA = Path(__file__).parent / "data" / "fold"
VALID = sorted(p.name for p in DATA.glob("*.fold"))
COMPLETE = [n for n in VALID if n != "two_vertex.fold"]  # two_vertex has no faces_vertices
DEG = np.pi / 180


def origami_simulator_import_problems(text: str) -> list[str]:
    """The checks Origami Simulator applies when it imports a .fold file, as a list of problems.

    Read from its source (github.com/amandaghassaei/OrigamiSimulator):
    1. `js/importer.js`: `JSON.parse(reader.result)`; a parse error is "Unable to parse FOLD json".
    2. `js/importer.js`: `if (!fold || !fold.vertices_coords || !fold.edges_assignment ||
       !fold.edges_vertices || !fold.faces_vertices)` → "Invalid FOLD file, must contain all of:
       vertices_coords, edges_vertices, edges_assignment, faces_vertices".
    3. `js/importer.js`: `edges_foldAngles` (FOLD 1.0) is renamed `edges_foldAngle`; when
       `edges_foldAngle` is present the file is used directly (degrees, indexed by edge; `null`
       allowed), otherwise the user is asked how to derive angles. We always write it.
    4. `js/pattern.js` `processFold`: 2D `vertices_coords` become `(x, 0, y)`; `C` edges are split
       (we never write any); only the key frame is read (`file_frames` are ignored).
    5. `js/pattern.js` `triangulatePolys`: triangles kept, quads split along the shorter diagonal,
       larger faces earcut in 2D: each face needs at least 3 distinct, valid vertex ids.
    6. `js/pattern.js` `getFacesAndVerticesForEdges`: every `M`/`V`/`F` edge with a fold angle
       becomes a crease only if two (triangulated) faces contain both its ends; otherwise it is
       silently dropped. So each such edge must be a side of exactly two faces.
    7. `js/model.js` `buildModel`: returns with "no vertices" / "no faces" / "no edges" warnings on
       empty arrays; `sync` stores face indices in a `Uint16Array` (fewer than 65536 vertices).
    """
    problems = []
    try:
        fold = json.loads(text)
    except json.JSONDecodeError as error:
        return [f"Unable to parse FOLD json ({error})"]
    if not isinstance(fold, dict):
        return ["Unable to parse FOLD json (not an object)"]
    for key in ("vertices_coords", "edges_vertices", "edges_assignment", "faces_vertices"):
        if key not in fold or fold[key] is None:
            problems.append(f"Invalid FOLD file, must contain all of ...: {key} missing")
    if problems:
        return problems
    angles = fold.get("edges_foldAngle", fold.get("edges_foldAngles"))
    vertices, edges, faces = fold["vertices_coords"], fold["edges_vertices"], fold["faces_vertices"]
    assignment = fold["edges_assignment"]
    if angles is None:
        problems.append("no edges_foldAngle: Origami Simulator would ask how to fold")
    elif len(angles) != len(edges) or any(
        a is not None and not (isinstance(a, int | float) and -180 <= a <= 180) for a in angles
    ):
        problems.append("edges_foldAngle must hold one angle in degrees (or null) per edge")
    if not vertices or not faces or not edges:
        problems.append("no vertices / no faces / no edges")
    if len(vertices) >= 65536:
        problems.append("too many vertices for Uint16Array face indices")
    if len(assignment) != len(edges) or any(a not in "BMVFU" for a in assignment):
        problems.append("edges_assignment must give one of B M V F U per edge (no C, no J)")
    if any(len(v) not in (2, 3) for v in vertices):
        problems.append("vertices_coords must be 2D or 3D")
    sides = {}
    for f, face in enumerate(faces):
        if len(set(face)) < 3 or any(not 0 <= i < len(vertices) for i in face):
            problems.append(f"face {f} cannot be triangulated")
            continue
        for u, v in zip(face, face[1:] + face[:1], strict=True):
            sides[frozenset((u, v))] = sides.get(frozenset((u, v)), 0) + 1
    for e, ((u, v), a) in enumerate(zip(edges, assignment, strict=False)):
        if not (0 <= u < len(vertices) and 0 <= v < len(vertices)):
            problems.append(f"edge {e} refers to a missing vertex")
        elif a in "MVF" and angles is not None and angles[e] is not None:
            if sides.get(frozenset((u, v)), 0) != 2:
                problems.append(f"crease {e} ({a}) is not shared by exactly two faces: dropped")
        elif a == "B" and sides.get(frozenset((u, v)), 0) != 1:
            problems.append(f"boundary edge {e} is not the side of exactly one face")
    return problems


@pytest.mark.parametrize("name", COMPLETE)
def test_round_trip_read_write_read_is_identical(name, tmp_path):
    original = read_fold(DATA / name)
    path = write_fold(tmp_path / name, original)
    again = read_fold(path)
    assert again == original
    assert again.to_dict() == original.to_dict()
    # And the text is stable: writing the re-read file gives the same bytes.
    assert dumps_fold(again) == path.read_text()


@pytest.mark.parametrize("name", VALID)
def test_normalised_files_round_trip_and_satisfy_origami_simulator(name, tmp_path):
    normalised = normalise_fold(read_fold(DATA / name))
    assert normalised.file_spec == 1.2
    assert normalise_fold(normalised) == normalised  # idempotent
    path = write_fold(tmp_path / name, normalised)
    assert read_fold(path) == normalised
    assert origami_simulator_import_problems(path.read_text()) == []


def test_normalise_makes_defaults_explicit_and_derives_faces():
    fold = normalise_fold(read_fold(DATA / "two_vertex.fold"))
    key = fold.key_frame
    assert len(key.faces_vertices) == 6
    assert key.edges_fold_angle_deg[1] == -180 and key.edges_fold_angle_deg[2] == 180
    assert math.isnan(key.edges_fold_angle_deg[0])  # U stays free: null in the file
    data = json.loads(dumps_fold(fold))
    assert data["edges_foldAngle"][0] is None
    assert data["file_creator"] == "hand-written for origami_jax tests"  # kept
    # Without assignments: boundary from the faces, creases from the fold-angle signs.
    raw = {
        "vertices_coords": [[0, 0], [1, 0], [1, 1], [0, 1]],
        "edges_vertices": [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]],
        "edges_foldAngle": [0, 0, 0, 0, -30],
    }
    fold = normalise_fold(fold_from_dict(raw))
    assert fold.key_frame.edges_assignment == ("B", "B", "B", "B", "M")
    assert fold.file_metadata["file_creator"] == "origami_jax"


def test_writer_refuses_files_other_tools_cannot_load(tmp_path):
    fold = read_fold(DATA / "two_vertex.fold")
    with pytest.raises(FoldFormatError, match="without faces_vertices"):
        write_fold(tmp_path / "x.fold", fold)
    assert not (tmp_path / "x.fold").exists()


def test_single_vertex_path_file_layout():
    sectors = single_vertex_geometry(DATA / "degree4.fold").sector_angles
    # Rays 0 and 2 of the degree-4 fixture are collinear: folding just that line closes the loop.
    rhos = [np.array([t, 0.0, t, 0.0]) for t in (1.0, 0.5, 0.01)]
    path = np.stack([folded_directions(sectors, rho, closed=True) for rho in rhos])
    times = np.array([0.0, 1.0, 2.0])
    fold = single_vertex_fold(path, closed=True, sector_angles=sectors, times=times)
    assert fold.n_frames == 4
    key = fold.key_frame
    assert key.frame_classes == ("creasePattern",)
    assert key.vertices_coords.shape == (5, 2)
    assert key.extra["origami_jax:kind"] == "single_vertex"
    assert key.extra["origami_jax:closed"] is True
    np.testing.assert_allclose(key.extra["origami_jax:sector_angles"], sectors)
    np.testing.assert_allclose(key.edges_fold_angle_deg[:4], np.rad2deg(rhos[0]), atol=1e-9)
    assert key.edges_assignment[:4] == ("V", "F", "V", "F")
    assert fold.file_metadata["file_classes"] == ["singleModel", "animation"]
    for k in range(3):
        frame = fold.frame(1 + k)
        raw = fold.frames[1 + k]
        assert raw.frame_inherit is True and raw.frame_parent == 0
        assert raw.vertices_coords is not None and raw.edges_fold_angle_deg is not None
        assert raw.edges_vertices is None and raw.faces_vertices is None  # inherited
        assert raw.extra["origami_jax:time"] == times[k]
        np.testing.assert_allclose(frame.vertices_coords[1:], path[k], atol=1e-15)
        # The written fold angles match the folded mesh's dihedral angles (FOLD's sign).
        dihedral = fold_angles_from_coords(
            frame.vertices_coords, frame.faces_vertices, frame.edges_vertices
        )
        np.testing.assert_allclose(
            np.deg2rad(frame.edges_fold_angle_deg[:4]), dihedral[:4], atol=1e-9
        )
        np.testing.assert_allclose(np.deg2rad(frame.edges_fold_angle_deg[:4]), rhos[k], atol=1e-9)
    text = dumps_fold(fold)
    if validate_schema(json.loads(text)) is False:
        pytest.skip("jsonschema not installed")  # pragma: no cover
    assert origami_simulator_import_problems(text) == []
    assert read_fold_text(text) == fold


def read_fold_text(text):
    return fold_from_dict(json.loads(text))


def test_single_vertex_writer_open_chain_and_sign_changes():
    sectors = np.array([45, 45, 45, 45]) * DEG
    a = folded_directions(sectors, np.array([30, -40, 50]) * DEG, closed=False)
    b = folded_directions(sectors, np.array([-10, 0.0, 20]) * DEG, closed=False)
    fold = single_vertex_fold(np.stack([a, b]), closed=False)
    key = fold.key_frame
    # Rays 0 and 4 are the paper's boundary; rays 1..3 creases.
    assert key.edges_assignment[:5] == ("B", "V", "M", "V", "B")
    assert key.extra["origami_jax:crease_edges"] == [1, 2, 3]
    # State 2 changes crease 1 to a mountain and flattens crease 2: it overrides the assignment.
    assert fold.frames[1].edges_assignment is None
    assert fold.frames[2].edges_assignment[:5] == ("B", "M", "F", "V", "B")
    assert fold.frames[2].edges_fold_angle_deg[2] == 0.0
    again = single_vertex_geometry(read_fold_text(dumps_fold(fold)))
    assert not again.closed
    np.testing.assert_allclose(again.sector_angles, sectors)
    np.testing.assert_allclose(again.fold_angles, np.array([30, -40, 50]) * DEG)
    assert origami_simulator_import_problems(dumps_fold(fold)) == []


def test_single_vertex_writer_checks_its_input():
    sectors = np.array([60, 120, 120, 60]) * DEG
    x = folded_directions(sectors, [0.3, 0, 0.3, 0], closed=True)
    with pytest.raises(FoldFormatError, match="disagree with the crease directions"):
        single_vertex_fold(x, closed=True, fold_angles=-np.array([0.3, 0, 0.3, 0]))
    single_vertex_fold(
        x, closed=True, fold_angles=-np.array([0.3, 0, 0.3, 0]), check_fold_angles=False
    )
    with pytest.raises(FoldFormatError, match="shape"):
        single_vertex_fold(x[:, :2], closed=True)
    with pytest.raises(FoldFormatError, match="sum to 2π"):
        single_vertex_fold(x, closed=True, sector_angles=np.array([1.0, 1.0, 1.0, 1.0]))
    with pytest.raises(FoldFormatError, match="strictly between 0 and π"):
        single_vertex_fold(x, closed=True, sector_angles=np.array([np.pi, 0.5, 0.5, np.pi - 1]))
    with pytest.raises(FoldFormatError, match="times must have shape"):
        single_vertex_fold(x, closed=True, times=np.array([0.0, 1.0]))


def test_chain_trajectory_file():
    lengths = np.array([200.0, 200.0, 200.0])
    theta = np.array([[0.0, 0.0, 0.0], [1.0, -1.2, 0.5], [np.pi, -np.pi, np.pi], [3.6, -3.0, 2.0]])
    times = np.array([0.0, 10.0, 20.0, 30.0])
    fold = chain_fold(theta, lengths, width=200.0, times=times, time_unit="us")
    assert fold.n_frames == 5
    key = fold.key_frame
    assert key.frame_unit == "um"
    assert key.extra["origami_jax:kind"] == "chain"
    assert key.edges_assignment[:3] == ("F", "F", "F")  # the first state is flat
    # The crease pattern reads back as the same chain: base + three 200 µm flaps.
    geometry = chain_geometry(fold)
    np.testing.assert_allclose(geometry.flap_lengths, [200, 200, 200, 200])
    np.testing.assert_allclose(geometry.axis, [1, 0, 0])
    for k in range(4):
        frame = fold.frame(k + 1)
        assert frame.extra["origami_jax:time"] == times[k]
        np.testing.assert_allclose(frame.extra["origami_jax:hinge_angles"], theta[k])
        dihedral = fold_angles_from_coords(
            frame.vertices_coords, frame.faces_vertices, frame.edges_vertices
        )
        wrapped = np.arctan2(np.sin(theta[k]), np.cos(theta[k]))
        np.testing.assert_allclose(np.deg2rad(frame.edges_fold_angle_deg[:3]), wrapped, atol=1e-12)
        # The mesh agrees with the written angles, except at exactly ±180° where faces lie flat
        # on each other and the dihedral's sign is undefined.
        ok = np.abs(np.abs(wrapped) - np.pi) > 1e-9
        np.testing.assert_allclose(dihedral[:3][ok], wrapped[ok], atol=1e-9)
        # Flap lengths are kept in 3D.
        coords = frame.vertices_coords
        np.testing.assert_allclose(np.linalg.norm(coords[4] - coords[2]), 200.0)
    # The overshoot past 180° (3.6 rad) is wrapped in edges_foldAngle but kept unwrapped as ours.
    assert fold.frame(4).edges_fold_angle_deg[0] == pytest.approx(np.rad2deg(3.6 - 2 * np.pi))
    text = dumps_fold(fold)
    assert origami_simulator_import_problems(text) == []
    assert read_fold_text(text) == fold


def test_chain_writer_checks_its_input():
    with pytest.raises(FoldFormatError, match="must agree"):
        chain_fold(np.zeros((2, 3)), np.ones(2), width=1.0)
    with pytest.raises(FoldFormatError, match="positive"):
        chain_fold(np.zeros(2), np.array([1.0, -1.0]), width=1.0)
    with pytest.raises(FoldFormatError, match="finite"):
        chain_fold(np.array([np.inf, 0.0]), np.ones(2), width=1.0)


def test_fold_file_equality_and_errors():
    a = read_fold(DATA / "degree4.fold")
    b = read_fold(DATA / "degree4.fold")
    assert a == b and a != read_fold(DATA / "waterbomb.fold")
    assert (a == "degree4") is False
    with pytest.raises(FoldFormatError, match="at least its key frame"):
        FoldFile(frames=())
