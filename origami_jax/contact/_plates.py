"""`PlateContact`: contact between thin plates from their exact geometry, with continuous collision
detection.

**Model.** Every panel is a plate: its polygon (the mid-surface; a panel whose outline is not
convex is several plates of one body, its convex pieces, `PlateTables`) swept by a ball of half
its thickness. Two plates are apart by the distance between their polygons
less their two half-thicknesses. That distance is the least over the primitive pairs of
Incremental Potential Contact (Li et al., SIGGRAPH 2020): every vertex of one polygon against the
other polygon, and every edge of one against every edge of the other (`PlateTables`; exact for
disjoint convex polygons, corners and edges between vertices included). For each primitive pair
with gap ``g``:

- energy ``κ m B(g/ĝ)``, IPC's barrier ``B(x) = −(x − 1)² ln x`` (zero beyond the activation gap
  ``ĝ``, unbounded as the gap closes; below ``x = 0.1`` continued by its Taylor polynomial, so that
  a state past contact still has a finite, steep restoring force), ``m`` = 1 but for edge–edge
  pairs of nearly parallel edges, where IPC's mollifier ``m`` takes the energy smoothly to zero
  (parallel edges meet at their ends, which the vertex–face pairs hold, so that the force does not
  jump as the closest points slide along them);
- a dissipative force ``−c a(g) ġ ∇g`` (``a`` a C² ramp from 0 at ``ĝ`` to 1 at contact), so contact
  never adds energy: ``v · f = −dE/dt − c Σ a ġ² ≤ −dE/dt``.

Forces act at each pair's closest points, along the line joining them (``−∂E/∂g`` times the gap's
gradient: the derivative of a least distance is the derivative at its minimiser, so no
differentiation of the distance functions is needed), plus the turning of nearly parallel edge
pairs by their mollifier, and add up to one wrench per body, which the mechanism maps to its
coordinates; the same as ``−∂E/∂x`` on every polygon vertex, at a fraction of the cost.
`force_jacobians` adds the Gauss–Newton derivatives an implicit step's Newton iterations use.

**Continuous collision detection.** `crossed` is the step guard of `simulate`
(`ContactGuard`): a step is refused when, with every vertex moving on the straight path between
the step's two states, a primitive pair would come closer than half the two plates'
half-thicknesses (``ξ``; additive CCD, `additive_ccd`), or when the two polygons of any pair of
bodies, including panels joined by a crease, overlap more at its end than at its start (exact,
`overlap_depth`). So no accepted step carries a plate through another, at corners and between
vertices alike.

**Broad phase.** Past `BROAD_PHASE_MIN_PAIRS` primitive pairs (patterns of many panels), the
force, the energy and the collision check first box every body (`_near_bodies`) and evaluate only
the pairs of bodies whose boxes, grown by the reach, overlap (`_broad`): the others are beyond it,
where their terms are exactly zero.

**Reports.** `report`'s penetration is the exact depth by which two plates overlap (the shortest
translation that separates them, `overlap_depth`): as prisms of their thicknesses for panels apart
in the flat state; on their mid-surfaces for panels that touch in the flat state (a shared crease,
corner or cut edge), whose plates overlap along it by construction (a point hinge).

**Adhesion and friction** (`Adhesion`, `Friction`, module `_surface`): optional, off by default.
Adhesion adds a short-range attractive energy on quadrature points of the plates' faces and on
pairs of nearly parallel edges (seams); friction a smoothed Coulomb force at every primitive pair,
with the barrier's push as its normal force. Attach them with `from_mechanism(..., adhesion=,
friction=)` or `with_surface`.

Defaults (`PlateContact.for_system`) as `PanelContact`'s: ``ĝ`` = the larger of the panel thickness
and 0.5 % of the largest panel, ``κ = Σ ½ k θ_target²`` (the energy the hinges can release), ``c`` from
a damping ratio of the contact's stiffness at ``g = ĝ/2`` and the lightest panel's mass.
"""

import dataclasses

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from .._math import normalise
from ..system import AbstractContact, AbstractMechanism
from ._barrier import (
    DEFAULT_DAMPING_RATIO,
    _barrier_curvature,
    _barrier_slope,
    _rest_poses,
    barrier,
    check_contact_numbers,
    half_thicknesses,
    smoothstep,
    smoothstep_slope,
    with_base_pose,
    with_default_contact,
)
from ._pick import dense_pick, one_hot_rows, pick
from ._plate_geometry import (
    plate_half_thickness,
    plate_overlaps,
    plate_tables_for,
    plate_vertices,
)
from ._plate_tables import PlateTables
from ._primitives import (
    _closest,
    _closest_on_polygon,
    _normal,
    _split,
    _sub,
    _vcross,
    _vdot,
    closest_on_segments,
    earliest_impact,
    overlap_depth,
    point_polygon_sq,
    polygon_normal,
    segment_segment_sq,
)
from ._surface import (
    Adhesion,
    Friction,
    SurfaceTables,
    adhesion_energy,
    build_surface_tables,
    friction_wrenches,
)

# IPC's edge–edge mollifier switches on below this fraction of |e_a|²|e_b|² for |e_a × e_b|².
_PARALLEL = 1e-3
# The guard's impact distance ξ, as a fraction of the two plates' half-thicknesses added.
_CCD_SEPARATION = 0.5
# A working set's pairs are surely apart (`PlateContact._apart`) while its least gap, less twice
# the vertices' largest displacement, exceeds the activation gap by this factor (a margin for the
# rounding of the gaps).
_APART = 1.01
# Pairs of each kind whose time of impact the collision check iterates (`earliest_impact`).
_CCD_PAIRS = 32
# The broad phase (`PlateContact._broad`): patterns with more primitive pairs than this evaluate
# only the pairs whose bodies' bounding boxes come within reach. The catalogue's largest pattern
# (a 2×2 waterbomb) has about 2,000; one of 100 squares (120,000) takes a force in 40 % of the
# time, one of 200 in a quarter (`benchmarks/bench_broad_phase.py`). With the pairs gathered, the
# boxes break even at ~28,000 pairs (a strip of 50 squares) and save a third at 44,000 (62).
BROAD_PHASE_MIN_PAIRS = 1 << 15
# Room the broad phase keeps per body, for primitive pairs of each kind and for body pairs (a
# square among neighbours on every side meets each in ~24 primitive pairs); a state with more
# within reach evaluates every pair instead (the same result, at the full cost).
_BROAD_PAIRS_PER_BODY = 128
_BROAD_BODY_PAIRS_PER_BODY = 16


def _mollifier_parts(ea, eb):
    """IPC's mollifier ``m(x) = (2 − x/ε) x/ε`` below ``ε = 10⁻³ |e_a|²|e_b|²``, 1 beyond, with
    ``x = |e_a × e_b|²``, and its turns ``(e_a × ∂m/∂e_a, e_b × ∂m/∂e_b)``, all by component (edges
    and turns tuples of three `(m,)` arrays): the moment about the origin of the forces ``∓∂m/∂e``
    on an edge's two ends is ``−e × ∂m/∂e`` (the part of ``∂ε`` along ``e`` has none)."""
    cross = _vcross(ea, eb)
    eps = _PARALLEL * _vdot(ea, ea) * _vdot(eb, eb)
    r = _vdot(cross, cross) / eps
    mollifier = jnp.where(r < 1, (2 - r) * r, 1.0)
    scale = jnp.where(r < 1, 2 - 2 * r, 0.0) * 2 / eps
    turn_a = _vcross(ea, _vcross(eb, cross))
    turn_b = _vcross(eb, _vcross(cross, ea))
    return mollifier, (tuple(scale * c for c in turn_a), tuple(scale * c for c in turn_b))


def _mollifier(ea, eb):
    """`_mollifier_parts`' mollifier of edges `(m, 3)`."""
    return _mollifier_parts(_split(ea), _split(eb))[0]


class _Pairs(eqx.Module):
    """Every primitive pair's state at some world vertices (vertex–face pairs first, then
    edge–edge), vectors by component (tuples of three `(k,)` arrays: elementwise arithmetic over
    the pairs vectorises, over a batch too, where a trailing axis of three does not): the closest
    points `on_first` and `on_second` on the pair's first and second bodies, `direction`
    ``∂g/∂(on_first)`` (the unit normal from the second towards the first, shortened by the
    distance's smoothing), the `gap` `(k,)` (length), the energy's `weight` (the edge pairs'
    mollifier, 1 for vertex–face pairs) and the edge pairs' mollifier turns
    (`_mollifier_parts`, `(m,)` components)."""

    on_first: tuple[Array, Array, Array]
    on_second: tuple[Array, Array, Array]
    direction: tuple[Array, Array, Array]
    gap: Array
    weight: Array
    turns: tuple[tuple[Array, Array, Array], tuple[Array, Array, Array]]

    def midpoints(self):
        """The midpoints of the closest points, `(k, 3)`."""
        return 0.5 * (jnp.stack(self.on_first, axis=-1) + jnp.stack(self.on_second, axis=-1))

    def normals(self):
        """The unit normals from the second body towards the first, `(k, 3)`."""
        return normalise(jnp.stack(_sub(self.on_first, self.on_second), axis=-1))


class PairSelection(eqx.Module):
    """The primitive pairs a contact evaluates for a while (`PlateContact.select_pairs`): the rows
    of the vertex–face and edge–edge tables kept, `(k,)` and `(m,)` integer indices; `cut`, the
    smallest gap (length) of the pairs left out (``inf`` where none is); `at`, the world vertices
    `(n, v, 3)` at which the gaps were taken (the collision check bounds the left-out pairs from
    there); `least`, the smallest gap of every pair there, kept or left out (`None`: not known).
    Where no vertex has moved far enough from `at` for the `least` gap to close to the activation
    gap, the contact's force and derivatives are zero and its collision check clear without
    evaluating a pair (`PlateContact._apart`)."""

    vertex_face: Array
    edge_edge: Array
    cut: Array
    at: Array
    least: Array | None = None


class PlateContact(AbstractContact):
    """Exact contact between the plates of a mechanism and its fixed base, with continuous collision
    detection (module docstring: the model).

    **Fields:**
    - `tables`: the [`origami_jax.contact.PlateTables`][] geometry (its coordinates are data, its
      index tables static).
    - `stiffness`: ``κ``, energy units (µN·µm = pJ in `MICRO`).
    - `activation`: ``ĝ``, the gap at which contact switches on, length.
    - `damping`: ``c``, force·time/length, per primitive pair in contact.
    - `half_thickness`: half of each body's thickness, the base last, `(n,)`, length.
    - `adhesion`: an [`origami_jax.contact.Adhesion`][] or `None` (default: none).
    - `friction`: a [`origami_jax.contact.Friction`][] or `None` (default: frictionless).
    - `surface` (static): adhesion's quadrature points and edge pairs
      ([`origami_jax.contact.SurfaceTables`][]), present with `adhesion`.
    - `selection`: `None` (every primitive pair, the default) or a `PairSelection` of the pairs
      evaluated (`select_pairs`: an implicit step's working set).

    Build it with [`origami_jax.contact.PlateContact.for_system`][] (defaults from the hinges and
    panels) or `PlateContact.from_mechanism`.
    """

    tables: PlateTables
    stiffness: Float[Array, ""]
    activation: Float[Array, ""]
    damping: Float[Array, ""]
    half_thickness: Float[Array, " n"]
    adhesion: Adhesion | None = None
    friction: Friction | None = None
    surface: SurfaceTables | None = eqx.field(static=True, default=None)
    selection: PairSelection | None = None

    def __check_init__(self):
        self._check_surface()

    def _check_surface(self):
        # Also checked where adhesion is used: `eqx.tree_at` builds a module without its checks.
        if self.adhesion is not None and self.surface is None:
            raise ValueError(
                "PlateContact.adhesion needs its surface tables: attach it with "
                "PlateContact.with_surface(mechanism, adhesion=...) or from_mechanism(adhesion=...)."
            )

    @classmethod
    def from_mechanism(
        cls,
        mechanism: AbstractMechanism,
        *,
        thickness: Float[ArrayLike, "*#b"],
        stiffness: Float[ArrayLike, ""],
        damping: Float[ArrayLike, ""],
        activation: Float[ArrayLike, ""] | None = None,
        base_outline: np.ndarray | None = None,
        base_thickness: Float[ArrayLike, ""] | None = None,
        tables: PlateTables | None = None,
        adhesion: Adhesion | None = None,
        friction: Friction | None = None,
    ) -> "PlateContact":
        """Contact of `mechanism`'s panels (their `outlines()`) with each other and with its base.

        **Arguments** (the mechanism's units): `thickness` per panel (scalar or `(b,)`), `stiffness`
        ``κ``, `damping` ``c``, `activation` ``ĝ`` (default: the larger of the thickness and 0.5 % of
        the largest panel), `base_outline` (world polygon; default the mechanism's
        `base_outline()`), `base_thickness` (default the largest panel thickness), `tables` (the
        geometry, from `tables_for`, when at hand: under `jit` the mechanism's own arrays are traced
        and cannot give it), `adhesion` and `friction` (`with_surface`; default none). The numbers
        may be traced; the geometry may not.

        **Raises:** `ValueError` for non-positive values (when known) or degenerate outlines.
        """
        dtype = jnp.result_type(float)
        thickness, half = half_thicknesses(mechanism, thickness, base_thickness)
        if tables is None:
            tables = cls.tables_for(mechanism, base_outline=base_outline)
        if activation is None:
            activation = jnp.maximum(jnp.max(thickness), 0.005 * tables.scale)
        activation = jnp.asarray(activation, dtype)
        check_contact_numbers(thickness, stiffness, damping, activation)
        n_all = tables.n_all
        contact = cls(
            tables=tables,
            stiffness=jnp.asarray(stiffness, dtype),
            activation=activation,
            damping=jnp.asarray(damping, dtype),
            half_thickness=half[:n_all],
        )
        if adhesion is None and friction is None:
            return contact
        return contact.with_surface(mechanism, adhesion=adhesion, friction=friction)

    def with_surface(
        self,
        mechanism: AbstractMechanism,
        *,
        adhesion: Adhesion | None = None,
        friction: Friction | None = None,
        clearance: float | None = None,
    ) -> "PlateContact":
        """This contact with `adhesion` and `friction` (each replaced, `None` removes it) for
        `mechanism` (the one the tables were built for; its flat state places adhesion's
        quadrature points, `build_surface_tables`, whose `clearance` this passes on). The
        mechanism's geometry must be known (not traced), as for `tables_for`."""
        surface = None
        if adhesion is not None:
            try:
                rest = np.asarray(_rest_poses(mechanism))
            except jax.errors.TracerArrayConversionError as error:
                raise ValueError(
                    "adhesion needs the panels' flat state before compilation: attach it to a "
                    "contact built outside jit, vmap or grad."
                ) from error
            layout = mechanism.hinge_layout()
            surface = build_surface_tables(
                self.tables,
                rest,
                layout.parent,
                layout.child,
                layout.ends,
                samples=adhesion.samples,
                clearance=clearance,
            )
        return dataclasses.replace(self, adhesion=adhesion, friction=friction, surface=surface)

    @staticmethod
    def tables_for(
        mechanism: AbstractMechanism, *, base_outline: np.ndarray | None = None
    ) -> PlateTables:
        """The plate geometry of a mechanism whose arrays are known (host; `PlateTables`): its
        outlines, rest poses and hinge layout."""
        return plate_tables_for(mechanism, base_outline=base_outline)

    @classmethod
    def for_system(
        cls,
        mechanism: AbstractMechanism,
        hinge_stiffness: Float[ArrayLike, " h"],
        hinge_target: Float[ArrayLike, " h"],
        *,
        thickness: Float[ArrayLike, "*#b"],
        damping_ratio: float = DEFAULT_DAMPING_RATIO,
        **kwargs,
    ) -> "PlateContact":
        """Contact with defaults from the hinges and panels (module docstring, "Defaults"):
        ``κ = Σ ½ k θ_target²``; ``c = 2 ζ sqrt(k_c m)`` with ``k_c = κ B''(½)/ĝ²`` and ``m`` the
        lightest panel's mass (the smallest diagonal entry of ``M(0)`` over its squared lever arm,
        the panel size), ``ζ`` = `damping_ratio`. Other keyword arguments go to `from_mechanism`.
        Traceable in the hinges, the thickness and the mechanism's masses."""
        return with_default_contact(
            cls, mechanism, hinge_stiffness, hinge_target, damping_ratio, thickness, kwargs
        )

    # ---- geometry ----

    def _frames(self, poses):
        """World poses `(n, 4, 4)` of every body, the base last, from the moving bodies' poses."""
        return with_base_pose(self.tables, poses)

    def vertices(self, mechanism: AbstractMechanism, q: Float[Array, " nq"]) -> Array:
        """World positions of every plate's polygon vertices at ``q``, `(p, v, 3)` (a body's
        plates: one, or a non-convex panel's convex pieces; the base's last; padded by repeating a
        vertex), length units."""
        return self._world(self._frames(mechanism.body_poses(q)))

    def _world(self, poses):
        return plate_vertices(self.tables, poses)

    # The primitives' points are picked from the world vertices by gathers, their wrenches summed
    # onto the bodies by scatter-adds (`_pick`'s module docstring: faster than one-hot products).

    def _rows(self):
        """The vertex–face `(k, 3)` and edge–edge `(m, 6)` table rows evaluated: every one (host
        arrays), or those of the `selection` (traced)."""
        if self.selection is None:
            return self.tables.vertex_face, self.tables.edge_edge
        return (
            jnp.asarray(self.tables.vertex_face)[self.selection.vertex_face],
            jnp.asarray(self.tables.edge_edge)[self.selection.edge_edge],
        )

    def _vertex_face_points(self, x):
        """The vertex–face pairs' points: each vertex `(k, 3)` and the other polygon `(k, v, 3)`."""
        a, i, b = self._rows()[0].T
        n, v = x.shape[:2]
        flat = x.reshape(n * v, 3)
        point = pick(a * v + i, n * v, flat)
        polygon = pick((b[:, None] * v + np.arange(v)).ravel(), n * v, flat)
        return point, polygon.reshape(a.shape[0], v, 3)

    def _edge_edge_points(self, x):
        """The edge–edge pairs' end points, four `(m, 3)` arrays."""
        a, i0, i1, b, j0, j1 = self._rows()[1].T
        n, v = x.shape[:2]
        flat = x.reshape(n * v, 3)
        return tuple(
            pick(body * v + k, n * v, flat) for body, k in ((a, i0), (a, i1), (b, j0), (b, j1))
        )

    def _half_sums(self, dtype):
        """The two half-thicknesses of each vertex–face and each edge–edge pair, added."""
        half = plate_half_thickness(self.tables, self.half_thickness).astype(dtype)
        vf, ee = self._rows()
        return half[vf[:, 0]] + half[vf[:, 2]], half[ee[:, 0]] + half[ee[:, 3]]

    def _gaps(self, x):
        """Every primitive pair's gap (length; vertex–face pairs first, then edge–edge) and the
        edge–edge pairs' mollifier, at world vertices `x`."""
        tiny = 1e-6 * self.activation
        point, polygon = self._vertex_face_points(x)
        d_vf = point_polygon_sq(point, polygon, polygon_normal(polygon))
        p0, p1, q0, q1 = self._edge_edge_points(x)
        d_ee = segment_segment_sq(p0, p1, q0, q1)
        half_vf, half_ee = self._half_sums(x.dtype)
        distance = jnp.sqrt(jnp.concatenate([d_vf, d_ee]) + tiny**2) - tiny
        return distance - jnp.concatenate([half_vf, half_ee]), _mollifier(p1 - p0, q1 - q0)

    def _pairs(self, x) -> _Pairs:
        """The primitive pairs' closest points, gaps and directions at world vertices `x`
        (`_Pairs`): the gaps of `_gaps`, and ``∂g/∂x`` as a direction at two points. Any
        change of the vertices that moves each body rigidly changes a gap by the direction dotted
        with the motion of the first point less that of the second (the closest points are where
        the distance is least: the derivative of a minimum is the derivative at its minimiser), so
        the forces and rates of contact need no differentiation of the distances."""
        tiny = 1e-6 * self.activation
        point, polygon = self._vertex_face_points(x)
        point, polygon = _split(point), _split(polygon)
        on_face = _closest_on_polygon(point, polygon, _normal(polygon))
        p0, p1, q0, q1 = (_split(e) for e in self._edge_edge_points(x))
        on_p, on_q = _closest(p0, p1, q0, q1)
        first = tuple(jnp.concatenate(c) for c in zip(point, on_p, strict=True))
        second = tuple(jnp.concatenate(c) for c in zip(on_face, on_q, strict=True))
        apart = _sub(first, second)
        smoothed = jnp.sqrt(_vdot(apart, apart) + tiny**2)
        half_vf, half_ee = self._half_sums(x.dtype)
        gap = smoothed - tiny - jnp.concatenate([half_vf, half_ee])
        mollifier, turns = _mollifier_parts(_sub(p1, p0), _sub(q1, q0))
        weight = jnp.concatenate([jnp.ones(len(half_vf), x.dtype), mollifier])
        direction = tuple(c / smoothed for c in apart)
        return _Pairs(first, second, direction, gap, weight, turns)

    def _pair_rates(self, pairs: _Pairs, velocity):
        """Each pair's gap rate ``ġ`` `(k,)` under world body twists `velocity` `(n, 6)` (the base
        last): the direction dotted with the first point's velocity less the second's."""
        a, b = self._pair_bodies()
        n = velocity.shape[0]
        first, second = pick(a, n, velocity), pick(b, n, velocity)
        speed_first = _point_velocity(_split6(first), pairs.on_first)
        speed_second = _point_velocity(_split6(second), pairs.on_second)
        return _vdot(pairs.direction, _sub(speed_first, speed_second))

    def _gap_gradient(self, pairs: _Pairs, unit_twists):
        """``G = ∂g/∂q̇`` `(k, nv)`: each pair's gap rate per unit generalized velocity, from the
        bodies' unit twists `(n, 6, nv)` (the base last): each pair's unit wrenches on the bodies,
        ``(u, p × u)`` on its first body at its point ``p`` and the opposite on its second, `(k,
        6n)`, times the twists `(6n, nv)`: each pair's two bodies' twists gathered, or one dense
        product with one-hot matrices where `DENSE_PICK_LIMIT` allows it (`_pick`)."""
        a, b = self._pair_bodies()
        n, _, nv = unit_twists.shape
        u = pairs.direction
        wrench_first = jnp.stack([*u, *_vcross(pairs.on_first, u)], axis=-1)
        wrench_second = jnp.stack([*u, *_vcross(pairs.on_second, u)], axis=-1)
        if not dense_pick(a, n):
            # Gathered (the default; `_pick`'s module docstring).
            return jnp.einsum("kc,kcv->kv", wrench_first, unit_twists[a]) - jnp.einsum(
                "kc,kcv->kv", wrench_second, unit_twists[b]
            )
        first, second = one_hot_rows(a, n, u[0].dtype), one_hot_rows(b, n, u[0].dtype)
        wrenches = (
            first[:, :, None] * wrench_first[:, None, :]
            - second[:, :, None] * wrench_second[:, None, :]
        )
        return wrenches.reshape(-1, n * 6) @ unit_twists.reshape(n * 6, nv)

    def _pair_wrenches(self, pairs: _Pairs, push, on_mollifier, n: int):
        """One world wrench per body `(n, 6)` from each pair's `push` ``∂E/∂g`` (plus damping) along
        its direction (``−push·direction`` at the first point, the opposite at the second) and the
        edge pairs' energy `on_mollifier` ``κ B`` turning them through the mollifier."""
        a, b = self._pair_bodies()
        force = tuple(-push * c for c in pairs.direction)
        n_vf = self._rows()[0].shape[0]
        zeros = jnp.zeros((n_vf,), push.dtype)
        turn_a, turn_b = (
            tuple(jnp.concatenate([zeros, -on_mollifier * c]) for c in turn) for turn in pairs.turns
        )
        moment_first = _vcross(pairs.on_first, force)
        moment_second = _vcross(pairs.on_second, force)
        on_first = jnp.stack(
            [*force, *(m + t for m, t in zip(moment_first, turn_a, strict=True))], axis=-1
        )
        on_second = jnp.stack(
            [*(-f for f in force), *(t - m for m, t in zip(moment_second, turn_b, strict=True))],
            axis=-1,
        )
        return pick(a, n, on_first, transpose=True) + pick(b, n, on_second, transpose=True)

    def _energy(self, x):
        gap, mollifier = self._gaps(x)
        n_vf = self._rows()[0].shape[0]
        weight = jnp.concatenate([jnp.ones(n_vf, x.dtype), mollifier])
        return self.stiffness * jnp.sum(weight * barrier(gap / self.activation))

    def _wrenches(self, x, forces):
        """One world wrench ``(F, x × F)`` about the origin per body from forces on its plates'
        vertices."""
        wrenches = jnp.concatenate(
            [jnp.sum(forces, axis=1), jnp.sum(jnp.cross(x, forces), axis=1)], axis=-1
        )
        if self.tables.plate_body is None:
            return wrenches
        return jnp.zeros((self.tables.n_all, 6), x.dtype).at[self.tables.plate_body].add(wrenches)

    # ---- the contact force ----

    def _adhesion(self, x):
        """The adhesive energy at world vertices `x` (0 without adhesion)."""
        if self.adhesion is None:
            return jnp.zeros((), x.dtype)
        self._check_surface()
        half = plate_half_thickness(self.tables, self.half_thickness)
        return adhesion_energy(self.adhesion, self.surface, half, x)

    def potential(self, mechanism, q):
        x = self.vertices(mechanism, q)
        energy = self._broad(x, x, self.activation, lambda contact: contact._energy(x))
        if self.adhesion is None:
            return energy
        return energy + self._adhesion(x)

    def force(self, mechanism, q, v):
        if not self._has_broad_phase():
            return self._unless_apart(
                mechanism,
                q,
                v,
                lambda motion: self._force(mechanism, q, v, motion)[0],
                jnp.zeros_like(v),
            )
        x = self.vertices(mechanism, q)
        return self._broad(
            x, x, self.activation, lambda contact: contact._force(mechanism, q, v)[0]
        )

    # ---- the broad phase ----

    def _has_broad_phase(self) -> bool:
        """Whether this contact sorts out far pairs before evaluating (a large pattern, and no
        working set chosen already): `BROAD_PHASE_MIN_PAIRS`."""
        return self.selection is None and self.tables.n_primitives > BROAD_PHASE_MIN_PAIRS

    def _near_bodies(self, x0, x1, reach):
        """`(n, n)` bool: whether two bodies' bounding boxes, over world vertices `x0` and `x1`
        (`(n, v, 3)`; a step's two ends: every point of a plate on the straight path between them
        stays in the box of both), each grown by its half-thickness and half of `reach`, overlap.
        Two bodies whose boxes do not are more than `reach` apart plate to plate throughout, so
        none of their primitive pairs is within `reach` (a force's activation gap, a collision
        check's ``ξ``) and none of their polygons overlaps."""
        lo = jnp.minimum(jnp.min(x0, axis=1), jnp.min(x1, axis=1))
        hi = jnp.maximum(jnp.max(x0, axis=1), jnp.max(x1, axis=1))
        # 1 % more: the gaps are taken on a smoothed distance, a hair shorter than the box bound.
        half = plate_half_thickness(self.tables, self.half_thickness).astype(x0.dtype)
        grow = (half + 0.505 * reach)[:, None]
        lo, hi = lo - grow, hi + grow
        return jnp.all((lo[:, None] <= hi[None, :]) & (lo[None, :] <= hi[:, None]), axis=-1)

    def _broad(self, x0, x1, reach, evaluate):
        """`evaluate(contact)` of this contact narrowed to the primitive pairs whose bodies come
        within `reach` between world vertices `x0` and `x1` (`_near_bodies`), where there is room
        for them, else of this contact whole; `evaluate(self)` without a broad phase. Each kind of
        pair is kept in a fixed number of rows (`_BROAD_PAIRS_PER_BODY` per body), filled up with
        distinct pairs from far bodies, whose barrier, damping and friction are exactly zero, so
        the result is the whole contact's either way."""
        if not self._has_broad_phase():
            return evaluate(self)
        near = self._near_bodies(x0, x1, reach)
        n = self.tables.vertices.shape[0]
        kept, overflow = [], jnp.zeros((), bool)
        for rows, second in ((self.tables.vertex_face, 2), (self.tables.edge_edge, 3)):
            index, full = _compact(near[rows[:, 0], rows[:, second]], _BROAD_PAIRS_PER_BODY * n)
            kept.append(index)
            overflow = overflow | full
        inf = jnp.full((), jnp.inf, x0.dtype)
        narrow = dataclasses.replace(self, selection=PairSelection(*kept, inf, x0))
        return jax.lax.cond(overflow, lambda: evaluate(self), lambda: evaluate(narrow))

    def _force(self, mechanism, q, v, motion=None):
        """The generalized force at ``(q, v)`` and what `force_jacobians` builds on: the pairs
        (`_Pairs`), their rates, the bodies' world twists and the mechanism's wrench map.
        `motion`: the mechanism's `body_motion(q, v)` where the caller has it."""
        poses, velocity, wrench_force = mechanism.body_motion(q, v) if motion is None else motion
        poses = self._frames(poses)
        velocity = self._with_base_twist(velocity)
        x = self._world(poses)
        pairs = self._pairs(x)
        rate = self._pair_rates(pairs, velocity)
        ratio = pairs.gap / self.activation
        # ∂E/∂g of the barrier, and the damping along the same direction.
        push = (
            self.stiffness * pairs.weight * _barrier_slope(ratio) / self.activation
            + self.damping * smoothstep(1 - ratio) * rate
        )
        n_vf = self._rows()[0].shape[0]
        on_mollifier = self.stiffness * barrier(ratio[n_vf:])
        wrenches = self._pair_wrenches(pairs, push, on_mollifier, self.tables.n_all)
        if self.adhesion is not None:
            wrenches = wrenches + self._wrenches(x, -jax.grad(self._adhesion)(x))
        if self.friction is not None:
            # The normal force of each pair: the barrier's push alone (not its damping).
            normal_force = -self.stiffness * pairs.weight * _barrier_slope(ratio) / self.activation
            a, b = self._pair_bodies()
            wrenches = wrenches + friction_wrenches(
                self.friction, normal_force, pairs.midpoints(), pairs.normals(), a, b, velocity
            )
        return wrench_force(wrenches[: self.tables.n_bodies]), pairs, rate, velocity

    def _with_base_twist(self, velocity):
        if self.tables.has_base:
            return jnp.concatenate([velocity, jnp.zeros((1, 6), velocity.dtype)], axis=0)
        return velocity

    def force_jacobians(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"], v: Float[Array, " nv"]
    ) -> tuple[Float[Array, " nv"], Float[Array, "nv nq"], Float[Array, "nv nv"]]:
        zeros = (
            jnp.zeros_like(v),
            jnp.zeros(v.shape + q.shape, v.dtype),
            jnp.zeros(v.shape + v.shape, v.dtype),
        )
        return self._unless_apart(
            mechanism, q, v, lambda motion: self._force_jacobians(mechanism, q, v, motion), zeros
        )

    def _force_jacobians(self, mechanism, q, v, motion=None):
        """The force at ``(q, v)`` with Gauss–Newton approximations of its derivatives
        ``(f, ∂f/∂q, ∂f/∂v)`` (what an implicit step's Newton iterations need).

        The barrier and its damping act on each pair along its gap's gradient ``G_p = ∂g_p/∂q``
        (each row the pair's direction paired with the unit twists of the mechanism); holding
        ``G`` fixed, ``∂f/∂q ≈ −Gᵀ diag(κ m B''/ĝ² + c a'(g) ġ) G`` and ``∂f/∂v = −Gᵀ diag(c a(g)) G``,
        as IPC's Newton iterations do. Left out: the change of the contact directions and points
        (the barrier's force times the pairs' curvature, small against the barrier's stiffness
        near contact), the mollifier's and adhesion's and friction's own derivatives. Symmetric and
        positive semi-definite in the barrier's part. Exact values of ``f``; only the Newton
        directions use the approximations, so a converged step is the same root."""
        if motion is None:
            motion = mechanism.body_motion(q, v)
        force, pairs, rate, _ = self._force(mechanism, q, v, motion)
        # The bodies' twists per unit generalized velocity, `(n, 6, nv)` (the base's zero): the
        # wrench map's transpose (a unit wrench's generalized force is the twist per unit
        # velocity it pairs with), without evaluating the kinematics again.
        unit_twists = _unit_twists(motion[2], motion[1].shape[0], v.dtype)
        if self.tables.has_base:
            unit_twists = jnp.concatenate([unit_twists, jnp.zeros_like(unit_twists[:1])], axis=0)
        gradient = self._gap_gradient(pairs, unit_twists)
        ratio = pairs.gap / self.activation
        ramp = smoothstep(1 - ratio)
        stiffness = (
            self.stiffness * pairs.weight * _barrier_curvature(ratio) / self.activation**2
            - self.damping * smoothstep_slope(1 - ratio) * rate / self.activation
        )
        d_dq = -_weighted_gram(gradient, jnp.maximum(stiffness, 0.0))
        d_dv = -_weighted_gram(gradient, self.damping * ramp)
        return force, d_dq, d_dv

    def _apart(self, x):
        """Whether every primitive pair is surely beyond the activation gap at world vertices `x`
        (boolean scalar), from the `selection`'s least gap: a gap (a distance between two plates'
        primitives less their half-thicknesses) shrinks no more than its two primitives move, and
        no point of a plate moves further than its farthest vertex, so by at most twice the largest
        vertex displacement from where it was taken. `None` where that cannot tell: no selection
        that knows its least gap, or adhesion, whose range is its own."""
        selection = self.selection
        if selection is None or selection.least is None or self.adhesion is not None:
            return None
        drift = jnp.max(jnp.linalg.norm(x - selection.at, axis=-1))
        return selection.least - 2 * drift > _APART * self.activation

    def surely_apart(self, mechanism: AbstractMechanism, q: Float[Array, " nq"]) -> Array | None:
        """Whether every primitive pair is surely beyond the activation gap at ``q``, where the
        contact has no force (boolean scalar): from a working set's least gap (`_apart`), or
        without one from every pair's gap; `None` with adhesion (whose range is its own)."""
        if self.adhesion is not None:
            return None
        if self.selection is None:
            gap, _ = self._every_gap(mechanism, q)
            return jnp.min(gap, initial=jnp.inf) > _APART * self.activation
        return self._apart(self.vertices(mechanism, q))

    def _unless_apart(self, mechanism, q, v, evaluate, zero):
        """`evaluate(motion)` (the force, or the force and its derivatives) with the mechanism's
        `body_motion(q, v)` (`None` without a working set), or `zero` where every pair is surely
        beyond the activation gap at ``q`` (`_apart`), where the barrier, its damping and friction
        are exactly zero, without evaluating a pair (`_computed_where`). The kinematics are
        evaluated once for both."""
        if self.selection is None:
            return evaluate(None)
        motion = mechanism.body_motion(q, v)
        apart = self._apart(self._world(self._frames(motion[0])))
        if apart is None:
            return evaluate(motion)
        return _computed_where(~apart, lambda: evaluate(motion), zero)

    # ---- a working set of pairs ----

    def select_pairs(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"], counts: tuple[int, int]
    ) -> "PlateContact":
        """This contact evaluating only the primitive pairs of least gap at ``q``: `counts` ``(k,
        m)`` vertex–face and edge–edge pairs (each at most as many as there are). The forces and
        their derivatives are those of every pair as long as each pair left out stays beyond the
        activation gap, where it has none (`left_out_engaged` tells); the collision check still
        covers every pair, the left-out ones by a bound from their least gap (`_left_out_impact`),
        so no plate passes through another either way. An implicit step's working set
        (`ImplicitStep.active_pairs`): its Newton iterations then cost in proportion to the pairs
        kept, not to every pair of the pattern."""
        gap, x = self._every_gap(mechanism, q)
        return dataclasses.replace(self, selection=self._selection_from(gap, x, counts))

    def _selection_from(self, gap, x, counts) -> PairSelection:
        """The working set of `select_pairs` from every pair's gap `gap` at world vertices `x`."""
        n_vf = len(self.tables.vertex_face)
        cut = jnp.full((), jnp.inf, x.dtype)
        least = jnp.min(gap, initial=jnp.inf)
        kept = []
        for part, count in ((gap[:n_vf], counts[0]), (gap[n_vf:], counts[1])):
            size = part.shape[0]
            count = min(int(count), size)
            if size == 0 or count == 0:
                kept.append(jnp.zeros((0,), jnp.int32))
                if size:
                    cut = jnp.minimum(cut, jnp.min(part))
                continue
            smallest, index = jax.lax.top_k(-part, min(count + 1, size))
            if size > count:
                cut = jnp.minimum(cut, -smallest[count])
            kept.append(index[:count])
        return PairSelection(*kept, cut, x, least)

    def _has_room(self, mechanism, q) -> Array:
        """Whether the `selection` still has room at ``q``: the vertices have drifted from where it
        was chosen by less than a quarter of its least gap's margin over the activation gap, so
        every pair is still beyond that gap by half the margin (`_apart`) and choosing again would
        evaluate no force either."""
        selection = self.selection
        drift = jnp.max(jnp.linalg.norm(self.vertices(mechanism, q) - selection.at, axis=-1))
        return 4 * drift < selection.least - _APART * self.activation

    def next_working_set(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"], counts: tuple[int, int]
    ) -> tuple[PairSelection, Array]:
        """At the end ``q`` of a step taken on this contact's working set (its `selection`,
        chosen by `select_pairs` with these `counts`): the next step's working set, this one while
        it has room at ``q`` (`_has_room`), else one chosen again at ``q``; and whether a pair this
        one left out is within the activation gap at ``q`` (`left_out_engaged`), from one
        evaluation of every pair's gap where either needs it (a working set kept for its room
        leaves every pair apart). A kept working set bounds every pair as a fresh one does (its
        gaps, cut and least gap as taken, less the drift since), so the collision check stays
        conservative; it spares each step of a fold's free flight every pair's gap and their
        sorting."""

        def chosen_again():
            gap, x = self._every_gap(mechanism, q)
            return self._selection_from(gap, x, counts), self._left_out_within(gap)

        return _computed_where(
            ~self._has_room(mechanism, q), chosen_again, (self.selection, jnp.zeros((), bool))
        )

    def _left_out_within(self, gap) -> Array:
        """Whether a pair left out of the `selection` has its gap (of every pair's, `gap`) within
        the activation gap."""
        n_vf = len(self.tables.vertex_face)
        kept = (
            jnp.zeros(gap.shape, bool)
            .at[self.selection.vertex_face]
            .set(True)
            .at[n_vf + self.selection.edge_edge]
            .set(True)
        )
        return jnp.any(~kept & (gap < self.activation))

    def _every_gap(self, mechanism, q):
        """Every primitive pair's gap at ``q`` whatever the `selection` (vertex–face pairs first,
        as the tables), and the world vertices."""
        full = dataclasses.replace(self, selection=None)
        x = full.vertices(mechanism, q)
        return full._gaps(x)[0], x

    def left_out_engaged(self, mechanism: AbstractMechanism, q: Float[Array, " nq"]) -> Array:
        """Whether some primitive pair left out of the `selection` is within the activation gap at
        ``q`` (a force the selection missed; boolean scalar, `False` without a selection)."""
        if self.selection is None:
            return jnp.zeros((), bool)
        return self._left_out_within(self._every_gap(mechanism, q)[0])

    # ---- continuous collision detection (the step guard) ----

    def time_of_impact(
        self, mechanism: AbstractMechanism, q0: Float[Array, " nq"], q1: Float[Array, " nq"]
    ) -> Float[Array, ""]:
        """The largest fraction of the straight step from ``q0`` to ``q1`` (in the vertices'
        positions) that no primitive pair is known to take closer than ``ξ``: a conservative time of
        impact in ``[0, 1]``, 1 where the whole step is clear (a line search's cap, as in IPC)."""
        x0, x1 = self.vertices(mechanism, q0), self.vertices(mechanism, q1)
        return jnp.minimum(self._swept_impact(x0, x1), 1.0)

    def _swept_impact(self, x0, x1):
        """`_earliest_impact` over the pairs whose bodies' boxes, swept from `x0` to `x1`, come
        within reach of each other (`_broad`; ``ξ`` is less than the two half-thicknesses the boxes
        are grown by, so a pair left out cannot come within it)."""
        return self._broad(x0, x1, 0.0, lambda contact: contact._earliest_impact(x0, x1))

    def _earliest_impact(self, x0, x1):
        """The earliest conservative time of impact of any primitive pair between world vertices
        `x0` and `x1` (`earliest_impact`: at most `_CCD_PAIRS` pairs of each kind iterated, a lower
        bound for the others), ``inf`` where none comes within ``ξ``; pairs already closer than
        ``ξ`` at `x0` are not counted (the barrier pushes them apart; a step cannot be refused for
        them). With a `selection`, the pairs left out are bounded together (`_left_out_impact`)."""
        if self.selection is None:
            return self._iterated_impact(x0, x1)
        never = jnp.full((), jnp.inf, x0.dtype)
        if self.selection.least is None:
            return jnp.minimum(self._iterated_impact(x0, x1), self._left_out_impact(x0, x1))
        # Every pair bounded as the left-out ones are (from the least gap) clears the whole path:
        # the iterated pairs would find no impact either (each stops at the same fraction of its
        # own clearance, at least this one), so none is evaluated.
        clear = self._left_out_impact(x0, x1, gap=self.selection.least) > 1
        return _computed_where(
            ~clear,
            lambda: jnp.minimum(self._iterated_impact(x0, x1), self._left_out_impact(x0, x1)),
            never,
        )

    def _iterated_impact(self, x0, x1):
        """`earliest_impact` of the pairs evaluated, ``inf`` where there are none."""
        groups = self._ccd_groups(x0, x1)
        if not groups:
            return jnp.full((), jnp.inf, x0.dtype)
        return earliest_impact(groups, limit=_CCD_PAIRS)

    def _left_out_impact(self, x0, x1, conservative: float = 0.1, gap=None):
        """A lower bound of the time of impact of every pair left out of the `selection`, on the
        straight path from world vertices `x0` to `x1` (``inf`` where none can come within ``ξ``);
        with `gap` (the selection's `least`), of every pair.

        Each left-out pair's distance less its ``ξ`` was at least ``cut + (1 − ½)·(t_a + t_b)/2 ≥
        cut + ½ t_min`` where the selection was made (`selection.at`); a distance changes no more
        than its two primitives' points move, and no point of a plate moves further than its
        farthest vertex, so from there to `x0` it shrank by at most ``2 D`` (``D`` the largest
        vertex displacement) and along the path by at most ``2 M t`` (``M`` the largest vertex
        move over it). Stopping at the fraction ``1 − conservative`` of that, as the iterated
        pairs do, keeps a step short of any impact."""
        selection = self.selection
        half = jnp.min(self.half_thickness).astype(x0.dtype)
        drift = jnp.max(jnp.linalg.norm(x0 - selection.at, axis=-1))
        move = jnp.max(jnp.linalg.norm(x1 - x0, axis=-1))
        cut = selection.cut if gap is None else gap
        clearance = cut + 2 * (1 - _CCD_SEPARATION) * half - 2 * drift
        bound = (
            (1 - conservative) * jnp.maximum(clearance, 0.0) / jnp.where(move > 0, 2 * move, 1.0)
        )
        return jnp.where(move > 0, bound, jnp.inf)

    def _ccd_groups(self, x0, x1):
        """The vertex–face and edge–edge pairs' CCD arguments (`additive_ccd_groups`) between
        world vertices `x0` and `x1`."""
        half_vf, half_ee = self._half_sums(x0.dtype)
        groups = []
        for points, distance_sq, half in (
            (
                self._vertex_face_points,
                lambda p, poly: point_polygon_sq(p, poly, polygon_normal(poly)),
                half_vf,
            ),
            (self._edge_edge_points, segment_segment_sq, half_ee),
        ):
            if not len(half):
                continue
            start, end = points(x0), points(x1)
            motion = tuple(e - s for s, e in zip(start, end, strict=True))
            groups.append((distance_sq, start, motion, _CCD_SEPARATION * half))
        return groups

    def crossed(self, mechanism, q0, q1) -> Array:
        """Whether the straight path of every vertex from ``q0`` to ``q1`` brings a primitive pair
        closer than ``ξ`` (half the two half-thicknesses added; pairs already closer at ``q0`` are
        not counted, the barrier pushes them apart), or the polygons of two bodies overlap more at
        ``q1`` than at ``q0`` (boolean scalar): a step that would let a plate through another."""
        x0, x1 = self.vertices(mechanism, q0), self.vertices(mechanism, q1)
        hit = self._swept_impact(x0, x1) <= 1
        pairs = self.tables.plate_pairs[0]

        def grew(rows):
            a, b = rows.T
            before = overlap_depth(x0[a], x0[b])
            after = overlap_depth(x1[a], x1[b])
            return jnp.any(after > before + 1e-9 * self.tables.scale)

        if not self._has_broad_phase():
            return hit | grew(pairs)
        # Polygons whose swept boxes are apart overlap neither before nor after.
        near = self._near_bodies(x0, x1, 0.0)
        n = self.tables.vertices.shape[0]
        index, overflow = _compact(near[pairs[:, 0], pairs[:, 1]], _BROAD_BODY_PAIRS_PER_BODY * n)
        narrow = jnp.asarray(pairs)[index]
        return hit | jax.lax.cond(overflow, lambda: grew(pairs), lambda: grew(narrow))

    # ---- reports ----

    def penetration(self, mechanism: AbstractMechanism, q: Float[Array, " nq"]) -> Array:
        """The exact overlap of every pair of bodies at ``q`` (`(p,)` over `tables.body_pairs`,
        length): `plate_overlaps` (module docstring, "Reports")."""
        return plate_overlaps(self.tables, self.half_thickness, self.vertices(mechanism, q))

    def _pair_bodies(self):
        """The bodies of each evaluated pair's first and second plates, `(k,)` each."""
        vf, ee = self._rows()
        xp = np if self.selection is None else jnp
        a, b = xp.concatenate([vf[:, 0], ee[:, 0]]), xp.concatenate([vf[:, 2], ee[:, 3]])
        if self.tables.plate_body is None:
            return a, b
        body = xp.asarray(self.tables.plate_body)
        return body[a], body[b]

    def report(self, mechanism, q) -> dict[str, Array]:
        """Contact state at ``q``: the smallest primitive gap (length, `inf` if none is checked), how
        many primitive pairs are engaged (``g < 1.1 ĝ``), the penetration (the largest exact overlap
        of two bodies, `penetration`, length), and `touching` `(n, n)` bool over body pairs (the
        base last, symmetric): some primitive pair of the two is engaged, i.e. one rests on or meets
        the other (the verdict's seams closed by contact)."""
        x = self.vertices(mechanism, q)
        gap, _ = self._gaps(x)
        near = gap < 1.1 * self.activation
        n = self.tables.n_all
        a, b = self._pair_bodies()
        touching = jnp.zeros((n, n), bool).at[a, b].max(near)
        touching = touching | touching.T
        extra = {} if self.adhesion is None else {"adhesion": self._adhesion(x)}
        return extra | {
            "min_gap": jnp.min(gap, initial=jnp.inf),
            "engaged": jnp.sum(near),
            "penetration": jnp.max(
                plate_overlaps(self.tables, self.half_thickness, x), initial=0.0
            ),
            "touching": touching,
        }

    def engaged_points(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"]
    ) -> tuple[Float[Array, "n n 3"], Int[Array, "n n"]]:
        """Where the plates touch at ``q``, for drawing: for every ordered pair of bodies `(a, b)`
        (the base last) the mean world position of their engaged primitive pairs (``g < 1.1 ĝ``:
        the vertex of a vertex–face pair, the midpoint of an edge–edge pair's closest points),
        shape `(n, n, 3)` (length; zeros where none), and how many there are, `(n, n)`."""
        x = self.vertices(mechanism, q)
        gap, _ = self._gaps(x)
        near = (gap < 1.1 * self.activation).astype(x.dtype)
        point, _ = self._vertex_face_points(x)
        on_p, on_q = closest_on_segments(*self._edge_edge_points(x))
        where = jnp.concatenate([point, 0.5 * (on_p + on_q)], axis=0)
        n = self.tables.n_all
        a, b = self._pair_bodies()
        count = jnp.zeros((n, n), x.dtype).at[a, b].add(near)
        total = jnp.zeros((n, n, 3), x.dtype).at[a, b].add(near[:, None] * where)
        return total / jnp.maximum(count, 1)[..., None], count.astype(jnp.int32)


def _computed_where(needed, compute, otherwise):
    """`compute()` where the boolean scalar `needed` holds, else `otherwise` (of the same
    structure), computing it only when needed: a conditional whose branch index stays unbatched
    under `vmap` (`unvmap_any`: some member needs it), where a `lax.cond` of a batched index would
    compute both branches for every member. Each member's value is its own either way (the members
    that do not need it keep `otherwise` in both branches). Not a loop of one pass: XLA hoists a
    loop's body that does not depend on its carry, and computes it whatever the condition."""

    def computed():
        return jax.tree.map(lambda a, b: jnp.where(needed, a, b), compute(), otherwise)

    return jax.lax.cond(eqxi.unvmap_any(needed), computed, lambda: otherwise)


def _unit_twists(wrench_force, n: int, dtype) -> Array:
    """The world twists of `n` bodies per unit generalized velocity, `(n, 6, nv)`, from the wrench
    map `wrench_force` (world wrenches `(n, 6)` to generalized forces `(nv,)`): its transpose,
    since the power of a wrench ``W_b`` on twists ``V_b = J_b q̇`` is ``(Σ_b J_bᵀ W_b) · q̇``."""
    basis = jnp.eye(6 * n, dtype=dtype).reshape(6 * n, n, 6)
    return jax.vmap(wrench_force)(basis).reshape(n, 6, -1)


def _compact(flags: Array, size: int) -> tuple[Array, Array]:
    """The indices of the `True` entries of `flags` `(k,)` in `size` rows (at most `k`), filled up
    with distinct indices of `False` entries, and whether the `True` ones did not fit (then the
    rows hold the first `size` of them)."""
    size = min(size, flags.shape[0])
    count = jnp.sum(flags)
    chosen = jnp.nonzero(flags, size=size, fill_value=0)[0]
    others = jnp.nonzero(~flags, size=size, fill_value=0)[0]
    slot = jnp.arange(size)
    index = jnp.where(slot < count, chosen, others[jnp.maximum(slot - count, 0)])
    return index, count > size


def _split6(twists, axis=-1):
    """World twists ``(v, ω)`` along `axis` (of six) as two component triples."""
    parts = tuple(jnp.take(twists, j, axis=axis) for j in range(6))
    return parts[:3], parts[3:]


def _point_velocity(twist, point):
    """The velocity ``v + ω × p`` of a point `p` moving with twist ``(v, ω)``, by component."""
    linear, angular = twist
    return tuple(u + w for u, w in zip(linear, _vcross(angular, point), strict=True))


def _weighted_gram(rows, weights):
    """``Σ_k w_k g_k g_kᵀ`` `(nv, nv)` of rows `(k, nv)` and weights `(k,)` (``Gᵀ diag(w) G``)."""
    return jnp.sum(weights[:, None, None] * rows[:, :, None] * rows[:, None, :], axis=0)
