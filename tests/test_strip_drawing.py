"""Nets drawn with their hinge strips (`faces_origami_jax:hinge`): a cube net written as its fillet
layout's panels and strips reads back as the cube net with that layout, its arc system's seams
closing; a flap drawn by hand folds on a strip as long as it is wide (closed form); malformed
strips and a design whose radius the strips are not drawn for are refused in one line."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from origami_jax import fold
from origami_jax.cli import main
from origami_jax.fold import FoldFormatError
from origami_jax.net import HINGE_KEY, fillet_layout, load_net, strip_fold
from origami_jax.net._net import default_design

jax.config.update("jax_enable_x64", True)

# Kinematics and layouts in float64: round-off relative to the panels' size (200 µm), as
# tests/test_arc_layout.py.
GEOMETRY_RTOL = 1e-9


@pytest.fixture(scope="module")
def cube(tmp_path_factory):
    """cube_net_01, its design, its fillet layout, and that layout drawn as a strip file, read."""
    net = load_net("cube_net_01")
    design = default_design(net)
    layout = net.arc_layout(design)
    path = tmp_path_factory.mktemp("strips") / "cube_strips.fold"
    fold.write_fold(path, strip_fold(net, layout))
    return net, design, layout, path, load_net(path)


def _gaps(net, system):
    return np.asarray(net.seam_gap_function(system)(jnp.asarray(net.intended_angles)))


def test_strip_file_marks_one_strip_per_crease_as_wide_as_its_arc(cube):
    """The file holds the 6 panels and 5 strips, marked; each strip's two creases are ``ρπ/2``
    apart (the 90° arc) and fold 45° each; measured on the file's coordinates."""
    net, design, layout, path, _ = cube
    frame = fold.read_fold(path).key_frame
    marks = frame.extra[HINGE_KEY]
    assert marks == [False] * 6 + [True] * 5
    coords = frame.vertices_coords
    rho = float(design.radius())
    for face in frame.faces_vertices[6:]:
        creases = []
        for a, b in zip(face, face[1:] + face[:1], strict=True):
            e = next(
                i for i, (u, v) in enumerate(frame.edges_vertices.tolist()) if {u, v} == {a, b}
            )
            if frame.edges_assignment[e] != "B":
                creases.append((coords[a], coords[b], frame.edges_fold_angle_deg[e]))
        assert len(creases) == 2
        (a0, a1, t0), (b0, _, t1) = creases
        along = (a1 - a0) / np.linalg.norm(a1 - a0)
        rel = b0 - a0
        width = np.linalg.norm(rel - (rel @ along) * along)
        np.testing.assert_allclose(width, rho * np.pi / 2, rtol=GEOMETRY_RTOL)
        np.testing.assert_allclose([t0, t1], [45.0, 45.0], rtol=1e-12)


def test_strip_file_reads_back_as_the_cube_net_and_its_fillet_layout(cube):
    """Read back: the point-crease net is cube_net_01 (faces, targets, seams) and the drawn layout
    is its fillet layout (panels, strip lengths, hinge points, seams' ends), to round-off."""
    net, _, layout, _, back = cube
    size = net.panel_size()
    g, h = net.geometry, back.geometry
    np.testing.assert_allclose(h.face_coords, g.face_coords, rtol=0, atol=GEOMETRY_RTOL * 200.0)
    np.testing.assert_allclose(h.targets, g.targets, rtol=1e-12)
    assert h.root == g.root
    np.testing.assert_array_equal(h.target_seams.faces, g.target_seams.faces)
    drawn = back.drawn_layout
    assert back.default_arc_layout is drawn
    for name in ("lengths", "trims", "shifts", "hinge_points", "seam_points", "face_coords"):
        np.testing.assert_allclose(
            getattr(drawn, name),
            getattr(layout, name),
            rtol=0,
            atol=GEOMETRY_RTOL * size,
            err_msg=name,
        )


@pytest.mark.slow  # ~10 s: two arc systems' kinematics compiled
def test_strip_net_arc_system_is_the_fillet_system_and_closes(cube):
    """Its arc system (the strips as drawn, by default) folds to the targets with every seam
    closed to round-off; its panels (rest frames, outlines, base) and strips (hinge points,
    lengths) are those of cube_net_01's fillet-layout system."""
    net, design, _, _, back = cube
    size = net.panel_size()
    system = back.system(design, hinges="arc", contact=False)
    reference = net.system(design, hinges="arc", contact=False)
    assert np.max(_gaps(back, system)) < GEOMETRY_RTOL * size
    np.testing.assert_allclose(
        system.mechanism.panels.joints.lengths,
        reference.mechanism.panels.joints.lengths,
        rtol=GEOMETRY_RTOL,
    )
    mine, theirs = system.mechanism.panels, reference.mechanism.panels
    for name, x, y in (
        ("frames", mine.frames, theirs.frames),
        ("hinge points", mine.joints.points, theirs.joints.points),
        ("base", mine.base_outline(), theirs.base_outline()),
        *(("outline", a, b) for a, b in zip(mine.outlines(), theirs.outlines(), strict=True)),
    ):
        np.testing.assert_allclose(
            np.asarray(x), np.asarray(y), rtol=0, atol=GEOMETRY_RTOL * size, err_msg=name
        )


def _flap(width, angles=(45.0, 45.0), declared=True, third=False):
    """A 100 µm square base, a strip `width` wide, a 100 µm square flap: hand-drawn FOLD."""
    w = width
    coords = [[0, 0], [100, 0], [100, 100], [0, 100], [100 + w, 0], [100 + w, 100],
              [200 + w, 0], [200 + w, 100]]  # fmt: skip
    edges = [[0, 1], [1, 2], [2, 3], [3, 0], [1, 4], [4, 5], [5, 2], [4, 6], [6, 7], [7, 5]]
    degrees = [0, angles[0], 0, 0, 0, angles[1], 0, 0, 0, 0]
    faces = [[0, 1, 2, 3], [1, 4, 5, 2], [4, 6, 7, 5]]
    marks = [False, declared, False]
    if third:  # a panel below the strip, joined to it across its short side
        coords += [[100, -50], [100 + w, -50]]
        edges += [[8, 9], [9, 4], [1, 8]]
        degrees[4] = 45.0
        degrees += [0, 0, 0]
        faces.append([8, 9, 4, 1])
        marks.append(False)

    def assign(d):
        return "V" if d > 0 else "M" if d < 0 else "B"

    return fold.fold_from_dict(
        {
            "file_spec": 1.2,
            "frame_unit": "um",
            "vertices_coords": coords,
            "edges_vertices": edges,
            "edges_assignment": [assign(d) for d in degrees],
            "edges_foldAngle": degrees,
            "faces_vertices": faces,
            HINGE_KEY: marks,
        }
    )


def test_hand_drawn_flap_folds_on_a_strip_as_long_as_it_is_wide():
    """A flap drawn 120 µm from its base across a strip: one crease of 90°, a strip 120 µm long
    of radius ``ρ = 120/(π/2)``; the point-crease net's panels extended by ``d = ρ`` (tan 45°)
    and its flap brought ``w − 2d`` closer; folded to 90° the flap stands at ``x = 100 + ρ``
    from ``z = ρ`` to ``ρ + 100`` (closed form of a quarter circle)."""
    w = 120.0
    net = load_net(_flap(w), name="flap")
    rho = w / (np.pi / 2)
    assert net.n_creases == 1 and np.degrees(net.intended_angles[0]) == pytest.approx(90.0)
    layout = net.drawn_layout
    np.testing.assert_allclose(layout.lengths, [w], rtol=1e-14)
    np.testing.assert_allclose(layout.radius, [rho], rtol=1e-14)
    g = net.geometry
    xs = [np.ptp(g.face_coords[f][:, 0]) for f in range(2)]
    np.testing.assert_allclose(sorted(xs), [100 + rho, 100 + rho], rtol=1e-12)
    np.testing.assert_allclose(layout.face_coords[1][:, 0], [100 + w, 200 + w, 200 + w, 100 + w])
    design = default_design(net)
    # The literature films bend to another radius: the drawn strip is refused for them...
    with pytest.raises(ValueError, match="drawn for") as refused:
        net.system(design, hinges="arc", contact=False)
    assert "\n" not in str(refused.value)
    # ... and taken with a design drawn for it (same films, the radius the strip says).
    matched = load_net(_flap(float(design.radius()) * np.pi / 2), name="flap")
    rho = float(design.radius())
    w = rho * np.pi / 2
    system = matched.system(design, hinges="arc", contact=False)
    mechanism = system.mechanism
    q = jnp.asarray(matched.intended_angles)
    rest = np.asarray(mechanism.body_poses(jnp.zeros_like(q)))[0]
    pose = np.asarray(mechanism.body_poses(q))[0]
    corners = np.array([[100 + w, 0, 0], [200 + w, 100, 0]])
    world = ((corners - rest[:3, 3]) @ rest[:3, :3]) @ pose[:3, :3].T + pose[:3, 3]
    np.testing.assert_allclose(
        world, [[100 + rho, 0, rho], [100 + rho, 100, rho + 100]], rtol=0, atol=1e-9 * 200
    )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"third": True}, "strip joins exactly two panels"),
        ({"angles": (45.0, -45.0)}, "fold opposite ways"),
        ({"angles": (0.0, 0.0), "declared": 90.0}, None),  # declared angle, no crease angles
        ({"angles": (45.0, -45.0), "declared": 90.0}, "fold opposite ways"),
        ({"angles": (90.0, 90.0)}, "less than 180°"),
    ],
)
def test_malformed_strips_are_refused_in_one_line(kwargs, match):
    """A strip between three panels, creases bending opposite ways (given or against a declared
    angle), or folding by 180° is refused, one line; a declared angle with flat creases reads."""
    if match is None:
        kw = dict(kwargs)
        data = _flap(120.0, **kw).to_dict()
        data["edges_assignment"] = ["F" if a == "B" and i in (1, 5) else a
                                    for i, a in enumerate(data["edges_assignment"])]  # fmt: skip
        net = load_net(fold.fold_from_dict(data), name="flap")
        assert np.degrees(net.intended_angles[0]) == pytest.approx(90.0)
        return
    with pytest.raises(FoldFormatError, match=match) as refused:
        load_net(_flap(120.0, **kwargs), name="flap")
    assert "\n" not in str(refused.value)


def test_strips_that_no_point_crease_net_fillets_are_refused(tmp_path):
    """Equal squares with strips between them (the natural drawing of a cube whose walls would stand
    ``ρ`` apart): the base, extended across its two strips, is wider than either flap; refused
    naming the way out. A crease between panels without a strip is refused too."""
    w = 120.0
    coords = [
        [0, 0],
        [100, 0],
        [100, 100],
        [0, 100],  # base 0-3
        [100 + w, 0],
        [100 + w, 100],
        [200 + w, 0],
        [200 + w, 100],  # right strip, flap
        [0, 100 + w],
        [100, 100 + w],
        [0, 200 + w],
        [100, 200 + w],
    ]  # top strip, flap
    faces = [[0, 1, 2, 3], [1, 4, 5, 2], [4, 6, 7, 5], [3, 2, 9, 8], [8, 9, 11, 10]]
    sides = {tuple(sorted((a, b))) for f in faces for a, b in zip(f, f[1:] + f[:1], strict=True)}
    creases = {(1, 2), (4, 5), (2, 3), (8, 9)}
    edges = sorted(sides)
    data = {
        "frame_unit": "um",
        "vertices_coords": coords,
        "edges_vertices": [list(e) for e in edges],
        "edges_assignment": ["V" if e in creases else "B" for e in edges],
        "edges_foldAngle": [45.0 if e in creases else 0.0 for e in edges],
        "faces_vertices": faces,
        HINGE_KEY: [False, True, False, True, False],
    }
    with pytest.raises(FoldFormatError, match="do not meet along one edge") as refused:
        load_net(fold.fold_from_dict(data), name="squares")
    assert "\n" not in str(refused.value) and "strip_fold" in str(refused.value)
    data[HINGE_KEY] = [False, False, False, True, False]
    with pytest.raises(FoldFormatError, match="without a strip"):
        load_net(fold.fold_from_dict(data), name="squares")


def test_a_design_other_than_the_strips_radius_is_refused(cube):
    """Strips drawn for 1.2 ρ: the arc system of the literature design (ρ) is refused, one line;
    the point-crease system still builds."""
    net, design, _, _, _ = cube
    wide = fillet_layout(
        net.geometry, net.length_scale, 1.2 * float(design.radius()), net.intended_angles
    )
    back = load_net(fold.fold_from_dict(strip_fold(net, wide).to_dict()), name="wide")
    np.testing.assert_allclose(back.drawn_layout.radius, 1.2 * float(design.radius()))
    with pytest.raises(ValueError, match="20 % off") as refused:
        back.system(design, hinges="arc", contact=False)
    assert "\n" not in str(refused.value)
    back.system(design, contact=False)
    assert math.isfinite(float(np.max(back.seam_gaps(back.intended_angles))))


def test_cli_refuses_strips_drawn_for_another_radius(cube, tmp_path, capsys):
    """`origami-jax fold FILE --hinges arc` on strips drawn for 1.2 ρ: exit 2, one line, before
    anything compiles (the run of a well-drawn file is the fold command's own)."""
    net, design, _, _, _ = cube
    wide = fillet_layout(
        net.geometry, net.length_scale, 1.2 * float(design.radius()), net.intended_angles
    )
    path = tmp_path / "wide.fold"
    fold.write_fold(path, strip_fold(net, wide))
    code = main(["fold", str(path), "--hinges", "arc", "--t1", "10", "--no-figures",
                 "--out", str(tmp_path / "out")])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert "20 % off" in err and len(err.splitlines()) == 1
