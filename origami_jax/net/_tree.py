"""`PanelTree`: rigid panels joined by creases whose faces form a tree, and its builder `panel_tree`.

A net of panels becomes a tree once its seams are cut: each panel's parent is the panel across its
crease towards the root (the fixed base: the substrate, or a panel held fixed). A serial chain is the
tree ``parents = (−1, 0, 1, …)``. The dynamics are Featherstone's tree algorithms in the world frame
(`origami_jax.net._dynamics`); the hinges are joint models (`origami_jax.net._joints`): point creases
(revolute) or bending arcs.

**Fold angles.** ``q[i]`` is the angle of hinge ``i``, between panel ``i`` and its parent, in radians,
zero in the flat pattern, *valley positive*: with the pattern in a plane and its faces
counter-clockwise seen from its normal ``+z``, a positive angle lifts the child towards ``+z`` (the
two top faces close on each other). A positive rotation about the hinge axis ``ω`` lifts the child
when ``ω × (c − p)`` points along ``+z`` (``c`` the child's CG, ``p`` a point on the crease): the
axis runs along the crease in the direction in which the *child's* counter-clockwise outline
traverses it. `panel_tree` checks this.
"""

import functools
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validate import (
    as_float_array,
    check_finite,
    check_positive,
    check_rigid_transforms,
    check_shape,
    check_symmetric_positive,
    check_unit_vectors,
    is_traced,
)
from ..system import AbstractMechanism, HingeLayout
from . import _batching, _dynamics, _motion
from ._joints import AbstractJoints, ArcJoints, RevoluteJoints
from ._plate import polygon_plate
from ._topology import check_parents

# |ω · z| above this means an arc hinge's crease does not lie in its child's plane.
_IN_PLANE_TOLERANCE = 1e-6


def _as_polygon(polygon, name: str) -> np.ndarray:
    host = np.array(polygon, dtype=float)
    if host.ndim != 2 or host.shape[1] != 3 or host.shape[0] < 3:
        raise ValueError(f"{name} must be a polygon of shape (k, 3) with k ≥ 3, got {host.shape}.")
    if not np.all(np.isfinite(host)):
        raise ValueError(f"{name} contains NaN or inf.")
    return host


def forward_inputs(n: int, q, v, force) -> tuple[Array, Array, Array]:
    """`q`, `v`, `force` of a tree's `forward_dynamics` as arrays, checked: each `(n,)`, or `(t, n)`
    for `t` states."""
    q, v, force = jnp.asarray(q), jnp.asarray(v), jnp.asarray(force)
    if q.ndim not in (1, 2) or q.shape[-1] != n or v.shape != q.shape or force.shape != q.shape:
        raise ValueError(
            f"q, v and force must have shape ({n},) or (t, {n}) for this {n}-panel tree, got "
            f"{q.shape}, {v.shape} and {force.shape}."
        )
    return q, v, force


class PanelTree(AbstractMechanism):
    """Rigid panels hinged in a tree (module docstring: conventions), any consistent units.

    **Fields** (rest values are at ``q = 0``, in the world frame; ``n`` panels = ``n`` hinges):
    - `parents` (static): ``parents[i]`` is body ``i``'s parent, ``−1`` for the fixed base.
    - `joints`: the hinge models, [`RevoluteJoints`][origami_jax.net.RevoluteJoints] (axes ``ω`` `(n, 3)` and crease points ``p``
      `(n, 3)`) or [`ArcJoints`][origami_jax.net.ArcJoints] (bending strips; adds directions and strip lengths).
    - `frames`: rest pose of each body frame, `(n, 4, 4)` (length in the last column).
    - `masses`: `(n,)`, mass. `cgs`: CG of each panel in its body frame, `(n, 3)`, length.
    - `inertias`: rotational inertia about the CG in the body frame's axes, `(n, 3, 3)`, mass·length².
    - `added_inertias`: a general symmetric positive semi-definite 6×6 spatial inertia per body, in
      its body frame about the body frame's origin, acting on body twists ordered ``(linear,
      angular)``, added to the rigid one (fluid added mass), `(n, 6, 6)`; or `None`. It has no weight.
    - `gravity`: `(3,)`, length/time²; zero by default.
    - `panel_outlines`, `base_polygon`: the drawing geometry behind `outlines()` and
      `base_outline()` (a tuple of `(k_i, 3)` host arrays, and a `(k, 3)` one; data, so a tree
      of another size compiles nothing).

    Bodies may be numbered in any order (the algorithms run in a topological order and permute
    back). Many states of one tree, as `(t, n)` rows or under `jax.vmap`, run in a layout with the
    states contiguous and in cache-sized chunks (`origami_jax.net._batching`): for a 20-panel tree
    on the CPU, faster per state than Pinocchio's ABA called in a loop.

    **Raises:** `ValueError` (before tracing) for bad `parents` (out of range, self-parent, cycles),
    shape mismatches, NaN/inf, non-unit axes, non-rigid frames, non-positive masses, inertias that
    are not symmetric positive definite (added ones: semi-definite), arc hinges whose crease is not in
    the child's plane. Built from traced values the value checks become `eqx.error_if`.
    """

    parents: tuple[int, ...] = eqx.field(static=True)
    joints: AbstractJoints
    frames: Float[Array, "n 4 4"]
    masses: Float[Array, " n"]
    cgs: Float[Array, "n 3"]
    inertias: Float[Array, "n 3 3"]
    added_inertias: Float[Array, "n 6 6"] | None
    gravity: Float[Array, "3"]
    panel_outlines: tuple | None
    base_polygon: Float[ArrayLike, "k 3"] | None

    def __init__(
        self,
        parents: Sequence,
        axes: ArrayLike,
        points: ArrayLike,
        frames: ArrayLike,
        masses: ArrayLike,
        cgs: ArrayLike | None,
        inertias: ArrayLike,
        *,
        added_inertias: ArrayLike | None = None,
        gravity: ArrayLike | None = None,
        arc_lengths: ArrayLike | None = None,
        outlines: Sequence | None = None,
        base_outline: ArrayLike | None = None,
    ):
        """**Arguments:** the fields above (`axes`, `points`: the hinges' rest axes and crease
        points; `cgs=None`: CGs at the body frames' origins), plus
        - `arc_lengths`: strip length ``l`` of each hinge, `(n,)`, length ≥ 0: bending-arc hinges
          (`ArcJoints`, strip leaving ``p`` along ``z_i × ω_i``, ``z_i`` the child frame's ``z``, which
          must be perpendicular to ``ω_i``); `None` (default): point creases (`RevoluteJoints`).
        - `outlines`: each panel's polygon in its body frame, `(k_i, 3)` each (drawing, export and
          contact); default a rectangle with the panel's radii of gyration.
        - `base_outline`: the fixed root panel's polygon in the world frame, `(k, 3)`, or `None`.
        """
        # Plain `ArrayLike` annotations (shapes in the docstring): the checks below give the
        # one-line messages, which run-time shape checking would pre-empt.
        self.parents = check_parents(parents)
        n = len(self.parents)
        hint = f"parents has {n} bodies, so every per-body array needs {n} rows."
        axes = as_float_array(axes, "axes")
        points = as_float_array(points, "points")
        frames = as_float_array(frames, "frames")
        masses = as_float_array(masses, "masses")
        inertias = as_float_array(inertias, "inertias")
        cgs = jnp.zeros((n, 3), masses.dtype) if cgs is None else as_float_array(cgs, "cgs")
        check_shape(axes, (n, 3), "axes", hint)
        check_shape(points, (n, 3), "points", hint)
        check_shape(frames, (n, 4, 4), "frames", hint)
        check_shape(masses, (n,), "masses", hint)
        check_shape(cgs, (n, 3), "cgs", hint)
        check_shape(inertias, (n, 3, 3), "inertias", hint)
        axes = check_unit_vectors(axes, "axes", "hinge")
        points = check_finite(points, "points")
        self.frames = check_rigid_transforms(frames, "frames")
        self.masses = check_positive(masses, "masses", "mass units")
        self.cgs = check_finite(cgs, "cgs")
        self.inertias = check_symmetric_positive(
            inertias,
            "inertias",
            hint="A rigid panel with positive mass has a positive-definite inertia about its CG.",
        )
        if added_inertias is None:
            self.added_inertias = None
        else:
            added = as_float_array(added_inertias, "added_inertias")
            check_shape(added, (n, 6, 6), "added_inertias", hint)
            self.added_inertias = check_symmetric_positive(
                added,
                "added_inertias",
                definite=False,
                hint="Added inertia stores kinetic energy, so it is positive semi-definite.",
            )
        if gravity is None:
            self.gravity = jnp.zeros(3, masses.dtype)
        else:
            gravity = as_float_array(gravity, "gravity")
            check_shape(gravity, (3,), "gravity")
            self.gravity = check_finite(gravity, "gravity")
        if arc_lengths is None:
            self.joints = RevoluteJoints(axes, points)
        else:
            self.joints = _arc_joints(axes, points, self.frames, arc_lengths, n)
        if outlines is None:
            self.panel_outlines = None
        else:
            if len(outlines) != n:
                raise ValueError(f"outlines has {len(outlines)} polygons; {hint}")
            self.panel_outlines = tuple(
                _as_polygon(o, f"outlines[{i}]") for i, o in enumerate(outlines)
            )
        self.base_polygon = (
            None if base_outline is None else _as_polygon(base_outline, "base_outline")
        )

    @classmethod
    def from_chain(cls, chain) -> "PanelTree":
        """The serial chain `chain` (an `origami_jax.chain.Chain`) as the tree ``(−1, 0, 1, …)``: same
        hinges, its flaps' CG frames as body frames."""
        n = chain.n_hinges
        return cls(
            tuple(range(-1, n - 1)),
            chain.axes,
            chain.points,
            chain.cg_poses,
            chain.masses,
            None,
            chain.inertias,
            gravity=chain.gravity,
        )

    @property
    def axes(self) -> Float[Array, "n 3"]:
        """Rest hinge axes ``ω``, `(n, 3)`."""
        return self.joints.axes

    @property
    def points(self) -> Float[Array, "n 3"]:
        """Rest crease points ``p``, `(n, 3)`."""
        return self.joints.points

    # ---- AbstractMechanism ----

    @property
    def n_hinges(self) -> int:
        return len(self.parents)

    @property
    def n_bodies(self) -> int:
        return len(self.parents)

    def mass_matrix(self, q):
        return _mass_matrix(self, jnp.asarray(q))

    def bias_force(self, q, v):
        return _bias_force(self, jnp.asarray(q), jnp.asarray(v))

    def forward_dynamics(self, q, v, force, *, forward_mode_only: bool = False):
        """Accelerations ``q̈ = M⁻¹ (force − C q̇ − G)`` (CRBA, RNEA and the tree-sparse ``LᵀL``
        solve; `_dynamics`). `q`, `v`, `force`: `(n,)`, or `(t, n)` for `t` states (vmapped).
        `forward_mode_only` is accepted and ignored (one derivative rule, from the inverse
        dynamics, serves both modes; `_batching`)."""
        del forward_mode_only
        q, v, force = forward_inputs(self.n_hinges, q, v, force)
        if q.ndim == 2:
            return _rows(self, q, v, force)
        return _single(self, q, v, force)

    def inverse_dynamics(self, q, v, a):
        return _inverse_dynamics(self, jnp.asarray(q), jnp.asarray(v), jnp.asarray(a))

    def potential_energy(self, q):
        return _potential_energy(self, jnp.asarray(q))

    def body_poses(self, q):
        return _body_poses(self, jnp.asarray(q))

    def spatial_velocities(self, q, v):
        """``V_b = Σ_{j ⪯ b} S_j q̇_j`` from the hinges' world motion subspaces (`_motion`)."""
        return _motion.spatial_velocities(self, jnp.asarray(q), jnp.asarray(v))

    def apply_wrenches(self, q, wrenches):
        """``f_j = S_j · Σ_{b ⪰ j} W_b``: hinge ``j`` carries its subtree (`_motion`)."""
        return _motion.apply_wrenches(self, jnp.asarray(q), jnp.asarray(wrenches))

    def body_motion(self, q, v):
        """Poses, twists and the wrench map from one evaluation of the kinematics (the poses and
        the hinges' world subspaces, `_motion`)."""
        q, v = jnp.asarray(q), jnp.asarray(v)
        poses = self.body_poses(q)
        subspaces = _motion.world_subspaces(self, q, poses)
        return (
            poses,
            _motion.twists(self, subspaces, v),
            functools.partial(_motion.generalized_force, self, subspaces),
        )

    def mass_matrix_and_bias(self, q, v):
        """``(M(q), C(q, v) v + G(q))`` from one evaluation of the kinematics and inertias (what a
        constrained solve needs; `mass_matrix` and `bias_force` separately compute them twice)."""
        return _mass_matrix_and_bias(self, jnp.asarray(q), jnp.asarray(v))

    @property
    def carries_added_inertia(self) -> bool:
        return self.added_inertias is not None

    def with_added_inertias(self, added: Float[ArrayLike, "n 6 6"] | None) -> "PanelTree":
        """The same tree with its panels' added inertias replaced (`None`: none)."""
        return eqx.tree_at(lambda t: t.added_inertias, self, added, is_leaf=lambda x: x is None)

    def outlines(self) -> list[np.ndarray]:
        """Each panel's polygon in its body frame, `(k_i, 3)` host arrays; without stored outlines a
        rectangle in the body ``x–y`` plane about the CG whose sides give the panel's inertia
        (``I_xx = m L²/12``, ``I_yy = m w²/12``)."""
        if self.panel_outlines is not None:
            return [np.array(o) for o in self.panel_outlines]
        masses, inertias, cgs = (np.asarray(x) for x in (self.masses, self.inertias, self.cgs))
        out = []
        for m, inertia, cg in zip(masses, inertias, cgs, strict=True):
            length = np.sqrt(max(12 * inertia[0, 0] / m, 0.0))
            width = np.sqrt(max(12 * inertia[1, 1] / m, 0.0))
            corners = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=float)
            out.append(cg + corners * np.array([width / 2, length / 2, 0.0]))
        return out

    def base_outline(self) -> np.ndarray | None:
        return None if self.base_polygon is None else np.array(self.base_polygon)

    def hinge_layout(self) -> HingeLayout:
        """Hinge ``i`` joins body ``parents[i]`` (−1: the base) and body ``i``; its crease is the part
        of the hinge axis the child's outline runs along in the flat state (for an arc hinge, the
        parent's edge), or the child's whole extent along the axis when no outline edge lies on it."""
        axes = np.asarray(self.axes, dtype=float)
        points = np.asarray(self.points, dtype=float)
        frames = np.asarray(self.frames, dtype=float)
        ends = np.empty((self.n_hinges, 2, 3))
        for i, (outline, frame) in enumerate(zip(self.outlines(), frames, strict=True)):
            world = outline @ frame[:3, :3].T + frame[:3, 3]
            along = (world - points[i]) @ axes[i]
            off = world - points[i] - along[:, None] * axes[i]
            size = float(np.max(np.ptp(world, axis=0)))
            on_axis = np.linalg.norm(off, axis=-1) < 1e-6 * size
            span = along[on_axis] if np.count_nonzero(on_axis) >= 2 else along
            ends[i] = points[i] + np.outer([span.min(), span.max()], axes[i])
        return HingeLayout(np.asarray(self.parents), np.arange(self.n_hinges), axes, ends)


# Compiled once per tree shape: the algorithms are many small array operations, slow to dispatch one
# by one when called outside `jit` (inside another `jit` these are inlined).
_mass_matrix = jax.jit(_dynamics.mass_matrix)
_bias_force = jax.jit(_dynamics.bias_force)
_mass_matrix_and_bias = jax.jit(_dynamics.mass_matrix_and_bias)
_inverse_dynamics = jax.jit(_dynamics.inverse_dynamics)
_potential_energy = jax.jit(_dynamics.potential_energy)
_body_poses = jax.jit(_dynamics.body_poses)
_single = jax.jit(_batching.single)
_rows = jax.jit(_batching.rows)


def _arc_joints(axes, points, frames, arc_lengths, n: int) -> ArcJoints:
    lengths = as_float_array(arc_lengths, "arc_lengths")
    check_shape(lengths, (n,), "arc_lengths", f"give one strip length per hinge ({n}).")
    lengths = check_finite(lengths, "arc_lengths")
    if not is_traced(lengths) and bool(jnp.any(lengths < 0)):
        raise ValueError("arc_lengths must be >= 0 (length units); 0 is a point crease.")
    normals = frames[:, :3, 2]
    off_plane = jnp.abs(jnp.sum(normals * axes, axis=-1))
    if not is_traced(normals, axes) and bool(jnp.any(off_plane > _IN_PLANE_TOLERANCE)):
        i = int(jnp.argmax(off_plane))
        raise ValueError(
            f"axes[{i}] is not in the plane of panel {i} (|ω · z| = {float(off_plane[i]):.3g}); "
            "an arc hinge's crease lies in its child panel, whose frame's z is the panel normal."
        )
    directions = jnp.cross(normals, axes)
    directions = directions / jnp.linalg.norm(directions, axis=-1, keepdims=True)
    return ArcJoints(axes, points, directions, lengths)


def panel_tree(
    parents: Sequence,
    hinge_axes: ArrayLike,
    hinge_points: ArrayLike,
    outlines: Sequence,
    *,
    thickness: ArrayLike,
    density: ArrayLike,
    gravity: ArrayLike | None = None,
    base_outline: ArrayLike | None = None,
    hinge_lengths: ArrayLike | None = None,
    added_inertias: ArrayLike | None = None,
) -> PanelTree:
    """A tree of uniform polygonal plates from a flat pattern (module docstring: conventions).

    **Arguments** (any consistent units; world frame at ``q = 0``):
    - `parents`: parent of each panel, ``−1`` for the fixed base.
    - `hinge_axes`: unit direction of each panel's crease, `(n, 3)`, oriented valley positive (the
      direction in which the panel's own counter-clockwise outline runs along the crease).
    - `hinge_points`: a point on each crease, `(n, 3)`, length (for arc hinges: on the parent's edge).
    - `outlines`: each panel's polygon in the world frame, `(k_i, 3)` each, counter-clockwise seen from
      the pattern's upper side.
    - `thickness` (length), `density` (mass/length³): scalars or one per panel.
    - `gravity`: `(3,)`; `base_outline`: the fixed root panel's world polygon (drawing and contact).
    - `hinge_lengths`: strip length of each hinge for bending-arc hinges, `(n,)` (the child's outline
      then starts that far from its crease); default point creases.
    - `added_inertias`: see `PanelTree` (body frames: origin at each panel's CG, ``z`` its normal,
      ``x`` along its hinge axis).

    Each body frame has its origin at the panel's CG (the polygon's centroid, on its mid-plane),
    ``z`` along its normal and ``x`` along its hinge axis; mass and inertia come from
    `polygon_plate`.

    **Returns:** a `PanelTree` whose `outlines()` are the given polygons in the body frames.

    **Raises:** `ValueError` for a hinge axis oriented against the valley-positive convention, a
    non-planar or self-crossing outline, and everything `PanelTree` raises.
    """
    parents = check_parents(parents)
    n = len(parents)
    thickness = _per_panel(thickness, "thickness", n)
    density = _per_panel(density, "density", n)
    # The geometry (axes, points, frames) is known even when the thickness or density is traced (a
    # design fit or a sweep over them under `jit`, where `jnp.asarray` of a host array is staged):
    # evaluate what can be evaluated now, so the host-side checks below and the static outlines see
    # concrete values.
    with jax.ensure_compile_time_eval():
        axes = as_float_array(hinge_axes, "hinge_axes")
        points = as_float_array(hinge_points, "hinge_points")
        check_shape(axes, (n, 3), "hinge_axes", f"parents has {n} panels.")
        check_shape(points, (n, 3), "hinge_points", f"parents has {n} panels.")
        if len(outlines) != n:
            raise ValueError(f"outlines has {len(outlines)} polygons but parents has {n} panels.")
        plates = [
            polygon_plate(outline, thickness=thickness[i], density=density[i], x_axis=axes[i])
            for i, outline in enumerate(outlines)
        ]
        frames = jnp.stack([p.frame for p in plates])
    host_frames = np.asarray(frames)
    host_axes, host_points = np.asarray(axes), np.asarray(points)
    for i in range(n):
        normal, cg = host_frames[i, :3, 2], host_frames[i, :3, 3]
        lift = float(np.dot(np.cross(host_axes[i], cg - host_points[i]), normal))
        if lift <= 0:
            raise ValueError(
                f"hinge_axes[{i}] turns panel {i} down for a positive (valley) angle: flip it (the "
                "axis runs along the crease the way the panel's counter-clockwise outline does)."
            )
    body_outlines = [
        (np.asarray(o, dtype=float) - f[:3, 3]) @ f[:3, :3]
        for o, f in zip(outlines, host_frames, strict=True)
    ]
    return PanelTree(
        parents,
        axes,
        points,
        frames,
        jnp.stack([p.mass for p in plates]),
        None,
        jnp.stack([p.inertia for p in plates]),
        added_inertias=added_inertias,
        gravity=gravity,
        arc_lengths=hinge_lengths,
        outlines=body_outlines,
        base_outline=base_outline,
    )


def _per_panel(value, name: str, n: int) -> Array:
    array = as_float_array(value, name)
    if array.ndim > 1 or (array.ndim == 1 and array.shape[0] != n):
        raise ValueError(f"{name} must be a scalar or have shape ({n},), got {array.shape}.")
    return check_positive(jnp.broadcast_to(array, (n,)), name)
