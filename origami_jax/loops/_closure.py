"""Loop closure around the interior vertices of a crease pattern: residual, Jacobian, curvature.

Around an interior vertex the faces close up when the product of the rotations about its creases'
outward directions ``d_k`` (flat pattern, counter-clockwise seen from the paper's normal) by their
fold angles is the identity,

    P(θ) = R(d_1, θ_1) R(d_2, θ_2) ⋯ R(d_D, θ_D) = I,

three equations per vertex (all the creases pass through the vertex, so the translations close with
the rotations). The residual is ``c = vee(P − Pᵀ)/2`` (``sin φ`` times the axis of ``P``, zero at
closure). Its derivative along crease ``k`` is ``∂P/∂θ_k = [w_k]× P`` with ``w_k = R_1⋯R_{k−1} d_k``
(crease ``k``'s direction carried by the rotations before it), so with the identity
``vee(Bᵀ[w] + [w]B) = (tr B · I − B) w``

    ∂c/∂θ_k = ½ (tr P · I − P) w_k,

one 3×3 matrix per vertex times the carried directions: no automatic differentiation in the inner
loop. The second-order term ``γ = (d/dt ∂c/∂θ) θ̇`` that acceleration-level constraints need comes from
one forward-mode derivative of ``θ ↦ J(θ) θ̇``.

Vertices are padded to the largest degree ``D``: padding slots point at an extra zero angle (index
``m``, appended) and contribute identity rotations and zero columns.
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float


def _rodrigues(axes: Float[Array, "*b 3"], angles: Float[Array, "*b"]) -> Float[Array, "*b 3 3"]:
    x, y, z = axes[..., 0], axes[..., 1], axes[..., 2]
    zero = jnp.zeros_like(x)
    skew = jnp.stack(
        [jnp.stack([zero, -z, y], -1), jnp.stack([z, zero, -x], -1), jnp.stack([-y, x, zero], -1)],
        axis=-2,
    )
    s = jnp.sin(angles)[..., None, None]
    c = jnp.cos(angles)[..., None, None]
    eye = jnp.eye(3, dtype=axes.dtype)
    return eye + s * skew + (1 - c) * (skew @ skew)


def gather_angles(theta: Float[Array, " m"], index) -> Float[Array, "n_v D"]:
    """Each vertex's crease angles `(n_v, D)` (padding slots read an appended zero)."""
    padded = jnp.concatenate([theta, jnp.zeros((1,), theta.dtype)])
    return padded[index]


def loop_products(
    directions: Float[Array, "n_v D 3"], angles: Float[Array, "n_v D"]
) -> tuple[Float[Array, "n_v 3 3"], Float[Array, "n_v D 3"]]:
    """The product ``P`` around every vertex and the carried directions ``w_k`` (module docstring)."""
    rotations = _rodrigues(directions, angles)
    n_v, depth = angles.shape
    product = jnp.broadcast_to(jnp.eye(3, dtype=angles.dtype), (n_v, 3, 3))
    carried = []
    for k in range(depth):
        carried.append(jnp.einsum("vij,vj->vi", product, directions[:, k]))
        product = product @ rotations[:, k]
    return product, jnp.stack(carried, axis=1)


def residual_of(product: Float[Array, "n_v 3 3"]) -> Float[Array, "n_v 3"]:
    """``vee(P − Pᵀ)/2`` per vertex."""
    skew = 0.5 * (product - jnp.swapaxes(product, -1, -2))
    return jnp.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=-1)


def jacobian_blocks(
    product: Float[Array, "n_v 3 3"], carried: Float[Array, "n_v D 3"]
) -> Float[Array, "n_v 3 D"]:
    """``∂c_v/∂θ`` for the creases of each vertex, `(n_v, 3, D)`."""
    trace = jnp.trace(product, axis1=-2, axis2=-1)
    eye = jnp.eye(3, dtype=product.dtype)
    left = 0.5 * (trace[:, None, None] * eye - product)
    return jnp.einsum("vij,vkj->vik", left, carried)


def closure(
    directions: Float[Array, "n_v D 3"], index, theta: Float[Array, " m"]
) -> Float[Array, "n_v 3"]:
    """Closure residual of every vertex at fold angles `theta` (rad), `(n_v, 3)`."""
    product, _ = loop_products(directions, gather_angles(theta, index))
    return residual_of(product)


def closure_terms(
    directions: Float[Array, "n_v D 3"], index, theta: Float[Array, " m"], rate: Float[Array, " m"]
) -> tuple[Float[Array, "n_v 3"], Float[Array, "n_v 3 D"], Float[Array, "n_v 3"]]:
    """Residual ``c``, Jacobian blocks ``J_v`` and curvature ``γ = J̇ θ̇`` of every vertex."""
    angles = gather_angles(theta, index)
    rates = gather_angles(rate, index)

    def blocks(angles):
        product, carried = loop_products(directions, angles)
        return residual_of(product), jacobian_blocks(product, carried)

    (residual, jac), (_, jac_rate) = jax.jvp(blocks, (angles,), (rates,))
    gamma = jnp.einsum("vik,vk->vi", jac_rate, rates)
    return residual, jac, gamma


def apply_blocks(
    jac: Float[Array, "n_v 3 D"], index, x: Float[Array, " m"]
) -> Float[Array, "n_v 3"]:
    """``J x`` from the blocks."""
    return jnp.einsum("vik,vk->vi", jac, gather_angles(x, index))


def apply_transpose(
    jac: Float[Array, "n_v 3 D"], index, y: Float[Array, "n_v 3"], m: int
) -> Float[Array, " m"]:
    """``Jᵀ y`` from the blocks, `(m,)`."""
    contributions = jnp.einsum("vik,vi->vk", jac, y)
    out = jnp.zeros((m + 1,), y.dtype).at[index].add(contributions)
    return out[:m]


def normal_matrix(jac: Float[Array, "n_v 3 D"], index, m: int) -> Float[Array, "m m"]:
    """``JᵀJ`` `(m, m)`, assembled from the per-vertex ``J_vᵀJ_v`` (the creases of one vertex only
    meet each other's: no dense product)."""
    blocks = jnp.einsum("vik,vil->vkl", jac, jac)
    rows = index[:, :, None]
    cols = index[:, None, :]
    out = jnp.zeros((m + 1, m + 1), jac.dtype).at[rows, cols].add(blocks)
    return out[:m, :m]
