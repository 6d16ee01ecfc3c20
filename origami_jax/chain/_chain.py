"""The serial chain of rigid flaps joined by revolute hinges, and its builders.

A `Chain` holds, at the reference configuration ``θ = 0`` and in the inertial frame: each hinge's unit axis
``ω_i`` and a point ``q_i`` on it, each flap's centre-of-gravity pose, its mass and its inertia about the CG
(in the flap frame). Flap ``i`` is carried by hinges ``1..i`` (paper Eq. 8). The kernels never look at units;
any consistent system works (see `UnitSystem`; the builders default to `MICRO`: µm, µs, ng).
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validate import as_float_array, check_finite, check_positive, check_shape, is_traced
from ..system import MICRO, AbstractMechanism, HingeLayout, UnitSystem
from ._axes import PARALLEL_TOLERANCE, _sines_to_first_axis, axes_parallel_error
from ._dynamics import (
    bias_torque,
    forward_dynamics,
    inverse_dynamics,
    kinetic_energy,
    mass_matrix,
    potential_energy,
)
from ._kinematics import forward_kinematics, joint_frames

# Relative tolerance on |ω| = 1 and on RᵀR = I. Inputs typed by hand or stored in float32 carry ~1e-7
# relative error; anything beyond 1e-6 is a wrong input, not round-off.
_UNIT_TOLERANCE = 1e-6

# SiNx density, kg/m³: 3100 (LPCVD low-stress silicon nitride; e.g. Petersen, "Silicon as a mechanical
# material", Proc. IEEE 70 (1982)). Used as the accordion's default flap density.
_SINX_DENSITY_SI = 3100.0
FLAP_SIZE_SI = 200e-6
"""The accordion's default flap length and width, m: the paper's 200 µm flaps (Fig. 4; the width is
not given there, so the flaps are square)."""


def flap_size(
    units: UnitSystem, flap_length: ArrayLike | None = None, flap_width: ArrayLike | None = None
) -> tuple[Array, Array]:
    """`(flap_length, flap_width)` of the accordion's flaps in `units`, as float arrays checked
    positive (inside `jit` too): a `None` is the paper's 200 µm (`FLAP_SIZE_SI`) converted into
    `units`; given values (possibly traced) pass through."""
    length = units.length(FLAP_SIZE_SI) if flap_length is None else flap_length
    width = units.length(FLAP_SIZE_SI) if flap_width is None else flap_width
    return (
        check_positive(as_float_array(length, "flap_length"), "flap_length"),
        check_positive(as_float_array(width, "flap_width"), "flap_width"),
    )


class Chain(AbstractMechanism):
    """A serial chain of ``n`` rigid flaps joined by revolute hinges (any consistent units).

    The first implementation of [`origami_jax.system.AbstractMechanism`][]: its state is the hinge
    angles ``q = θ`` and rates ``v = θ̇``; flap ``i`` is carried by hinges ``1..i``.

    **Fields** (all at ``θ = 0``, inertial frame):
    - `axes`: unit hinge axes ``ω_i``, shape `(n, 3)`, dimensionless.
    - `points`: a point ``q_i`` on each hinge axis, shape `(n, 3)`, length.
    - `cg_poses`: pose ``g_{sl_i}(0)`` of each flap's CG frame, shape `(n, 4, 4)` (length in the last column).
    - `masses`: flap masses, shape `(n,)`, mass.
    - `inertias`: inertia of each flap about its CG, in its CG frame, shape `(n, 3, 3)`, mass·length².
    - `gravity`: acceleration of gravity, shape `(3,)`, length/time²; zero by default (negligible at the
      µm scale and absent in the paper).
    - `planar` (static): every hinge axis is parallel to the first (within `PARALLEL_TOLERANCE`), so the
      flaps move in parallel planes and the dynamics run in two dimensions (same answer to round-off,
      ~5× fewer operations; see `_planar`). By default detected from `axes` when their values are
      known, i.e. not traced (the builders pass constant axes, so an accordion built under `jit` is
      planar too); `planar=True` asserts it (checked, with `eqx.error_if` when traced), `planar=False`
      keeps the spatial algorithm.

    **Raises:** `ValueError` (before tracing) for wrong shapes or mismatched lengths, NaN/inf, zero or
    non-unit axes, non-positive masses, non-symmetric or non-positive-definite inertias, non-rigid CG poses.
    When built from traced values (under `jit`/`vmap`) the value checks become `eqx.error_if`.
    """

    axes: Float[Array, "n 3"]
    points: Float[Array, "n 3"]
    cg_poses: Float[Array, "n 4 4"]
    masses: Float[Array, " n"]
    inertias: Float[Array, "n 3 3"]
    gravity: Float[Array, "3"]
    planar: bool = eqx.field(static=True)

    def __init__(
        self,
        axes: ArrayLike,
        points: ArrayLike,
        cg_poses: ArrayLike,
        masses: ArrayLike,
        inertias: ArrayLike,
        gravity: ArrayLike | None = None,
        *,
        planar: bool | None = None,
    ):
        given_axes = axes
        axes = as_float_array(axes, "axes")
        points = as_float_array(points, "points")
        cg_poses = as_float_array(cg_poses, "cg_poses")
        masses = as_float_array(masses, "masses")
        inertias = as_float_array(inertias, "inertias")
        gravity = (
            jnp.zeros(3, axes.dtype) if gravity is None else as_float_array(gravity, "gravity")
        )

        check_shape(axes, (None, 3), "axes", "Give one 3-vector per hinge.")
        n = axes.shape[0]
        if n < 1:
            raise ValueError("A chain needs at least one hinge; axes is empty.")
        hint = f"axes has {n} hinges, so every per-hinge array needs {n} rows."
        check_shape(points, (n, 3), "points", hint)
        check_shape(cg_poses, (n, 4, 4), "cg_poses", hint)
        check_shape(masses, (n,), "masses", hint)
        check_shape(inertias, (n, 3, 3), "inertias", hint)
        check_shape(gravity, (3,), "gravity")

        points = check_finite(points, "points")
        gravity = check_finite(gravity, "gravity")
        axes = _check_axes(axes)
        self.axes, self.planar = _check_planar(given_axes, axes, planar)
        self.points = points
        self.cg_poses = _check_poses(cg_poses)
        self.masses = check_positive(masses, "masses", "mass units")
        self.inertias = _check_inertias(inertias)
        self.gravity = gravity

    @property
    def n_joints(self) -> int:
        """Number of hinges (= flaps), a static Python int."""
        return self.axes.shape[0]

    # ---- AbstractMechanism ----
    # The kernels live in `_dynamics` and `_kinematics`.

    @property
    def n_hinges(self) -> int:
        return self.axes.shape[0]

    @property
    def n_bodies(self) -> int:
        return self.axes.shape[0]

    def mass_matrix(self, q):
        return mass_matrix(self, q)

    def bias_force(self, q, v):
        return bias_torque(self, q, v)

    def forward_dynamics(self, q, v, force, *, forward_mode_only: bool = False):
        return forward_dynamics(self, q, v, force, forward_mode_only=forward_mode_only)

    def inverse_dynamics(self, q, v, a):
        return inverse_dynamics(self, q, v, a)

    def kinetic_energy(self, q, v):
        return kinetic_energy(self, q, v)

    def potential_energy(self, q):
        return potential_energy(self, q)

    def body_poses(self, q):
        return forward_kinematics(self, q)

    def spatial_velocities(self, q, v):
        """``V_i = Σ_{j ≤ i} S_j θ̇_j`` with ``S_j = (p_j × ω_j, ω_j)`` hinge ``j``'s world twist."""
        w, p, _, _ = joint_frames(self, q)
        twists = jnp.concatenate([jnp.cross(p, w), w], axis=-1) * v[:, None]
        return jnp.cumsum(twists, axis=0)

    def apply_wrenches(self, q, wrenches):
        """``f_j = S_j · Σ_{i ≥ j} W_i``: hinge ``j`` carries every flap from ``j`` on."""
        w, p, _, _ = joint_frames(self, q)
        carried = jnp.flip(jnp.cumsum(jnp.flip(wrenches, axis=0), axis=0), axis=0)
        return jnp.sum(jnp.cross(p, w) * carried[:, :3], axis=-1) + jnp.sum(
            w * carried[:, 3:], axis=-1
        )

    def hinge_layout(self) -> HingeLayout:
        """Hinge ``i`` joins flap ``i − 1`` (the base for the first) and flap ``i``; its crease is as wide
        as the child flap (`outlines`), centred on the flap's CG along the axis."""
        axes = np.asarray(self.axes, dtype=float)
        points = np.asarray(self.points, dtype=float)
        cg = np.asarray(self.cg_poses, dtype=float)[:, :3, 3]
        half = np.array([np.abs(outline[:, 0]).max() for outline in self.outlines()])
        # The crease's centre: the point of the axis closest to the child's CG.
        centre = points + np.sum((cg - points) * axes, axis=-1, keepdims=True) * axes
        ends = np.stack([centre - half[:, None] * axes, centre + half[:, None] * axes], axis=1)
        n = self.n_hinges
        return HingeLayout(np.arange(n) - 1, np.arange(n), axes, ends)

    def outlines(self) -> list[np.ndarray]:
        """Each flap as a rectangle in its CG frame's x–y plane (x along the hinge), `(4, 3)` each.

        Length and width come from the plate inertia about the CG, ``I_xx = m(L² + t²)/12`` and
        ``I_yy = m(w² + t²)/12`` (`plate_inertia`; the thickness term is below drawing accuracy)."""
        masses = np.asarray(self.masses)
        inertias = np.asarray(self.inertias)
        length = np.sqrt(np.maximum(12 * inertias[:, 0, 0] / masses, 0.0))
        width = np.sqrt(np.maximum(12 * inertias[:, 1, 1] / masses, 0.0))
        return [
            np.array(
                [
                    [-w / 2, -h / 2, 0.0],
                    [w / 2, -h / 2, 0.0],
                    [w / 2, h / 2, 0.0],
                    [-w / 2, h / 2, 0.0],
                ]
            )
            for h, w in zip(length, width, strict=True)
        ]


def _check_axes(axes: Array) -> Array:
    axes = check_finite(axes, "axes")
    if is_traced(axes):
        norms = jnp.linalg.norm(axes, axis=-1)
        return eqx.error_if(
            axes, jnp.any(jnp.abs(norms - 1) > _UNIT_TOLERANCE), "hinge axes must be unit vectors."
        )
    norms = np.linalg.norm(np.asarray(axes), axis=-1)
    for i, norm in enumerate(norms):
        if norm == 0:
            raise ValueError(f"axes[{i}] is the zero vector; a hinge needs a direction.")
        if abs(norm - 1) > _UNIT_TOLERANCE:
            raise ValueError(
                f"axes[{i}] has norm {norm:.6g}, not 1; pass unit vectors "
                "(e.g. origami_jax._math.normalise(axes)) so that θ is an angle in radians."
            )
    return axes


def _check_planar(given_axes: ArrayLike, axes: Array, planar: bool | None) -> tuple[Array, bool]:
    """The chain's static `planar` flag: detected from `given_axes` when known, else as asserted."""
    if planar is not None and not isinstance(planar, bool):
        raise ValueError(f"planar must be True, False or None (detect), got {planar!r}.")
    if planar is False:
        return axes, False
    if is_traced(given_axes):
        if planar is None:
            return axes, False
        too_far = axes_parallel_error(axes) > PARALLEL_TOLERANCE**2
        return eqx.error_if(axes, too_far, "planar=True but the hinge axes are not parallel."), True
    sines = _sines_to_first_axis(given_axes)
    parallel = bool(np.all(sines <= PARALLEL_TOLERANCE))
    if planar and not parallel:
        worst = int(np.argmax(sines))
        raise ValueError(
            f"planar=True but axes[{worst}] is not parallel to axes[0] (sine of the angle "
            f"{sines[worst]:.3g}, tolerance {PARALLEL_TOLERANCE:g}); pass planar=None to detect it."
        )
    return axes, parallel


def _pose_errors(poses, xp) -> tuple:
    """``(max |RᵀR − I|, max bottom-row error, det R per pose)`` with `xp` = `jnp` (traced) or `np`
    (known values: checked on the host, nothing compiled)."""
    rotation = poses[:, :3, :3]
    orthogonality = xp.max(xp.abs(xp.swapaxes(rotation, -1, -2) @ rotation - xp.eye(3)))
    bottom = xp.max(xp.abs(poses[:, 3, :] - xp.asarray([0.0, 0.0, 0.0, 1.0])))
    return orthogonality, bottom, xp.linalg.det(rotation)


def _check_poses(poses: Array) -> Array:
    poses = check_finite(poses, "cg_poses")
    if is_traced(poses):
        orthogonality, bottom, determinant = _pose_errors(poses, jnp)
        bad = (orthogonality > _UNIT_TOLERANCE) | (bottom > 0) | jnp.any(determinant <= 0)
        return eqx.error_if(poses, bad, "cg_poses must be rigid transforms [[R, p], [0, 1]].")
    orthogonality, bottom, determinant = _pose_errors(np.asarray(poses), np)
    if orthogonality > _UNIT_TOLERANCE or bottom > 0 or np.any(determinant <= 0):
        raise ValueError(
            "cg_poses must be rigid transforms [[R, p], [0, 0, 0, 1]] with R a rotation "
            f"(max |RᵀR − I| = {float(orthogonality):.3g}, max bottom-row error {float(bottom):.3g}, "
            f"min det R = {float(np.min(determinant)):.3g})."
        )
    return poses


def _check_inertias(inertias: Array) -> Array:
    inertias = check_finite(inertias, "inertias")
    if is_traced(inertias):
        asymmetry = jnp.max(jnp.abs(inertias - jnp.swapaxes(inertias, -1, -2)), axis=(-1, -2))
        scale = jnp.max(jnp.abs(inertias), axis=(-1, -2))
        # Sylvester's criterion (leading minors) works on tracers, where eigvalsh would be wasteful.
        minor1 = inertias[:, 0, 0]
        minor2 = inertias[:, 0, 0] * inertias[:, 1, 1] - inertias[:, 0, 1] * inertias[:, 1, 0]
        minor3 = jnp.linalg.det(inertias)
        not_pd = (minor1 <= 0) | (minor2 <= 0) | (minor3 <= 0)
        not_symmetric = asymmetry > 1e-9 * scale
        return eqx.error_if(
            inertias,
            jnp.any(not_pd | not_symmetric),
            "inertias must be symmetric positive definite 3x3 matrices.",
        )
    # Known values: checked on the host (nothing compiled).
    host = np.asarray(inertias)
    asymmetry = np.max(np.abs(host - np.swapaxes(host, -1, -2)), axis=(-1, -2))
    scale = np.max(np.abs(host), axis=(-1, -2))
    for i in range(host.shape[0]):
        if asymmetry[i] > 1e-9 * scale[i]:
            raise ValueError(f"inertias[{i}] is not symmetric; an inertia tensor is.")
        eigenvalues = np.linalg.eigvalsh(host[i])
        if eigenvalues.min() <= 0:
            raise ValueError(
                f"inertias[{i}] is not positive definite (eigenvalues {eigenvalues}); every rigid "
                "flap with positive mass has a positive-definite inertia about its CG."
            )
    return inertias


def plate_inertia(
    length: Float[ArrayLike, "*batch"],
    width: Float[ArrayLike, "*batch"],
    thickness: Float[ArrayLike, "*batch"],
    density: Float[ArrayLike, "*batch"],
) -> tuple[Float[Array, "*batch"], Float[Array, "*batch 3 3"]]:
    """Mass and inertia about the CG of a uniform rectangular plate (any consistent units).

    The plate frame has ``x`` along the width (parallel to the hinge), ``y`` along the length (away from
    the hinge) and ``z`` along the thickness (the flap normal). The formula is the exact cuboid one, so the
    thin-plate limit is included: ``I_xx = m(L² + t²)/12``, ``I_yy = m(w² + t²)/12``, ``I_zz = m(L² + w²)/12``.

    **Arguments:** `length` ``L``, `width` ``w``, `thickness` ``t`` (length), `density` (mass/length³).

    **Returns:** `(mass, inertia)`, mass ``ρ L w t`` and the diagonal inertia (mass·length²).
    """
    length, width, thickness, density = jnp.broadcast_arrays(
        *(jnp.asarray(x) for x in (length, width, thickness, density))
    )
    mass = density * length * width * thickness
    diagonal = jnp.stack(
        [length**2 + thickness**2, width**2 + thickness**2, length**2 + width**2], axis=-1
    ) * (mass[..., None] / 12)
    return mass, diagonal[..., None] * jnp.eye(3, dtype=diagonal.dtype)


def flap_chain(
    axes: Float[ArrayLike, "n 3"],
    points: Float[ArrayLike, "n 3"],
    cg_positions: Float[ArrayLike, "n 3"],
    *,
    flap_length: Float[ArrayLike, "*#n"],
    flap_width: Float[ArrayLike, "*#n"],
    thickness: Float[ArrayLike, "*#n"],
    density: Float[ArrayLike, "*#n"],
    flap_rotations: Float[ArrayLike, "n 3 3"] | None = None,
    gravity: Float[ArrayLike, "3"] | None = None,
    planar: bool | None = None,
) -> Chain:
    """A chain of thin rectangular flaps: mass and inertia computed from the plate geometry.

    **Arguments** (any consistent units; `MICRO` is µm, ng/µm³):
    - `axes`: unit hinge axes at ``θ = 0``, shape `(n, 3)`.
    - `points`: a point on each hinge axis, shape `(n, 3)`, length.
    - `cg_positions`: each flap's centre of gravity at ``θ = 0``, shape `(n, 3)`, length.
    - `flap_length`, `flap_width`, `thickness`: plate dimensions (length), scalars or shape `(n,)`.
    - `density`: plate density (mass/length³), scalar or shape `(n,)`.
    - `flap_rotations`: orientation of each flap frame at ``θ = 0`` (columns: width, length and normal
      directions, see `plate_inertia`), shape `(n, 3, 3)`; identity by default.
    - `gravity`: shape `(3,)`, length/time²; zero by default.
    - `planar`: see `Chain` (default: detected from `axes` when they are not traced).

    **Returns:** a `Chain`.

    **Raises:** `ValueError` for non-positive or non-finite dimensions or density, and everything `Chain`
    raises.
    """
    given_axes = axes  # `Chain` detects planarity from the values as given, before tracing
    axes = as_float_array(axes, "axes")
    check_shape(axes, (None, 3), "axes", "Give one 3-vector per hinge.")
    n = axes.shape[0]
    dims = {}
    for name, value in (
        ("flap_length", flap_length),
        ("flap_width", flap_width),
        ("thickness", thickness),
        ("density", density),
    ):
        array = as_float_array(value, name)
        if array.ndim > 1 or (array.ndim == 1 and array.shape[0] != n):
            raise ValueError(f"{name} must be a scalar or have shape ({n},), got {array.shape}.")
        dims[name] = check_positive(jnp.broadcast_to(array, (n,)), name)
    cg_positions = as_float_array(cg_positions, "cg_positions")
    check_shape(cg_positions, (n, 3), "cg_positions", f"axes has {n} hinges.")
    if flap_rotations is None:
        rotations = jnp.broadcast_to(jnp.eye(3, dtype=cg_positions.dtype), (n, 3, 3))
    else:
        rotations = as_float_array(flap_rotations, "flap_rotations")
        check_shape(rotations, (n, 3, 3), "flap_rotations", f"axes has {n} hinges.")
    masses, inertias = plate_inertia(
        dims["flap_length"], dims["flap_width"], dims["thickness"], dims["density"]
    )
    top = jnp.concatenate([rotations, cg_positions[:, :, None]], axis=-1)
    bottom = jnp.broadcast_to(jnp.array([0.0, 0.0, 0.0, 1.0], dtype=top.dtype), (n, 1, 4))
    poses = jnp.concatenate([top, bottom], axis=-2)
    return Chain(given_axes, points, poses, masses, inertias, gravity, planar=planar)


def accordion(
    n_flaps: int = 3,
    *,
    flap_length: ArrayLike | None = None,
    flap_width: ArrayLike | None = None,
    thickness: ArrayLike | None = None,
    density: ArrayLike | None = None,
    gravity: ArrayLike | None = None,
    units: UnitSystem = MICRO,
) -> Chain:
    """The paper's accordion: ``n_flaps`` flaps in a row along ``y``, all hinges along ``x``.

    Hinge ``i`` (1-based) passes through ``(0, L(i − 1), 0)`` and flap ``i``'s CG sits at
    ``(0, L/2 + L(i − 1), 0)`` with the identity orientation (paper Eq. 9 for n = 3).

    **Arguments** (in `units`; a `None` takes the Fig. 4 default converted into `units`):
    - `n_flaps`: number of flaps (= hinges), any ``n ≥ 1``.
    - `flap_length`: ``L``, default 200 µm (the paper).
    - `flap_width`: default 200 µm (not given in the paper: a parameter; square flaps by default).
    - `thickness`: membrane thickness, default 200 nm (Fig. 4 SiNx).
    - `density`: default SiNx, 3100 kg/m³.
    - `gravity`: shape `(3,)`; zero by default.
    - `units`: the unit system of the inputs and of the returned chain, default `MICRO` (µm, µs, ng).

    **Returns:** a `Chain`.
    """
    if not isinstance(n_flaps, int | np.integer) or isinstance(n_flaps, bool) or n_flaps < 1:
        raise ValueError(f"n_flaps must be an integer >= 1, got {n_flaps!r}.")
    n_flaps = int(n_flaps)
    length = units.length(FLAP_SIZE_SI) if flap_length is None else flap_length
    width = units.length(FLAP_SIZE_SI) if flap_width is None else flap_width
    thickness = units.length(200e-9) if thickness is None else thickness
    density = units.density(_SINX_DENSITY_SI) if density is None else density
    length_array = check_positive(as_float_array(length, "flap_length"), "flap_length")
    if length_array.ndim != 0:
        raise ValueError(
            "accordion's flap_length must be a scalar (all flaps alike); use flap_chain."
        )
    index = jnp.arange(n_flaps, dtype=length_array.dtype)
    e_y = jnp.array([0.0, 1.0, 0.0], dtype=length_array.dtype)
    # Host constants, so that the chain is known to be planar even when built under `jit`.
    axes = np.broadcast_to(np.array([1.0, 0.0, 0.0]), (n_flaps, 3))
    return flap_chain(
        axes,
        (length_array * index)[:, None] * e_y,
        (length_array * (index + 0.5))[:, None] * e_y,
        flap_length=length_array,
        flap_width=width,
        thickness=thickness,
        density=density,
        gravity=gravity,
    )
