"""`PanelContact`: smooth, frictionless, energy-consistent contact between thin panels.

**Model.** Every panel is a plate of thickness ``t`` around its mid-plane. As other panels meet it, its
face is the convex hull of its outline moved ``ι`` inwards (``ι = 2δ`` by default, `ContactTables.
face_inset`), swept by a ball of radius ``t/2``: a plate with a rounded rim. Points sampled on each
panel (`ContactTables`: its centre, a ring on that inset rim, and points on the outline's rim itself,
two per edge, a quarter of the edge from its corners) are kept off the other panels' plates and the
fixed base's. For a point ``p`` and a face ``F`` (frame
``(R, o)``, ``p_F = Rᵀ (p − o)``, ``e_k`` its inward distance from the face's edge ``k``):

- *gap* ``g = sqrt(z² + Σ_k d_k²) − (t_p + t_F)/2`` with ``z = p_F,z`` and ``d_k = δ m((ι − e_k)/δ)``:
  over the inset face every ``d_k`` is 0 and ``g = |z| − (t_p + t_F)/2``, the clearance between the two
  plates' surfaces along the face's normal; beside it, ``g`` is the distance to the rim (to a corner
  where two ``d_k`` are on) less the two half-thicknesses. ``m`` is the integral of the C² smoothstep
  ``s(x) = x³(10 − 15x + 6x²)``, 0 for ``x ≤ 0`` and ``x − ½`` beyond 1, so ``g`` is C³ in ``p`` (the
  rim's edge rounded over ``δ``; ``|·|`` smoothed at 0 so that its gradient stays finite deep inside).

The contact energy is ``E = κ Σ w B(g/ĝ)`` with the barrier of Incremental Potential Contact (Li et al.,
SIGGRAPH 2020), ``B(x) = −(x − 1)² ln x`` for ``x < 1`` and 0 beyond: it switches on at the activation
gap ``ĝ``, is C² there, and grows without bound as the gap closes. Below ``x = 0.1`` it continues as its
own second-order Taylor polynomial, so that an integrator step that lands past contact sees a finite,
steep, restoring force instead of a NaN (penetration is then possible, and reported). Each pair's
energy depends only on the point's coordinates in the face's frame, so its force is a force at the point
and the opposite force on the face's body at the same place (virtual work); with a dissipative part
``−c w a(g) ġ ∇g`` (``a`` a C² ramp from 0 at ``ĝ`` to 1 at contact, ``ġ = ∇g · v`` from the two
bodies' velocities at the point) they add up to one wrench per body, which the mechanism maps to its
coordinates (`apply_wrenches`). The elastic part is exactly ``−∂E/∂q``, and contact never adds
energy: ``v · f = −dE/dt − c Σ w a ġ² ≤ −dE/dt``. ``w`` is the point's share (`ContactTables.
weights`): 1 for every point of the default sampling, and for a denser ring or rim its spacing
over the default's, so that more points resolve the same contact (a quadrature along the rings
and rims) instead of stiffening it.

**Why rim points and an inset face.** A closed seam of a rigidly folded net puts two panels' rims on
one line, each panel in the plane through the other's rim, and a panel turned past it slides its rim
along the other's face (its points move in that face's plane, across its edge). The points on the
rim meet the neighbour's rounded rim there: a rim pushed more than about ``δ`` past the neighbour's
(into its plate) is stopped, edge on edge, and a rim point cannot pass a face's plane within its
plate. The inset face keeps the closed seam itself free: a rim point on the neighbour's outline is
``ι − δ/2`` from its rounded rim, ``g = 1.3 ĝ`` for a 0.2 µm film with the defaults, so the exactly
closed cube feels no contact. The inner ring lies on the inset rim, so that a panel stacked on another
of the same outline lies over its face (its rim points, over the other's rim, do not touch it). The
price: within ``ι`` of a face's outline the plates may overlap (the model's resolution, 2 µm for a
200 µm panel; a rim point passes a face's plane freely less than ``ι − δ/2 − t − ĝ`` inside it, 0.3 µm
with the defaults), and two panels that share a corner of a closed seam meet through the rim points
nearest it: one held inside the other turns it out by about ``(t + ĝ)/s`` rad, ``s`` that point's
distance from the corner (1.4° for 200 µm edges, their rim points 50 µm from the corners). The rim
points keep off the corners: a rim corner meets the neighbour's inset plate where it is inset along
two edges, and adds nothing; the ring's density is the trade between cost and how firmly two rims
that meet stay meeting (the midpoints alone let a flap that overfolds by 4° slip past a neighbour
that overfolds by 2°; two per edge jam them at 90°).

Shared creases: two panels joined by a hinge touch along it by construction; their points near the
crease are not paired (the hinge keeps them apart, the barrier would fight it). A seam whose last panel
lands on the neighbour's face or rim instead of closing (one plate resting on the other, its corners a
few µm from the neighbour's) is held there by the barrier; the verdict counts such a seam as closed
when the two panels touch (`origami_jax.simulation.fold_outcome`, `report`'s `touching`).

Defaults (`PanelContact.for_system`): ``ĝ`` = the larger of the panel thickness and 0.5 % of the
largest panel (a standoff that keeps contact from being stiffer than the impact it has to resolve:
a 200 µm flap landing at 10 m/s is stopped within ``ĝ`` in ~0.2 µs whatever the stiffness),
``δ`` = ``ĝ``, ``ι = 2δ``, ``κ`` = the energy the hinges can release (``Σ ½ k θ_target²``), so a single
point stops the whole fold's energy at about a fifth of ``ĝ`` (``B(0.2) ≈ 1``); ``c`` from a damping
ratio of the contact's stiffness at ``g = ĝ/2`` and the lightest panel's mass.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._exported import exported_jit
from .._validate import is_traced
from ..system import AbstractContact, AbstractMechanism
from ._barrier import (
    DEFAULT_DAMPING_RATIO,
    _barrier_slope,
    _ramp_integral,
    barrier,
    check_contact_numbers,
    half_thicknesses,
    host_rest_poses,
    smoothstep,
    with_base_pose,
    with_default_contact,
)
from ._plate_geometry import plate_overlaps, plate_tables_for, plate_vertices
from ._plate_tables import PlateTables
from ._tables import RIM_POINTS_PER_EDGE, RING_POINTS_PER_EDGE, ContactTables, build_tables


class PanelContact(AbstractContact):
    """Contact between the panels of a mechanism and its fixed base (module docstring: the model).

    **Fields:**
    - `tables` (static): the [`origami_jax.contact.ContactTables`][] geometry.
    - `stiffness`: ``κ``, energy units (µN·µm = pJ in `MICRO`).
    - `activation`: ``ĝ``, the gap at which contact switches on, length.
    - `damping`: ``c``, force·time/length, per (point, face) pair in contact.
    - `edge_width`: ``δ``, the width over which a face's rim is rounded (and `report`'s coverage
      ramp), length.
    - `half_thickness`: half of each body's thickness, the base last, `(n,)`, length.
    - `plates`: the panels' exact polygons ([`origami_jax.contact.PlateTables`][]), from
      which `report` measures the penetration exactly (`None`: from the sample points' gaps).

    Build it with [`origami_jax.contact.PanelContact.for_system`][] (defaults from the hinges and
    panels) or `PanelContact.from_mechanism`.
    """

    tables: ContactTables = eqx.field(static=True)
    stiffness: Float[Array, ""]
    activation: Float[Array, ""]
    damping: Float[Array, ""]
    edge_width: Float[Array, ""]
    half_thickness: Float[Array, " n"]
    plates: PlateTables | None = None

    @classmethod
    def from_mechanism(
        cls,
        mechanism: AbstractMechanism,
        *,
        thickness: Float[ArrayLike, "*#b"],
        stiffness: Float[ArrayLike, ""],
        damping: Float[ArrayLike, ""],
        activation: Float[ArrayLike, ""] | None = None,
        edge_width: Float[ArrayLike, ""] | None = None,
        base_outline: np.ndarray | None = None,
        base_thickness: Float[ArrayLike, ""] | None = None,
        points_per_edge: int = RING_POINTS_PER_EDGE,
        rim_points_per_edge: int = RIM_POINTS_PER_EDGE,
        tables: ContactTables | None = None,
        plates: PlateTables | None = None,
    ) -> "PanelContact":
        """Contact of `mechanism`'s panels (their `outlines()`) with each other and with its base.

        **Arguments** (the mechanism's units): `thickness` per panel (scalar or `(b,)`), `stiffness`
        ``κ``, `damping` ``c``, `activation` ``ĝ`` (default: the largest of the thickness and 0.5 %
        of the largest panel), `edge_width` ``δ`` (default ``ĝ``), `base_outline` (world polygon; default
        the mechanism's `base_outline()`), `base_thickness` (default the largest panel thickness),
        `points_per_edge`, `rim_points_per_edge` (samples along a panel's longest edge on its inner
        ring and on its rim, see `build_tables`), `tables` (the geometry,
        from `tables_for`, when it is at hand: under `jit` the mechanism's own arrays are traced and
        cannot give it), `plates` (the exact polygons for `report`'s penetration, from
        `PlateContact.tables_for`; default: built here with the tables, when they are). The numbers may be traced (a fit or a sweep over the thickness or the
        hinges); the geometry may not.

        **Raises:** `ValueError` for non-positive values (when known) or degenerate outlines.
        """
        dtype = jnp.result_type(float)
        thickness, half = half_thicknesses(mechanism, thickness, base_thickness)
        base = mechanism.base_outline() if base_outline is None else base_outline
        size = max(float(np.max(np.ptp(o, axis=0))) for o in mechanism.outlines())
        if activation is None:
            activation = jnp.maximum(jnp.max(thickness), 0.005 * size)
        activation = jnp.asarray(activation, dtype)
        edge_width = activation if edge_width is None else jnp.asarray(edge_width, dtype)
        check_contact_numbers(
            thickness, stiffness, damping, activation,
            ("edge_width", edge_width, True),
        )  # fmt: skip
        if tables is None:
            # Faces (and the inner ring of points) inset by twice the rounding width (host
            # geometry: the nominal width when the thickness is traced).
            ramp = float(edge_width) if not is_traced(edge_width) else 0.005 * size
            tables = cls.tables_for(
                mechanism,
                base_outline=base,
                inset=2 * ramp,
                points_per_edge=points_per_edge,
                rim_points_per_edge=rim_points_per_edge,
            )
            if plates is None:
                plates = plate_tables_for(mechanism, base_outline=base)
        return cls(
            tables=tables,
            stiffness=jnp.asarray(stiffness, dtype),
            activation=activation,
            damping=jnp.asarray(damping, dtype),
            edge_width=edge_width,
            half_thickness=half[: tables.points.shape[0]],
            plates=plates,
        )

    @staticmethod
    def tables_for(
        mechanism: AbstractMechanism,
        *,
        base_outline: np.ndarray | None = None,
        inset: float | None = None,
        points_per_edge: int = RING_POINTS_PER_EDGE,
        rim_points_per_edge: int = RIM_POINTS_PER_EDGE,
    ) -> ContactTables:
        """The contact geometry of a mechanism whose arrays are known (host; see `ContactTables`):
        its outlines, rest poses and hinge layout. `inset` (the faces' inset ``ι`` and the inner ring's)
        defaults to twice 0.5 % of the largest panel (twice the default rounding width of a thin
        panel); `points_per_edge` and `rim_points_per_edge` set the sampling (`build_tables`)."""
        outlines = mechanism.outlines()
        size = max(float(np.max(np.ptp(o, axis=0))) for o in outlines)
        base = mechanism.base_outline() if base_outline is None else base_outline
        rest = host_rest_poses(mechanism, "ContactTables", "PanelContact.tables_for")
        layout = mechanism.hinge_layout()
        return build_tables(
            outlines,
            rest,
            base,
            layout.parent,
            layout.child,
            layout.ends,
            inset=0.01 * size if inset is None else float(inset),
            points_per_edge=points_per_edge,
            rim_points_per_edge=rim_points_per_edge,
        )

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
    ) -> "PanelContact":
        """Contact with defaults from the hinges and panels (module docstring, "Defaults").

        ``κ = Σ ½ k θ_target²``; ``c = 2 ζ sqrt(k_c m)`` with ``k_c = κ B''(½)/ĝ²`` the contact's
        stiffness half-way into the activation gap, ``m`` the lightest panel's mass (the smallest
        diagonal entry of ``M(0)``, divided by its squared lever arm, the panel size) and ``ζ`` =
        `damping_ratio`. Other keyword arguments go to `from_mechanism`. Traceable in the hinges,
        the thickness and the mechanism's masses.
        """
        return with_default_contact(
            cls, mechanism, hinge_stiffness, hinge_target, damping_ratio, thickness, kwargs
        )

    # ---- kernels ----
    #
    # Everything per (point, face) pair is computed in the face's own frame, by component, so that
    # the work per pair is a few fused multiply-adds and no per-pair 3×3 products: the relative frame
    # of each body pair carries a's points into b's face frame, and each pair's force is summed
    # into one wrench per body pair there before a single rotation to the world. The hot kernels
    # (`force`, `crossed`: every right-hand side and every step) run over the checked pairs only,
    # packed in blocks of body pairs with the same number of checked points (`ContactTables.
    # blocks`); the others (`potential`, `gaps`, `report`, ...) over the dense `(a, b, i)` layout,
    # masked, whose shape they return.

    def _frames(self, poses):
        """World rotations `(n, 3, 3)` and origins `(n, 3)` of every body, the base last, from the
        moving bodies' poses `(b, 4, 4)`."""
        poses = with_base_pose(self.tables, poses)
        return poses[:, :3, :3], poses[:, :3, 3]

    def _local(self, mechanism, q, poses=None):
        """World frames of every body (the base last) and each body's points in every face frame,
        ``R_bᵀ (R_a p_i + o_a − o_b)``: `(rotations, origins, (x, y, z))`, the components `(a, b, i)`.
        `poses`: the bodies' poses at `q` when already at hand (default `body_poses(q)`)."""
        poses = mechanism.body_poses(q) if poses is None else poses
        rotation, origin = self._frames(poses)
        relative = jnp.einsum("bki,akj->abij", rotation, rotation)  # R_bᵀ R_a
        shift = jnp.einsum("bki,abk->abi", rotation, origin[:, None] - origin[None, :])
        points = self.tables.points[:, None]  # host (a, 1, i, 3)
        return rotation, origin, _carried(relative, shift, points, self.tables.pairs.shape)

    def _edge_distances(self, x, y):
        """Per edge of every face, the inward distance of face-frame positions `(a, b, i)` from the
        edge (length), with the edge's inward normal ``(a, b)`` as `(1, b, 1)` constants."""
        return _edge_distances(x, y, _dense_edges(self.tables.face_edges))

    def _coverage(self, x, y):
        """Coverage ``w`` of face-frame positions `(a, b, i)`: 1 over the face's outline by more than
        ``δ``, 0 beside it (zero for pairs not checked); `report` and `engaged_points` count it."""
        coverage = 1.0
        for inward, _ in self._edge_distances(x, y):
            coverage = coverage * smoothstep(inward / self.edge_width)
        return jnp.where(self.tables.pairs, coverage, 0.0)

    def _gap(self, local, edges=None, half_sum=None):
        """Per pair `(a, b, i)`: the gap ``g`` between the point's ball and the face's rounded plate
        (module docstring) and its gradient in the face frame, a component tuple. `edges` and
        `half_sum` (the faces' half-planes as `(a, b, c)` rows and the two half-thicknesses, both
        broadcasting against `local`) default to the dense layout's."""
        x, y, z = local
        dtype = x.dtype
        if edges is None:
            edges = _dense_edges(self.tables.face_edges)
            half = self.half_thickness.astype(dtype)
            half_sum = half[:, None, None] + half[None, :, None]
        tiny = 1e-6 * self.activation
        width = self.edge_width
        inset = self.tables.face_inset
        # Beyond each edge of the inset face, a smoothed distance ``δ m(−e/δ)`` (``m`` the integral
        # of the smoothstep: 0 inside, ``x − ½`` beyond ``δ``), its slope ``−S(−e/δ)`` along the
        # edge's inward normal.
        squares, dx, dy = 0.0, 0.0, 0.0
        for inward, (a, b) in _edge_distances(x, y, edges):
            out = -(inward - inset) / width
            beyond = width * _ramp_integral(out)
            slope = -smoothstep(out)
            squares = squares + beyond**2
            dx = dx + beyond * slope * a
            dy = dy + beyond * slope * b
        root = jnp.sqrt(z**2 + squares + tiny**2)
        gap = root - tiny - half_sum
        return gap, (dx / root, dy / root, z / root)

    def _pair_terms(self, local):
        """Per pair `(a, b, i)`: the energy ``κ w B(g/ĝ)``, its gradient in the face frame, the gap and
        its gradient (component tuples; zero for pairs not checked)."""
        mask = self.tables.pairs
        weight = self.tables.weights[:, None, :]  # host (a, 1, i): each point's share
        gap, normal = self._gap(local)
        ratio = gap / self.activation
        energy = jnp.where(mask, weight * self.stiffness * barrier(ratio), 0.0)
        slope = jnp.where(
            mask, weight * self.stiffness * _barrier_slope(ratio) / self.activation, 0.0
        )
        gradient = tuple(slope * n for n in normal)
        return energy, gradient, gap, normal

    def gaps(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"]
    ) -> tuple[Float[Array, "n n p"], Float[Array, "n n p"]]:
        """Gap ``g`` (length: from the point's ball to the face's rounded plate, module docstring)
        and coverage ``w`` (0–1: 1 where the point lies over the face's outline by more than ``δ``,
        0 beside it; zero for pairs not checked) of point `i` of body `a` against the face of body
        `b`, shape `(n, n, p)` over `(a, b, i)` (the base last)."""
        _, _, local = self._local(mechanism, q)
        gap, _ = self._gap(local)
        return gap, self._coverage(local[0], local[1])

    def potential(self, mechanism, q):
        _, _, local = self._local(mechanism, q)
        energy, *_ = self._pair_terms(local)
        return jnp.sum(energy)

    def _block_local(self, block, rotation, origin):
        """A `PairBlock`'s points in their faces' frames, ``R_bᵀ (R_a p_i + o_a − o_b)``, as
        components `(k, m)` each, and the faces' rotations and origins `(k, 3, 3)`, `(k, 3)`."""
        face_rotation, face_origin = rotation[block.face_body], origin[block.face_body]
        relative = jnp.einsum("kji,kjl->kil", face_rotation, rotation[block.point_body])
        shift = jnp.einsum("kji,kj->ki", face_rotation, origin[block.point_body] - face_origin)
        local = _carried(relative, shift, block.points, block.points.shape[:2])
        return local, face_rotation, face_origin

    def _block_gap(self, block, local):
        """`_gap` of a `PairBlock`'s points (components `(k, m)`)."""
        edges = [
            tuple(block.face_edges[:, k, j, None] for j in range(3))
            for k in range(block.face_edges.shape[1])
        ]
        half = self.half_thickness.astype(local[0].dtype)
        half_sum = (half[block.point_body] + half[block.face_body])[:, None]
        return self._gap(local, edges, half_sum)

    def force(self, mechanism, q, v):
        # The kinematics once for the poses, the twists and the wrench map (`body_motion`). The
        # pairs are packed in blocks (`ContactTables.blocks`): no work on unchecked pairs.
        poses, velocity, wrench_force = mechanism.body_motion(q, v)
        rotation, origin = self._frames(poses)
        if self.tables.has_base:
            velocity = jnp.concatenate([velocity, jnp.zeros((1, 6), velocity.dtype)], axis=0)
        n = rotation.shape[0]
        wrenches = jnp.zeros((n, 6), rotation.dtype)
        for block in self.tables.blocks:
            local, face_rotation, face_origin = self._block_local(block, rotation, origin)
            gap, (nx, ny, nz) = self._block_gap(block, local)
            x, y, z = local
            ratio = gap / self.activation
            slope = self.stiffness * _barrier_slope(ratio) / self.activation
            # The motion of a relative to b in b's face frame about its origin, per body pair:
            # u = R_bᵀ (Δv_O + Δω × o_b), w = R_bᵀ Δω from the world twists about the origin.
            d_linear = velocity[block.point_body, :3] - velocity[block.face_body, :3]
            d_angular = velocity[block.point_body, 3:] - velocity[block.face_body, 3:]
            u = jnp.einsum(
                "kji,kj->ki", face_rotation, d_linear + jnp.cross(d_angular, face_origin)
            )
            w = jnp.einsum("kji,kj->ki", face_rotation, d_angular)
            ux, uy, uz = (u[:, k, None] for k in range(3))
            wx, wy, wz = (w[:, k, None] for k in range(3))
            # Dissipative: −c a(g) ġ ∇g, ġ = ∇g · (the point's velocity relative to the face,
            # u + w × p).
            rate = (
                nx * (ux + wy * z - wz * y)
                + ny * (uy + wz * x - wx * z)
                + nz * (uz + wx * y - wy * x)
            )
            engaged = smoothstep(1 - ratio)
            # Each point's share of the energy (1 at the default sampling) scales both parts.
            push = block.weights * (-self.damping * engaged * rate - slope)
            # Elastic (−∇e, the slope along the normal) and dissipative, on the point of a; b takes
            # the opposite at the same place.
            fx, fy, fz = push * nx, push * ny, push * nz
            force = jnp.stack([jnp.sum(f, axis=-1) for f in (fx, fy, fz)], axis=-1)  # (k, 3)
            moment = jnp.stack(
                [jnp.sum(m, axis=-1) for m in (y * fz - z * fy, z * fx - x * fz, x * fy - y * fx)],
                axis=-1,
            )  # about b's face origin, in its frame
            force = jnp.einsum("kij,kj->ki", face_rotation, force)
            moment = jnp.einsum("kij,kj->ki", face_rotation, moment) + jnp.cross(face_origin, force)
            pair = jnp.concatenate([force, moment], axis=-1)  # (k, 6): on a; −pair on b
            onto = np.eye(n)[block.point_body] - np.eye(n)[block.face_body]  # host (k, n)
            wrenches = wrenches + jnp.einsum("kn,kc->nc", onto, pair)
        return wrench_force(wrenches[: self.tables.n_bodies])

    def crossed(self, mechanism, q0, q1) -> Array:
        """Whether some sample point crosses the mid-plane of a face between ``q0`` and ``q1`` through
        the face's rounded plate (its gap there, on the mid-plane, below zero; the place from the
        straight path between the point's two positions in the face's frame): a panel passed through
        another (boolean scalar). A point that passes a face's plane beside its plate, where the
        barrier holds it off the rounded rim, does not count."""
        frames0 = self._frames(mechanism.body_poses(q0))
        frames1 = self._frames(mechanism.body_poses(q1))
        crossed = jnp.asarray(False)
        for block in self.tables.blocks:
            (x0, y0, z0), *_ = self._block_local(block, *frames0)
            (x1, y1, z1), *_ = self._block_local(block, *frames1)
            flipped = z0 * z1 < 0
            s = z0 / jnp.where(flipped, z0 - z1, 1.0)
            place = (x0 + s * (x1 - x0), y0 + s * (y1 - y0), jnp.zeros_like(z0))
            gap, _ = self._block_gap(block, place)
            crossed = crossed | jnp.any(flipped & (gap < 0))
        return crossed

    def engaged_points(
        self, mechanism: AbstractMechanism, q: Float[Array, " nq"]
    ) -> tuple[Float[Array, "n n 3"], Float[Array, "n n"]]:
        """Where the panels touch at ``q``, for drawing: for every ordered pair of bodies `(a, b)`
        (the base last) the mean world position of `a`'s points that `report` counts as engaged
        on `b`'s face or rim (``g < 1.1 ĝ``), shape `(n, n, 3)` (length; zeros where none), and how
        many there are, `(n, n)`."""
        rotation, origin, local = self._local(mechanism, q)
        gap, _ = self._gap(local)
        points = jnp.asarray(self.tables.points, rotation.dtype)
        world = jnp.einsum("aij,apj->api", rotation, points) + origin[:, None, :]
        engaged = self.tables.pairs & (gap < 1.1 * self.activation)  # (a, b, p)
        count = jnp.sum(engaged, axis=-1)
        total = jnp.einsum("abp,api->abi", engaged.astype(world.dtype), world)
        mean = total / jnp.maximum(count, 1)[..., None].astype(world.dtype)
        return mean, count

    def report(self, mechanism, q) -> dict[str, Array]:
        """Contact state at ``q``: the smallest gap over the pairs checked (length, `inf` if none),
        how many are engaged (``g < 1.1 ĝ``: a panel resting on another hovers at the edge of the
        activation layer, where the barrier's force rises from zero), the penetration (length: the
        exact overlap of the panels' plates, `origami_jax.contact.PlateContact.penetration`, when
        `plates` is known; else ``max(0, −g)`` at the sample points), and `touching` `(n, n)` bool over (point body `a`, face body `b`,
        the base last): some point of `a` has ``g < 1.1 ĝ`` against `b`'s face or rim, i.e. `a`
        rests on `b` or meets its edge (the verdict's seams closed by contact,
        `origami_jax.simulation.fold_outcome`)."""
        poses = mechanism.body_poses(q)
        _, _, local = self._local(mechanism, q, poses)
        gap, _ = self._gap(local)
        checked = self.tables.pairs
        smallest = jnp.min(jnp.where(checked, gap, jnp.inf))
        near = checked & (gap < 1.1 * self.activation)
        if self.plates is None:
            penetration = jnp.maximum(-smallest, 0.0)
        else:
            poses = with_base_pose(self.tables, poses)
            x = plate_vertices(self.plates, poses)
            depths = plate_overlaps(self.plates, self.half_thickness, x)
            penetration = jnp.max(depths, initial=0.0)
        return {
            "min_gap": smallest,
            "engaged": jnp.sum(near),
            "penetration": penetration,
            "touching": jnp.any(near, axis=-1),
        }


def _carried(relative, shift, points, shape):
    """Points carried into other frames, ``relative p + shift``, by component: `relative` `(..., 3,
    3)` and `shift` `(..., 3)` per frame pair, `points` (host) `(..., m, 3)` broadcasting against
    their leading axes; returns the three components, each of `shape`. A coordinate that is zero
    for every point (panel points lie in their frame's x–y plane) costs nothing."""
    local = []
    for row in range(3):
        value = shift[..., row, None]
        for col in range(3):
            component = points[..., col]
            if np.any(component != 0):
                value = value + relative[..., row, col, None] * component
        local.append(jnp.broadcast_to(value, shape))
    return tuple(local)


def _dense_edges(face_edges):
    """The faces' half-planes `(n, e, 3)` (host) as `(a, b, c)` rows of `(1, n, 1)` constants, one
    per edge, for the dense `(a, b, i)` layout."""
    return [
        tuple(face_edges[None, :, k, j, None] for j in range(3)) for k in range(face_edges.shape[1])
    ]


def _edge_distances(x, y, edges):
    """The inward distance ``a x + b y + c`` of face-frame positions from each edge in `edges` (rows
    ``(a, b, c)`` broadcasting against `x`), with the edge's inward normal ``(a, b)``."""
    return [(a * x + b * y + c, (a, b)) for a, b, c in edges]


def contact_points(
    system, q: Float[ArrayLike, "T nq"]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the panels of `system` (a `FoldingSystem` with a `PanelContact`) touch at each of the
    states `q` `(T, n_coordinates)`, for drawing and export: one entry per engaged ordered body pair
    and state (`PanelContact.engaged_points`), as host arrays `frames` `(K,)` (index into `q`),
    `points` `(K, 3)` (world, length units) and `bodies` `(K, 2)` (the point's body, the face's
    body; the base is `n_bodies`). Empty without a contact model; non-finite states are skipped."""
    contact = getattr(system, "contact", None)
    if contact is None or not hasattr(contact, "engaged_points"):
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 2), np.int64)
    q = jax.device_put(np.asarray(q))  # put, not converted: `jnp.asarray` compiles per shape
    points, count = _engaged_over_states(contact, system.mechanism, q)
    points, count = np.asarray(points), np.asarray(count)
    count = np.where(np.all(np.isfinite(np.asarray(q)), axis=1)[:, None, None], count, 0)
    frames, a, b = np.nonzero(count > 0)
    return frames.astype(np.int64), points[frames, a, b], np.stack([a, b], axis=1).astype(np.int64)


@exported_jit("engaged_points")
def _engaged_over_states(contact, mechanism, q):
    return jax.vmap(lambda x: contact.engaged_points(mechanism, x))(q)
