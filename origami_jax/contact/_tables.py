"""Host-side contact geometry: sample points on every panel's rim, each panel's face as half-planes,
and the (point, face) pairs that can touch.

Built once from a mechanism's flat-state geometry (`outlines`, `base_outline`, `hinge_layout`), kept as
static data of the contact model (a content hash makes it hashable, so a compiled simulation is reused
for the same geometry).
"""

import dataclasses
import hashlib

import numpy as np


@dataclasses.dataclass(frozen=True, eq=False)
class ContactTables:
    """The static geometry of `PanelContact` (host NumPy arrays; body index `n_bodies` is the base).

    **Fields:**
    - `n_bodies`: moving bodies; the fixed base, when there is one, is body `n_bodies`.
    - `base_pose`: `(4, 4)` world pose of the base's face frame (identity if there is no base).
    - `points`: `(p, 3)` sample points in their body's frame (the rim of each panel: corners and
      points along every edge; and a grid inside it, so that two panels of the same outline stacked
      on each other meet where their rims coincide with each other's edges); `point_body`: `(p,)`
      their body.
    - `face_body`: `(f,)` the body of each face (one per panel, the base last); `face_edges`:
      `(f, e, 3)` inward half-planes ``a x + b y + c ≥ 0`` of each face's convex outline in its body
      frame (``(a, b)`` a unit normal, `c` in length units), padded with always-true rows.
    - `pair_point`, `pair_face`: `(k,)` the (point, face) pairs that are checked.
    - `half_thickness`: `(n_bodies + 1,)` half of each body's thickness (the base last), length.
    - `scale`: a length of the geometry's size (the largest panel's diameter).
    """

    n_bodies: int
    base_pose: np.ndarray
    points: np.ndarray
    point_body: np.ndarray
    face_body: np.ndarray
    face_edges: np.ndarray
    pair_point: np.ndarray
    pair_face: np.ndarray
    half_thickness: np.ndarray
    scale: float
    digest: str = dataclasses.field(default="", repr=False)

    def __post_init__(self):
        h = hashlib.sha256()
        for name in (
            "base_pose",
            "points",
            "point_body",
            "face_body",
            "face_edges",
            "pair_point",
            "pair_face",
            "half_thickness",
        ):
            array = np.ascontiguousarray(getattr(self, name))
            h.update(name.encode())
            h.update(str(array.shape).encode())
            h.update(array.tobytes())
        h.update(repr((self.n_bodies, self.scale)).encode())
        object.__setattr__(self, "digest", h.hexdigest())

    def __hash__(self) -> int:
        return hash(self.digest)

    def __eq__(self, other) -> bool:
        return isinstance(other, ContactTables) and other.digest == self.digest

    @property
    def n_pairs(self) -> int:
        return int(self.pair_point.shape[0])


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
    hull = _convex_hull(xy)
    rows = []
    for a, b in zip(hull, np.roll(hull, -1, axis=0), strict=True):
        edge = b - a
        length = np.linalg.norm(edge)
        if length == 0:
            continue
        inward = np.array([-edge[1], edge[0]]) / length  # left of a counter-clockwise edge
        rows.append([inward[0], inward[1], -float(inward @ a)])
    return np.asarray(rows)


def _convex_hull(xy: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (Andrew's monotone chain)."""
    pts = sorted({(float(x), float(y)) for x, y in xy})
    if len(pts) < 3:
        raise ValueError("a contact outline needs at least three distinct corners.")

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.asarray(lower[:-1] + upper[:-1])


def _rim_points(outline: np.ndarray, spacing: float) -> np.ndarray:
    """Corners and points along every edge, about `spacing` apart."""
    points = []
    for a, b in zip(outline, np.roll(outline, -1, axis=0), strict=True):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / spacing)))
        for s in np.arange(n) / n:
            points.append(a + s * (b - a))
    return np.asarray(points)


def _interior_points(outline: np.ndarray, spacing: float) -> np.ndarray:
    """Points of a square grid of `spacing` strictly inside a convex polygon (in its x–y plane), at
    least half a spacing from its rim."""
    planes = _half_planes(outline)
    lo, hi = outline[:, :2].min(axis=0), outline[:, :2].max(axis=0)
    xs = np.arange(lo[0] + spacing / 2, hi[0], spacing)
    ys = np.arange(lo[1] + spacing / 2, hi[1], spacing)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    inside = np.all(grid @ planes[:, :2].T + planes[:, 2] >= spacing / 2 - 1e-12, axis=1)
    grid = grid[inside]
    return np.concatenate([grid, np.zeros((len(grid), 1))], axis=1)


def _distance_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    s = np.clip(((points - a) @ ab) / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(points - (a + s[:, None] * ab), axis=-1)


def build_tables(
    outlines: list[np.ndarray],
    rest_poses: np.ndarray,
    base_outline: np.ndarray | None,
    thickness: np.ndarray,
    base_thickness: float,
    crease_parent: np.ndarray,
    crease_child: np.ndarray,
    crease_ends: np.ndarray,
    *,
    points_per_edge: int = 8,
    crease_clearance: float = 0.1,
) -> ContactTables:
    """The contact geometry of panels given by their body-frame outlines.

    **Arguments:**
    - `outlines`: each moving body's polygon in its body frame, lying in the frame's x–y plane
      (the mechanism's `outlines()`); `rest_poses`: `(b, 4, 4)` body poses in the flat state.
    - `base_outline`: the fixed base's polygon in world coordinates, or `None`.
    - `thickness`: `(b,)` panel thicknesses; `base_thickness` (length).
    - `crease_parent`, `crease_child`, `crease_ends`: the hinge layout (`(h,)`, `(h,)`, `(h, 2, 3)`
      world, flat state): rim points of two panels that share a crease and lie within
      `crease_clearance` × (the smaller panel's size) of it are not paired with each other's face (the
      hinge keeps the two apart there; the barrier would fight it).
    - `points_per_edge`: samples along the longest edge (the spacing of rim and interior points);
      shorter edges get proportionally fewer (at least the corners).
    """
    n = len(outlines)
    outlines = [np.asarray(o, dtype=float) for o in outlines]
    for i, outline in enumerate(outlines):
        if outline.ndim != 2 or outline.shape[1] != 3 or outline.shape[0] < 3:
            raise ValueError(f"outline {i} must be a polygon of shape (k >= 3, 3).")
        if np.max(np.abs(outline[:, 2])) > 1e-9 * max(1.0, np.max(np.abs(outline))):
            raise ValueError(f"outline {i} does not lie in its body frame's x–y plane.")
    faces = list(outlines)
    world_outlines = [
        o @ pose[:3, :3].T + pose[:3, 3] for o, pose in zip(outlines, rest_poses, strict=True)
    ]
    base_pose = np.eye(4)
    if base_outline is not None:
        base_outline = np.asarray(base_outline, dtype=float)
        base_pose = plane_frame(base_outline)
        local = (base_outline - base_pose[:3, 3]) @ base_pose[:3, :3]
        faces.append(local)
        world_outlines.append(base_outline)
    sizes = [float(np.max(np.ptp(w, axis=0))) for w in world_outlines]
    scale = max(sizes)
    longest = max(
        float(np.max(np.linalg.norm(f - np.roll(f, -1, axis=0), axis=-1))) for f in faces
    )
    spacing = longest / max(points_per_edge, 1)

    points, point_body, world_points = [], [], []
    for body, face in enumerate(faces):
        rim = np.concatenate([_rim_points(face, spacing), _interior_points(face, spacing)])
        points.append(rim)
        point_body.append(np.full(len(rim), body))
        pose = base_pose if body == n else rest_poses[body]
        world_points.append(rim @ pose[:3, :3].T + pose[:3, 3])
    planes = [_half_planes(f) for f in faces]
    n_edges = max(len(p) for p in planes)
    face_edges = np.zeros((len(faces), n_edges, 3))
    face_edges[:, :, 2] = 1e300  # padding rows: always inside
    for i, p in enumerate(planes):
        face_edges[i, : len(p)] = p

    crease_parent = np.where(np.asarray(crease_parent) < 0, n, np.asarray(crease_parent))
    crease_child = np.asarray(crease_child)
    pair_point, pair_face = [], []
    offset = 0
    for body, rim_world in enumerate(world_points):
        for face in range(len(faces)):
            if face == body:
                continue
            keep = np.ones(len(rim_world), bool)
            for h in range(len(crease_child)):
                if {int(crease_parent[h]), int(crease_child[h])} == {body, face}:
                    near = _distance_to_segment(rim_world, *crease_ends[h])
                    keep &= near > crease_clearance * min(sizes[body], sizes[face])
            index = offset + np.nonzero(keep)[0]
            pair_point.append(index)
            pair_face.append(np.full(len(index), face))
        offset += len(rim_world)
    half = np.concatenate([np.asarray(thickness, float), [float(base_thickness)]]) / 2
    return ContactTables(
        n_bodies=n,
        base_pose=base_pose,
        points=np.concatenate(points),
        point_body=np.concatenate(point_body),
        face_body=np.arange(len(faces)),
        face_edges=face_edges,
        pair_point=np.concatenate(pair_point).astype(np.int64),
        pair_face=np.concatenate(pair_face).astype(np.int64),
        half_thickness=half,
        scale=scale,
    )
