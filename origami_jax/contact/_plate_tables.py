"""Host-side geometry of exact plate contact: every panel's polygon and the primitive pairs checked.

Built once from a mechanism's flat-state geometry (`outlines`, `base_outline`, `hinge_layout`) and
kept as static data of `PlateContact` (a content hash makes it hashable, so a compiled simulation
is reused for the same geometry). The primitives are those of Incremental Potential Contact:
every vertex of a panel against every other panel's polygon (*vertex–face*), and every edge of a
panel against every edge of every other panel (*edge–edge*).

Left out, because they touch by construction: between two panels that share a crease, the
primitives within `crease_clearance` × (the smaller panel's size) of it (a point hinge joins the
two there, so only their far parts can meet, as for `PanelContact`); between any two panels,
the primitives that already touch in the flat state (a corner or a cut edge two panels share:
two plates of thickness ``t`` meeting there would otherwise start ``t`` deep in each other).
"""

import dataclasses

import numpy as np

from ._tables import _convex_hull, _distance_to_segment, content_digest, plane_frame


@dataclasses.dataclass(frozen=True, eq=False)
class PlateTables:
    """The static geometry of `PlateContact` (host NumPy arrays; body `n_bodies` is the fixed base
    when there is one).

    **Fields:**
    - `n_bodies`: moving bodies; `has_base`: whether a fixed base takes part.
    - `base_pose`: `(4, 4)` world pose of the base's frame (identity if there is no base).
    - `vertices`: `(n, v, 3)` each body's polygon (the convex hull of its outline, counter-clockwise
      about the frame's +z) in its body frame, padded by repeating its last vertex.
    - `vertex_face`: `(k, 3)` integer rows ``(a, i, b)``: vertex `i` of body `a` against the polygon
      of body `b`.
    - `edge_edge`: `(m, 6)` integer rows ``(a, i0, i1, b, j0, j1)``: the edge from vertex `i0` to `i1`
      of body `a` against the edge ``j0 → j1`` of body `b` (``a < b``).
    - `joined`: `(n, n)` bool: the two bodies touch in the flat state (a shared crease, corner or
      edge); their overlap is judged on their mid-surfaces (`PlateContact.report`).
    - `scale`: the largest panel's diameter (length).
    """

    n_bodies: int
    has_base: bool
    base_pose: np.ndarray
    vertices: np.ndarray
    vertex_face: np.ndarray
    edge_edge: np.ndarray
    joined: np.ndarray
    scale: float
    digest: str = dataclasses.field(default="", repr=False)

    def __post_init__(self):
        arrays = ("base_pose", "vertices", "vertex_face", "edge_edge", "joined")
        scalars = (self.n_bodies, self.has_base, self.scale)
        object.__setattr__(self, "digest", content_digest(self, arrays, scalars))

    def __hash__(self) -> int:
        return hash(self.digest)

    def __eq__(self, other) -> bool:
        return isinstance(other, PlateTables) and other.digest == self.digest

    @property
    def n_primitives(self) -> int:
        """How many primitive pairs are checked (vertex–face and edge–edge)."""
        return len(self.vertex_face) + len(self.edge_edge)

    @property
    def body_pairs(self) -> np.ndarray:
        """`(p, 2)` every unordered pair of bodies ``a < b`` (for the overlap report)."""
        n = self.vertices.shape[0]
        return np.asarray([(a, b) for a in range(n) for b in range(a + 1, n)], dtype=np.int64)


def _segment_distance(p0, p1, q0, q1) -> float:
    """Distance between two segments (host; sampled finely enough for a table's decision: the
    exact answer of the closest endpoints and the closed form of crossing interiors)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e, b = d1 @ d1, d2 @ d2, d1 @ d2
    c, f = d1 @ r, d2 @ r
    denom = a * e - b * b
    s = np.clip((b * f - c * e) / denom, 0, 1) if denom > 1e-12 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0:
        t, s = 0.0, np.clip(-c / a, 0, 1)
    elif t > 1:
        t, s = 1.0, np.clip((b - c) / a, 0, 1)
    return float(np.linalg.norm(p0 + s * d1 - q0 - t * d2))


def _point_polygon_distance(p, polygon) -> float:
    """Distance from a point to a planar convex polygon (host, counter-clockwise `(v, 3)`)."""
    normal = np.cross(polygon[1] - polygon[0], polygon[2] - polygon[0])
    normal /= np.linalg.norm(normal)
    nxt = np.roll(polygon, -1, axis=0)
    inward = np.cross(normal, nxt - polygon)
    if np.all(np.einsum("ki,ki->k", p - polygon, inward) >= 0):
        return float(abs((p - polygon[0]) @ normal))
    return float(
        min(_distance_to_segment(p[None], a, b)[0] for a, b in zip(polygon, nxt, strict=True))
    )


def build_plate_tables(
    outlines: list[np.ndarray],
    rest_poses: np.ndarray,
    base_outline: np.ndarray | None,
    crease_parent: np.ndarray,
    crease_child: np.ndarray,
    crease_ends: np.ndarray,
    *,
    crease_clearance: float = 0.5,
    touching: float | None = None,
) -> PlateTables:
    """The exact contact geometry of panels given by their body-frame outlines.

    **Arguments:** `outlines` (each moving body's polygon in its frame's x–y plane), `rest_poses`
    `(b, 4, 4)`, `base_outline` (world polygon or `None`) and the hinge layout (`crease_parent`,
    `crease_child`, `crease_ends`), as for `build_tables`; `crease_clearance` (module docstring);
    `touching`: primitives closer than this in the flat state are left out (length; default
    ``1e-6`` × the largest panel).
    """
    n = len(outlines)
    local = []
    for i, outline in enumerate(outlines):
        outline = np.asarray(outline, dtype=float)
        if outline.ndim != 2 or outline.shape[1] != 3 or outline.shape[0] < 3:
            raise ValueError(f"outline {i} must be a polygon of shape (k >= 3, 3).")
        local.append(outline)
    world_pose = [np.asarray(p, dtype=float) for p in rest_poses]
    base_pose = np.eye(4)
    if base_outline is not None:
        base_outline = np.asarray(base_outline, dtype=float)
        base_pose = plane_frame(base_outline)
        local.append((base_outline - base_pose[:3, 3]) @ base_pose[:3, :3])
        world_pose.append(base_pose)
    hulls = []
    for polygon in local:
        hull = _convex_hull(polygon[:, :2])
        hulls.append(np.concatenate([hull, np.zeros((len(hull), 1))], axis=1))
    n_all = len(hulls)
    width = max(len(h) for h in hulls)
    vertices = np.stack([np.concatenate([h, np.repeat(h[-1:], width - len(h), 0)]) for h in hulls])
    world = [h @ pose[:3, :3].T + pose[:3, 3] for h, pose in zip(hulls, world_pose, strict=True)]
    sizes = [float(np.max(np.ptp(w, axis=0))) for w in world]
    scale = max(sizes)
    touching = 1e-6 * scale if touching is None else float(touching)

    parent = np.where(np.asarray(crease_parent) < 0, n, np.asarray(crease_parent))
    child = np.asarray(crease_child)
    creases: dict[tuple[int, int], list] = {}
    for h in range(len(child)):
        key = tuple(sorted((int(parent[h]), int(child[h]))))
        creases.setdefault(key, []).append(np.asarray(crease_ends[h], dtype=float))

    def near_crease(key, points) -> bool:
        reach = crease_clearance * min(sizes[key[0]], sizes[key[1]])
        return any(
            np.min(_distance_to_segment(np.asarray(points), *ends)) < reach
            for ends in creases.get(key, [])
        )

    def edge_points(w, i0, i1):
        return w[i0] + np.linspace(0, 1, 33)[:, None] * (w[i1] - w[i0])

    vertex_face, edge_edge = [], []
    joined = np.zeros((n_all, n_all), bool)
    for a in range(n_all):
        for b in range(n_all):
            if a == b:
                continue
            key = (min(a, b), max(a, b))
            if key in creases:
                joined[a, b] = True
            for i, p in enumerate(world[a]):
                if key in creases and near_crease(key, p[None]):
                    continue
                if _point_polygon_distance(p, world[b]) < touching:
                    joined[a, b] = joined[b, a] = True
                    continue
                vertex_face.append((a, i, b))
            if b <= a:
                continue
            ka, kb = len(world[a]), len(world[b])
            for i in range(ka):
                ea = (i, (i + 1) % ka)
                if key in creases and near_crease(key, edge_points(world[a], *ea)):
                    continue
                for j in range(kb):
                    eb = (j, (j + 1) % kb)
                    if key in creases and near_crease(key, edge_points(world[b], *eb)):
                        continue
                    gap = _segment_distance(world[a][ea[0]], world[a][ea[1]], *world[b][list(eb)])
                    if gap < touching:
                        joined[a, b] = joined[b, a] = True
                        continue
                    edge_edge.append((a, *ea, b, *eb))
    return PlateTables(
        n_bodies=n,
        has_base=base_outline is not None,
        base_pose=base_pose,
        vertices=vertices,
        vertex_face=np.asarray(vertex_face, dtype=np.int64).reshape(-1, 3),
        edge_edge=np.asarray(edge_edge, dtype=np.int64).reshape(-1, 6),
        joined=joined | joined.T,
        scale=scale,
    )
