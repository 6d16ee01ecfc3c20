"""Host-side contact geometry: sample points on every panel's rim, each panel's face as half-planes,
and the (point, face) pairs that can touch.

Built once from a mechanism's flat-state geometry (`outlines`, `base_outline`, `hinge_layout`), kept as
static data of the contact model (a content hash makes it hashable, so a compiled simulation is reused
for the same geometry).
"""

import dataclasses
import functools
import hashlib

import numpy as np

from .._limits import CONTACT_SAMPLING
from ..fold import convex_hull, convex_pieces


def content_digest(tables, arrays: tuple[str, ...], scalars: tuple) -> str:
    """A SHA-256 of host tables' named arrays (names, shapes, bytes) and scalars: what makes static
    geometry hashable, so that a compiled simulation is reused for the same geometry."""
    h = hashlib.sha256()
    for name in arrays:
        array = np.ascontiguousarray(getattr(tables, name))
        h.update(name.encode())
        h.update(str(array.shape).encode())
        h.update(array.tobytes())
    h.update(repr(scalars).encode())
    return h.hexdigest()


@dataclasses.dataclass(frozen=True, eq=False)
class ContactTables:
    """The static geometry of `PanelContact`, laid out densely by body (host NumPy arrays; body index
    `n_bodies` is the fixed base when there is one).

    **Fields:**
    - `n_bodies`: moving bodies; `has_base`: whether a fixed base takes part.
    - `base_pose`: `(4, 4)` world pose of the base's face frame (identity if there is no base).
    - `points`: `(n, p, 3)` sample points of every body (moving bodies, then the base) in its body
      frame, padded to the same count `p` (`_sample_points`: the centre, the rim moved `face_inset`
      inwards, and the rim itself).
    - `face_edges`: `(n, e, 3)` inward half-planes ``a x + b y + c ≥ 0`` of each body's face (the
      convex hull of its outline) in its body frame (``(a, b)`` a unit normal, `c` a length), padded
      with always-true rows.
    - `face_inset`: how far inside its outline the face that other panels' points meet begins
      (length; `PanelContact`'s rounded rim), the inner ring of points lies on it.
    - `pairs`: `(n, n, p)` booleans: point `i` of body `a` is checked against the face of body `b`
      (never its own; padding and points near a crease the two share are left out).
    - `scale`: the largest panel's diameter (length).
    - `weights`: `(n, p)` each point's share of the contact energy (`PanelContact`'s
      ``κ Σ w B(g/ĝ)``): 1 at the default sampling, so that denser sampling refines the same contact
      (a quadrature along the rings and rims) instead of stiffening it; 0 for padding. Default: 1
      for every point.
    """

    n_bodies: int
    has_base: bool
    base_pose: np.ndarray
    points: np.ndarray
    face_edges: np.ndarray
    pairs: np.ndarray
    scale: float
    face_inset: float = 0.0
    weights: np.ndarray | None = None
    digest: str = dataclasses.field(default="", repr=False)

    def __post_init__(self):
        if self.weights is None:
            object.__setattr__(self, "weights", np.ones(self.points.shape[:2]))
        object.__setattr__(
            self,
            "digest",
            content_digest(
                self,
                ("base_pose", "points", "face_edges", "pairs", "weights"),
                (self.n_bodies, self.has_base, self.scale, self.face_inset),
            ),
        )

    def __hash__(self) -> int:
        return hash(self.digest)

    def __eq__(self, other) -> bool:
        return isinstance(other, ContactTables) and other.digest == self.digest

    @property
    def n_pairs(self) -> int:
        """How many (point, face) pairs are checked."""
        return int(self.pairs.sum())

    @functools.cached_property
    def blocks(self) -> tuple["PairBlock", ...]:
        """The checked pairs packed without padding: one `PairBlock` per count of checked points,
        holding every body pair `(a, b)` that checks that many of `a`'s points against `b`'s face.
        The hot kernels (`PanelContact.force`, `crossed`) run over these, so that no work is spent
        on a body against itself or on points near a shared crease (a third of the dense layout
        for a cube net)."""
        counts = self.pairs.sum(axis=-1)  # (n, n)
        blocks = []
        for count in sorted(set(counts[counts > 0].tolist()), reverse=True):
            a, b = np.nonzero(counts == count)
            points = np.stack([self.points[i][self.pairs[i, j]] for i, j in zip(a, b, strict=True)])
            weights = np.stack(
                [self.weights[i][self.pairs[i, j]] for i, j in zip(a, b, strict=True)]
            )
            blocks.append(
                PairBlock(
                    point_body=a,
                    face_body=b,
                    points=points,
                    face_edges=self.face_edges[b],
                    weights=weights,
                )
            )
        return tuple(blocks)


@dataclasses.dataclass(frozen=True, eq=False)
class PairBlock:
    """Body pairs that check the same number ``m`` of points (host NumPy arrays; `ContactTables.
    blocks`): `point_body` `(k,)` and `face_body` `(k,)` the two bodies of each pair (the base is
    `n_bodies`), `points` `(k, m, 3)` the point body's checked points in its frame, `face_edges`
    `(k, e, 3)` the face body's half-planes, `weights` `(k, m)` the points' shares of the energy."""

    point_body: np.ndarray
    face_body: np.ndarray
    points: np.ndarray
    face_edges: np.ndarray
    weights: np.ndarray


def plane_frame(polygon: np.ndarray) -> np.ndarray:
    """A `(4, 4)` frame with origin at the polygon's vertex mean and z along its normal (right-handed
    with the vertices counter-clockwise), for a planar polygon given in world coordinates."""
    polygon = np.asarray(polygon, dtype=float)
    centre = polygon.mean(axis=0)
    normal = np.zeros(3)
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        normal += np.cross(a - centre, b - centre)
    norm = np.linalg.norm(normal)
    if norm == 0:
        raise ValueError("a contact outline has zero area; give panels as non-degenerate polygons.")
    z = normal / norm
    x = polygon[0] - centre
    x -= np.dot(x, z) * z
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    pose[:3, 3] = centre
    return pose


def _half_planes(outline: np.ndarray) -> np.ndarray:
    """Inward half-planes of a counter-clockwise convex polygon (its convex hull) in its own x–y plane."""
    xy = outline[:, :2]
    hull = convex_hull(xy)
    rows = []
    for a, b in zip(hull, np.roll(hull, -1, axis=0), strict=True):
        edge = b - a
        length = np.linalg.norm(edge)
        if length == 0:
            continue
        inward = np.array([-edge[1], edge[0]]) / length  # left of a counter-clockwise edge
        rows.append([inward[0], inward[1], -float(inward @ a)])
    return np.asarray(rows)


def _inset_polygon(outline: np.ndarray, inset: float) -> np.ndarray:
    """The convex hull of `outline` (x–y plane) with every edge moved `inset` inwards; its corners are
    the intersections of neighbouring moved edges. The vertex mean if the inset swallows the polygon."""
    planes = _half_planes(outline)
    moved = planes.copy()
    moved[:, 2] -= inset
    corners = []
    for (a1, b1, c1), (a2, b2, c2) in zip(moved, np.roll(moved, -1, axis=0), strict=True):
        det = a1 * b2 - a2 * b1
        if abs(det) < 1e-12:
            continue
        corners.append([(b1 * c2 - b2 * c1) / det, (a2 * c1 - a1 * c2) / det, 0.0])
    corners = np.asarray(corners)
    if len(corners) < 3 or np.any(corners[:, :2] @ planes[:, :2].T + planes[:, 2] < inset - 1e-9):
        return np.asarray(outline, dtype=float).mean(axis=0, keepdims=True)
    return corners


def _ring_counts(polygon: np.ndarray, per_edge: int) -> np.ndarray:
    """How many points `_ring` puts on each edge of `polygon`: `per_edge` on the longest,
    proportionally fewer (at least one) on shorter ones."""
    lengths = np.linalg.norm(polygon - np.roll(polygon, -1, axis=0), axis=-1)
    spacing = lengths.max() / max(per_edge, 1)
    return np.maximum(1, np.ceil(lengths / spacing - 1e-9).astype(int))


def _ring(
    polygon: np.ndarray, per_edge: int, default: int, offset: float = 0.0
) -> tuple[list, list]:
    """`per_edge` points along a convex polygon's longest edge, proportionally fewer on shorter ones,
    spaced evenly from each edge's start (its corner) or, with `offset` ½, from half a spacing in;
    and each point's weight: its spacing over the spacing on the same edge with `default` points
    along the longest (1 at the default; the weights on an edge sum to the default's count)."""
    points, weights = [], []
    for a, b, n, m in zip(
        polygon,
        np.roll(polygon, -1, axis=0),
        _ring_counts(polygon, per_edge),
        _ring_counts(polygon, default),
        strict=True,
    ):
        points += [a + s * (b - a) for s in (np.arange(n) + offset) / n]
        weights += [m / n] * n
    return points, weights


# The default sampling (`build_tables`): its points weigh 1 each; denser rings and rims share the
# same weight per length of ring or rim.
RING_POINTS_PER_EDGE, RIM_POINTS_PER_EDGE = CONTACT_SAMPLING


def sampling_pair(sampling) -> tuple[int, int]:
    """``(points_per_edge, rim_points_per_edge)`` from a `contact_sampling` argument: whole numbers,
    at least 1 and 0; otherwise a one-line `ValueError`."""
    try:
        points_per_edge, rim_points_per_edge = sampling
    except (TypeError, ValueError):
        raise ValueError(
            "contact_sampling must be a pair (points_per_edge, rim_points_per_edge), e.g. "
            f"{CONTACT_SAMPLING}, got {sampling!r}."
        ) from None
    for name, value, least in (
        ("points_per_edge", points_per_edge, 1),
        ("rim_points_per_edge", rim_points_per_edge, 0),
    ):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least:
            raise ValueError(f"{name} must be a whole number >= {least}, got {value!r}.")
    return int(points_per_edge), int(rim_points_per_edge)


def _sample_points(
    outline: np.ndarray, inset: float, per_edge: int, rim: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """The vertex mean, a ring on the rim of the panel moved `inset` inwards (`per_edge` points along
    its longest edge and the corners, `_ring`), and a ring on the rim itself: `rim` points along
    its longest edge, half a spacing from the corners (the edges' midpoints for 1; none for 0).
    Returns the points `(p, 3)` and their weights `(p,)`: 1 for the centre, and on the rings each
    point's spacing over the spacing on its edge at the default sampling (`RING_POINTS_PER_EDGE`,
    `RIM_POINTS_PER_EDGE`): 1 at the default, and each edge's total the same at any sampling.

    The inner ring lies on the face that other panels' points meet (`PanelContact` insets every face
    by `inset`), so that a panel stacked on another of the same outline lies over its face; the
    outer ring is where an edge meets another panel's edge."""
    inner = _inset_polygon(outline, inset)
    points = [np.asarray(outline, dtype=float).mean(axis=0)]
    weights = [1.0]
    if len(inner) >= 3:
        ring, shares = _ring(inner, per_edge, RING_POINTS_PER_EDGE)
        points += ring
        weights += shares
        if rim > 0:
            hull = convex_hull(np.asarray(outline, dtype=float)[:, :2])
            hull = np.concatenate([hull, np.zeros((len(hull), 1))], axis=1)
            edge, shares = _ring(hull, rim, RIM_POINTS_PER_EDGE, offset=0.5)
            points += edge
            weights += shares
    return np.asarray(points), np.asarray(weights)


def _distance_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    s = np.clip(((points - a) @ ab) / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(points - (a + s[:, None] * ab), axis=-1)


def _check_convex(outline: np.ndarray, name: str) -> None:
    """Refuse a panel whose outline (its frame's x–y plane) is not convex: the sampled contact's
    faces are convex hulls (`_half_planes`), which would fill its notch."""
    if len(convex_pieces(outline[:, :2])[0]) > 1:
        raise ValueError(
            f"{name} is not convex: the sampled contact would take its convex hull and fill its "
            "notch; use the plate contact (contact='plate', --contact plate: the default), which "
            "takes non-convex panels as they are."
        )


def build_tables(
    outlines: list[np.ndarray],
    rest_poses: np.ndarray,
    base_outline: np.ndarray | None,
    crease_parent: np.ndarray,
    crease_child: np.ndarray,
    crease_ends: np.ndarray,
    *,
    inset: float,
    points_per_edge: int = RING_POINTS_PER_EDGE,
    crease_clearance: float = 0.5,
    rim_points_per_edge: int = RIM_POINTS_PER_EDGE,
) -> ContactTables:
    """The contact geometry of panels given by their body-frame outlines.

    **Arguments:**
    - `outlines`: each moving body's polygon in its body frame, lying in the frame's x–y plane
      (the mechanism's `outlines()`); `rest_poses`: `(b, 4, 4)` body poses in the flat state.
    - `base_outline`: the fixed base's polygon in world coordinates, or `None`.
    - `crease_parent`, `crease_child`, `crease_ends`: the hinge layout (`(h,)`, `(h,)`, `(h, 2, 3)`
      world, flat state): points of two panels that share a crease and lie within
      `crease_clearance` × (the smaller panel's size) of it are not paired with each other's face. A
      point hinge holds the two together there (folded flat onto each other, their surfaces would
      overlap for any angle short of π·(1 − t/r) at a distance r from the crease), so only their far
      halves meet.
    - `inset`: how far inside each panel's outline its face begins for other panels' points, and its
      inner ring of sample points lies (length; see `_sample_points`).
    - `points_per_edge`: samples along each panel's longest edge, per ring; shorter edges get
      proportionally fewer (at least the corners).
    - `rim_points_per_edge`: points along each panel's longest edge on its rim itself (edge-on-edge
      contact), half a spacing from the corners: 2 (the default) a quarter of the edge from either
      corner, 1 the edges' midpoints, 0 none.

    Each point's share of the energy (`ContactTables.weights`) is its ring's spacing over the
    default's, so that a denser sampling resolves the same contact more finely rather than making
    it stiffer (the default points weigh 1).
    """
    points_per_edge, rim_points_per_edge = sampling_pair((points_per_edge, rim_points_per_edge))
    n = len(outlines)
    outlines = [np.asarray(o, dtype=float) for o in outlines]
    for i, outline in enumerate(outlines):
        if outline.ndim != 2 or outline.shape[1] != 3 or outline.shape[0] < 3:
            raise ValueError(f"outline {i} must be a polygon of shape (k >= 3, 3).")
        if np.max(np.abs(outline[:, 2])) > 1e-9 * max(1.0, np.max(np.abs(outline))):
            raise ValueError(f"outline {i} does not lie in its body frame's x–y plane.")
        _check_convex(outline, f"panel {i}")
    faces = list(outlines)
    world_outlines = [
        o @ pose[:3, :3].T + pose[:3, 3] for o, pose in zip(outlines, rest_poses, strict=True)
    ]
    base_pose = np.eye(4)
    if base_outline is not None:
        base_outline = np.asarray(base_outline, dtype=float)
        base_pose = plane_frame(base_outline)
        local = (base_outline - base_pose[:3, 3]) @ base_pose[:3, :3]
        _check_convex(local, "the base panel")
        faces.append(local)
        world_outlines.append(base_outline)
    sizes = [float(np.max(np.ptp(w, axis=0))) for w in world_outlines]
    scale = max(sizes)

    points, weights, world_points = [], [], []
    for body, face in enumerate(faces):
        samples, shares = _sample_points(face, inset, points_per_edge, rim_points_per_edge)
        points.append(samples)
        weights.append(shares)
        pose = base_pose if body == n else rest_poses[body]
        world_points.append(samples @ pose[:3, :3].T + pose[:3, 3])
    planes = [_half_planes(f) for f in faces]
    n_edges = max(len(p) for p in planes)
    face_edges = np.zeros((len(faces), n_edges, 3))
    face_edges[:, :, 2] = 1e300  # padding rows: always inside
    for i, p in enumerate(planes):
        face_edges[i, : len(p)] = p

    crease_parent = np.where(np.asarray(crease_parent) < 0, n, np.asarray(crease_parent))
    crease_child = np.asarray(crease_child)
    n_all = len(faces)
    width = max(len(p) for p in points)
    padded = np.zeros((n_all, width, 3))
    padded_weights = np.zeros((n_all, width))
    pairs = np.zeros((n_all, n_all, width), bool)
    for body, (samples, rim_world) in enumerate(zip(points, world_points, strict=True)):
        padded[body, : len(samples)] = samples
        padded_weights[body, : len(samples)] = weights[body]
        for face in range(n_all):
            if face == body:
                continue
            keep = np.ones(len(rim_world), bool)
            for h in range(len(crease_child)):
                if {int(crease_parent[h]), int(crease_child[h])} == {body, face}:
                    near = _distance_to_segment(rim_world, *crease_ends[h])
                    keep &= near > crease_clearance * min(sizes[body], sizes[face])
            pairs[body, face, : len(samples)] = keep
    return ContactTables(
        n_bodies=n,
        has_base=base_outline is not None,
        base_pose=base_pose,
        points=padded,
        face_edges=face_edges,
        pairs=pairs,
        scale=scale,
        face_inset=float(inset),
        weights=padded_weights,
    )
