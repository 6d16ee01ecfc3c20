"""Interactive views: scenes from every source, the self-contained page, and the page in a real browser.

Geometry is checked against independent computations: a mechanism's own `panel_polygons`, FOLD files'
stored coordinates, `fold_angles_from_coords` on rigidly folded crease patterns, the vertex package's
arc clearances. Browser tests drive Debian's headless Chromium over the DevTools pipe
(`tests/browser.py`); they skip, saying why, where no Chromium is installed (`apt-get install -y
chromium` as root; see docs/development.md, "Tests").
"""

import base64
import io
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from origami_jax import view
from origami_jax.view import Scene, frame_indices, resample, scene_from, triangulate

from .browser import Browser, find_chromium

DATA = Path(__file__).resolve().parent / "data" / "fold"
# Geometry built from the same float64 numbers by two routes agrees to round-off.
GEOMETRY_TOL = 1e-9


# ---------------------------------------------------------------- the scene model


def square(x0=0.0):
    return np.array([[x0, 0, 0], [x0 + 1, 0, 0], [x0 + 1, 1, 0], [x0, 1, 0]], dtype=float)


def test_scene_checks_its_input():
    good = dict(
        vertices=np.zeros((2, 4, 3)),
        offsets=[0, 4],
        times=[0, 1],
        hinges=[[0, 1]],
        fold_angles=[[0], [1]],
    )
    Scene(**good)
    with pytest.raises(ValueError, match="at least 3 corners"):
        Scene(**{**good, "offsets": [0, 2, 4]})
    with pytest.raises(ValueError, match="non-decreasing"):
        Scene(**{**good, "times": [1, 0]})
    with pytest.raises(ValueError, match="fold_angles must have shape"):
        Scene(**{**good, "fold_angles": [0, 1, 2]})
    with pytest.raises(ValueError, match="not finite in frame"):
        Scene(**{**good, "vertices": np.full((2, 4, 3), np.nan)})
    with pytest.raises(ValueError, match="hinges must index"):
        Scene(**{**good, "hinges": [[0, 7]]})


def test_frame_indices_keep_short_results_and_spread_long_ones_in_time():
    assert frame_indices(np.arange(10.0), 300).tolist() == list(range(10))
    times = np.concatenate([np.linspace(0, 1, 900), np.linspace(1.01, 10, 100)])  # dense start
    keep = frame_indices(times, 50)
    assert keep[0] == 0 and keep[-1] == len(times) - 1 and len(keep) <= 51
    # Evenly spread in time, not in sample index: gaps are about 10/49, never more than twice that.
    gaps = np.diff(times[keep])
    assert np.max(gaps) < 2 * 10 / 49


def test_resample_moves_contacts_to_the_nearest_kept_frame():
    frames = [[square()] for _ in range(1000)]
    scene = view.scene_from_polygons(
        frames,
        times=np.linspace(0, 1, 1000),
        contact_frames=[3, 998],
        contact_points=[[0, 0, 0], [1, 1, 0]],
    )
    small = resample(scene, 11)
    assert small.n_frames == 11
    assert small.contact_frames.tolist() == [0, 10]
    assert "1000 samples shown as 11 frames" in small.notes[-1]


def polygon_area(points):
    x, y = points[:, 0], points[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def test_triangulate_covers_a_non_convex_panel_with_its_own_winding():
    # An L-shaped hexagon in a tilted plane: area preserved, every triangle counter-clockwise.
    flat = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
    triangles = triangulate(np.c_[flat, np.zeros(6)])
    assert triangles.shape == (4, 3)
    areas = [polygon_area(flat[t]) for t in triangles]
    assert min(areas) > 0
    assert math.isclose(sum(areas), polygon_area(flat), rel_tol=1e-12)


# ---------------------------------------------------------------- FOLD files


def test_fold_frames_that_change_only_angles_are_folded_rigidly():
    from origami_jax.fold import fold_angles_from_coords, read_fold

    scene = scene_from(DATA / "frames.fold")
    fold = read_fold(DATA / "frames.fold")
    key = fold.frame(0)
    # Frames 1 and 2 are drawn; frame 3 is another graph.
    assert scene.n_frames == 2 and scene.n_panels == 4 and scene.n_hinges == 4
    assert any("frame 3 skipped" in note for note in scene.notes)
    faces = key.faces_vertices
    for f, index in enumerate((1, 2)):
        # Rigid: every face keeps its crease-pattern edge lengths and diagonals.
        for p, face in enumerate(faces):
            flat = key.coords3[list(face)]
            folded = scene.panel(p, f)
            d_flat = np.linalg.norm(flat[:, None] - flat[None], axis=-1)
            d_fold = np.linalg.norm(folded[:, None] - folded[None], axis=-1)
            np.testing.assert_allclose(d_fold, d_flat, atol=GEOMETRY_TOL)
        # The folded state has the file's fold angles, read back by the fold package's own formula.
        coords = np.zeros((key.n_vertices, 3))
        for p, face in enumerate(faces):
            coords[list(face)] = scene.panel(p, f)
        measured = fold_angles_from_coords(coords, faces, key.edges_vertices)
        given = np.deg2rad(fold.fold_angles_deg(index))
        creases = [0, 1, 2, 3]
        np.testing.assert_allclose(measured[creases], given[creases], atol=GEOMETRY_TOL)
        np.testing.assert_allclose(scene.fold_angles[f], given[creases], atol=GEOMETRY_TOL)


def test_fold_frames_with_3d_coordinates_are_drawn_as_stored():
    from origami_jax.fold import chain_fold

    theta = np.linspace(0, 1, 7)[:, None] * np.array([2.0, -1.0, 2.5])
    fold = chain_fold(
        theta, np.array([1.0, 2.0, 1.5]), width=0.8, times=np.linspace(0, 3, 7), time_unit="us"
    )
    scene = scene_from(fold)
    assert scene.n_frames == 7 and scene.n_panels == 4 and scene.n_hinges == 3
    assert scene.time_unit == "µs" and scene.length_unit == "µm"
    np.testing.assert_allclose(scene.times, np.linspace(0, 3, 7))
    for k in range(7):
        coords = fold.frame(k + 1).coords3
        for p, face in enumerate(fold.key_frame.faces_vertices):
            np.testing.assert_array_equal(scene.panel(p, k), coords[list(face)])
    np.testing.assert_allclose(scene.fold_angles, theta, atol=GEOMETRY_TOL)


# ---------------------------------------------------------------- single vertex


def random_unit(rng, shape):
    x = rng.normal(size=shape)
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def test_vertex_sectors_are_flat_wedges_between_their_rays():
    # A closed, folded degree-5 vertex; every sector below π.
    phi = np.array([0.0, 1.1, 2.5, 3.9, 5.2])
    rays = np.stack([np.cos(phi), np.sin(phi), 0.5 * np.cos(3 * phi)], axis=1)
    path = (rays / np.linalg.norm(rays, axis=1, keepdims=True))[None]
    u, v = path[0], np.roll(path[0], -1, axis=0)
    sectors = np.arccos(np.clip(np.sum(u * v, 1), -1, 1))
    scene = view.scene_from_vertex_path(path[:1], sectors, closed=True)
    for i in range(5):
        panel = scene.panel(i, 0)
        np.testing.assert_allclose(panel[0], 0.0)
        np.testing.assert_allclose(panel[1], u[i], atol=GEOMETRY_TOL)
        np.testing.assert_allclose(panel[-1], v[i], atol=GEOMETRY_TOL)
        np.testing.assert_allclose(np.linalg.norm(panel[1:], axis=1), 1.0, atol=GEOMETRY_TOL)
        normal = np.cross(u[i], v[i])
        np.testing.assert_allclose(panel @ normal, 0.0, atol=GEOMETRY_TOL)  # planar wedge
    from origami_jax.fold import vertex_fold_angles

    np.testing.assert_allclose(scene.fold_angles[0], vertex_fold_angles(path[0], closed=True))


def test_vertex_crossing_arcs_are_marked_where_they_cross():
    # Rays u0 u1 span an arc on the equator through +x; u2 u3 an arc on the meridian through +x:
    # the two (non-adjacent) arcs cross at exactly (1, 0, 0).
    def ray(lon, lat):
        return np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])

    rays = np.array([ray(-0.3, 0), ray(0.3, 0), ray(0, -0.3), ray(0, 0.3)])
    u, v = rays, np.roll(rays, -1, axis=0)
    sectors = np.arccos(np.sum(u * v, 1))
    sectors[-1] = 2 * np.pi - sectors[:-1].sum()  # a self-crossing vertex: the last sector closes
    scene = view.scene_from_vertex_path(rays[None], sectors, closed=True)
    assert scene.contact_frames.tolist() == [0]
    np.testing.assert_allclose(scene.contact_points[0], [1.0, 0.0, 0.0], atol=GEOMETRY_TOL)
    assert scene.highlight_panels.tolist() == [True, False, True, False]


# ---------------------------------------------------------------- trajectories and mechanisms


@pytest.fixture(scope="module")
def accordion():
    from origami_jax.chain import accordion_system
    from origami_jax.system import HingeDesign

    return accordion_system(HingeDesign.literature(), 3)


def synthetic_trajectory(system, theta, *, failed_after=None, times=None):
    import jax.numpy as jnp

    from origami_jax.simulation import RESULTS, Trajectory

    theta = np.array(theta, dtype=float)
    result = RESULTS.successful
    if failed_after is not None:
        theta[failed_after:] = np.inf
        result = RESULTS.max_steps_reached
    zeros = jnp.zeros_like(theta)
    return Trajectory(
        times=jnp.linspace(0.0, 100.0, len(theta)) if times is None else jnp.asarray(times),
        theta=jnp.asarray(theta),
        theta_dot=zeros,
        theta_ddot=zeros,
        tau=zeros,
        target=jnp.asarray(system.hinges.target),
        stats={},
        result=result,
    )


def test_trajectory_panels_match_the_mechanism_polygons(accordion):
    theta = np.linspace(0, 1, 50)[:, None] * np.array([3.3, -2.0, 1.0])
    trajectory = synthetic_trajectory(accordion, theta)
    scene = scene_from(trajectory, system=accordion, thickness=0.2)
    assert scene.n_frames == 50 and scene.n_panels == 4 and scene.n_hinges == 3
    assert scene.fixed_panels.tolist() == [True, False, False, False]
    assert scene.length_unit == "µm" and scene.time_unit == "µs"
    mechanism = accordion.mechanism
    for k in (0, 17, 49):
        expected = mechanism.panel_polygons(theta[k])
        for b, polygon in enumerate(expected):
            np.testing.assert_allclose(scene.panel(b + 1, k), polygon, atol=GEOMETRY_TOL)
        # Each hinge segment is shared with the panel before it (base or previous flap), up to the
        # outline's length error: Chain.outlines reads L from I_xx = m (L² + t²) / 12, so a flap is
        # drawn sqrt(L² + t²) - L = t² / 2L = 1e-4 µm too long (200 µm flaps, 200 nm thick).
        for i, (a, c) in enumerate(scene.hinges):
            parent = scene.panel(i, k)
            for end in (scene.vertices[k, a], scene.vertices[k, c]):
                assert np.min(np.linalg.norm(parent - end, axis=1)) < 2e-4
    np.testing.assert_allclose(scene.fold_angles, theta)
    # Hinge 1 passes π (flaps 0 and 1 meet): contacts exactly on those frames, at that hinge.
    crossed = np.nonzero(np.abs(theta[:, 0]) >= np.pi - 1e-3)[0]
    assert scene.contact_frames.tolist() == crossed.tolist()
    assert scene.verdict_level == "warn" and "contacts marked" in scene.verdict


def test_failed_trajectory_drops_bad_samples_and_says_so(accordion):
    theta = np.linspace(0, 1, 20)[:, None] * np.array([1.0, -1.0, 1.0])
    scene = scene_from(synthetic_trajectory(accordion, theta, failed_after=12), system=accordion)
    assert scene.n_frames == 12
    assert scene.verdict_level == "fail" and "maximum number of solver steps" in scene.verdict
    assert any("8 samples after the failure dropped" in note for note in scene.notes)


def test_trajectory_needs_its_system(accordion):
    trajectory = synthetic_trajectory(accordion, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="pass system="):
        scene_from(trajectory)


def test_trajectory_with_its_pattern(accordion):
    """`pattern=` (and `design=`) stand for the system: the pattern builds it, the design gives the
    panels' thickness; the flap size is the pattern's (100 µm flaps end at y = 100, 200, 300)."""
    from origami_jax.chain import Accordion

    theta = np.linspace(0, 1, 5)[:, None] * np.array([1.0, -1.0, 1.0])
    trajectory = synthetic_trajectory(accordion, theta)
    direct = scene_from(trajectory, system=accordion, thickness=0.2)
    through = scene_from(trajectory, pattern=Accordion(3))
    np.testing.assert_array_equal(through.vertices, direct.vertices)
    assert through.thickness == pytest.approx(0.2)  # the literature design's 200 nm, in µm
    short = scene_from(trajectory, pattern=Accordion(3, flap_length=100.0))
    far = [float(np.max(short.panel(b, 0)[:, 1])) for b in (1, 2, 3)]
    np.testing.assert_allclose(far, [100.0, 200.0, 300.0], atol=2e-4)  # t²/2L: see above
    with pytest.raises(ValueError, match="not both"):
        scene_from(trajectory, system=accordion, pattern=Accordion(3))
    with pytest.raises(ValueError, match="pattern= takes a Net, CreasePattern or Accordion"):
        scene_from(trajectory, pattern=accordion)


def test_folding_system_at_rest_is_flat(accordion):
    scene = scene_from(accordion)
    assert scene.n_frames == 1 and scene.n_panels == 4
    np.testing.assert_allclose(scene.vertices[0, :, 2], 0.0, atol=GEOMETRY_TOL)


# ---------------------------------------------------------------- sweep members


def fake_sweep(tmp_path, **coords):
    import xarray as xr

    from origami_jax.sweep import get_model

    kernel = get_model("accordion-step", n_flaps=3, t_end=100.0, n_save=51, solver="tsit5")
    n = len(next(iter(coords.values())))
    dataset = xr.Dataset(
        {"result": ("design", np.zeros(n, np.int32))},
        coords={"design": np.arange(n), **{k: ("design", v) for k, v in coords.items()}},
        attrs={"model": kernel.name, "settings": json.dumps(kernel.settings, sort_keys=True)},
    )
    path = tmp_path / "sweep.nc"
    dataset.to_netcdf(path, engine="h5netcdf")
    return dataset, path


def test_sweep_member_rebuilds_that_design(tmp_path):
    from origami_jax.chain import Accordion, accordion_system
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    dataset, _ = fake_sweep(
        tmp_path,
        hinge_width=np.array([50.0, 120.0]),
        n_flaps=np.array([2, 4]),
        fluid=np.array(["air", "koh"]),
        flap_length=np.array([200.0, 150.0]),
    )
    system, design, _, description = view.sweep_member_system(dataset, 1)
    assert system.mechanism.n_hinges == 4 and "hinge_width=120" in description
    # The stored model and settings become the pattern once: the member's flaps are its.
    pattern, *_ = view.sweep_member_pattern(dataset, 1)
    assert isinstance(pattern, Accordion) and (pattern.n_flaps, pattern.flap_length) == (4, 150.0)
    assert pattern.flap_width == pytest.approx(200.0)  # the kernel's recorded default
    reference = accordion_system(
        HingeDesign.literature(hinge_width=120.0, fluid=KOH_SOLUTION), 4, flap_length=150.0
    )
    np.testing.assert_allclose(system.hinges.stiffness, reference.hinges.stiffness, rtol=1e-12)
    np.testing.assert_allclose(system.drag.coefficient, reference.drag.coefficient, rtol=1e-12)
    with pytest.raises(ValueError, match="numbered 0 to 1"):
        view.sweep_member_system(dataset, None)
    with pytest.raises(ValueError, match="not in the sweep"):
        view.sweep_member_system(dataset, 5)


# ---------------------------------------------------------------- the page


def decode(b64):
    return np.frombuffer(base64.b64decode(b64), dtype="<f4")


def test_page_is_self_contained_and_carries_the_scene():
    scene = scene_from(DATA / "frames.fold")
    page = view.to_html(scene)
    # No resource loaded from the web: no src/href/url() pointing at http(s) or protocol-relative.
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", page, re.I)
    assert not re.search(r"""url\(\s*["']?\s*(https?:)?//""", page, re.I)
    assert not re.search(r"<link\b|<script[^>]*\bsrc\s*=", page, re.I)
    assert "Copyright 2010-2026 Three.js Authors" in page
    payload = json.loads(
        re.search(
            r'<script type="application/json" id="origami-scene">\n(.*?)\n</script>', page, re.S
        )
        .group(1)
        .replace("<\\/", "</")
    )
    assert payload["nPanels"] == 4 and payload["nFrames"] == 2
    vertices = decode(payload["vertices"]).reshape(2, -1, 3)
    center = (scene.vertices.min((0, 1)) + scene.vertices.max((0, 1))) / 2
    np.testing.assert_allclose(vertices, scene.vertices - center, atol=1e-6)  # float32
    np.testing.assert_allclose(
        decode(payload["foldAngles"]).reshape(2, 4), np.rad2deg(scene.fold_angles), rtol=1e-6
    )


def test_write_html_is_atomic_and_view_displays_inline(tmp_path):
    path = view.write_html(DATA / "frames.fold", tmp_path / "sub" / "page.html")
    assert path.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert [p.name for p in path.parent.iterdir()] == ["page.html"]  # no temporary left behind
    shown = view.show(DATA / "frames.fold", height=500)
    frame = shown._repr_html_()
    assert frame.startswith("<iframe srcdoc=") and "height:500px" in frame
    assert "4 panels" in repr(shown)


# ---------------------------------------------------------------- command line


def run_cli(*argv):
    from origami_jax.cli import main

    return main([str(a) for a in argv])


def test_cli_view_fold_file(tmp_path, capsys):
    assert run_cli("view", DATA / "frames.fold", "--out", tmp_path) == 0
    out = capsys.readouterr().out
    assert (tmp_path / "frames.html").is_file()
    assert "4 panels, 4 hinges, 2 frames" in out


@pytest.mark.slow  # a shipped pattern's system and view compiled: ~9 s
def test_cli_view_previews_a_shipped_pattern(tmp_path, capsys, monkeypatch):
    # A catalogue name is not a file: the page goes to the working folder, named after it; the
    # last frame is the cube net folded to its intended 90° creases.
    monkeypatch.chdir(tmp_path)
    assert run_cli("view", "cube_net_01") == 0
    out = capsys.readouterr().out
    assert (tmp_path / "cube_net_01.html").is_file()
    assert "6 panels, 5 hinges, 25 frames" in out
    assert run_cli("view", "cube_net_01") == 2  # the page exists: refused without --overwrite
    assert "--overwrite" in capsys.readouterr().err
    page = (tmp_path / "cube_net_01.html").read_text()
    assert "kinematic preview" in page and "cube_net_01" in page


def test_cli_view_open_hands_the_page_to_the_web_browser(tmp_path, capsys, monkeypatch):
    import webbrowser

    opened = []
    monkeypatch.setattr(webbrowser, "open", lambda url: opened.append(url) or True)
    page = tmp_path / "x.html"
    assert run_cli("view", DATA / "frames.fold", "--out", page, "--open") == 0
    assert opened == [page.resolve().as_uri()]


def test_cli_view_simulate_output(tmp_path, capsys, accordion):
    from origami_jax.cli._simulate import write_trajectory

    theta = np.linspace(0, 1, 401)[:, None] * np.array([3.0, -3.0, 3.0])
    path = write_trajectory(synthetic_trajectory(accordion, theta), tmp_path / "trajectory")
    (tmp_path / "metrics.json").write_text(
        json.dumps(
            {"flaps": 3, "fluid": "air", "params": {}, "result": "successful", "succeeded": True}
        )
    )
    assert run_cli("view", path, "--frames", "100", "--out", tmp_path / "page.html") == 0
    assert "4 panels, 3 hinges, 100 frames of 401 samples" in capsys.readouterr().out
    scene = view.load_scene(path)
    k = 200
    for b, polygon in enumerate(accordion.mechanism.panel_polygons(theta[k])):
        np.testing.assert_allclose(scene.panel(b + 1, k), polygon, atol=1e-6)  # CSV keeps 12 digits
    assert scene.thickness == pytest.approx(0.2)  # the literature design's 200 nm SiNx, in µm


@pytest.mark.parametrize(
    "argv, message",
    [
        (["missing.fold"], "no such file"),
        ([DATA / "frames.fold", "--member", "2"], "--member only applies to a sweep.nc"),
        ([DATA / "frames.fold", "--frames", "1"], "--frames must be 0"),
        ([DATA / "errors" / "bad_json.fold"], "bad_json.fold"),
        ([Path(__file__)], "cannot view test_view.py"),
    ],
)
def test_cli_view_bad_input_is_one_line(argv, message, capsys):
    assert run_cli("view", *argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert message in err


def test_cli_view_sweep_without_member(tmp_path, capsys):
    _, path = fake_sweep(tmp_path, hinge_width=np.array([50.0, 120.0]))
    assert run_cli("view", path) == 2
    assert "give the member to view (--member K)" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_view_sweep_member_simulates_it_again(tmp_path):
    """A real two-design sweep from the command line; the viewed member's rebuilt hinges are the
    ones the sweep stored. (The sweep runs in its own process, as users run it.)"""
    import os
    import subprocess

    import xarray as xr

    config = tmp_path / "sweep.toml"
    config.write_text(
        '[model]\nname = "accordion"\ninput = "step"\nn_flaps = 2\nt_end = 300.0\n'
        'n_save = 301\nsolver = "tsit5"\n[sweep]\nkind = "grid"\n'
        "[parameters]\nhinge_width = { values = [100.0, 200.0] }\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    subprocess.run(
        [
            sys.executable,
            "-m",
            "origami_jax",
            "sweep",
            str(config),
            "--out",
            str(tmp_path / "sw"),
            "--no-plots",
            "--no-progress",
        ],
        check=True,
        env=env,
        capture_output=True,
    )
    with xr.open_dataset(tmp_path / "sw" / "sweep.nc") as stored:
        dataset = stored.load()
    system, *_ = view.sweep_member_system(dataset, 1)
    for name, value in (("stiffness", system.hinges.stiffness), ("drag", system.drag.coefficient)):
        assert float(value[0]) == pytest.approx(float(dataset[name].sel(design=1)), rel=1e-12)
    viewed = subprocess.run(
        [
            sys.executable,
            "-m",
            "origami_jax",
            "view",
            str(tmp_path / "sw" / "sweep.nc"),
            "--member",
            "1",
        ],
        check=True,
        env=env,
        capture_output=True,
        text=True,
    )
    assert "3 panels, 2 hinges" in viewed.stdout
    assert (tmp_path / "sw" / "sweep_member_1.html").is_file()


# ---------------------------------------------------------------- nets and crease patterns


@pytest.fixture(scope="module")
def corner_cube():
    from origami_jax.net import load_net

    net = load_net("corner_cube")
    return net, net.system()


def test_a_pattern_is_shown_flat_then_folded_as_intended(corner_cube):
    """`scene_from(pattern)`: the flat net, then every hinge turned linearly to its intended
    angle; the last frame is the intended shape (the mechanism's own polygons there), hinges
    named as the pattern names them, panels as thick as the design's film (200 nm)."""
    net, system = corner_cube
    scene = scene_from(net)
    folded = np.asarray(net.intended_angles, dtype=float)
    assert scene.n_frames == view.PATTERN_FRAMES
    np.testing.assert_allclose(scene.fold_angles[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(scene.fold_angles[-1], folded, atol=1e-9)
    np.testing.assert_allclose(scene.vertices[0, :, 2], 0.0, atol=GEOMETRY_TOL)
    for b, polygon in enumerate(system.mechanism.panel_polygons(folded)):
        np.testing.assert_allclose(scene.panel(b + 1, -1), polygon, atol=GEOMETRY_TOL)
    assert scene.hinge_names == tuple(net.hinge_name(j) for j in range(2))
    assert scene.thickness == pytest.approx(0.2) and scene.time_label == "fold fraction"
    flat = view.scene_from_pattern(net, frames=1)
    assert flat.n_frames == 1 and flat.verdict == "flat pattern"
    with pytest.raises(ValueError, match="frames must be an integer >= 1"):
        view.scene_from_pattern(net, frames=0)


def test_simulate_results_name_their_pattern():
    """A simulate run's stored names (metrics.json) become the accordion and its design once: the
    flap size goes to the pattern, the rest to the design."""
    from origami_jax.chain import Accordion

    report = {"fluid": "30 wt% KOH solution", "params": {"flap_length": 120.0, "k_scale": 2.0}}
    pattern, design = view.simulated_pattern(report, 2)
    assert pattern == Accordion(2, flap_length=120.0)
    assert float(design.k_scale) == 2.0 and "KOH" in design.fluid.name


def test_net_hinges_ride_their_creases_and_contacts_are_marked(corner_cube):
    """Hinge segments of a net lie on the crease in the flat state (`hinge_layout`) and, folded, on
    an edge shared by the two panels the hinge joins (their own `panel_polygons`); a flap turned
    by π onto the base is marked as touching it, inside the base, and both panels highlighted."""
    net, system = corner_cube
    mechanism = system.mechanism
    folded = np.array(net.intended_angles, dtype=float)
    onto_base = np.array([math.pi, 0.0])
    scene = view.scene_from_mechanism(system, np.stack([np.zeros(2), folded, onto_base]))
    layout = mechanism.hinge_layout()
    assert scene.n_hinges == mechanism.n_hinges == 2
    for h in range(2):
        ends = scene.vertices[0][scene.hinges[h]]
        assert (
            min(np.abs(ends - layout.ends[h]).max(), np.abs(ends[::-1] - layout.ends[h]).max())
            < GEOMETRY_TOL
        )
    polygons = [np.asarray(mechanism.base_outline()), *mechanism.panel_polygons(folded)]
    for h in range(2):
        ends = scene.vertices[1][scene.hinges[h]]
        for body in (int(layout.child[h]) + 1, int(layout.parent[h]) + 1):
            distance = np.linalg.norm(ends[:, None] - polygons[body][None], axis=-1).min(axis=1)
            assert np.all(distance < GEOMETRY_TOL), (h, body, distance)
    # Contacts: none flat; folded, the flaps' rims meet at their seam (plates of the film's
    # thickness); flap 1 on the base at θ = π (the base is the square [0, 200]² µm).
    assert set(scene.contact_frames.tolist()) == {1, 2}
    points = scene.contact_points[scene.contact_frames == 2]
    inside = (points[:, :2] >= -1e-9) & (points[:, :2] <= 200 + 1e-9)  # on the base, rims included
    assert np.all(inside) and np.all(np.abs(points[:, 2]) < 1)
    # At the end all three touch: flap 1 lies on the base, its rim along the crease of flap 2
    # (flat beside the base) within the contact's activation gap.
    assert scene.highlight_panels.tolist() == [True, True, True]


def test_fold_result_file_carries_verdict_and_contacts(corner_cube, tmp_path):
    """`origami-jax fold` annotates `trajectory.fold`: the view of that file shows the verdict, the
    creases outside tolerance and the contacts, as the view of the trajectory itself does."""
    from origami_jax.cli._fold import _view_annotations
    from origami_jax.fold import write_fold
    from origami_jax.simulation import FoldReport, FoldVerdict

    net, system = corner_cube
    theta = np.stack([np.zeros(2), np.array(net.intended_angles), np.array([math.pi, 0.0])])
    trajectory = synthetic_trajectory(system, theta)
    report = FoldReport(
        verdict=FoldVerdict.JAMMED,
        reason="contact stops a crease short",
        final_angles=theta[-1],
        intended_angles=np.array(net.intended_angles),
        angle_errors=theta[-1] - np.array(net.intended_angles),
        seam_gaps=np.zeros(1),
        angle_tolerance=math.radians(3),
        seam_tolerance=2.0,
        time_to_fold=None,
        settled=True,
        contacts=14,
        min_gap=-0.2,
        max_penetration=0.2,
        penetration_fraction=1.0,
        result="successful",
    )
    extras, key_extra = _view_annotations(net, system, trajectory, report, every=1)
    path = tmp_path / "trajectory.fold"
    write_fold(path, net.to_fold(trajectory, extras=extras, key_extra=key_extra))
    from_file = view.scene_from_fold(path)
    direct = scene_from(trajectory, system=system, report=report)
    for scene in (from_file, direct):
        assert scene.verdict.startswith("verdict: jammed (contact stops a crease short)")
        assert scene.verdict_level == "fail"
        assert scene.highlight_hinges.tolist() == [True, True]
        assert set(scene.contact_frames.tolist()) == {1, 2}  # the seam's rims, then the base
    # The file's contact points are the trajectory's, in the FOLD file's unit.
    np.testing.assert_allclose(
        np.sort(from_file.contact_points, axis=0),
        np.sort(direct.contact_points / net.length_scale, axis=0),
        atol=1e-8,
    )
    with pytest.raises(ValueError, match="one dict per sample"):
        net.to_fold(trajectory, extras=extras[:1])


def test_fold_figures_name_the_verdict_and_the_time_to_fold(corner_cube, tmp_path, monkeypatch):
    """`origami-jax fold`'s figures: the angle plot is titled with the verdict, its lines are the
    creases and a folded run marks its time to fold; the frame strip's titles give times without an
    exponent. The command lists what it wrote from the names its figures' `paint` returns."""
    import dataclasses

    import matplotlib.pyplot as plt

    from origami_jax.cli._fold import _figure_job
    from origami_jax.cli._painter import paint
    from origami_jax.simulation import FoldReport, FoldVerdict

    net, system = corner_cube
    theta = np.stack([np.zeros(2), 0.5 * np.array(net.intended_angles), net.intended_angles])
    trajectory = synthetic_trajectory(system, theta, times=[0.0, 700.0, 1400.0])
    folded = FoldReport(
        verdict=FoldVerdict.FOLDED,
        reason="every crease at its angle, every seam closed",
        final_angles=theta[-1],
        intended_angles=np.array(net.intended_angles),
        angle_errors=np.zeros(2),
        seam_gaps=np.zeros(1),
        angle_tolerance=math.radians(3),
        seam_tolerance=2.0,
        time_to_fold=1354.0,
        settled=True,
        contacts=0,
        min_gap=1.0,
        max_penetration=0.0,
        penetration_fraction=0.0,
        result="successful",
    )
    jammed = dataclasses.replace(folded, verdict=FoldVerdict.JAMMED, time_to_fold=None)
    saved, savefig = {}, plt.Figure.savefig

    def keep(fig, path, **kwargs):  # the figures, to read their titles and labels
        saved[str(path)] = fig
        savefig(fig, path, **kwargs)

    monkeypatch.setattr(plt.Figure, "savefig", keep)
    for report in (folded, jammed):
        out = tmp_path / str(report.verdict)
        out.mkdir()
        job = _figure_job(system, trajectory, report, out, "corner_cube", None, animation=False)
        written = paint(job)
        assert written == ["angles.png", "frames.png"]
        assert all((out / name).stat().st_size > 1000 for name in written)
        angles = saved[str(out / "angles.png")].axes[0]
        assert angles.get_title() == f"corner_cube: {report.verdict}"
        assert angles.get_ylabel() == "crease angle [deg]"
        assert [t.get_text() for t in angles.get_legend().get_texts()] == [
            "crease 0",
            "crease 1",
        ]  # as the verdict numbers them
        marked = [t.get_text().strip() for t in angles.texts]
        assert marked == (["folded at 1354 µs"] if report is folded else [])
        titles = [ax.get_title() for ax in saved[str(out / "frames.png")].axes]
        assert titles == ["t = 0 µs", "t = 700 µs", "t = 1400 µs"]


@pytest.mark.slow  # a closed-loop pattern and an arc-hinge net compile their own kinematics
@pytest.mark.parametrize("case", ["loops", "arc"])
def test_every_mechanism_draws_its_hinges(case):
    """Closed loops (tree hinges and cut creases) and arc hinges (the strip starts at the parent's
    edge) get hinge segments on their creases in the flat state, and fold angles plotted."""
    if case == "loops":
        from origami_jax.loops import load_pattern

        system = load_pattern("vertex_degree4").system(contact=False)
    else:
        from origami_jax.net import load_net

        system = load_net("corner_cube").system(hinges="arc", contact=False)
    mechanism = system.mechanism
    scene = view.scene_from_mechanism(system)
    layout = mechanism.hinge_layout()
    assert scene.n_hinges == mechanism.n_hinges == len(layout.parent)
    for h in range(scene.n_hinges):
        ends = scene.vertices[0][scene.hinges[h]]
        # On the crease's line, within its extent.
        direction = layout.ends[h][1] - layout.ends[h][0]
        rel = ends - layout.ends[h][0]
        off = rel - np.outer(rel @ direction, direction) / (direction @ direction)
        assert np.abs(off).max() < GEOMETRY_TOL
    assert "hinge positions unknown" not in " ".join(scene.notes)


# ---------------------------------------------------------------- a real browser


def miura_scene(nx=20, ny=20, frames=500, a=1.0, b=1.0, alpha=math.pi / 3):
    """A Miura-ori of nx × ny parallelograms, each split in two triangles, folding rigidly
    (Schenk and Guest's closed form: heights, offsets and widths of the cell for a fold angle θ)."""
    theta = np.linspace(0.0, np.deg2rad(80), frames)[:, None, None]
    H = a * np.sin(theta) * np.sin(alpha)
    S = b * np.cos(theta) * np.tan(alpha) / np.sqrt(1 + np.cos(theta) ** 2 * np.tan(alpha) ** 2)
    L = a * np.sqrt(1 - np.sin(theta) ** 2 * np.sin(alpha) ** 2)
    V = b / np.sqrt(1 + np.cos(theta) ** 2 * np.tan(alpha) ** 2)
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), indexing="ij")
    x = i * S
    y = j * L + (i % 2) * V
    z = (j % 2) * H * np.ones_like(x)
    grid = np.stack([x, y, z], axis=-1)  # (T, nx+1, ny+1, 3)
    p00, p10 = grid[:, :-1, :-1], grid[:, 1:, :-1]
    p11, p01 = grid[:, 1:, 1:], grid[:, :-1, 1:]
    first = np.stack([p00, p10, p11], axis=3).reshape(frames, -1, 3, 3)
    second = np.stack([p00, p11, p01], axis=3).reshape(frames, -1, 3, 3)
    panels = np.concatenate([first, second], axis=1)  # (T, 2 nx ny, 3, 3)
    n = panels.shape[1]
    return Scene(
        vertices=panels.reshape(frames, -1, 3),
        offsets=np.arange(0, 3 * n + 1, 3),
        times=np.linspace(0, 1, frames),
        hinges=np.zeros((0, 2), np.int64),
        fold_angles=np.zeros((frames, 0)),
        title=f"Miura-ori {nx}×{ny}",
    )


def test_miura_case_is_a_rigid_folding():
    scene = miura_scene(nx=4, ny=4, frames=5)
    lengths = np.linalg.norm(np.diff(scene.vertices.reshape(5, -1, 3, 3), axis=2), axis=-1)
    np.testing.assert_allclose(lengths, lengths[:1].repeat(5, 0), atol=1e-12)
    assert np.ptp(scene.vertices[-1, :, 2]) > 0.5  # it does fold


@pytest.fixture(scope="module")
def browser():
    executable = find_chromium()
    if executable is None:
        pytest.skip(
            "no Chromium on PATH (chromium, chromium-browser or google-chrome): install Debian's "
            "with `apt-get install -y chromium` to run the browser tests"
        )
    if sys.platform != "linux":
        pytest.skip("the DevTools pipe driver is written for Linux")
    with Browser(executable) as chromium:
        yield chromium


def load(browser, url):
    page = browser.open(url)
    page.wait_for("window.__origami && (window.__origami.ready || window.__origami.error)")
    assert page.evaluate("window.__origami.error || null") is None
    return page


def pixel_std(png):
    from PIL import Image

    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)
    return float(image[:, : int(image.shape[1] * 0.6)].std())  # the 3D viewport, left of the panel


def test_page_renders_and_the_slider_moves_the_panels(browser, tmp_path, accordion):
    theta = np.linspace(0, 1, 40)[:, None] * np.array([2.0, -2.0, 2.0])
    path = view.write_html(
        synthetic_trajectory(accordion, theta), tmp_path / "a.html", system=accordion
    )
    page = load(browser, path.as_uri())
    assert page.evaluate("window.__origami.countPanels()") == 4
    assert page.evaluate("window.__origami.nFrames") == 40
    before = page.evaluate("window.__origami.vertexSample(48)")
    std = pixel_std(page.screenshot())
    assert std > 5.0, f"blank screenshot (pixel std {std:.2f})"
    assert page.evaluate("window.__origami.setFrame(39)") == 39
    assert page.evaluate("document.querySelector('.slider').value") == "39"
    after = page.evaluate("window.__origami.vertexSample(48)")
    assert np.max(np.abs(np.subtract(after, before))) > 1.0  # µm: the flaps moved
    # Play runs the animation from the start (30 frames a second at 1x); pause stops it.
    page.evaluate("document.querySelector('.play').click()")
    page.wait_for("window.__origami.frame > 3", timeout=10)
    page.evaluate("document.querySelector('.play').click()")
    stopped = page.evaluate("window.__origami.frame")
    time.sleep(0.3)
    assert page.evaluate("window.__origami.frame") == stopped
    assert page.problems() == []
    remote = [u for u in page.requests() if not u.startswith(("file:", "blob:", "data:"))]
    assert remote == []


def test_notebook_iframe_renders_the_same_view(browser, tmp_path):
    shown = view.show(DATA / "frames.fold")
    host = tmp_path / "notebook.html"
    host.write_text(f"<!DOCTYPE html><html><body>{shown._repr_html_()}</body></html>")
    page = browser.open(host.as_uri())
    page.wait_for(
        "(() => { const w = document.querySelector('iframe').contentWindow;"
        " return w.__origami && (w.__origami.ready || w.__origami.error); })()"
    )
    inner = "document.querySelector('iframe').contentWindow.__origami"
    assert page.evaluate(f"{inner}.countPanels()") == 4
    assert page.problems() == []


@pytest.mark.slow  # a timing on a shared machine: run it alone (-m slow -k screen_rate)
def test_large_pattern_updates_at_screen_rate(browser, tmp_path):
    scene = miura_scene()
    assert scene.n_panels == 800 and scene.n_frames == 500
    path = view.write_html(scene, tmp_path / "miura.html", max_frames=None)
    page = load(browser, path.as_uri())
    assert page.evaluate("window.__origami.countPanels()") == 800
    assert page.evaluate("window.__origami.nFrames") == 500
    timing = page.evaluate("window.__origami.timeUpdates(200)", timeout=120)
    print(
        f"\n800-panel Miura, 500 frames, {'software' if timing['software'] else 'GPU'} WebGL: "
        f"{timing['submitMs']:.2f} ms per frame change on the page's thread (geometry "
        f"{timing['geometryMs']:.2f} ms), {timing['meanMs']:.1f} ms waiting for the rasterizer too"
    )
    # Screen rate is 60 Hz, 16.7 ms a frame. What the page does per frame change (new positions,
    # normals, outlines, hinges; buffer upload; draw calls) must fit; the rasterizer's own time is
    # the machine's (SwiftShader on a shared CPU core here, well under a millisecond on a GPU).
    assert timing["submitMs"] < 16.0
    assert page.problems() == []
