"""Forward kinematics by the product of exponentials, and spatial and body Jacobians (paper Eqs. 8–10).

`forward_kinematics` and the internal `joint_frames` are the fast path (closed-form Rodrigues per hinge,
one sequential composition, 3×3 products written as broadcast-and-sum because XLA on the CPU runs many
tiny `dot`s slowly). `body_jacobians` follows the ``Ad⁻¹`` formula of the paper's appendix literally, column by column; it is
the paper's formulation and the reference the recursive dynamics are tested against.
"""

from typing import TYPE_CHECKING, Any

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ._se3 import exp_twist, make_transform, revolute_twist

if TYPE_CHECKING:
    from ._chain import Chain


def matmul3(
    a: Float[Array, "*batch 3 3"], b: Float[Array, "*batch 3 3"]
) -> Float[Array, "*batch 3 3"]:
    """``a @ b`` for stacks of 3×3 matrices as one fused multiply-and-sum."""
    return jnp.sum(a[..., :, :, None] * b[..., None, :, :], axis=-2)


def matvec3(a: Float[Array, "*batch 3 3"], x: Float[Array, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """``a @ x`` for stacks of 3×3 matrices and 3-vectors as one fused multiply-and-sum."""
    return jnp.sum(a * x[..., None, :], axis=-1)


def _hinge_rotations(axes: Array, theta: Array) -> Array:
    # Rodrigues for unit axes, R = I + sin θ ω̂ + (1 − cos θ) ω̂², written with ω̂² = ωωᵀ − I so that no
    # matrix product is needed. Entire in θ, so derivatives at θ = 0 are exact.
    s = jnp.sin(theta)[:, None, None]
    c = jnp.cos(theta)[:, None, None]
    x, y, z = axes[:, 0], axes[:, 1], axes[:, 2]
    zero = jnp.zeros_like(x)
    w_hat = jnp.stack(
        [
            jnp.stack([zero, -z, y], axis=-1),
            jnp.stack([z, zero, -x], axis=-1),
            jnp.stack([-y, x, zero], axis=-1),
        ],
        axis=-2,
    )
    outer = axes[:, :, None] * axes[:, None, :]
    return c * jnp.eye(3, dtype=axes.dtype) + s * w_hat + (1 - c) * outer


def joint_frames(
    chain: "Chain", theta: Float[ArrayLike, " n"]
) -> tuple[Float[Array, "n 3"], Float[Array, "n 3"], Float[Array, "n 3 3"], Float[Array, "n 3"]]:
    """World-frame hinge axes and points, and flap CG rotations and positions, at ``θ``.

    **Returns:** `(w, p, rotations, cg)`: ``w_i`` and ``p_i`` the axis and a point of hinge ``i`` moved by
    hinges ``1..i−1`` (shape `(n, 3)`), and flap ``i``'s CG frame ``g_{sl_i}(θ) = (rotations_i, cg_i)``.
    """
    theta = jnp.asarray(theta)
    n = chain.n_joints
    rotations = _hinge_rotations(chain.axes, theta)
    # A rotation about the axis through q maps x to R(x − q) + q, so its translation is q − R q.
    translations = chain.points - matvec3(rotations, chain.points)
    r_prefix: list[Any] = [None] * n
    t_prefix: list[Any] = [None] * n
    r_cum, t_cum = rotations[0], translations[0]
    r_prefix[0], t_prefix[0] = r_cum, t_cum
    for i in range(1, n):
        t_cum = matvec3(r_cum, translations[i]) + t_cum
        r_cum = matmul3(r_cum, rotations[i])
        r_prefix[i], t_prefix[i] = r_cum, t_cum
    r_after = jnp.stack(r_prefix)  # e^{ξ̂_1 θ_1} ⋯ e^{ξ̂_i θ_i}
    t_after = jnp.stack(t_prefix)
    eye = jnp.eye(3, dtype=r_after.dtype)[None]
    r_before = jnp.concatenate([eye, r_after[:-1]], axis=0)  # e^{ξ̂_1 θ_1} ⋯ e^{ξ̂_{i−1} θ_{i−1}}
    t_before = jnp.concatenate([jnp.zeros_like(t_after[:1]), t_after[:-1]], axis=0)
    w = matvec3(r_before, chain.axes)
    p = matvec3(r_before, chain.points) + t_before
    flap_rotations = matmul3(r_after, chain.cg_poses[:, :3, :3])
    cg = matvec3(r_after, chain.cg_poses[:, :3, 3]) + t_after
    return w, p, flap_rotations, cg


def forward_kinematics(chain: "Chain", theta: Float[ArrayLike, " n"]) -> Float[Array, "n 4 4"]:
    """CG pose of every flap, ``g_{sl_i}(θ) = e^{ξ̂_1 θ_1} ⋯ e^{ξ̂_i θ_i} g_{sl_i}(0)`` (paper Eq. 8).

    **Arguments:** `chain`; `theta`, hinge angles (rad), shape `(n,)`.

    **Returns:** homogeneous transforms, shape `(n, 4, 4)`, translations in the chain's length unit.
    """
    _, _, rotations, cg = joint_frames(chain, theta)
    return make_transform(rotations, cg)


def spatial_jacobians(chain: "Chain", theta: Float[ArrayLike, " n"]) -> Float[Array, "n 6 n"]:
    """Spatial Jacobian of every flap: column ``j ≤ i`` is ``ξ'_j = Ad_{e^{ξ̂_1θ_1}⋯e^{ξ̂_{j−1}θ_{j−1}}} ξ_j``.

    Twists are ``(v, ω)``; the spatial velocity of flap ``i`` is ``J^s_i θ̇``.

    **Returns:** shape `(n, 6, n)` (flap, twist component, hinge); columns ``j > i`` are zero.
    """
    w, p, _, _ = joint_frames(chain, theta)
    columns = revolute_twist(w, p).T  # (6, n)
    n = chain.n_joints
    mask = jnp.arange(n)[None, :] <= jnp.arange(n)[:, None]  # (flap i, hinge j): j ≤ i
    return jnp.where(mask[:, None, :], columns[None], 0.0)


def body_jacobians(chain: "Chain", theta: Float[ArrayLike, " n"]) -> Float[Array, "n 6 n"]:
    """Body Jacobian of every flap by the appendix's formula (the paper's printed ``J_3`` is wrong: its second column is shifted down a row).

    Column ``j ≤ i`` of flap ``i`` is ``ξ_j^† = Ad⁻¹_{(e^{ξ̂_j θ_j} ⋯ e^{ξ̂_i θ_i} g_{sl_i}(0))} ξ_j``; columns
    ``j > i`` are zero. Body velocity of flap ``i`` (in its CG frame) is ``J_i θ̇``. This is the paper's
    formulation, O(n²) transforms, kept as the reference; the dynamics use the recursive path.

    **Returns:** shape `(n, 6, n)` (flap, twist component ``(v, ω)``, hinge).
    """
    theta = jnp.asarray(theta)
    n = chain.n_joints
    twists = revolute_twist(chain.axes, chain.points)
    exps = exp_twist(twists, theta)
    exp_rotations, exp_translations = exps[:, :3, :3], exps[:, :3, 3]
    flaps = []
    for i in range(n):
        columns = []
        # g = e^{ξ̂_j θ_j} ⋯ e^{ξ̂_i θ_i} g_{sl_i}(0), grown from the flap back towards the base; kept as
        # (R, p) because Ad⁻¹_g ξ = (Rᵀ(v + ω × p), Rᵀ ω) needs no 4×4 or 6×6 matrix.
        rotation, translation = chain.cg_poses[i, :3, :3], chain.cg_poses[i, :3, 3]
        for j in range(i, -1, -1):
            translation = exp_rotations[j] @ translation + exp_translations[j]
            rotation = exp_rotations[j] @ rotation
            v, w = twists[j, :3], twists[j, 3:]
            columns.append(
                jnp.concatenate([rotation.T @ (v + jnp.cross(w, translation)), rotation.T @ w])
            )
        columns = columns[::-1] + [jnp.zeros(6, dtype=twists.dtype)] * (n - i - 1)
        flaps.append(jnp.stack(columns, axis=-1))
    return jnp.stack(flaps)
