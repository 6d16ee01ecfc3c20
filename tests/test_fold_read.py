"""FOLD reading: the hand-written files in tests/data/fold, defaults, frames, and every error case."""

import json
from pathlib import Path

import numpy as np
import pytest

from origami_jax import _exported
from origami_jax.fold import (
    FoldFile,
    FoldFormatError,
    fold_from_dict,
    fold_schema,
    loads_fold,
    read_fold,
    validate_schema,
)
from origami_jax.fold import _schema as schema_module

DATA = Path(__file__).parent / "data" / "fold"
VALID = sorted(p.name for p in DATA.glob("*.fold"))


@pytest.mark.parametrize("name", VALID)
def test_every_valid_fixture_reads(name):
    fold = read_fold(DATA / name)
    assert isinstance(fold, FoldFile)
    key = fold.frame(0)
    assert key.vertices_coords is not None and key.edges_vertices is not None
    assert key.vertices_coords.shape[1] in (2, 3)


def test_degree4_arrays_and_units():
    fold = read_fold(DATA / "degree4.fold")
    key = fold.key_frame
    assert fold.file_spec == 1.2
    assert fold.file_metadata["file_title"].startswith("Degree-4")
    assert key.vertices_coords.shape == (9, 2)
    assert key.edges_vertices.shape == (12, 2)
    assert key.edges_assignment[:4] == ("V", "M", "M", "M")
    assert key.frame_unit == "unit"
    assert key.frame_classes == ("creasePattern",)
    assert key.frame_attributes == ("2D", "manifold", "orientable")
    np.testing.assert_allclose(
        key.edges_fold_angle_deg[:4], [60, -98.21321070173823, -60, -98.21321070173823]
    )
    # Arrays are read-only: a FoldFile cannot be changed behind the reader's checks.
    with pytest.raises(ValueError):
        key.vertices_coords[0, 0] = 1.0


def test_missing_fold_angles_default_from_assignment():
    fold = read_fold(DATA / "accordion.fold")
    assert fold.key_frame.edges_fold_angle_deg is None
    angles = fold.fold_angles_deg()
    np.testing.assert_array_equal(angles[:3], [180.0, -180.0, 180.0])  # V, M, V
    np.testing.assert_array_equal(angles[3:], 0.0)  # B


def test_unassigned_crease_is_free_and_null_angles_default():
    data = json.loads((DATA / "two_vertex.fold").read_text())
    fold = fold_from_dict(data)
    angles = fold.fold_angles_deg()
    assert np.isnan(angles[0])  # "U": free
    assert angles[1] == -180.0 and angles[2] == 180.0  # M, V
    data["edges_foldAngle"] = [None] * len(data["edges_vertices"])
    data["edges_foldAngle"][2] = 45
    fold = fold_from_dict(data)
    angles = fold.fold_angles_deg()
    assert np.isnan(angles[0]) and angles[1] == -180.0 and angles[2] == 45.0


def test_legacy_edges_fold_angles_is_read_as_edges_fold_angle():
    legacy = read_fold(DATA / "legacy_fold_angles.fold")
    current = read_fold(DATA / "boundary_vertex.fold")
    assert legacy.file_spec == 1
    np.testing.assert_array_equal(
        legacy.key_frame.edges_fold_angle_deg, current.key_frame.edges_fold_angle_deg
    )
    assert "edges_foldAngles" not in legacy.to_dict()
    assert "edges_foldAngle" in legacy.to_dict()


def test_legacy_and_current_names_must_agree():
    data = json.loads((DATA / "boundary_vertex.fold").read_text())
    data["edges_foldAngles"] = list(data["edges_foldAngle"])
    fold_from_dict(data)  # the same values: fine
    data["edges_foldAngles"][6] = 10
    with pytest.raises(FoldFormatError, match="legacy edges_foldAngles"):
        fold_from_dict(data)


def test_frames_inherit_recursively():
    fold = read_fold(DATA / "frames.fold")
    assert fold.n_frames == 4
    key = fold.frame(0)
    half = fold.frame(1)
    grandchild = fold.frame(2)
    standalone = fold.frame(3)
    # Frame 1 changes only the fold angles; its mesh comes from the key frame.
    np.testing.assert_array_equal(half.vertices_coords, key.vertices_coords)
    assert half.faces_vertices == key.faces_vertices
    assert half.edges_fold_angle_deg[0] == pytest.approx(30.0)
    assert half.frame_unit == "unit"
    assert half.frame_parent == 0 and half.frame_inherit is True
    # Frame 2 inherits from frame 1 (and through it from the key frame), overriding the unit.
    assert grandchild.edges_fold_angle_deg[0] == pytest.approx(30.0)
    assert grandchild.frame_unit == "mm"
    assert grandchild.frame_parent == 1
    assert grandchild.extra["test:custom"] == {"kept": [1, 2, 3]}
    # Frame 3 names a parent but does not inherit (frame_inherit absent).
    assert standalone.vertices_coords.shape == (2, 2)
    assert standalone.edges_assignment is None and standalone.faces_vertices is None
    assert standalone.frame_classes == ("graph",)
    # As written, frames keep their own properties only.
    assert fold.frames[1].vertices_coords is None


def test_frame_index_out_of_range():
    fold = read_fold(DATA / "frames.fold")
    with pytest.raises(FoldFormatError, match="frame 7 does not exist"):
        fold.frame(7)


def test_lowercase_assignments_are_accepted():
    data = json.loads((DATA / "waterbomb.fold").read_text())
    data["edges_assignment"] = [a.lower() for a in data["edges_assignment"]]
    fold = fold_from_dict(data)
    assert fold.key_frame.edges_assignment[0] == "M"


def test_custom_keys_are_kept():
    data = json.loads((DATA / "degree4.fold").read_text())
    data["origami_jax:note"] = "kept"
    data["vertices_vertices"] = [[1]]  # a FOLD key we do not interpret: kept verbatim
    fold = fold_from_dict(data)
    out = fold.to_dict()
    assert out["origami_jax:note"] == "kept"
    assert out["vertices_vertices"] == [[1]]


# Each error fixture, and the words its message must contain (so that messages stay helpful).
ERRORS = {
    "bad_json.fold": "not valid JSON (line 4",
    "not_an_object.fold": "must be a JSON object",
    "join_edge.fold": "'J' (join edge)",
    "missing_edges.fold": "missing key edges_vertices",
    "clockwise_face.fold": "is clockwise",
    # Every face clockwise (a y-down drawing): one message for the whole file, not face by face.
    "clockwise_faces_all.fold": "every face is listed clockwise seen from +z",
    "spec_2.fold": "unsupported FOLD spec version file_spec = 2",
    "sign_mismatch.fold": "assigned 'M' but edges_foldAngle[4] = 90",
    "vertex_out_of_range.fold": "refers to a vertex that does not exist",
    "short_assignment.fold": "edges_assignment has 2 entries but there are 3 edges",
    "parent_cycle.fold": "cycle",
    "four_d_coords.fold": "only 2D and 3D",
    "nan_coordinate.fold": "NaN is not a JSON number",
    "fold_angle_out_of_range.fold": "in [-180, 180]",
}


def test_every_error_fixture_is_listed():
    assert sorted(p.name for p in (DATA / "errors").glob("*.fold")) == sorted(
        [*ERRORS, "missing_assignment.fold"]
    )


@pytest.mark.parametrize("name", sorted(ERRORS))
def test_error_fixtures_raise_a_clear_fold_format_error(name):
    with pytest.raises(FoldFormatError) as excinfo:
        read_fold(DATA / "errors" / name)
    message = str(excinfo.value)
    assert ERRORS[name] in message
    assert name in message  # the file is named
    assert message.count("not valid JSON") <= 1  # said once (a NaN's message was wrapped twice)
    assert isinstance(excinfo.value, ValueError)


@pytest.mark.parametrize(
    "data, words",
    [
        ({"vertices_coords": [[0, 0]], "edges_vertices": [[0, 0]]}, "is a loop"),
        ({"vertices_coords": "abc", "edges_vertices": []}, "must be an array"),
        ({"vertices_coords": [[0, "x"]], "edges_vertices": []}, "finite numbers"),
        ({"vertices_coords": [[0, 0], [1, 0]], "edges_vertices": [[0, 1.5]]}, "pair [u, v]"),
        (
            {"vertices_coords": [[0, 0]], "edges_vertices": [], "faces_vertices": [[0, 0]]},
            "at least 3",
        ),
        (
            {"vertices_coords": [[0, 0]], "edges_vertices": [], "edges_assignment": ["X"]},
            "not one of",
        ),
        ({"vertices_coords": [[0, 0]], "edges_vertices": [], "frame_unit": 3}, "must be a string"),
        (
            {"vertices_coords": [[0, 0]], "edges_vertices": [], "frame_classes": [1]},
            "array of strings",
        ),
        (
            {"vertices_coords": [[0, 0]], "edges_vertices": [], "file_spec": "1.2"},
            "must be a number",
        ),
        ({"vertices_coords": [[0, 0]], "edges_vertices": [], "file_frames": {}}, "array of frame"),
        ({"vertices_coords": [[0, 0]], "edges_vertices": [], "file_frames": [3]}, "JSON object"),
        (
            {"vertices_coords": [[0, 0]], "edges_vertices": [], "file_frames": [{"file_spec": 1}]},
            "top level only",
        ),
        (
            {
                "vertices_coords": [[0, 0]],
                "edges_vertices": [],
                "file_frames": [{"frame_parent": 5, "frame_inherit": True}],
            },
            "does not exist",
        ),
        (
            {
                "vertices_coords": [[0, 0]],
                "edges_vertices": [],
                "file_frames": [{"frame_inherit": "yes"}],
            },
            "true or false",
        ),
        (
            {"vertices_coords": [[0, 0]], "edges_vertices": [], "frame_parent": 0},
            "cannot have a frame_parent",
        ),
        (
            {
                "vertices_coords": [[0, 0]],
                "edges_vertices": [],
                "file_frames": [{"frame_title": "no mesh"}],
            },
            "frame 1: missing key vertices_coords",
        ),
        ({"edges_vertices": []}, "missing key vertices_coords"),
    ],
)
def test_malformed_data_gives_clear_errors(data, words):
    with pytest.raises(FoldFormatError, match=None) as excinfo:
        fold_from_dict(data)
    assert words in str(excinfo.value)


def test_faces_must_be_consistently_oriented_in_3d():
    data = {
        "vertices_coords": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
        "edges_vertices": [[0, 1], [1, 2], [2, 0]],
        "faces_vertices": [[0, 1, 2], [0, 1, 3]],  # both run 0 -> 1
    }
    with pytest.raises(FoldFormatError, match="opposite directions"):
        fold_from_dict(data)


def test_degenerate_face():
    data = {
        "vertices_coords": [[0, 0], [1, 0], [2, 0]],
        "edges_vertices": [[0, 1], [1, 2]],
        "faces_vertices": [[0, 1, 2]],
    }
    with pytest.raises(FoldFormatError, match="has zero area"):
        fold_from_dict(data)
    data["vertices_coords"] = [[0, 0], [1, 1], [1, 0], [0, 1]]  # a bow-tie: its lobes cancel
    data["edges_vertices"] = [[0, 1], [1, 2], [2, 3], [3, 0]]
    data["faces_vertices"] = [[0, 1, 2, 3]]
    with pytest.raises(FoldFormatError, match=r"crosses itself \(its edges 0 and 2 cross\)"):
        fold_from_dict(data)


@pytest.mark.parametrize("z", [0.0, 5.0])  # a flat pattern and a face of a 3D form
def test_two_corners_at_one_point_are_named(z):
    """Two vertices at the same place, both corners of a face: the message names them (it used to
    say the polygon crosses itself, after a NumPy warning from the zero-length side)."""
    data = {
        "vertices_coords": [[0, 0, 0], [0, 0, 0], [1, 0, z], [1, 1, z], [0, 1, 0]],
        "edges_vertices": [[0, 1], [1, 2], [2, 3], [3, 4], [4, 0]],
        "faces_vertices": [[0, 1, 2, 3, 4]],
    }
    with pytest.raises(FoldFormatError, match=r"two corners at one point \(vertices 0 and 1\)"):
        fold_from_dict(data)


def test_missing_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_fold(tmp_path / "nope.fold")


def test_binary_file_is_a_format_error(tmp_path):
    path = tmp_path / "binary.fold"
    path.write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(FoldFormatError, match="not a text"):
        read_fold(path)


def test_schema_is_shipped_and_checks_types():
    schema = fold_schema()
    assert schema["$schema"].startswith("http://json-schema.org/draft-07")
    pytest.importorskip("jsonschema")
    assert validate_schema(json.loads((DATA / "degree4.fold").read_text())) is True
    with pytest.raises(FoldFormatError, match="does not match the FOLD schema at edges_length"):
        validate_schema({"edges_length": [-1]})


def test_a_file_found_valid_is_not_validated_again(tmp_path, monkeypatch):
    # Where a command keeps its programs, a FOLD file's schema check is kept with its contents:
    # a later read of the same file skips it; other contents, and invalid ones, are checked.
    pytest.importorskip("jsonschema")
    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    checked = []
    real = schema_module.validate_schema
    monkeypatch.setattr(
        schema_module, "validate_schema", lambda data: checked.append(data) or real(data)
    )
    text = (DATA / "degree4.fold").read_text()
    assert loads_fold(text).key_frame.n_edges == 12
    assert loads_fold(text).key_frame.n_edges == 12
    assert len(checked) == 1
    other = json.loads(text) | {"file_title": "another title"}
    loads_fold(json.dumps(other))
    assert len(checked) == 2
    invalid = json.dumps(json.loads(text) | {"file_author": 5})
    for _ in range(2):
        with pytest.raises(FoldFormatError, match="FOLD schema at file_author"):
            loads_fold(invalid)
    assert len(checked) == 4
    monkeypatch.setattr(_exported, "_FOLDER", None)  # nothing kept: checked every time
    loads_fold(text)
    assert len(checked) == 5


def test_reader_works_without_jsonschema(monkeypatch):
    # jsonschema is optional: the structural checks alone still reject what matters.
    monkeypatch.setattr(schema_module, "has_jsonschema", lambda: False)
    assert validate_schema({"edges_length": [-1]}) is False
    fold = loads_fold((DATA / "degree4.fold").read_text())
    assert fold.key_frame.n_edges == 12
    with pytest.raises(FoldFormatError, match="'J' \\(join edge\\)"):
        read_fold(DATA / "errors" / "join_edge.fold")
