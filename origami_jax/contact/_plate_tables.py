"""Host-side geometry of exact plate contact: every panel's polygon and the primitive pairs checked.

Built once from a mechanism's flat-state geometry (`outlines`, `base_outline`, `hinge_layout`). In
`PlateContact` the coordinates (`vertices`, `base_pose`, `scale`) are data of the compiled
programs and the index tables are static (hashed by their contents): a compiled simulation is
reused for the same panels at another size or another layout of the same topology. The primitives are those of Incremental Potential Contact:
every vertex of a panel against every other panel's polygon (*vertex–face*), and every edge of a
panel against every edge of every other panel (*edge–edge*).

A panel whose outline is not convex is several plates of one body, its convex pieces
(`convex_pieces`): the primitives are the plates', less the pieces' shared diagonals (inside the
panel) and a corner's repeats (each vertex of a panel counted once against each plate of another);
two plates of one body never meet.

Left out, because they touch by construction: between two panels that share a crease, the
primitives within `crease_clearance` × (the smaller panel's size) of it (a point hinge joins the
two there, so only their far parts can meet, as for `PanelContact`); between any two panels,
the primitives that already touch in the flat state (a corner or a cut edge two panels share:
two plates of thickness ``t`` meeting there would otherwise start ``t`` deep in each other).
"""

import dataclasses

import jax
import numpy as np

from ..fold import convex_pieces
from ._primitives import point_polygon_sq, polygon_normal, segment_segment_sq
from ._tables import _distance_to_segment, content_digest, plane_frame


@dataclasses.dataclass(frozen=True, eq=False)
class PlateTables:
    """The geometry of `PlateContact` (host NumPy arrays; body `n_bodies` is the fixed base when
    there is one). A pytree: `vertices`, `base_pose` and `scale` are its leaves (traced in a
    compiled program, so another size compiles nothing), the rest its static structure.

    **Fields:**
    - `n_bodies`: moving bodies; `has_base`: whether a fixed base takes part.
    - `base_pose`: `(4, 4)` world pose of the base's frame (identity if there is no base).
    - `vertices`: `(p, v, 3)` each plate's polygon (counter-clockwise about the frame's +z) in its
      body's frame, padded by repeating its last vertex: one plate per body, its outline's convex
      hull, where the outline is convex; a non-convex outline's convex pieces otherwise.
    - `vertex_face`: `(k, 3)` integer rows ``(a, i, b)``: vertex `i` of plate `a` against the polygon
      of plate `b`.
    - `edge_edge`: `(m, 6)` integer rows ``(a, i0, i1, b, j0, j1)``: the edge from vertex `i0` to `i1`
      of plate `a` against the edge ``j0 → j1`` of plate `b` (``a < b``).
    - `joined`: `(n, n)` bool: the two bodies touch in the flat state (a shared crease, corner or
      edge); their overlap is judged on their mid-surfaces (`PlateContact.report`).
    - `scale`: the largest panel's diameter (length).
    - `plate_body`: `(p,)` each plate's body (the base `n_bodies`); `None` (the default): plate `b`
      is body `b`, every outline convex.
    - `outline_edges`: `(p, v)` bool, whether each plate's edge from vertex ``i`` to ``i + 1`` lies
      on its panel's outline (not a diagonal between two pieces); `None`: every one does.
    """

    n_bodies: int
    has_base: bool
    base_pose: np.ndarray
    vertices: np.ndarray
    vertex_face: np.ndarray
    edge_edge: np.ndarray
    joined: np.ndarray
    scale: float
    plate_body: np.ndarray | None = None
    outline_edges: np.ndarray | None = None
    digest: str = dataclasses.field(default="", repr=False)

    def __post_init__(self):
        # A NumPy scalar (a float): a leaf that is the same object each time the tables flatten.
        object.__setattr__(self, "scale", np.float64(self.scale))
        if self.plate_body is not None and np.array_equal(
            self.plate_body, np.arange(self.n_all)
        ):  # one convex plate per body: the tables without pieces
            object.__setattr__(self, "plate_body", None)
            object.__setattr__(self, "outline_edges", None)
        object.__setattr__(self, "digest", self._content_digest())

    def _content_digest(self) -> str:
        arrays = ("base_pose", "vertices", "vertex_face", "edge_edge", "joined")
        scalars = (self.n_bodies, self.has_base, float(self.scale))
        if self.plate_body is not None:
            arrays = (*arrays, "plate_body", "outline_edges")
        return content_digest(self, arrays, scalars)

    def _digest(self) -> str:
        # Tables rebuilt from leaves (`_unflatten`) compute theirs when first compared.
        if not self.digest:
            object.__setattr__(self, "digest", self._content_digest())
        return self.digest

    def __hash__(self) -> int:
        return hash(self._digest())

    def __eq__(self, other) -> bool:
        return isinstance(other, PlateTables) and other._digest() == self._digest()

    def _flatten(self):
        # The index is hashed once per tables (every jitted call flattens its arguments, and a
        # pattern of many panels has megabytes of index tables), and kept by the tables rebuilt
        # from it.
        index = self.__dict__.get("_index")
        if index is None:
            index = _PlateIndex(self)
            object.__setattr__(self, "_index", index)
        return (self.vertices, self.base_pose, self.scale), index

    @classmethod
    def _unflatten(cls, index: "_PlateIndex", leaves) -> "PlateTables":
        # Not through `__init__`: the leaves may be traced; the digest of the whole is computed
        # when first compared (`_digest`).
        tables = object.__new__(cls)
        vertices, base_pose, scale = leaves
        fields = dict(index.fields, vertices=vertices, base_pose=base_pose, scale=scale)
        for name, value in fields.items():
            object.__setattr__(tables, name, value)
        object.__setattr__(tables, "_index", index)
        return tables

    @property
    def n_primitives(self) -> int:
        """How many primitive pairs are checked (vertex–face and edge–edge)."""
        return len(self.vertex_face) + len(self.edge_edge)

    @property
    def n_all(self) -> int:
        """How many bodies take part: the moving ones and the base, if any."""
        return self.n_bodies + int(self.has_base)

    @property
    def bodies_of_plates(self) -> np.ndarray:
        """`(p,)` each plate's body (`plate_body`, or every plate its own body)."""
        if self.plate_body is None:
            return np.arange(self.vertices.shape[0])
        return np.asarray(self.plate_body)

    @property
    def body_pairs(self) -> np.ndarray:
        """`(p, 2)` every unordered pair of bodies ``a < b`` (for the overlap report)."""
        n = self.n_all
        return np.asarray([(a, b) for a in range(n) for b in range(a + 1, n)], dtype=np.int64)

    @property
    def plate_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """`(q, 2)` every unordered pair of plates ``a < b`` of two bodies, and `(q,)` the index of
        their bodies' pair in `body_pairs` (each plate pair in order of its body pair)."""
        if self.plate_body is None:
            pairs = self.body_pairs
            return pairs, np.arange(len(pairs))
        body = self.bodies_of_plates
        rows, owner = [], []
        for k, (u, w) in enumerate(self.body_pairs):
            for a in np.flatnonzero(body == u):
                for b in np.flatnonzero(body == w):
                    rows.append((min(a, b), max(a, b)))
                    owner.append(k)
        return np.asarray(rows, np.int64).reshape(-1, 2), np.asarray(owner, np.int64)


class _PlateIndex:
    """`PlateTables`' static part (its pytree structure): the index tables and counts, compared by
    their contents, not the coordinates."""

    def __init__(self, tables: PlateTables):
        self.fields = {
            "n_bodies": tables.n_bodies,
            "has_base": tables.has_base,
            "vertex_face": tables.vertex_face,
            "edge_edge": tables.edge_edge,
            "joined": tables.joined,
            "plate_body": tables.plate_body,
            "outline_edges": tables.outline_edges,
            "digest": "",
        }
        # Not the vertices' shape: a leaf (its shape is part of every compiled program's key), and
        # a pytree partitioned by `equinox.partition` flattens with `None` in its place.
        arrays = ("vertex_face", "edge_edge", "joined")
        if tables.plate_body is not None:
            arrays = (*arrays, "plate_body", "outline_edges")
        self._key = content_digest(tables, arrays, (tables.n_bodies, tables.has_base))

    def __hash__(self) -> int:
        return hash(self._key)

    def __eq__(self, other) -> bool:
        return isinstance(other, _PlateIndex) and other._key == self._key

    def __repr__(self) -> str:
        return f"PlateIndex({self._key[:12]})"


jax.tree_util.register_pytree_node(PlateTables, PlateTables._flatten, PlateTables._unflatten)


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
    plates, outline_edges, plate_body = [], [], []
    for body, polygon in enumerate(local):
        pieces, on_outline = convex_pieces(polygon[:, :2])
        for piece, edges in zip(pieces, on_outline, strict=True):
            plates.append(np.concatenate([piece, np.zeros((len(piece), 1))], axis=1))
            outline_edges.append(edges)
            plate_body.append(body)
    plate_body = np.asarray(plate_body, np.int64)
    n_all = len(local)
    n_plates = len(plates)
    width = max(len(h) for h in plates)
    vertices = np.stack([np.concatenate([h, np.repeat(h[-1:], width - len(h), 0)]) for h in plates])
    world = [
        h @ world_pose[b][:3, :3].T + world_pose[b][:3, 3]
        for h, b in zip(plates, plate_body, strict=True)
    ]
    sizes = [
        float(
            np.max(
                np.ptp(
                    np.concatenate([w for w, c in zip(world, plate_body, strict=True) if c == b]), 0
                )
            )
        )
        for b in range(n_all)
    ]
    scale = max(sizes)
    touching = 1e-6 * scale if touching is None else float(touching)

    parent = np.where(np.asarray(crease_parent) < 0, n, np.asarray(crease_parent))
    child = np.asarray(crease_child)
    counts = np.asarray([len(h) for h in plates])
    padded = np.stack([w[np.minimum(np.arange(width), len(w) - 1)] for w in world])  # (p, v, 3)
    # Near a shared crease (within `crease_clearance` × the smaller panel): each vertex, and each
    # edge sampled at 33 points, of either panel's plates against the other panel.
    near_vertex = np.zeros((n_plates, width, n_all), bool)  # vertex i of a, near its crease with b
    near_edge = np.zeros((n_plates, width, n_all), bool)  # edge i → i+1 of a, likewise
    ramp = np.linspace(0, 1, 33)[:, None, None]
    ends = padded[:, (np.arange(width) + 1) % width]
    ends = np.where((np.arange(width) + 1 < counts[:, None])[..., None], ends, padded[:, :1])
    crease_pair = np.zeros((n_all, n_all), bool)
    for h in range(len(child)):
        a, b = int(parent[h]), int(child[h])
        crease_pair[a, b] = crease_pair[b, a] = True
        reach = crease_clearance * min(sizes[a], sizes[b])
        segment = np.asarray(crease_ends[h], dtype=float)
        for one, other in ((a, b), (b, a)):
            for plate in np.flatnonzero(plate_body == one):
                near_vertex[plate, :, other] |= (
                    _distance_to_segment(padded[plate], *segment) < reach
                )
                samples = padded[plate] + ramp * (ends[plate] - padded[plate])  # (33, v, 3)
                edge = _distance_to_segment(samples.reshape(-1, 3), *segment).reshape(33, width)
                near_edge[plate, :, other] |= edge.min(axis=0) < reach

    # A vertex of a panel split into pieces is counted once (in its first plate), and the
    # diagonals between pieces (inside the panel) are no edges of it.
    first_copy = np.zeros((n_plates, width), bool)
    on_outline = np.zeros((n_plates, width), bool)
    for body in range(n_all):
        seen = []
        for plate in np.flatnonzero(plate_body == body):
            on_outline[plate, : counts[plate]] = outline_edges[plate]
            for i in range(counts[plate]):
                point = vertices[plate, i]
                if not any(np.array_equal(point, other) for other in seen):
                    first_copy[plate, i] = True
                    seen.append(point)
    other_body = plate_body[:, None] != plate_body[None, :]

    # Every candidate in the order (a, b, i) and (a, b, i, j); kept unless near a shared crease;
    # those already touching in the flat state are left out and join their bodies.
    a, b, i = np.nonzero(first_copy[:, None, :] & other_body[..., None])
    keep = ~near_vertex[a, i, plate_body[b]]
    a, b, i = a[keep], b[keep], i[keep]
    polygon = padded[b]
    gap = np.sqrt(point_polygon_sq(padded[a, i], polygon, polygon_normal(polygon, xp=np), xp=np))
    joined = crease_pair.copy()
    close = gap < touching
    joined[plate_body[a[close]], plate_body[b[close]]] = True
    vertex_face = np.stack([a, i, b], axis=1)[~close]

    a, b, i, j = np.nonzero(
        (np.triu(np.ones((n_plates, n_plates), bool), 1) & other_body)[:, :, None, None]
        & on_outline[:, None, :, None]
        & on_outline[None, :, None, :]
    )
    keep = ~near_edge[a, i, plate_body[b]] & ~near_edge[b, j, plate_body[a]]
    a, b, i, j = a[keep], b[keep], i[keep], j[keep]
    i1, j1 = (i + 1) % counts[a], (j + 1) % counts[b]
    gap = np.sqrt(
        segment_segment_sq(padded[a, i], padded[a, i1], padded[b, j], padded[b, j1], xp=np)
    )
    close = gap < touching
    joined[plate_body[a[close]], plate_body[b[close]]] = True
    edge_edge = np.stack([a, i, i1, b, j, j1], axis=1)[~close]
    return PlateTables(
        n_bodies=n,
        has_base=base_outline is not None,
        base_pose=base_pose,
        vertices=vertices,
        vertex_face=vertex_face.astype(np.int64).reshape(-1, 3),
        edge_edge=edge_edge.astype(np.int64).reshape(-1, 6),
        joined=joined | joined.T,
        scale=scale,
        plate_body=plate_body,
        outline_edges=on_outline,
    )
