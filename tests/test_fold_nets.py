"""Nets of rigid panels read from FOLD crease patterns (`net_geometry`) and the shipped catalogue.

References, all independent of `NetGeometry.fold`:
- the signed dihedral angles of a folded mesh (`fold_angles_from_coords`, Newell normals);
- closed forms: a hinged square's centroid, the accordion's planar chain (angles add up), radii of
  gyration of the accordion and the tetrahedron net;
- the polyhedra's own geometry: a cube's six axis normals, the Gram matrices of the tetrahedron's
  and octahedron's face normals, a cube's 12 edges and 8 corners (the cut tree's leaves give the
  vertex connections);
- the eleven cube nets: a die rolled over the hexomino (the generator) against rigid folding of
  all 35 hexominoes (here), and their symmetry classes computed here with integer matrices;
- the eleven octahedron nets: spanning trees of the face graph unfolded (the generator) against
  rigid folding of all 66 octiamonds (here), and their congruence classes from the sorted
  distances between face centres (here);
- `chain_geometry` for the accordion's hinge axes and offsets.

Tolerances: positions come out of a few 3×3 rotations composed in float64, so closure and rigidity
errors are ~1e-13 µm on 200 µm panels; the tests ask for 1e-9 × the edge (the brief's bound), far
above rounding and far below any real gap (an 80° fold leaves seams ~50 µm open).
"""

import dataclasses
import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from origami_jax.fold import (
    FoldFile,
    FoldFormatError,
    catalogue_names,
    catalogue_path,
    chain_geometry,
    fold_angles_from_coords,
    fold_from_dict,
    net_geometry,
    read_fold,
)
from origami_jax.fold._catalogue import (
    _cube_net,
    _octahedron_net,
    build_catalogue,
    free_polyominoes,
    octahedron_spanning_trees,
    unfold_octahedron,
)
from origami_jax.fold._catalogue_loops import VERBATIM, loop_patterns

DATA = Path(__file__).parent / "data" / "fold"
EDGE = 200.0  # µm, every catalogue edge
GAP_TOL = 1e-9 * EDGE
RIGID_TOL = 1e-9 * EDGE
ANGLE_TOL = 1e-9  # rad, dihedral angles measured on the folded mesh
LOOP_NAMES = tuple(
    sorted(loop_patterns())
)  # crease patterns with closed loops: tests/test_loops.py
NAMES = tuple(n for n in catalogue_names() if n not in LOOP_NAMES)  # the nets
CUBE_NETS = [n for n in NAMES if n.startswith("cube_net_")]
OCTAHEDRON_NETS = [n for n in NAMES if n.startswith("octahedron")]  # the eleven and `octahedron`
CLOSED = [n for n in NAMES if n != "accordion"]  # nets whose seams close into a polyhedron corner
# Seams of a closed polyhedron net: the polyhedron's edges that are not creases.
SEAMS = {"accordion": 0, "corner_cube": 1, "tetrahedron": 6 - 3, "octahedron": 12 - 7}
SEAMS.update({n: 12 - 5 for n in CUBE_NETS})
SEAMS.update({n: 12 - 7 for n in OCTAHEDRON_NETS})


@pytest.fixture(scope="module")
def nets():
    return {name: net_geometry(catalogue_path(name)) for name in NAMES}


def vertex_positions(net, positions):
    """One position per FOLD vertex from the faces' corners, and the largest spread between the
    copies of a vertex carried by different faces (0 when the faces agree where they meet)."""
    out = np.full((len(net.vertices_coords), 3), np.nan)
    spread = 0.0
    for f, face in enumerate(net.faces):
        for k, v in enumerate(face):
            if np.isnan(out[v, 0]):
                out[v] = positions[f, k]
            spread = max(spread, float(np.linalg.norm(out[v] - positions[f, k])))
    return out, spread


def edges_of(name):
    return read_fold(catalogue_path(name)).key_frame.edges_vertices


# --- the catalogue ---------------------------------------------------------------------------


def test_catalogue_names_and_paths():
    expected = {"accordion", "corner_cube", "tetrahedron", "octahedron"}
    expected |= {f"cube_net_{i:02d}" for i in range(1, 12)}
    expected |= {f"octahedron_net_{i:02d}" for i in range(1, 12)}
    assert set(NAMES) == expected and list(NAMES) == sorted(NAMES)
    assert set(catalogue_names()) == expected | set(LOOP_NAMES)
    assert list(catalogue_names()) == sorted(catalogue_names())
    assert catalogue_path("corner_cube") == catalogue_path("corner_cube.fold")
    assert catalogue_path("corner_cube").is_file()
    with pytest.raises(ValueError, match="no catalogue net named 'cube'.*accordion, corner_cube"):
        catalogue_path("cube")


def test_shipped_files_are_what_the_generator_writes():
    built = build_catalogue()
    assert set(built) == set(catalogue_names())
    for name, fold in built.items():
        shipped = read_fold(catalogue_path(name))
        # Patterns whose fold angles close their loops are solved numerically (Gauss–Newton with
        # LAPACK's least squares): the last digits differ between CPUs and BLAS builds (1e-9° seen),
        # so the angles are compared to 1e-6° (2e-8 rad) and everything else exactly.
        shipped_frames, built_frames = shipped.frames, fold.frames
        assert len(shipped_frames) == len(built_frames), name
        for a, b in zip(shipped_frames, built_frames, strict=True):
            np.testing.assert_allclose(
                np.asarray(a.edges_fold_angle_deg, dtype=float),
                np.asarray(b.edges_fold_angle_deg, dtype=float),
                rtol=0,
                atol=1e-6,
                err_msg=name,
            )
        same_angles = [
            dataclasses.replace(b, edges_fold_angle_deg=a.edges_fold_angle_deg)
            for a, b in zip(shipped_frames, built_frames, strict=True)
        ]
        assert shipped == dataclasses.replace(fold, frames=tuple(same_angles)), name
    for name, text in VERBATIM.items():
        assert catalogue_path(name).read_text() == text(), name


@pytest.mark.parametrize("name", NAMES)
def test_catalogue_file_conventions(name):
    fold = read_fold(catalogue_path(name))
    key = fold.key_frame
    assert fold.file_metadata["file_title"] and key.extra["frame_title"]
    assert key.frame_unit == "um"
    assert key.faces_vertices is not None and key.edges_fold_angle_deg is not None
    xy = key.vertices_coords
    lengths = np.linalg.norm(xy[key.edges_vertices[:, 0]] - xy[key.edges_vertices[:, 1]], axis=1)
    np.testing.assert_allclose(lengths, EDGE, rtol=1e-12)
    creases = np.array([a != "B" for a in key.edges_assignment])
    assert np.all(key.edges_fold_angle_deg[~creases] == 0)
    assert np.all(key.edges_fold_angle_deg[creases] != 0)


def test_catalogue_targets_in_degrees():
    def crease_angles(name):
        key = read_fold(catalogue_path(name)).key_frame
        return sorted(
            a
            for a, s in zip(key.edges_fold_angle_deg, key.edges_assignment, strict=True)
            if s != "B"
        )

    assert crease_angles("accordion") == [-180, 180, 180]
    assert crease_angles("corner_cube") == [90, 90]
    for name in CUBE_NETS:
        assert crease_angles(name) == [90] * 5
    # 180° minus the dihedral angles arccos(1/3) (tetrahedron) and arccos(-1/3) (octahedron).
    np.testing.assert_allclose(crease_angles("tetrahedron"), [109.47122063449069] * 3, rtol=1e-15)
    for name in OCTAHEDRON_NETS:
        np.testing.assert_allclose(crease_angles(name), [70.52877936550931] * 7, rtol=1e-15)


# --- trees and rigid folding -----------------------------------------------------------------


@pytest.mark.parametrize("name", NAMES)
def test_catalogue_net_is_a_tree(nets, name):
    net = nets[name]
    n = net.n_faces
    assert net.n_creases == n - 1
    assert net.root == 0  # all faces equal: the lowest index wins
    assert net.order[0] == net.root and net.parents[net.root] == -1
    assert sorted(net.order.tolist()) == list(range(n))
    position = {f: i for i, f in enumerate(net.order.tolist())}
    for f in range(n):
        if f != net.root:
            assert position[net.parents[f]] < position[f]  # parents first
    lam = net.body_parents
    assert lam[0] == -1 and all(0 <= lam[i] < i for i in range(1, n))
    np.testing.assert_array_equal(net.crease_child, net.order[1:])
    edges = edges_of(name)
    for j, (child, parent) in enumerate(zip(net.crease_child, net.crease_parent, strict=True)):
        (e,) = net.crease_edges[j]
        u, v = edges[e]
        assert {u, v} <= set(net.faces[child]) and {u, v} <= set(net.faces[parent])
        along = net.vertices_coords[v] - net.vertices_coords[u]
        assert abs(abs(net.hinge_axes[j] @ along) - EDGE) < 1e-9
        assert net.crease_lengths[j] == pytest.approx(EDGE)


@pytest.mark.parametrize("name", NAMES)
def test_fold_is_rigid_and_gives_the_fold_angles(nets, name):
    net = nets[name]
    # 0.99 × targets: away from ±180°, where a dihedral angle's sign is ambiguous.
    angles = 0.99 * net.targets
    positions = net.fold(angles)
    for f, face in enumerate(net.faces):
        flat = net.face_coords[f, : len(face)]
        folded = positions[f, : len(face)]
        d_flat = np.linalg.norm(flat[:, None] - flat[None], axis=-1)
        d_folded = np.linalg.norm(folded[:, None] - folded[None], axis=-1)
        assert np.max(np.abs(d_flat - d_folded)) < RIGID_TOL
    coords, spread = vertex_positions(net, positions)
    assert spread < RIGID_TOL  # faces meeting at a vertex carry it to the same place
    measured = fold_angles_from_coords(coords, net.faces, edges_of(name))
    for j, (e,) in enumerate(net.crease_edges):
        assert measured[e] == pytest.approx(angles[j], abs=ANGLE_TOL)
    np.testing.assert_allclose(net.fold(np.zeros(net.n_creases)), net.face_coords, atol=0)


@pytest.mark.parametrize("name", NAMES)
def test_folded_to_targets_every_seam_closes(nets, name):
    net = nets[name]
    seams = net.target_seams
    assert len(seams) == SEAMS[name]
    if len(seams):
        assert net.seam_gaps(net.fold(net.targets)).max() < GAP_TOL
    if name in CLOSED and name != "corner_cube":
        # A closed polyhedron: every boundary side is in exactly one seam.
        sides = {(int(f), int(e)) for f, e in zip(*net.boundary_sides[:, [0, 2]].T, strict=True)}
        in_seams = [
            (int(f), int(e))
            for s in range(len(seams))
            for f, e in zip(seams.faces[s], seams.edges[s], strict=True)
        ]
        assert sorted(in_seams) == sorted(sides)


@pytest.mark.parametrize("name", CLOSED)
def test_short_of_the_targets_the_seams_stay_open(nets, name):
    net = nets[name]
    gaps = net.seam_gaps(net.fold(net.targets * 8 / 9))  # 80° for the cube nets
    assert gaps.min() > 0.1 * EDGE


@pytest.mark.parametrize("name", CLOSED)
def test_folded_faces_do_not_overlap(nets, name):
    net = nets[name]
    assert net.face_overlaps(net.fold(net.targets)) == []
    assert net.face_overlaps() == []  # nor in the flat pattern


def test_overlap_detection_is_not_vacuous(nets):
    # Corner cube at 135°: both walls lean over the base and cross along x = y = z.
    net = nets["corner_cube"]
    assert net.face_overlaps(net.fold(np.full(2, np.deg2rad(135.0)))) == [(1, 2)]
    # Accordion at ±180°: the four flaps are stacked flat on the base's footprint.
    acc = nets["accordion"]
    folded = acc.fold(acc.targets)
    assert acc.face_overlaps(folded) == list(itertools.combinations(range(4), 2))
    for f in range(4):
        assert {tuple(np.round(p, 9)) for p in folded[f]} == {
            tuple(np.round(p, 9)) for p in acc.face_coords[0]
        }
    assert acc.face_overlaps(acc.fold(0.99 * acc.targets)) == []


@pytest.mark.parametrize("name", CUBE_NETS)
def test_cube_nets_fold_to_a_cube(nets, name):
    net = nets[name]
    normals = net.normals(net.targets)
    axes = np.rint(normals)
    np.testing.assert_allclose(normals, axes, atol=1e-12)
    assert np.all(np.abs(axes).sum(axis=1) == 1)  # each one of ±x, ±y, ±z
    assert len({tuple(a) for a in axes}) == 6  # all distinct
    corners = np.round(net.fold(net.targets).reshape(-1, 3) / EDGE, 9)
    unique = np.unique(corners, axis=0)
    assert len(unique) == 8
    np.testing.assert_allclose(np.ptp(unique, axis=0), 1.0)


@pytest.mark.parametrize(
    ("name", "values"),
    [("tetrahedron", (-1 / 3,))] + [(n, (-1, -1 / 3, 1 / 3)) for n in OCTAHEDRON_NETS],
)
def test_triangle_nets_fold_to_their_polyhedron(nets, name, values):
    net = nets[name]
    normals = net.normals(net.targets)
    gram = normals @ normals.T
    off = gram[~np.eye(len(gram), dtype=bool)]
    assert np.all(np.min(np.abs(off[:, None] - np.array(values)), axis=1) < 1e-12)
    assert np.allclose(np.diag(gram), 1)
    if name.startswith("octahedron"):  # every face has exactly one antipodal face
        assert np.all(np.sum(np.isclose(gram, -1), axis=1) == 1)
        # The regular octahedron: its 6 corners at ±(edge/√2) along three perpendicular axes
        # about the centre, every corner of the folded net on one of them.
        # (Corners rounded to 1e-6 µm to merge the faces' copies: 1e-7 relative tolerances.)
        corners = np.unique(np.round(net.fold(net.targets).reshape(-1, 3), 6), axis=0)
        assert len(corners) == 6
        centred = corners - corners.mean(axis=0)
        np.testing.assert_allclose(np.linalg.norm(centred, axis=1), EDGE / np.sqrt(2), rtol=1e-7)
        gram = centred @ centred.T / (EDGE**2 / 2)
        assert np.all(np.min(np.abs(gram[..., None] - np.array([-1, 0, 1])), axis=-1) < 1e-7)


def test_the_eleven_cube_nets_are_distinct_hexominoes(nets):
    assert len(CUBE_NETS) == 11

    def canonical(cells):
        cells = np.array(cells)
        forms = []  # the 8 symmetries of the square: diag(a, b) and antidiag(a, b), a, b = ±1
        for a, b in itertools.product((1, -1), repeat=2):
            for m in (np.array([[a, 0], [0, b]]), np.array([[0, a], [b, 0]])):
                image = cells @ m.T
                image = image - image.min(axis=0)
                forms.append(tuple(sorted(map(tuple, image.tolist()))))
        return min(forms)

    shapes = []
    for name in CUBE_NETS:
        cells = np.rint(nets[name].face_centroids[:, :2] / EDGE - 0.5).astype(int)
        np.testing.assert_allclose(nets[name].face_centroids[:, :2], (cells + 0.5) * EDGE)
        shapes.append(canonical(cells))
    assert len(set(shapes)) == 11


def test_exactly_eleven_hexominoes_fold_into_a_cube(nets):
    # Polyomino counts (OEIS A000105): the enumeration the generator relies on.
    assert [len(free_polyominoes(n)) for n in range(1, 7)] == [1, 1, 2, 5, 12, 35]
    folding = set()
    for cells in free_polyominoes(6):
        try:
            net = net_geometry(_cube_net(0, cells))
        except FoldFormatError as error:
            assert "closed-loop engine" in str(error)  # a 2 × 2 block of squares
            continue
        folded = net.fold(net.targets)
        normals = {tuple(np.rint(n)) for n in net.normals(net.targets)}
        if len(normals) == 6 and not net.face_overlaps(folded):
            folding.add(cells)
    shipped = {
        tuple(
            sorted(
                map(tuple, np.rint(nets[n].face_centroids[:, :2] / EDGE - 0.5).astype(int).tolist())
            )
        )
        for n in CUBE_NETS
    }
    assert len(folding) == 11 and folding == shipped


# The triangular lattice's 12 symmetries on lattice coordinates (p, q) ↦ p·a + q·b, a = (1, 0),
# b = (1/2, √3/2): 60° turns (a → b, b → b − a) and the mirror about the x axis (b → a − b).
TURN = np.array([[0, -1], [1, 1]])
MIRROR = np.array([[1, 1], [0, -1]])
LATTICE_SYMMETRIES = [
    np.linalg.matrix_power(TURN, k) @ m for k in range(6) for m in (np.eye(2, dtype=int), MIRROR)
]


def lattice_form(triangles):
    """The smallest image of triangles (each a (3, 2) int array of lattice corners) under the
    lattice's symmetries, translated to p, q >= 0: equal for congruent polyiamonds."""
    corners = np.asarray(triangles)  # (n, 3, 2)
    forms = []
    for g in LATTICE_SYMMETRIES:
        image = corners @ g.T
        image = image - image.reshape(-1, 2).min(axis=0)
        forms.append(tuple(sorted(tuple(sorted(map(tuple, t.tolist()))) for t in image)))
    return min(forms)


def lattice_triangles(net):
    """A flat triangle net's faces as lattice corners (`EDGE` edges): q = y / (EDGE √3/2),
    p = x / EDGE − q / 2, checked to be whole numbers."""
    xy = net.face_coords[:, :3, :2]
    q = xy[..., 1] / (EDGE * np.sqrt(3) / 2)
    p = xy[..., 0] / EDGE - q / 2
    lattice = np.rint(np.stack([p, q], axis=-1)).astype(int)
    np.testing.assert_allclose(np.stack([p, q], axis=-1), lattice, atol=1e-9)
    return lattice


def free_octiamonds():
    """Polyiamonds of 8 triangles up to congruence, as corner arrays, grown a triangle at a
    time; a triangle is `(i, j, up)`: up (i, j), (i+1, j), (i, j+1); down (i+1, j), (i+1, j+1),
    (i, j+1)."""

    def corners(i, j, up):
        return [(i, j), (i + 1, j), (i, j + 1)] if up else [(i + 1, j), (i + 1, j + 1), (i, j + 1)]

    def neighbours(i, j, up):
        if up:
            return [(i, j, False), (i, j - 1, False), (i - 1, j, False)]
        return [(i, j, True), (i + 1, j, True), (i, j + 1, True)]

    def cells_of(form):  # back from corners to cells (i = min p, j = min q)
        out = []
        for t in form:
            i, j = min(p for p, _ in t), min(q for _, q in t)
            out.append((i, j, sum(p + q for p, q in t) == 3 * (i + j) + 2))
        return out

    shapes = {lattice_form([corners(0, 0, True)])}
    counts = [1]
    for _ in range(7):
        grown = set()
        for form in shapes:
            cells = cells_of(form)
            for cell in cells:
                for other in neighbours(*cell):
                    if other not in cells:
                        grown.add(lattice_form([corners(*c) for c in [*cells, other]]))
        shapes = grown
        counts.append(len(shapes))
    return counts, [cells_of(form) for form in sorted(shapes)]


def test_exactly_eleven_octiamonds_fold_into_an_octahedron(nets):
    counts, octiamonds = free_octiamonds()
    assert counts == [1, 1, 1, 3, 4, 12, 24, 66]  # polyiamond counts (OEIS A000577)
    folding = set()
    for cells in octiamonds:
        try:
            net = net_geometry(_octahedron_net(0, cells))
        except FoldFormatError as error:
            assert "closed-loop engine" in str(error)  # six triangles round a lattice point
            continue
        normals = net.normals(net.targets)
        distinct = len(np.unique(np.round(normals, 9), axis=0))
        if distinct == 8 and not net.face_overlaps(net.fold(net.targets)):
            folding.add(lattice_form(lattice_triangles(net)))
    shipped = {lattice_form(lattice_triangles(nets[n])) for n in OCTAHEDRON_NETS}
    assert len(folding) == 11 and folding == shipped
    for name in OCTAHEDRON_NETS:
        assert nets[name].n_faces == 8 and nets[name].n_creases == 7


def test_the_eleven_octahedron_nets_are_distinct(nets):
    # Congruent nets have the same sorted distances between their face centres: 11 different
    # lists are 11 different nets, whatever the lattice bookkeeping above says.
    numbered = [n for n in OCTAHEDRON_NETS if n != "octahedron"]
    assert numbered == [f"octahedron_net_{i:02d}" for i in range(1, 12)]

    def distances(name):
        c = nets[name].face_centroids
        d = np.linalg.norm(c[:, None] - c[None], axis=-1)[np.triu_indices(len(c), 1)]
        return tuple(np.round(np.sort(d) / EDGE, 6))

    assert len({distances(n) for n in numbered}) == 11
    # The first-drawn `octahedron` is octahedron_net_06, moved and with its faces renumbered.
    assert [distances(n) == distances("octahedron") for n in numbered].index(True) == 5
    assert lattice_form(lattice_triangles(nets["octahedron"])) == lattice_form(
        lattice_triangles(nets["octahedron_net_06"])
    )


def test_the_generator_unfolds_every_spanning_tree():
    # Kirchhoff: the cube graph (the octahedron's faces, adjacent when they share an edge) has
    # det(reduced Laplacian) = 384 spanning trees.
    signs = np.array(list(itertools.product((1, -1), repeat=3)))
    adjacency = (np.abs(signs[:, None] - signs[None]).sum(axis=-1) == 2).astype(float)
    laplacian = np.diag(adjacency.sum(axis=1)) - adjacency
    assert round(np.linalg.det(laplacian[1:, 1:])) == 384
    trees = octahedron_spanning_trees()
    assert len(trees) == 384 == len({frozenset(t) for t in trees})
    forms = set()
    for tree in trees:
        triangles = unfold_octahedron(tree)
        assert len(set(triangles)) == 8  # every unfolding of the octahedron lies flat
        forms.add(lattice_form(triangles))
    assert len(forms) == 11


def test_families_of_nets():
    from origami_jax.fold import catalogue_families, catalogue_family

    assert catalogue_families() == ("cube_nets", "octahedron_nets")
    assert catalogue_family("cube_nets") == tuple(CUBE_NETS)
    assert catalogue_family("octahedron_nets") == tuple(
        f"octahedron_net_{i:02d}" for i in range(1, 12)
    )
    assert set(catalogue_family("octahedron_nets")) <= set(catalogue_names())
    with pytest.raises(ValueError, match="no family of catalogue nets named 'cubes'.*cube_nets"):
        catalogue_family("cubes")


@pytest.mark.parametrize("name", CUBE_NETS + OCTAHEDRON_NETS)
def test_compactness_of_the_polyhedron_nets(nets, name):
    # The radius of gyration from the FOLD file's corners (each face's centre the mean of its
    # corners: squares and equilateral triangles), independent of the net's area centroids.
    key = read_fold(catalogue_path(name)).key_frame
    centres = np.array([key.vertices_coords[list(f)].mean(axis=0) for f in key.faces_vertices])
    rg = np.sqrt(np.mean(np.sum((centres - centres.mean(axis=0)) ** 2, axis=1)))
    assert nets[name].radius_of_gyration() == pytest.approx(rg, rel=1e-12)
    # At least one corner where only two faces are cut apart (a cut tree has >= 2 leaves), at
    # most all but one of the polyhedron's corners (the cut tree is then a star).
    n = len(nets[name].vertex_connections())
    assert 2 <= n <= (7 if name in CUBE_NETS else 5)


# --- conventions and closed forms ------------------------------------------------------------


def two_squares(angle_deg, *, plane="xy", assignment=None, size=(1.0, 1.0)):
    """Face 0 = [0, 1] × [0, a], face 1 = [0, 1] × [a, a + b] beyond the crease y = a."""
    a, b = size
    xy = [[0, 0], [1, 0], [1, a], [0, a], [1, a + b], [0, a + b]]
    coords = [[x, 0, y] for x, y in xy] if plane == "xz" else xy
    kind = assignment or ("V" if angle_deg > 0 else "M" if angle_deg < 0 else "F")
    return fold_from_dict(
        {
            "vertices_coords": coords,
            "edges_vertices": [[2, 3], [0, 1], [1, 2], [3, 0], [2, 4], [4, 5], [5, 3]],
            "edges_assignment": [kind, "B", "B", "B", "B", "B", "B"],
            "edges_foldAngle": [angle_deg, 0, 0, 0, 0, 0, 0],
            "faces_vertices": [[0, 1, 2, 3], [3, 2, 4, 5]],
        }
    )


@pytest.mark.parametrize("angle", [90.0, -90.0, 30.0])
def test_sign_convention_valley_lifts_the_child_to_the_front(angle):
    net = net_geometry(two_squares(angle))
    assert net.root == 0 and np.allclose(net.normal, [0, 0, 1])
    np.testing.assert_allclose(net.hinge_axes[0], [1, 0, 0])  # as the child runs the crease
    centroid = net.fold(net.targets)[1].mean(axis=0)
    rho = np.deg2rad(angle)
    # The child's centre, 0.5 from the crease y = 1, turns by ρ towards +z (valley) or −z.
    np.testing.assert_allclose(
        centroid, [0.5, 1 + 0.5 * np.cos(rho), 0.5 * np.sin(rho)], atol=1e-15
    )


def test_sign_convention_in_another_plane():
    # Origami Simulator stores flat patterns as (x, 0, y); the faces then run counter-clockwise
    # about −y, which is the paper's normal, and a valley lifts the child towards it.
    net = net_geometry(two_squares(90.0, plane="xz"))
    np.testing.assert_allclose(net.normal, [0, -1, 0], atol=1e-15)
    centroid = net.fold(net.targets)[1].mean(axis=0)
    np.testing.assert_allclose(centroid, [0.5, -0.5, 1.0], atol=1e-15)


def test_root_is_the_largest_face_unless_given():
    fold = two_squares(60.0, size=(1.0, 2.0))
    net = net_geometry(fold)
    assert net.root == 1 and net.parents.tolist() == [1, -1]
    assert net_geometry(fold, root=0).root == 0
    for root in (0, 1):
        net = net_geometry(fold, root=root)
        coords, _ = vertex_positions(net, net.fold(net.targets))
        faces = fold.key_frame.faces_vertices
        assert fold_angles_from_coords(coords, faces, fold.key_frame.edges_vertices)[
            0
        ] == pytest.approx(np.deg2rad(60.0), abs=ANGLE_TOL)
    with pytest.raises(FoldFormatError, match="root face 2 does not exist"):
        net_geometry(fold, root=2)


def test_accordion_matches_the_chain_reader_and_the_planar_closed_form(nets):
    net = nets["accordion"]
    chain = chain_geometry(catalogue_path("accordion"))
    np.testing.assert_allclose(net.hinge_axes, np.tile(chain.axis, (3, 1)))
    np.testing.assert_allclose(net.hinge_points @ chain.direction, chain.hinge_offsets)
    np.testing.assert_allclose(net.targets, chain.fold_angles)
    np.testing.assert_allclose(net.targets, [np.pi, -np.pi, np.pi])
    # All axes along +x: flap k is turned by θ_1 + … + θ_k in the (y, z) plane.
    theta = np.array([0.3, -0.5, 0.9])
    centroids = net.fold(theta).mean(axis=1)
    hinge = np.zeros(2)
    for k in range(3):
        phi = theta[: k + 1].sum()
        along = np.array([np.cos(phi), np.sin(phi)])
        face = net.crease_child[k]
        np.testing.assert_allclose(centroids[face, 1:], hinge + 0.5 * EDGE * along, atol=1e-12)
        hinge = hinge + EDGE * along
    # Batched angles fold like one at a time.
    batch = np.stack([theta, -theta, 2 * theta]).reshape(3, 1, 3)
    np.testing.assert_allclose(net.fold(batch)[1, 0], net.fold(-theta))


def test_compactness_closed_forms(nets):
    # Accordion: centres 200 µm apart on a line: Rg² = 200² · mean((k − 1.5)²) = 200² · 1.25.
    assert nets["accordion"].radius_of_gyration() == pytest.approx(EDGE * np.sqrt(1.25))
    # Tetrahedron net: three centres 2r = a/√3 from the middle one: Rg = √(3/4) · a/√3 = a/2.
    assert nets["tetrahedron"].radius_of_gyration() == pytest.approx(EDGE / 2)
    assert nets["tetrahedron"].radius_of_gyration(weighted=True) == pytest.approx(EDGE / 2)
    # Unequal faces (1 × 1 and 1 × 2): centres at y = 0.5 and 2; by area, weights 1 and 2.
    net = net_geometry(two_squares(90.0, size=(1.0, 2.0)))
    assert net.radius_of_gyration() == pytest.approx(0.75)
    assert net.radius_of_gyration(weighted=True) == pytest.approx(
        np.sqrt((1.0**2 + 2 * 0.5**2) / 3)
    )


def test_vertex_connections_of_the_corner_cube(nets):
    net = nets["corner_cube"]
    (v,) = net.vertex_connections()
    np.testing.assert_array_equal(net.vertices_coords[v], [0, 0, 0])  # the shared corner


@pytest.mark.parametrize("name", CUBE_NETS + OCTAHEDRON_NETS)
def test_vertex_connections_are_the_cut_trees_leaves(nets, name):
    # Folded, the cube's 12 edges are the 5 creases and 7 cuts; the cuts form a spanning tree of
    # the 8 corners, and a corner with one cut (a leaf) is where only two faces are cut apart.
    # The octahedron alike: 12 edges, 7 creases, 5 cuts spanning its 6 corners.
    net = nets[name]
    n_corners = 8 if name in CUBE_NETS else 6
    positions = np.round(net.fold(net.targets) / EDGE, 9)
    corner_ids = {}
    folded_vertex = {}
    for f, face in enumerate(net.faces):
        for k, v in enumerate(face):
            folded_vertex[v] = corner_ids.setdefault(tuple(positions[f, k]), len(corner_ids))
    assert len(corner_ids) == n_corners
    corners = np.array(list(corner_ids))
    cube_edges = {
        frozenset((i, j))
        for i, j in itertools.combinations(range(n_corners), 2)
        if np.isclose(np.linalg.norm(corners[i] - corners[j]), 1.0)
    }
    edges = edges_of(name)
    creases = {frozenset(folded_vertex[int(w)] for w in edges[e]) for (e,) in net.crease_edges}
    cuts = cube_edges - creases
    assert len(cube_edges) == 12 and len(cuts) == n_corners - 1
    leaves = [c for c in range(n_corners) if sum(c in cut for cut in cuts) == 1]
    connections = net.vertex_connections()
    assert sorted(folded_vertex[int(v)] for v in connections) == sorted(leaves)


# --- errors ------------------------------------------------------------------------------------


def square_grid(cells, assignment=lambda u, v: "V", angle=90.0):
    """A pattern of unit squares at integer cells, every shared side a crease."""
    index = {}
    coords = []
    faces = []
    for x, y in cells:
        face = []
        for p in ((x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)):
            if p not in index:
                index[p] = len(coords)
                coords.append(list(p))
            face.append(index[p])
        faces.append(face)
    count = {}
    for face in faces:
        for u, v in zip(face, face[1:] + face[:1], strict=True):
            count[frozenset((u, v))] = count.get(frozenset((u, v)), 0) + 1
    edges = [sorted(e) for e in count]
    kinds = [assignment(*e) if count[frozenset(e)] == 2 else "B" for e in edges]
    angles = [0 if k in "BC" else (None if k == "U" else angle) for k in kinds]
    return {
        "vertices_coords": coords,
        "edges_vertices": edges,
        "edges_assignment": kinds,
        "edges_foldAngle": angles,
        "faces_vertices": faces,
    }


def error_message(fold, **kwargs):
    with pytest.raises(FoldFormatError) as info:
        net_geometry(fold, **kwargs)
    message = str(info.value)
    assert "\n" not in message  # one line
    return message


@pytest.mark.parametrize("name", ["degree4.fold", "waterbomb.fold"])
def test_closed_loop_around_an_interior_vertex(name):
    message = error_message(DATA / name)
    assert "interior vertex 0" in message and "close a loop" in message
    assert "closed-loop engine" in message and "cut one crease" in message


def test_closed_loop_around_a_hole():
    ring = [(x, y) for x in range(3) for y in range(3) if (x, y) != (1, 1)]
    message = error_message(fold_from_dict(square_grid(ring)))
    assert "closed loop" in message and "closed-loop engine" in message
    faces = json.loads(message.split("join faces ")[1].split(" in a closed loop")[0])
    assert sorted(faces) == list(range(8))


def test_a_cut_edge_is_read_and_breaks_a_loop():
    # Two triangles joined only by a cut: they are two pieces.
    message = error_message(DATA / "nets" / "cut_edge.fold")
    assert "faces [1] are not joined to the root face 0" in message
    # Four squares around a vertex with one of the four creases cut: a tree (a chain around it).
    data = square_grid([(0, 0), (1, 0), (1, 1), (0, 1)], angle=0.0, assignment=lambda u, v: "F")
    cut = data["edges_vertices"].index([2, 3])  # between the two left squares
    data["edges_assignment"][cut] = "C"
    fold = fold_from_dict(data)
    assert fold.key_frame.edges_assignment[cut] == "C"
    net = net_geometry(fold)
    assert net.n_creases == 3 and all(cut not in edges for edges in net.crease_edges)
    (edges,) = net.target_seams.edges  # flat: the cut's two sides lie on each other
    assert edges.tolist() == [cut, cut]
    assert net.seam_gaps(net.fold(net.targets)).max() == 0.0


def test_disconnected_faces():
    message = error_message(fold_from_dict(square_grid([(0, 0), (2, 0), (3, 0)])))
    assert "faces [1, 2] are not joined to the root face 0" in message and "one piece" in message


def test_overlapping_faces():
    data = square_grid([(0, 0), (1, 0)])
    # A third face on top of the second square's top side, reaching back over the first square.
    data["vertices_coords"].append([0.3, 0.6])
    v = len(data["vertices_coords"]) - 1
    top = data["faces_vertices"][1][2:]  # (2, 1), (1, 1): the second square's top side, backwards
    data["vertices_coords"].append([2, 2])
    data["faces_vertices"].append([top[1], top[0], v + 1, v])
    data["edges_assignment"][data["edges_vertices"].index(sorted(top))] = "V"
    data["edges_foldAngle"][data["edges_vertices"].index(sorted(top))] = 90
    data["edges_vertices"] += [[top[0], v + 1], [v + 1, v], [v, top[1]]]
    data["edges_assignment"] += ["B"] * 3
    data["edges_foldAngle"] += [0] * 3
    message = error_message(fold_from_dict(data))
    assert "faces 0 and 2 overlap in the flat pattern" in message


def test_crease_without_a_target():
    data = square_grid([(0, 0), (1, 0)], assignment=lambda u, v: "U")
    message = error_message(fold_from_dict(data))
    assert "crease edge(s) [1]" in message and "no target fold angle" in message
    net = net_geometry(fold_from_dict(data), require_targets=False)
    assert np.isnan(net.targets).all()
    with pytest.raises(ValueError, match="pass angles="):
        net.seams()
    assert len(net.seams(np.zeros(1))) == 0


def test_folded_frame_is_not_a_net():
    net = net_geometry(catalogue_path("corner_cube"))
    fold = read_fold(catalogue_path("corner_cube"))
    coords, _ = vertex_positions(net, net.fold(net.targets))
    folded = fold.key_frame.replace(vertices_coords=coords)
    message = error_message(FoldFile(frames=(folded,)))
    assert "do not lie in one plane" in message and "flat" in message


def test_other_malformed_nets():
    data = square_grid([(0, 0), (1, 0)])
    data["edges_assignment"][1] = "B"
    data["edges_foldAngle"][1] = 0
    assert "assign C for a cut" in error_message(fold_from_dict(data))
    data = square_grid([(0, 0), (1, 0)])
    data["edges_assignment"][0] = "V"  # a side of one face only
    data["edges_foldAngle"][0] = 90
    assert "crease edge 0 (assignment V) borders 1 face(s) [0]" in error_message(
        fold_from_dict(data)
    )
    # An L-shaped face and the square in its notch share two creases at a right angle.
    notch = {
        "vertices_coords": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2], [2, 2]],
        "edges_vertices": [[0, 1], [1, 2], [2, 3], [3, 4], [4, 5], [5, 0], [2, 6], [6, 4]],
        "edges_assignment": ["B", "B", "V", "V", "B", "B", "B", "B"],
        "edges_foldAngle": [0, 0, 90, 90, 0, 0, 0, 0],
        "faces_vertices": [[0, 1, 2, 3, 4, 5], [3, 2, 6, 4]],
    }
    assert "do not lie on one line" in error_message(fold_from_dict(notch))


def test_chain_and_single_vertex_readers_refuse_cuts():
    from origami_jax.fold import single_vertex_geometry

    data = square_grid([(0, 0), (1, 0), (1, 1), (0, 1)], angle=0.0, assignment=lambda u, v: "F")
    data["edges_assignment"][data["edges_vertices"].index([2, 3])] = "C"
    fold = fold_from_dict(data)
    with pytest.raises(FoldFormatError, match="net_geometry"):
        chain_geometry(fold)
    centre = fold.key_frame.vertices_coords.tolist().index([1, 1])
    with pytest.raises(FoldFormatError, match="net_geometry"):
        single_vertex_geometry(fold, centre)


@pytest.mark.parametrize("plane", ["xy", "xz"])
def test_faces_are_traced_when_the_file_has_none(plane):
    data = json.loads(catalogue_path("corner_cube").read_text())
    del data["faces_vertices"]
    if plane == "xz":  # Origami Simulator's layout of a flat pattern, (x, 0, y)
        data["vertices_coords"] = [[x, 0, y] for x, y in data["vertices_coords"]]
    net = net_geometry(fold_from_dict(data))
    assert net.n_faces == 3
    np.testing.assert_allclose(net.face_areas, EDGE**2, rtol=1e-12)
    assert len(net.target_seams) == 1
    assert net.seam_gaps(net.fold(net.targets)).max() < GAP_TOL
    (v,) = net.vertex_connections()
    np.testing.assert_array_equal(net.vertices_coords[v], [0, 0, 0])  # the shared corner
