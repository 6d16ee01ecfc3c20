"""Adhesion and friction at plate contacts: `Adhesion`, `Friction` and the host tables adhesion
samples (`SurfaceTables`), for [`origami_jax.contact.PlateContact`][].

**Adhesion.** Surfaces that touch stick. Face adhesion is a short-range potential on the plates'
gaps: every plate carries quadrature points on its mid-surface (`build_surface_tables`: the polygon
fanned from its vertex mean, each fan triangle cut into ``s²`` equal triangles, one point at each
centroid with that triangle's area ``a_p``), and each point ``p`` of body ``a`` against the polygon of
every other body ``b`` adds

    E_face = −w · ½ a_p · φ(g_pb / δ),      g_pb = dist(p, polygon_b) − (t_a + t_b)/2,

with ``w`` the work of adhesion (energy per area), ``δ`` its range and ``φ(x) = 1 − S(x)`` (``S`` the C²
smoothstep ``x³(10 − 15x + 6x²)``): ``φ = 1`` in contact, 0 from ``g = δ`` on, C². Each side's points
over the overlap of two parallel plates sum to the overlap's area, so the two halves give
``−w A_overlap φ(g/δ)``: exact for two equal plates stacked. A smaller plate over a larger one adds
a halo: the larger plate's points beside the smaller's rim are within ``δ`` of it too, adding
``½ w P ∫ φ`` over the lateral distance (``P`` the rim's length; about ``½ w P δ/2``, 5 % for a
20 µm plate with ``δ`` = 0.8 µm), the reach of adhesion past a rounded rim. The quadrature
converges to that within the cells the rim cuts (at most ``½ w P`` × a cell's side). The points sit at least a third of a cell inside the rim, so a plate
standing on its edge on another's face (edge-on contact, a line of width ~ the film) gets no face
adhesion: edges hold through line adhesion.

Seams bond through *line adhesion* on pairs of edges of different bodies,

    E_line = −γ · ℓ · (1 − m) · φ(g_ee / δ),

``γ`` energy per length, ``ℓ`` the length of the overlap of one edge's projection onto the other,
``m`` IPC's edge–edge parallelism mollifier (`PlateContact`: ``1 − m`` is 1 for parallel edges and 0
beyond ~1.8° apart) and ``g_ee`` the two edges' gap: two edges that meet along their length, as the
edges of a closing seam do, hold with energy ``γ ℓ``; crossing edges, which touch at a point, do not.

Left out (they touch by construction in the flat state, where adhesion would resist the fold from
its first instant): the points of a panel within ``½`` × the smaller panel's size of a crease it
shares (as `PlateTables` leaves out its vertices there), every edge pair of two panels that share a
crease, and the points and nearly parallel edge pairs within `clearance` of the other body in the
flat state (a shared cut edge). Unlike `PlateTables`, edges of two panels that share only a
corner in the flat state *are* paired: they are the edges of the seams that close first in a
cube's cross net.

**The range is numerical.** Physical adhesion acts over nanometres (van der Waals, a capillary
meniscus), while the plate contact keeps surfaces ``ĝ`` apart (the barrier's standoff, ~0.2 µm). For
the adhesive well to reach past the barrier ``δ`` must be of the order of ``ĝ`` or larger (``δ = 2 ĝ``
is a good choice): the energy ``w A`` of a contact is then physical, but its pull-off force
``~ w A max|φ'| / δ = 15 w A / (8 δ)`` is that of the model's range, far below the physical one.

**Friction.** Smoothed Coulomb friction of Incremental Potential Contact (Li et al., SIGGRAPH 2020,
§5) on every primitive pair of the plate contact: with ``λ_k`` the pair's normal force (the barrier's
push ``−κ m_k B'(g_k/ĝ)/ĝ``, which carries any load adhesion adds) and ``u_t`` the tangential part (normal
to the pair's contact normal ``n``) of the relative velocity of the two bodies at the pair's contact
point,

    f_k = −μ λ_k f₁(|u_t|)/|u_t| · u_t,   f₁(y) = 2y/ε_v − y²/ε_v² for y < ε_v, 1 beyond,

on the first body and ``−f_k`` on the second, at the same point. Its power is
``−μ λ_k f₁(|u_t|) |u_t| ≤ 0`` exactly: friction only dissipates. It is smooth in ``v`` except at
``u_t = 0`` (where it is continuous, its derivative bounded by ``2 μ λ / ε_v``) and at ``|u_t| = ε_v``
(C¹); below ``ε_v`` it is a viscous creep, so a body that "sticks" creeps at most at ``ε_v``.

**In the implicit step.** `ImplicitStep` solves the residual of implicit Euler with the full
generalized force, ``v = (q − q_n)/h``, by Newton with a forward-mode Jacobian: friction enters it as
a force, fully implicit in the velocity, normal and normal force, and needs no potential. IPC's
lagged friction potential ``D(x) = Σ μ λ_k^n f₀(|T_kⁿᵀ (x − xⁿ)|)`` (normal force and tangent
basis frozen at the step's start, ``f₀' = f₁``) is what a minimiser of the incremental potential
would take; its gradient is this force with ``λ``, ``n`` lagged.
"""

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._math import safe_norm
from ..system import UnitSystem
from ._barrier import check_known_values, smoothstep
from ._pick import pick
from ._plate_tables import PlateTables
from ._primitives import point_polygon_sq, polygon_normal, segment_segment_sq
from ._tables import _distance_to_segment, content_digest

# Each parameter and whether it must be > 0 (else >= 0).
_ADHESION_SIGNS = (("work", False), ("range", True), ("line", False))
_FRICTION_SIGNS = (("coefficient", False), ("slip", True))

# Points of a panel within this fraction of the smaller panel's size of a shared crease are not
# paired with the other panel (as `build_plate_tables`).
_CREASE_CLEARANCE = 0.5
# IPC's edge–edge mollifier threshold (as `PlateContact`): edges nearer parallel than this are
# "parallel" for line adhesion.
_PARALLEL = 1e-3


def detachment(x: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
    """``φ(x) = 1 − S(x)``: 1 for ``x ≤ 0``, 0 for ``x ≥ 1``, C² (``S`` the smoothstep)."""
    return 1.0 - smoothstep(x)


def slip_mollifier(y: Float[ArrayLike, "..."], eps: Float[ArrayLike, ""]) -> Float[Array, "..."]:
    """IPC's ``f₁(y)/y`` for ``y ≥ 0``: ``(2 − y/ε)/ε`` below ``ε``, ``1/y`` beyond (finite at 0, C⁰
    in ``y`` with a C¹ ``f₁``)."""
    y = jnp.asarray(y)
    inside = y < eps
    return jnp.where(inside, (2 - y / eps) / eps, 1 / jnp.where(inside, 1.0, y))


def _as_float(value) -> Array:
    return jnp.asarray(value, jnp.result_type(float))


class Adhesion(eqx.Module):
    """Adhesion between plates that touch (module docstring: the model).

    **Fields** (the system's units; `MICRO` in brackets):
    - `work`: ``w``, the work of adhesion, energy per area (µN·µm/µm² = µN/µm, which in `MICRO` is
      numerically J/m²: 1 MICRO unit = 1 J/m²; `Adhesion.from_si`).
    - `range`: ``δ``, the gap over which it falls from ``w`` to 0, length (µm). Numerical, of the order
      of the contact's activation gap ``ĝ`` (``2 ĝ`` is a good choice): module docstring.
    - `line`: ``γ``, seam (edge-on-edge) adhesion, energy per length (µN; 1 MICRO unit = 1e-6 J/m).
      Default 0.
    - `samples` (static): ``s``, each fan triangle of a plate cut into ``s²`` quadrature cells
      (default 3: 36 points on a square). Every point is paired with every other plate: on a cube
      net a force evaluation takes about 3× the plain contact's with ``s = 3``.

    **Values.** Orders of magnitude, not measurements of these devices; the module docstring's
    model reaches the energy, not the pull-off force:
    - *In air* adhesion of hydrophilic surfaces (SiO₂, SiNₓ with its native oxide, Si) is dominated
      by capillary condensation: ``w ≈ 2 γ_water cos θ ≈ 0.1 J/m²`` at most (water's surface
      tension 0.072 J/m²), and measured works of adhesion of MEMS beams stuck to their substrate
      (the stiction literature, cantilever-crack measurements on polysilicon: de Boer and
      Michalske) of ~10–100 mJ/m² for hydrophilic surfaces in humid air, ~µJ/m² to a few tens of
      µJ/m² for hydrophobic (SAM-coated or HF-terminated) ones. Range ``w`` ~ 1e-3–0.1 J/m².
    - *In water* the capillary term is gone; van der Waals across water,
      ``w ≈ A_H / (12 π D₀²)`` with a Hamaker constant across water of ~0.5–1e-20 J for oxides and
      nitrides (Israelachvili, *Intermolecular and Surface Forces*) and ``D₀ ≈ 0.2–0.4 nm``, gives
      ~1–10 mJ/m², an upper bound: hydration and electrical double-layer repulsion lower it.
    - *In KOH* (high pH, high ionic strength) oxide and nitride surfaces are strongly negatively
      charged, and the double layer is thin (Debye length < 1 nm at ~1 M), so the net work of
      adhesion is expected to be ≲ 1 mJ/m², possibly repulsive; Cr is etched/oxidised. We know of no
      measurement for these films: use ``w = 0`` (off) or a sensitivity range 1e-4–1e-2 J/m².
    - `line`: a seam of two films of thickness ``t`` that meet edge to edge over their rounded rims
      has ``γ ~ w t`` (0.2 µm × 0.05 J/m² = 1e-8 J/m = 0.01 µN); stronger where a solder or a
      deposited film fuses them.
    """

    work: Float[Array, ""] = eqx.field(converter=_as_float)
    range: Float[Array, ""] = eqx.field(converter=_as_float)
    line: Float[Array, ""] = eqx.field(converter=_as_float, default=0.0)
    samples: int = eqx.field(static=True, default=3)

    def __check_init__(self):
        if isinstance(self.samples, bool) or not isinstance(self.samples, int) or self.samples < 1:
            raise ValueError(f"Adhesion.samples must be a positive integer, got {self.samples!r}.")
        check_known_values(
            "Adhesion.",
            ((name, getattr(self, name), strict) for name, strict in _ADHESION_SIGNS),
        )

    @classmethod
    def from_si(
        cls,
        units: UnitSystem,
        *,
        work: float,
        range: float,
        line: float = 0.0,
        samples: int = 3,
    ) -> "Adhesion":
        """Adhesion from SI values: `work` J/m², `range` m, `line` J/m, into `units`."""
        return cls(
            work=units.from_si(work, mass=1, time=-2),
            range=units.length(range),
            line=units.from_si(line, mass=1, length=1, time=-2),
            samples=samples,
        )


class Friction(eqx.Module):
    """Smoothed Coulomb friction at the plate contact's primitive pairs (module docstring).

    **Fields:**
    - `coefficient`: ``μ``, dimensionless.
    - `slip`: ``ε_v``, the tangential speed below which friction is a viscous creep, length/time
      (µm/µs = m/s in `MICRO`). Smaller is closer to Coulomb and stiffer: the creep's damping rate
      is ``2 μ λ / (ε_v m)``.

    **Values.** Dry friction of Si, SiO₂ and SiNₓ on each other in air: ``μ ≈ 0.2–0.7``, widely
    scattered with humidity, surface films and load (micro-tribology measurements on MEMS
    sidewalls and on-chip tribometers, and Bhushan's *Handbook of Micro/Nanotribology*; Cr on
    oxides is similar). Adhesion-controlled at these loads: an effective ``μ`` of 1 or more is
    possible when adhesion is a large part of the normal load (the model adds adhesion's load to
    ``λ`` already). Wet (water, KOH): lubricated, ``μ`` ~ 0.05–0.3 (order of magnitude; hydration
    layers lower friction between hydrophilic oxides). Treat ``μ`` as uncertain by a factor of 2.
    """

    coefficient: Float[Array, ""] = eqx.field(converter=_as_float)
    slip: Float[Array, ""] = eqx.field(converter=_as_float)

    def __check_init__(self):
        check_known_values(
            "Friction.",
            ((name, getattr(self, name), strict) for name, strict in _FRICTION_SIGNS),
        )


@dataclasses.dataclass(frozen=True, eq=False)
class SurfaceTables:
    """The static geometry of adhesion (host NumPy arrays; plates and vertices as `PlateTables`).

    **Fields:**
    - `point_weights`: `(s, p·v)` each quadrature point as an affine combination of the flattened
      polygon vertices of its plate (rigid plates: exact in any pose).
    - `point_area`: `(s,)` each point's cell area (length²).
    - `point_body`: `(s,)` its plate (its body's, where each body is one plate).
    - `face_pairs`: `(k, 2)` rows ``(point, b)``: point against the polygon of plate `b` (of
      another body).
    - `line_pairs`: `(m, 6)` rows ``(a, i0, i1, b, j0, j1)`` as `PlateTables.edge_edge`.
    """

    point_weights: np.ndarray
    point_area: np.ndarray
    point_body: np.ndarray
    face_pairs: np.ndarray
    line_pairs: np.ndarray
    digest: str = dataclasses.field(default="", repr=False)

    def __post_init__(self):
        arrays = ("point_weights", "point_area", "point_body", "face_pairs", "line_pairs")
        object.__setattr__(self, "digest", content_digest(self, arrays, ()))

    def __hash__(self) -> int:
        return hash(self.digest)

    def __eq__(self, other) -> bool:
        return isinstance(other, SurfaceTables) and other.digest == self.digest


def _fan_samples(count: int, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric weights on a polygon's `count` vertices `(p, count)` of its quadrature points and
    their share of their fan triangle's area `(p,)`, fan triangle by fan triangle."""
    cells = []
    for i in range(samples):
        for j in range(samples - i):
            cells.append(((i + 1 / 3) / samples, (j + 1 / 3) / samples))
            if i + j <= samples - 2:
                cells.append(((i + 2 / 3) / samples, (j + 2 / 3) / samples))
    rows, fan = [], []
    for k in range(count):
        for alpha, beta in cells:
            row = np.full(count, (1 - alpha - beta) / count)
            row[k] += alpha
            row[(k + 1) % count] += beta
            rows.append(row)
            fan.append(k)
    return np.asarray(rows), np.asarray(fan)


def build_surface_tables(
    tables: PlateTables,
    rest_poses: np.ndarray,
    crease_parent: np.ndarray,
    crease_child: np.ndarray,
    crease_ends: np.ndarray,
    *,
    samples: int = 3,
    clearance: float | None = None,
) -> SurfaceTables:
    """The adhesion geometry of `tables` (module docstring: the samples and the pairs left out).

    **Arguments:** `tables` (the contact's `PlateTables`), `rest_poses` `(b, 4, 4)` of the moving
    bodies in the flat state, the hinge layout (`crease_parent` with −1 the base, `crease_child`,
    `crease_ends` `(h, 2, 3)`), `samples` ``s``, `clearance` (length; default 1 % of the largest
    panel): points and nearly parallel edge pairs closer than this to the other body in the flat
    state are left out.
    """
    # Per plate (a body's plates: one, or a non-convex panel's convex pieces, `PlateTables`).
    n_plates, width = tables.vertices.shape[:2]
    n = tables.n_bodies
    plate_body = tables.bodies_of_plates
    clearance = 0.01 * tables.scale if clearance is None else float(clearance)
    poses = [np.asarray(p, float) for p in rest_poses]
    if tables.has_base:
        poses.append(np.asarray(tables.base_pose, float))
    world = np.stack(
        [
            tables.vertices[b] @ poses[plate_body[b]][:3, :3].T + poses[plate_body[b]][:3, 3]
            for b in range(n_plates)
        ]
    )
    counts = [
        int(np.sum(np.any(np.diff(tables.vertices[b], axis=0) != 0, axis=1))) + 1
        for b in range(n_plates)
    ]
    on_outline = (
        np.ones((n_plates, width), bool)
        if tables.outline_edges is None
        else np.asarray(tables.outline_edges)
    )
    sizes = []  # each body's, over its plates
    for k in range(tables.n_all):
        mine = np.concatenate([world[p, : counts[p]] for p in np.flatnonzero(plate_body == k)])
        sizes.append(float(np.max(np.ptp(mine, axis=0))))

    weights, area, body = [], [], []
    for b in range(n_plates):
        rows, fan = _fan_samples(counts[b], samples)
        local = tables.vertices[b, : counts[b]]
        centre = local.mean(axis=0)
        corner, nxt = local, np.roll(local, -1, axis=0)
        fan_area = 0.5 * np.abs(np.cross(corner - centre, nxt - centre)[:, 2])
        full = np.zeros((len(rows), n_plates * width))
        full[:, b * width : b * width + counts[b]] = rows
        weights.append(full)
        area.append(fan_area[fan] / samples**2)
        body.append(np.full(len(rows), b))
    weights, area, body = np.concatenate(weights), np.concatenate(area), np.concatenate(body)
    points = weights @ world.reshape(-1, 3)

    parent = np.where(np.asarray(crease_parent) < 0, n, np.asarray(crease_parent))
    child = np.asarray(crease_child)
    crease_pair = np.zeros((tables.n_all, tables.n_all), bool)  # by body
    near = np.zeros((len(points), n_plates), bool)  # point near its crease with that plate's body
    for h in range(len(child)):
        a, b = int(parent[h]), int(child[h])
        if a >= tables.n_all:
            continue
        crease_pair[a, b] = crease_pair[b, a] = True
        reach = _CREASE_CLEARANCE * min(sizes[a], sizes[b])
        segment = np.asarray(crease_ends[h], float)
        close = _distance_to_segment(points, *segment) < reach
        near[:, plate_body == b] |= (close & (plate_body[body] == a))[:, None]
        near[:, plate_body == a] |= (close & (plate_body[body] == b))[:, None]

    point, other = np.nonzero((plate_body[body][:, None] != plate_body[None, :]) & ~near)
    polygon = world[other]
    gap = np.sqrt(point_polygon_sq(points[point], polygon, polygon_normal(polygon, xp=np), xp=np))
    face_pairs = np.stack([point, other], axis=1)[gap >= clearance]

    rows = []
    for a in range(n_plates):
        for b in range(a + 1, n_plates):
            if plate_body[a] == plate_body[b] or crease_pair[plate_body[a], plate_body[b]]:
                continue
            for i in range(counts[a]):
                i1 = (i + 1) % counts[a]
                if not on_outline[a, i]:
                    continue  # a diagonal between two pieces of a panel, inside it
                for j in range(counts[b]):
                    j1 = (j + 1) % counts[b]
                    if not on_outline[b, j]:
                        continue
                    ea, eb = world[a, i1] - world[a, i], world[b, j1] - world[b, j]
                    parallel = np.sum(np.cross(ea, eb) ** 2) < _PARALLEL * (ea @ ea) * (eb @ eb)
                    distance = np.sqrt(
                        segment_segment_sq(
                            world[a, i], world[a, i1], world[b, j], world[b, j1], xp=np
                        )
                    )
                    if parallel and distance < clearance:
                        continue
                    rows.append((a, i, i1, b, j, j1))
    return SurfaceTables(
        point_weights=weights,
        point_area=area,
        point_body=body.astype(np.int64),
        face_pairs=face_pairs.astype(np.int64).reshape(-1, 2),
        line_pairs=np.asarray(rows, dtype=np.int64).reshape(-1, 6),
    )


def _overlap_length(p0, p1, q0, q1):
    """The length of the overlap of segment ``[q0, q1]``'s projection onto ``[p0, p1]`` with it."""
    axis = p1 - p0
    length = safe_norm(axis)
    unit = axis / jnp.where(length > 0, length, 1.0)[..., None]
    t0 = jnp.sum((q0 - p0) * unit, axis=-1)
    t1 = jnp.sum((q1 - p0) * unit, axis=-1)
    low = jnp.maximum(jnp.minimum(t0, t1), 0.0)
    high = jnp.minimum(jnp.maximum(t0, t1), length)
    return jnp.maximum(high - low, 0.0)


def adhesion_energy(
    adhesion: Adhesion,
    surface: SurfaceTables,
    half_thickness: Float[Array, " n"],
    x: Float[Array, "n v 3"],
) -> Float[Array, ""]:
    """The adhesive energy (≤ 0, energy units) of plates with world vertices `x` (`plate_vertices`)
    and half-thicknesses `half_thickness` `(n,)`: face and line adhesion (module docstring)."""
    dtype = x.dtype
    half = half_thickness.astype(dtype)
    flat = x.reshape(-1, 3)
    total = jnp.zeros((), dtype)
    if len(surface.face_pairs):
        point, other = surface.face_pairs.T
        world = jnp.asarray(surface.point_weights, dtype) @ flat  # (s, 3)
        polygon = x[other]
        d_sq = point_polygon_sq(world[point], polygon, polygon_normal(polygon))
        tiny = 1e-6 * adhesion.range
        gap = jnp.sqrt(d_sq + tiny**2) - half[surface.point_body[point]] - half[other]
        area = jnp.asarray(surface.point_area[point], dtype)
        total = total - adhesion.work * jnp.sum(0.5 * area * detachment(gap / adhesion.range))
    if len(surface.line_pairs):
        a, i0, i1, b, j0, j1 = surface.line_pairs.T
        p0, p1, q0, q1 = x[a, i0], x[a, i1], x[b, j0], x[b, j1]
        tiny = 1e-6 * adhesion.range
        d_sq = segment_segment_sq(p0, p1, q0, q1)
        gap = jnp.sqrt(d_sq + tiny**2) - half[a] - half[b]
        ea, eb = p1 - p0, q1 - q0
        cross = jnp.cross(ea, eb)
        r = jnp.sum(cross * cross, axis=-1) / (
            _PARALLEL * jnp.sum(ea * ea, axis=-1) * jnp.sum(eb * eb, axis=-1)
        )
        parallel = jnp.where(r < 1, (1 - r) ** 2, 0.0)  # 1 − IPC's mollifier (2 − r) r
        length = _overlap_length(p0, p1, q0, q1)
        total = total - adhesion.line * jnp.sum(
            length * parallel * detachment(gap / adhesion.range)
        )
    return total


def friction_wrenches(
    friction: Friction,
    normal_force: Float[Array, " k"],
    point: Float[Array, "k 3"],
    normal: Float[Array, "k 3"],
    body_a: np.ndarray | Array,
    body_b: np.ndarray | Array,
    velocity: Float[Array, "n 6"],
) -> Float[Array, "n 6"]:
    """One world wrench ``(F, x × F)`` per body (the base last) of smoothed Coulomb friction at `k`
    primitive pairs (module docstring): `normal_force` ``λ`` `(k,)` (force), contact points `point`
    and unit normals `normal` `(k, 3)` (world), the pairs' bodies `body_a`, `body_b` (host), and
    every body's spatial velocity at the origin `velocity` `(n, 6)`."""
    n = velocity.shape[0]
    va, vb = pick(body_a, n, velocity), pick(body_b, n, velocity)
    relative = (va[:, :3] - vb[:, :3]) + jnp.cross(va[:, 3:] - vb[:, 3:], point)
    tangential = relative - jnp.sum(relative * normal, axis=-1, keepdims=True) * normal
    speed = safe_norm(tangential)
    force = (
        -(friction.coefficient * normal_force * slip_mollifier(speed, friction.slip))[:, None]
        * tangential
    )
    pair = jnp.concatenate([force, jnp.cross(point, force)], axis=-1)
    return pick(body_a, n, pair, transpose=True) - pick(body_b, n, pair, transpose=True)
