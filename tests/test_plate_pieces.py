"""Non-convex panels: their convex pieces, and contact that sees their notches.

A panel whose outline is not convex (an L, a notched tab) is several convex plates of one body
(`origami_jax.contact.PlateTables`). Its convex hull would fill the notch: the jigsaw net below, an
L-shaped flap folding round a tab that lands in its notch, was judged jammed 23° short, stopped by
a plate that is not there. Checked against geometry written here: the pieces against the outline's
area and point membership, the contact's gaps against sampled distances to the true L.
"""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from origami_jax.contact import PlateContact
from origami_jax.fold import convex_pieces, loads_fold
from origami_jax.net import load_net

SHAPES = {
    "L": [[0, 2], [2, 2], [2, 3], [1, 3], [1, 4], [0, 4]],
    "T": [[0, 0], [3, 0], [3, 1], [2, 1], [2, 3], [1, 3], [1, 1], [0, 1]],
    "U": [[0, 0], [3, 0], [3, 2], [2, 2], [2, 1], [1, 1], [1, 2], [0, 2]],
    "star": [
        [np.cos(a) * (1.0 if k % 2 == 0 else 0.4), np.sin(a) * (1.0 if k % 2 == 0 else 0.4)]
        for k, a in enumerate(np.linspace(0, 2 * np.pi, 11)[:-1])
    ],
    "L with a straight corner, clockwise": [
        [0, 0],
        [0, 1],
        [0, 2],
        [1, 2],
        [1, 1],
        [2, 1],
        [2, 0],
        [1, 0],
    ],  # fmt: skip
}


def _inside(points, polygon):
    """Whether each point `(k, 2)` is strictly inside a simple polygon (crossing number), written
    here apart from the package's geometry."""
    x, y = points[:, 0][:, None], points[:, 1][:, None]
    a, b = polygon, np.roll(polygon, -1, axis=0)
    straddles = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return np.sum(straddles & (x < at), axis=1) % 2 == 1


@pytest.mark.parametrize("name", SHAPES)
def test_a_non_convex_outline_is_cut_into_convex_pieces_that_tile_it(name):
    outline = np.asarray(SHAPES[name], float)
    pieces, on_outline = convex_pieces(outline)
    assert len(pieces) > 1
    corners = {tuple(p) for p in outline}
    area = 0.0
    for piece, edges in zip(pieces, on_outline, strict=True):
        nxt = np.roll(piece, -1, axis=0)
        u, w = nxt - piece, np.roll(nxt, -1, axis=0) - nxt
        turns = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
        assert np.all(turns > 0), "a piece is convex and counter-clockwise"
        assert {tuple(p) for p in piece} <= corners, "pieces are cut between the outline's corners"
        area += 0.5 * np.sum(piece[:, 0] * nxt[:, 1] - piece[:, 1] * nxt[:, 0])
        # An edge on the outline has the outline's interior on one side only.
        mid = 0.5 * (piece + nxt)
        normal = np.stack([nxt[:, 1] - piece[:, 1], piece[:, 0] - nxt[:, 0]], axis=1) * 1e-6
        across = _inside(mid + normal, outline)
        np.testing.assert_array_equal(edges, ~across)
    x, y = outline[:, 0], outline[:, 1]
    assert area == pytest.approx(0.5 * abs(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))
    # Every point of the outline's interior lies in exactly one piece, and no other point in any.
    rng = np.random.default_rng(0)
    lo, hi = outline.min(axis=0), outline.max(axis=0)
    points = lo + (hi - lo) * rng.random((4000, 2))
    count = sum(_inside(points, piece).astype(int) for piece in pieces)
    np.testing.assert_array_equal(count, _inside(points, outline).astype(int))


def test_rectilinear_outlines_come_out_in_their_fewest_pieces():
    """An L and a T are two rectangles' worth of pieces, a U three (the fewest convex pieces):
    the decomposition tries the triangulations from several corners."""
    counts = {name: len(convex_pieces(np.asarray(SHAPES[name], float))[0]) for name in "LTU"}
    assert counts == {"L": 2, "T": 2, "U": 3}


def test_a_convex_outline_is_one_piece_its_hull():
    square = np.asarray([[0, 0], [1, 0], [1, 0.5], [1, 1], [0, 1]], float)
    pieces, on_outline = convex_pieces(square[::-1])
    assert len(pieces) == 1 and on_outline[0].all()
    np.testing.assert_array_equal(pieces[0], [[0, 0], [1, 0], [1, 1], [0, 1]])


def test_a_crossing_outline_is_refused():
    with pytest.raises(ValueError, match="edges cross"):
        convex_pieces(np.asarray([[0, 0], [2, 0], [2, 2], [1, -1], [0, 2]], float))


def _jigsaw(tab_angle=175.0, l_angle=175.0):
    """A 200 µm square base; a tab (90 × 90 µm, hinged on the base's right edge) that folds over onto
    the base; an L-shaped flap (hinged on the base's top edge) that folds over onto the base with
    its notch (100 × 100 µm) landing round the tab, 5–10 µm clear of it on every side."""
    s = 100.0
    vertices = [[0, 0], [2, 0], [2, 0.05], [2, 0.95], [2, 2], [0, 2]]  # the base
    vertices += [[2.9, 0.05], [2.9, 0.95]]  # the tab
    vertices += [[2, 3], [1, 3], [1, 4], [0, 4]]  # the L
    faces = [[0, 1, 2, 3, 4, 5], [2, 6, 7, 3], [5, 4, 8, 9, 10, 11]]
    edges = [[0, 1], [1, 2], [2, 3], [3, 4], [4, 5], [5, 0], [2, 6], [6, 7], [7, 3]]
    edges += [[4, 8], [8, 9], [9, 10], [10, 11], [11, 5]]
    assignment = ["B"] * len(edges)
    angles = [0.0] * len(edges)
    assignment[2], angles[2] = "V", tab_angle
    assignment[4], angles[4] = "V", l_angle
    fold = {
        "file_spec": 1.1,
        "frame_classes": ["creasePattern"],
        "frame_unit": "um",
        "vertices_coords": [[s * x, s * y] for x, y in vertices],
        "faces_vertices": faces,
        "edges_vertices": edges,
        "edges_assignment": assignment,
        "edges_foldAngle": angles,
    }
    return load_net(loads_fold(json.dumps(fold)), name="jigsaw")


@pytest.fixture(scope="module")
def jigsaw():
    jax.config.update("jax_enable_x64", True)
    net = _jigsaw()
    system = net.system()
    return net, system


def _least_distance(a, b):
    """The least distance between two point clouds `(k, 3)` and `(m, 3)`."""
    return min(float(np.min(np.linalg.norm(a[:, None] - part[None], axis=-1))) for part in
               np.array_split(b, max(1, len(b) // 500)))  # fmt: skip


def _flat_grid(x0, x1, y0, y1, spacing, keep=None):
    """Points of the flat net's rectangle ``[x0, x1] × [y0, y1]`` (µm) about `spacing` apart,
    those `keep` accepts."""
    nx, ny = int(np.ceil((x1 - x0) / spacing)) + 1, int(np.ceil((y1 - y0) / spacing)) + 1
    x, y = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
    points = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    return points if keep is None else points[keep(points)]


def _moved(mechanism, body, q, flat_points):
    """`flat_points` of a body's panel in the flat net, where they are at ``q`` (the body's pose at
    ``q`` after its inverse rest pose)."""
    rest = np.asarray(mechanism.body_poses(jnp.zeros_like(q))[body])
    pose = np.asarray(mechanism.body_poses(q)[body])
    motion = pose @ np.linalg.inv(rest)
    return flat_points @ motion[:3, :3].T + motion[:3, 3]


def test_the_l_flap_is_two_plates_of_one_body(jigsaw):
    net, system = jigsaw
    tables = system.contact.tables
    assert isinstance(system.contact, PlateContact)
    np.testing.assert_array_equal(tables.bodies_of_plates, [0, 1, 1, 2])  # tab, L (2), base
    assert tables.n_all == 3
    # No pair between the L's own plates, and each of its corners counted once against the tab.
    body = tables.bodies_of_plates
    for a, _, b in tables.vertex_face:
        assert body[a] != body[b]
    l_against_tab = {
        tuple(np.round(tables.vertices[a, i, :2], 6))
        for a, i, b in tables.vertex_face
        if body[a] == 1 and body[b] == 0
    }
    count = sum(1 for a, _, b in tables.vertex_face if body[a] == 1 and body[b] == 0)
    assert count == len(l_against_tab)
    # A convex net keeps one plate per body.
    assert load_net("cube_net_01").plate_tables().plate_body is None


@pytest.mark.parametrize("tab_angle", [150.0, 160.0, 168.0])
def test_a_tab_passes_into_the_notch_that_its_convex_hull_would_fill(jigsaw, tab_angle):
    """The L lying at 175° over the base, the tab on its way in through the notch: the least gap
    between the two panels is the distance between the tab and the true L (sampled here on grids of
    both in the flat net, moved by the bodies' poses: within the grids' spacing), with no overlap;
    the L's convex hull, whose corner fills half the notch, would cross the tab."""
    net, system = jigsaw
    contact, mechanism = system.contact, system.mechanism
    q = jnp.deg2rad(jnp.asarray([tab_angle, 175.0]))
    report = contact.report(mechanism, q)
    assert float(report["penetration"]) == 0.0
    assert not bool(report["touching"][0, 1])

    spacing = 2.0
    tab = _moved(mechanism, 0, q, _flat_grid(200, 290, 5, 95, spacing))
    l_flap = _moved(
        mechanism,
        1,
        q,
        np.concatenate(
            [_flat_grid(0, 200, 200, 300, spacing), _flat_grid(0, 100, 300, 400, spacing)]
        ),
    )
    phantom = _moved(
        mechanism,
        1,
        q,
        _flat_grid(100, 200, 300, 400, spacing, keep=lambda p: p[:, 0] + p[:, 1] <= 500 - 1e-9),
    )
    half = np.asarray(contact.half_thickness)
    expected = _least_distance(tab, l_flap) - half[0] - half[1]
    x = contact.vertices(mechanism, q)
    gap, _ = contact._gaps(x)
    body = contact.tables.bodies_of_plates
    first = np.concatenate([contact.tables.vertex_face[:, 0], contact.tables.edge_edge[:, 0]])
    second = np.concatenate([contact.tables.vertex_face[:, 2], contact.tables.edge_edge[:, 3]])
    tab_l = ((body[first] == 0) & (body[second] == 1)) | ((body[first] == 1) & (body[second] == 0))
    least = float(jnp.min(gap[tab_l]))
    assert expected - np.sqrt(2) * spacing <= least <= expected + 1e-9
    assert least > 1.1 * float(contact.activation)
    # The hull's corner: within the tab's plate (the sampled distance below the thicknesses).
    assert _least_distance(tab, phantom) < half[0] + half[1] + np.sqrt(2) * spacing


def test_adhesion_samples_the_panels_not_their_hulls(jigsaw):
    """Adhesion's quadrature points cover each panel's own area (the L's 3 × 10⁴ µm², not its hull's
    3.5 × 10⁴), none in the notch, and pair no point with a plate of its own panel."""
    from origami_jax.contact import Adhesion

    net, system = jigsaw
    contact = system.contact.with_surface(
        system.mechanism, adhesion=Adhesion(work=1e-3, range=0.6, line=0.0)
    )
    surface, tables = contact.surface, contact.tables
    body = tables.bodies_of_plates[surface.point_body]
    area = np.bincount(body, weights=surface.point_area, minlength=3)
    np.testing.assert_allclose(area, [90 * 90, 3e4, 4e4], rtol=1e-12)
    q = jnp.zeros(2)
    x = np.asarray(contact.vertices(system.mechanism, q)).reshape(-1, 3)
    points = surface.point_weights @ x
    on_l = points[body == 1]  # in the flat net, where the world frame is the file's
    in_notch = (on_l[:, 0] > 100 + 1e-9) & (on_l[:, 1] > 300 + 1e-9)
    assert not np.any(in_notch)
    point, other = surface.face_pairs.T
    assert np.all(body[point] != tables.bodies_of_plates[other])


@pytest.mark.parametrize("lift", [False, True])
def test_the_drag_quadrature_integrates_a_u_shaped_panel_over_itself(lift):
    """`polygon_quadrature` of a U (its notch deep enough that a fan from its vertex mean covers
    the notch): area, first and second moments against the three rectangles it is made of, every
    point inside it, every weight positive; in the plane or tilted in space."""
    from origami_jax.fluid import polygon_quadrature

    u_shape = np.asarray(
        [[0, 0], [3, 0], [3, 2], [2, 2], [2, 0.5], [1, 0.5], [1, 2], [0, 2]], float
    )
    rectangles = [(0, 3, 0, 0.5), (0, 1, 0.5, 2), (2, 3, 0.5, 2)]  # x0, x1, y0, y1
    area = sum((x1 - x0) * (y1 - y0) for x0, x1, y0, y1 in rectangles)
    mx = sum((x1**2 - x0**2) / 2 * (y1 - y0) for x0, x1, y0, y1 in rectangles)
    myy = sum((x1 - x0) * (y1**3 - y0**3) / 3 for x0, x1, y0, y1 in rectangles)
    mxy = sum((x1**2 - x0**2) / 2 * (y1**2 - y0**2) / 2 for x0, x1, y0, y1 in rectangles)
    polygon = u_shape
    if lift:  # the same U tilted in space
        c, s = np.cos(0.7), np.sin(0.7)
        rotation = np.asarray([[1, 0, 0], [0, c, -s], [0, s, c]])
        polygon = np.c_[u_shape, np.zeros(len(u_shape))] @ rotation.T + [5.0, -2.0, 1.0]
    points, weights = polygon_quadrature(polygon, 2)
    if lift:
        points = (points - [5.0, -2.0, 1.0]) @ rotation
        np.testing.assert_allclose(points[:, 2], 0.0, atol=1e-12)
    x, y = points[:, 0], points[:, 1]
    assert np.all(weights > 0)
    assert np.all(_inside(points[:, :2], u_shape) | (weights == 0))
    np.testing.assert_allclose(
        [weights.sum(), weights @ x, weights @ y**2, weights @ (x * y)],
        [area, mx, myy, mxy],
        rtol=1e-12,
    )


def test_the_sampled_contact_refuses_a_panel_that_is_not_convex(jigsaw):
    """`contact="sampled"` takes each face as its convex hull: a notched panel is refused with the
    way out, not folded against a notch it has filled."""
    net, _ = jigsaw
    with pytest.raises(ValueError, match="panel 1 is not convex.*contact='plate'"):
        net.system(contact="sampled")
    # Without contact the verdict's scale (the largest panel, 200 µm) needs no contact model.
    assert net.panel_size() == pytest.approx(200.0, rel=1e-12)


@pytest.mark.parametrize("angles", [(170.0, 179.75), (179.8, 179.7), (179.85, 179.6)])
def test_the_contact_force_of_a_split_panel_is_its_energys_gradient(jigsaw, angles):
    """With the L's two plates engaged on the base (and the tab), the generalized contact force at
    rest is ``−∂E/∂q`` of the barrier energy (reverse-mode derivative of `potential`): the plates'
    wrenches are summed onto their body. The forces are of order 1e7 here; agreement to 1e-10
    relative is rounding."""
    net, system = jigsaw
    contact, mechanism = system.contact, system.mechanism
    q = jnp.deg2rad(jnp.asarray(angles))
    report = contact.report(mechanism, q)
    assert int(report["engaged"]) > 0 and bool(report["touching"][1, 2])
    force = contact.force(mechanism, q, jnp.zeros(2))
    gradient = -jax.grad(lambda q: contact.potential(mechanism, q))(q)
    assert float(jnp.max(jnp.abs(force))) > 0
    np.testing.assert_allclose(
        force, gradient, rtol=1e-10, atol=1e-10 * float(jnp.max(jnp.abs(force)))
    )
