"""FOLD in and out of the physics packages (`origami_jax.vertex`, `origami_jax.chain`) and
`origami-jax export`."""

import json
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from origami_jax import vertex as vertex_module
from origami_jax.chain import (
    Chain,
    accordion,
    accordion_dimensions,
    accordion_system,
    flap_chain,
    load_chain,
    trajectory_to_fold,
)
from origami_jax.cli import main
from origami_jax.fold import (
    FoldFormatError,
    chain_geometry,
    fold_from_dict,
    read_fold,
    single_vertex_geometry,
)
from origami_jax.system import MICRO, HingeDesign
from origami_jax.vertex import load_single_vertex, single_vertex_to_fold, unfolding_to_fold

from .test_fold_geometry import folded_directions
from .test_fold_write import origami_simulator_import_problems

DATA = Path(__file__).parent / "data" / "fold"
DEG = np.pi / 180


def test_fold_package_is_plain_numpy():
    # Layers point one way: the physics packages build on the FOLD package, never the reverse, and
    # reading or writing a file needs neither JAX nor physics.
    code = (
        "import sys, origami_jax.fold; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('jax', 'equinox') "
        "or m.startswith(('origami_jax.vertex', 'origami_jax.chain', 'origami_jax.system'))))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "[]"


def test_load_single_vertex_picks_and_reports():
    with pytest.raises(FoldFormatError, match="vertex_index="):
        load_single_vertex(DATA / "two_vertex.fold")
    with pytest.raises(FoldFormatError, match=r"creases \[0\] have no fold angle"):
        load_single_vertex(DATA / "two_vertex.fold", vertex_index=0)
    data = json.loads((DATA / "waterbomb.fold").read_text())
    del data["edges_foldAngle"]  # M/V defaults: ±180°, fully folded
    with pytest.raises(FoldFormatError, match="fully folded"):
        load_single_vertex(fold_from_dict(data))


def test_single_vertex_to_fold_and_unfolding_to_fold():
    vertex = load_single_vertex(DATA / "boundary_vertex.fold")
    fold = single_vertex_to_fold(vertex, title="boundary")
    assert fold.key_frame.extra["frame_title"] == "boundary"
    again = single_vertex_geometry(fold, frame=1)
    np.testing.assert_allclose(again.fold_angles, np.array([30, -40, 50]) * DEG, atol=1e-12)
    # An UnfoldResult-like object: path (k, n, 3), fold_angles (k, m), and the vertex.
    sectors = vertex.sector_angles
    path = np.stack(
        [
            folded_directions(sectors, s * np.array([30, -40, 50]) * DEG, closed=False)
            for s in (1, 0.5, 0)
        ]
    )
    result = types.SimpleNamespace(
        path=path,
        fold_angles=np.array([s * np.array([30, -40, 50]) * DEG for s in (1, 0.5, 0)]),
        energy=np.array([3.0, 2.0, 1.0]),
        path_length=np.array([0.0, 0.5, 1.0]),
        verdict=types.SimpleNamespace(value="flat-unfolded"),
    )
    fold = unfolding_to_fold(result, vertex=vertex, times=np.arange(3.0))
    assert fold.n_frames == 4
    assert fold.key_frame.extra["origami_jax:verdict"] == "flat-unfolded"
    assert fold.frames[2].extra["origami_jax:energy"] == 2.0
    assert fold.frames[3].extra["origami_jax:path_length"] == 1.0
    with pytest.raises(FoldFormatError, match="one value per state"):
        unfolding_to_fold(directions=path, closed=False, frame_data={"energy": [1.0]})
    assert fold.frames[3].edges_assignment[:5] == ("B", "F", "F", "F", "B")  # flat at the end
    assert origami_simulator_import_problems(json.dumps(fold.to_dict())) == []
    with pytest.raises(FoldFormatError, match="closed= or vertex="):
        unfolding_to_fold(types.SimpleNamespace(path=path, fold_angles=None))
    with pytest.raises(FoldFormatError, match="not both"):
        unfolding_to_fold(result, directions=path, closed=False)
    with pytest.raises(FoldFormatError, match="needs an UnfoldResult"):
        unfolding_to_fold(closed=True)


@pytest.mark.parametrize(
    "name",
    [
        "corner_cube",
        "boundary_vertex",
        # Each case compiles the vertex package's checks anew (~5 s): two run by default.
        pytest.param("degree4", marks=pytest.mark.slow),
        pytest.param("waterbomb", marks=pytest.mark.slow),
    ],
)
def test_single_vertex_round_trip(name):
    # A flat crease pattern builds the vertex from its sector and fold angles: the vertex's own fold
    # angles (computed from its directions) agree with the file's to rounding.
    geometry = single_vertex_geometry(DATA / f"{name}.fold")
    vertex = load_single_vertex(DATA / f"{name}.fold")
    assert isinstance(vertex, vertex_module.SingleVertex)
    assert vertex.closed == geometry.closed
    np.testing.assert_allclose(vertex.sector_angles, geometry.sector_angles, atol=1e-12)
    np.testing.assert_allclose(vertex_module.fold_angles(vertex), geometry.fold_angles, atol=1e-9)
    # Written with the vertex package's own fold angles: the writer's sign check passes, and the
    # folded frame reads back as the same vertex.
    fold = single_vertex_to_fold(vertex)
    again = load_single_vertex(fold, frame=1)
    np.testing.assert_allclose(again.directions, vertex.directions, atol=1e-12)


def test_accordion_dimensions_and_trajectory_to_fold():
    chain = accordion(3)
    lengths, width = accordion_dimensions(chain)
    np.testing.assert_allclose(lengths, 200.0, rtol=1e-12)
    assert width == pytest.approx(200.0, rel=1e-9)
    theta = np.array([[0.0, 0.0, 0.0], [1.0, -1.0, 1.0], [np.pi, -np.pi, np.pi], [np.inf] * 3])
    trajectory = types.SimpleNamespace(times=np.array([0.0, 1.0, 2.0, 3.0]), theta=theta)
    fold = trajectory_to_fold(chain, trajectory)
    assert fold.n_frames == 4  # the non-finite sample after a failed solve is dropped
    assert fold.key_frame.extra["origami_jax:dropped_samples"] == 1
    assert fold.key_frame.extra["origami_jax:time_unit"] == "us"
    geometry = chain_geometry(fold)
    np.testing.assert_allclose(geometry.flap_lengths, 200.0)
    assert origami_simulator_import_problems(json.dumps(fold.to_dict())) == []
    # A folding system writes the same file as its chain (the literature design: 200 µm flaps).
    system = accordion_system(HingeDesign.literature(MICRO), 3)
    assert isinstance(system.mechanism, Chain)
    assert trajectory_to_fold(system, trajectory).to_dict() == fold.to_dict()
    thinned = trajectory_to_fold(hinge_angles=theta[:3], flap_lengths=lengths, width=width, every=2)
    assert thinned.n_frames == 3  # samples 0 and 2 (the last is always kept)
    with pytest.raises(FoldFormatError, match="needs the system"):
        trajectory_to_fold(trajectory=trajectory)
    with pytest.raises(FoldFormatError, match="no finite samples"):
        trajectory_to_fold(hinge_angles=theta[3:], flap_lengths=lengths, width=width)


def test_load_chain_matches_the_papers_accordion():
    chain, geometry = load_chain(DATA / "accordion.fold")
    reference = accordion(3)
    for field in ("axes", "points", "cg_poses", "masses", "inertias"):
        np.testing.assert_allclose(getattr(chain, field), getattr(reference, field), rtol=1e-12)
    np.testing.assert_allclose(geometry.fold_angles, [np.pi, -np.pi, np.pi])
    # A file in millimetres is converted into the chain's units (MICRO: µm).
    data = json.loads((DATA / "accordion.fold").read_text())
    data["frame_unit"] = "mm"
    data["vertices_coords"] = [[x / 1000, y / 1000] for x, y in data["vertices_coords"]]
    chain_mm, _ = load_chain(fold_from_dict(data))
    np.testing.assert_allclose(chain_mm.points, reference.points, rtol=1e-12, atol=1e-9)


def test_accordion_dimensions_rejects_non_parallel_hinges():
    e_x, e_y = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    chain = flap_chain(
        np.stack([e_x, e_y]),
        np.stack([0 * e_y, 200 * e_y]),
        np.stack([100 * e_y, 300 * e_y]),
        flap_length=200.0,
        flap_width=200.0,
        thickness=0.2,
        density=3.1e-3,
    )
    with pytest.raises(FoldFormatError, match="parallel hinges"):
        accordion_dimensions(chain)


# --- origami-jax export -------------------------------------------------------------------------


def test_cli_export_normalises_a_fold_file(tmp_path, capsys):
    code = main(
        ["export", str(DATA / "two_vertex.fold"), "--format", "fold", "--out", str(tmp_path)]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert "two_vertex.fold" in out and "vertex   0" in out and "vertex   1" in out
    written = tmp_path / "two_vertex.fold"
    assert origami_simulator_import_problems(written.read_text()) == []
    fold = read_fold(written)
    assert fold.file_spec == 1.2 and len(fold.key_frame.faces_vertices) == 6


def test_cli_export_errors(tmp_path, capsys):
    assert main(["export", str(DATA / "errors" / "join_edge.fold"), "--out", str(tmp_path)]) == 2
    assert "'J' (join edge)" in capsys.readouterr().err
    assert main(["export", str(tmp_path / "missing.fold"), "--out", str(tmp_path)]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["export", "teapot", "--out", str(tmp_path)]) == 2
    assert "unknown SOURCE" in capsys.readouterr().err
    source = tmp_path / "degree4.fold"
    source.write_text((DATA / "degree4.fold").read_text())
    assert main(["export", str(source), "--out", str(tmp_path)]) == 2
    assert "refusing to overwrite" in capsys.readouterr().err


def test_cli_export_catalogue_vertex(tmp_path):
    assert main(["export", "corner-cube", "--format", "fold", "--out", str(tmp_path)]) == 0
    written = tmp_path / "corner-cube.fold"
    assert origami_simulator_import_problems(written.read_text()) == []
    # The catalogue's corner cube is the one in tests/data (read by the FOLD reader alone).
    geometry = single_vertex_geometry(written, frame=1)
    np.testing.assert_allclose(
        geometry.fold_angles,
        single_vertex_geometry(DATA / "corner_cube.fold").fold_angles,
        atol=1e-9,
    )


@pytest.mark.slow
def test_real_unfolding_written_as_fold(tmp_path):
    """Read a crease pattern, unfold it with the vertex package, write the path, read it back."""
    vertex = load_single_vertex(DATA / "corner_cube.fold")
    result = vertex_module.unfold(vertex)
    path = tmp_path / "corner_cube_unfolding.fold"
    from origami_jax.fold import write_fold

    write_fold(path, unfolding_to_fold(result))
    fold = read_fold(path)
    assert fold.n_frames == len(result.path) + 1
    assert origami_simulator_import_problems(path.read_text()) == []
    last = single_vertex_geometry(fold, frame=fold.n_frames - 1)
    np.testing.assert_allclose(last.fold_angles, result.fold_angles[-1], atol=1e-9)
