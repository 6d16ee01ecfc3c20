"""Equations of motion ``M(θ) θ̈ + C(θ, θ̇) θ̇ + G(θ) = f`` of a flap chain (paper Eq. 11): every kernel.

**Evaluation paths** (all the same model; tests hold them to each other at 1e-12 relative and to
Pinocchio at 1e-10):
- *Arrays* (`_Bodies`, `_composite_mass_matrix`, `_newton_euler`): composite-rigid-body mass matrix
  and recursive Newton–Euler bias in the inertial frame about its origin, on `(n, 3)` arrays; any
  chain length. `mass_matrix`, `bias_torque` and `inverse_dynamics` use it.
- *Scalar* (`_scalar`): the same algorithm with every 3-vector a tuple of arrays and a Python loop
  over the hinges; under `vmap` one fused elementwise pass per operation (4.6× faster for a spatial
  chain). Used by `forward_dynamics` for chains of up to `_SCALAR_FORWARD_MAX` hinges.
- *Planar* (`_planar`): a chain whose hinge axes are all parallel (`Chain.planar`, the accordion) is
  a planar linkage; the scalar algorithm in two dimensions, ~5× fewer operations.
- *Reference* (`mass_matrix(..., method="jacobian")`, `coriolis_matrix`): the paper's
  ``Σ J_iᵀ 𝕄_i J_i`` and Christoffel symbols by autodiff, ~30× the FLOPs; for tests.
One unrolled Cholesky (`_scalar.cholesky_lists`) factors ``M`` on every path up to `_UNROLL_MAX` hinges.

**Derivative rules of `forward_dynamics`** (the contract; each is a `jax.custom_jvp` whose tangent is
exact to rounding and agrees with plain autodiff of the array path):
1. *Default rule* (`_planar_or_arrays_jvp`), for the scalar path's value: forward-mode autodiff of
   the planar form when the chain is planar and the tangent does not tilt an axis, else of the array
   form. Being autodiff of a JAX function, it is linear in the tangents, so reverse mode transposes
   it: `jax.grad` through `simulate` works. The planar form is differentiated in ``sin θ`` and
   ``cos θ`` with their tangents by hand; chain fields without a tangent stay constants.
2. *Rows* (`_forward_dynamics_scalar_samples`): `(t, n)` stacks of states of one chain, the rule of
   1 applied outside the `vmap` over rows (inside it, `jacfwd` through a forward-mode diffrax solve
   returned transposed tangents in jax 0.10.2).
3. *Complex step* (`forward_mode_only=True`, `_complex_step_jvp`): ``M dθ̈ = d f − d ID`` with
   ``d ID`` the imaginary part of one complex evaluation of the (polynomial) inverse dynamics at step
   1e-100, exact in floating point, fused by XLA into one kernel (~2× faster for a forward-mode
   solve). Not linear in the tangents as traced, so forward mode only; differentiated again (an
   implicit solver's Jacobian inside a forward-mode solve) it falls back to rule 1's array form.
All functions are unit-agnostic: torque comes out in mass·length²/time² of the chain's units.
Spatial vectors are ordered ``(linear, angular)`` like the twists; motion vectors are taken at the
world origin (Featherstone's spatial vectors), so the composite inertia of a sub-chain is a plain sum.
"""

import functools
from typing import TYPE_CHECKING, Literal, cast

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._math import sin_cos_once
from ._axes import PARALLEL_TOLERANCE, axes_parallel_error, check_still_planar
from ._kinematics import body_jacobians, joint_frames, matmul3, matvec3
from ._planar import PlanarBodies, planar_inverse_dynamics_lists, planar_mass_matrix_lists
from ._scalar import (
    CholeskyLists,
    ScalarBodies,
    cholesky_lists,
    cholesky_solve_factored,
    mass_matrix_lists,
    newton_euler_lists,
)

if TYPE_CHECKING:
    from ._chain import Chain

# Chains of up to this many hinges take the scalar (or planar) path in `forward_dynamics` (module
# docstring); longer ones the array path, whose graph grows linearly instead of with the unrolled loops.
_SCALAR_FORWARD_MAX = 6

# Above this size the unrolled Cholesky in `_solve_spd` would unroll O(n³) scalar operations into the
# graph; LAPACK's is cheaper to compile then.
_UNROLL_MAX = 8


def _assemble(scalars: list[Array]) -> Array:
    # Stack per-hinge scalars into the last axis as Σ_i x_i e_i. A plain `jnp.stack` (a concatenate) gets
    # fused with the whole scalar graph into one branching loop over the output elements that XLA does
    # not vectorise: vmapped over 10,000 accordion states the bias took ~30 µs per state that way and
    # ~0.3 µs this way (an optimisation barrier did not help).
    eye = jnp.eye(len(scalars), dtype=jnp.result_type(*scalars))
    return cast(Array, sum(x[..., None] * eye[i] for i, x in enumerate(scalars)))


def _cross(a: Array, b: Array) -> Array:
    # Written out: jnp.cross on (…, 3) lowers to slices and a concatenate, this to three fused lines.
    return jnp.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def _dot(a: Array, b: Array) -> Array:
    return jnp.sum(a * b, axis=-1)


def _reverse_cumsum(x: Array) -> Array:
    return jnp.flip(jnp.cumsum(jnp.flip(x, axis=0), axis=0), axis=0)


class _Bodies:
    """Per-flap rigid-body data at ``θ``, in the inertial frame about its origin."""

    def __init__(self, chain: "Chain", theta: Array):
        w, p, rotations, cg = joint_frames(chain, theta)
        self.w = w  # hinge axes, (n, 3)
        self.v = _cross(p, w)  # linear part of the hinge twists at the origin, −w × p
        self.mass = chain.masses  # (n,)
        self.moment = chain.masses[:, None] * cg  # first moment h = m c, (n, 3)
        inertia_cg = matmul3(matmul3(rotations, chain.inertias), jnp.swapaxes(rotations, -1, -2))
        # Parallel-axis theorem to the origin: I_o = I_c + m (|c|² I − c cᵀ).
        c2 = _dot(cg, cg)[:, None, None] * jnp.eye(3, dtype=cg.dtype)
        self.inertia = inertia_cg + chain.masses[:, None, None] * (
            c2 - cg[:, :, None] * cg[:, None, :]
        )

    def apply_inertia(self, mass, moment, inertia, lin, ang):
        """Spatial inertia times a motion vector: ``(m a − h × α, h × a + I_o α)``."""
        force = mass[..., None] * lin - _cross(moment, ang)
        torque = _cross(moment, lin) + matvec3(inertia, ang)
        return force, torque


def _composite_mass_matrix(bodies: _Bodies) -> Array:
    # Composite inertia of flaps k..n (a plain sum, all about the same origin) applied to hinge k's
    # twist; then M_jk = S_j · (I^C_k S_k) for j ≤ k, and M is symmetric.
    force, torque = bodies.apply_inertia(
        _reverse_cumsum(bodies.mass),
        _reverse_cumsum(bodies.moment),
        _reverse_cumsum(bodies.inertia),
        bodies.v,
        bodies.w,
    )
    upper = jnp.sum(
        bodies.v[:, None, :] * force[None, :, :] + bodies.w[:, None, :] * torque[None, :, :],
        axis=-1,
    )
    n = bodies.w.shape[0]
    j_le_k = jnp.arange(n)[:, None] <= jnp.arange(n)[None, :]
    return jnp.where(j_le_k, upper, upper.T)


def _newton_euler(bodies: _Bodies, gravity: Array, theta_dot: Array, theta_ddot: Array) -> Array:
    s_lin, s_ang = bodies.v, bodies.w
    # Spatial velocity of flap i: the sum of the hinge twists up to i.
    vel_lin = jnp.cumsum(s_lin * theta_dot[:, None], axis=0)
    vel_ang = jnp.cumsum(s_ang * theta_dot[:, None], axis=0)
    # Spatial acceleration: Σ_{j≤i} (V_j × S_j) θ̇_j + S_j θ̈_j. The derivative of S_j is V_{j−1} × S_j;
    # V_j × S_j is the same because S_j × S_j = 0. Gravity enters as a base acceleration −g.
    cross_lin = _cross(vel_ang, s_lin) + _cross(vel_lin, s_ang)
    cross_ang = _cross(vel_ang, s_ang)
    acc_lin = jnp.cumsum(cross_lin * theta_dot[:, None] + s_lin * theta_ddot[:, None], axis=0)
    acc_ang = jnp.cumsum(cross_ang * theta_dot[:, None] + s_ang * theta_ddot[:, None], axis=0)
    acc_lin = acc_lin - gravity
    # Net spatial force on each flap: I a + V ×* (I V).
    f_acc, n_acc = bodies.apply_inertia(
        bodies.mass, bodies.moment, bodies.inertia, acc_lin, acc_ang
    )
    f_mom, n_mom = bodies.apply_inertia(
        bodies.mass, bodies.moment, bodies.inertia, vel_lin, vel_ang
    )
    force = f_acc + _cross(vel_ang, f_mom)
    torque = n_acc + _cross(vel_lin, f_mom) + _cross(vel_ang, n_mom)
    # Hinge j carries every flap from j on.
    return _dot(s_lin, _reverse_cumsum(force)) + _dot(s_ang, _reverse_cumsum(torque))


def mass_matrix(
    chain: "Chain",
    theta: Float[ArrayLike, " n"],
    *,
    method: Literal["recursive", "jacobian"] = "recursive",
) -> Float[Array, "n n"]:
    """Joint-space mass matrix ``M(θ)`` (mass·length², i.e. torque per rad/time²).

    **Arguments:**
    - `chain`; `theta`, hinge angles (rad), shape `(n,)`.
    - `method`: `"recursive"` (default, composite rigid bodies, fast) or `"jacobian"` (the paper's
      ``Σ J_iᵀ 𝕄_i J_i`` with ``𝕄_i = diag(m_i I₃, 𝓘_i)``, the reference).

    **Returns:** symmetric positive-definite matrix, shape `(n, n)`.
    """
    theta = jnp.asarray(theta)
    if method == "jacobian":
        jac = body_jacobians(chain, theta)  # (n, 6, n)
        lin, ang = jac[:, :3, :], jac[:, 3:, :]
        translational = jnp.einsum("i,iaj,iak->jk", chain.masses, lin, lin)
        rotational = jnp.einsum("iaj,iab,ibk->jk", ang, chain.inertias, ang)
        return translational + rotational
    if method != "recursive":
        raise ValueError(f"method must be 'recursive' or 'jacobian', got {method!r}.")
    return _composite_mass_matrix(_Bodies(chain, theta))


def inverse_dynamics(
    chain: "Chain",
    theta: Float[ArrayLike, " n"],
    theta_dot: Float[ArrayLike, " n"],
    theta_ddot: Float[ArrayLike, " n"],
) -> Float[Array, " n"]:
    """Rigid-body torques ``M θ̈ + C θ̇ + G`` by recursive Newton–Euler (no hinge springs or drag).

    ``G`` is the gravity torque (zero when `chain.gravity` is zero). Add `hinge_torque` for the full
    computed-torque input of paper Eq. 13.

    **Arguments:** `theta` (rad), `theta_dot` (rad/time), `theta_ddot` (rad/time²), each shape `(n,)`.

    **Returns:** joint torques, shape `(n,)`, mass·length²/time².
    """
    theta, theta_dot, theta_ddot = (jnp.asarray(x) for x in (theta, theta_dot, theta_ddot))
    return _newton_euler(_Bodies(chain, theta), chain.gravity, theta_dot, theta_ddot)


def bias_torque(
    chain: "Chain", theta: Float[ArrayLike, " n"], theta_dot: Float[ArrayLike, " n"]
) -> Float[Array, " n"]:
    """``C(θ, θ̇) θ̇`` (plus the gravity torque if `chain.gravity` is set), recursive Newton–Euler, O(n).

    **Arguments:** `theta` (rad), `theta_dot` (rad/time), shape `(n,)`.

    **Returns:** shape `(n,)`, torque (mass·length²/time²).
    """
    theta, theta_dot = jnp.asarray(theta), jnp.asarray(theta_dot)
    return _newton_euler(_Bodies(chain, theta), chain.gravity, theta_dot, jnp.zeros_like(theta_dot))


def coriolis_matrix(
    chain: "Chain", theta: Float[ArrayLike, " n"], theta_dot: Float[ArrayLike, " n"]
) -> Float[Array, "n n"]:
    """Coriolis matrix from the Christoffel symbols of ``M`` by autodiff (the paper's formulation).

    ``C_ij = ½ Σ_k (∂M_ij/∂θ_k + ∂M_ik/∂θ_j − ∂M_kj/∂θ_i) θ̇_k`` (the paper's sum limit "n = 1" is a
    misprint). ``M`` is the `"jacobian"` one, so this is independent of the recursive path. It is the
    reference: about 30× the FLOPs of `bias_torque`.

    **Returns:** shape `(n, n)`, mass·length²/time; ``Ṁ − 2C`` is skew-symmetric.
    """
    theta = jnp.asarray(theta)
    theta_dot = jnp.asarray(theta_dot)
    d_mass = jax.jacfwd(lambda t: mass_matrix(chain, t, method="jacobian"))(theta)  # [i, j, k]
    return 0.5 * (
        jnp.einsum("ijk,k->ij", d_mass, theta_dot)
        + jnp.einsum("ikj,k->ij", d_mass, theta_dot)
        - jnp.einsum("kji,k->ij", d_mass, theta_dot)
    )


def potential_energy(chain: "Chain", theta: Float[ArrayLike, " n"]) -> Float[Array, ""]:
    """Gravitational potential energy ``−Σ m_i g · c_i(θ)`` (mass·length²/time²); zero without gravity."""
    _, _, _, cg = joint_frames(chain, theta)
    return -jnp.sum(chain.masses * _dot(cg, chain.gravity))


def kinetic_energy(
    chain: "Chain", theta: Float[ArrayLike, " n"], theta_dot: Float[ArrayLike, " n"]
) -> Float[Array, ""]:
    """Kinetic energy ``½ θ̇ᵀ M(θ) θ̇`` (mass·length²/time²)."""
    theta_dot = jnp.asarray(theta_dot)
    return 0.5 * theta_dot @ mass_matrix(chain, theta) @ theta_dot


def hinge_torque(
    stiffness: Float[ArrayLike, "#n"] | Float[ArrayLike, ""],
    drag: Float[ArrayLike, "#n"] | Float[ArrayLike, ""],
    theta: Float[ArrayLike, "*t n"],
    theta_dot: Float[ArrayLike, "*t n"],
) -> Float[Array, "*t n"]:
    """Hinge spring and drag torque ``N = K θ + B θ̇|θ̇|`` with diagonal ``K``, ``B`` (paper Eq. 11).

    **Arguments:**
    - `stiffness`: ``k`` per hinge, torque/rad, shape `(n,)` or scalar.
    - `drag`: ``b`` per hinge, torque·time²/rad², shape `(n,)` or scalar.
    - `theta` (rad), `theta_dot` (rad/time): shape `(n,)`, or `(t, n)` for `t` states.

    **Returns:** the shape of `theta`, torque.
    """
    theta = jnp.asarray(theta)
    theta_dot = jnp.asarray(theta_dot)
    return jnp.asarray(stiffness) * theta + jnp.asarray(drag) * theta_dot * jnp.abs(theta_dot)


def _solve_spd(matrix: Array, rhs: Array) -> Array:
    n = matrix.shape[0]
    if n > _UNROLL_MAX:
        return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(matrix), rhs)
    # The scalar path's unrolled Cholesky: for a handful of hinges a few dozen fused flops, where a
    # LAPACK call (or jnp.linalg.solve) costs a custom call and pivoting logic per evaluation.
    entries = [[matrix[i, j] for j in range(n)] for i in range(n)]
    return jnp.stack(cholesky_solve_factored(cholesky_lists(entries), [rhs[i] for i in range(n)]))


def forward_dynamics(
    chain: "Chain",
    theta: Float[ArrayLike, "*t n"],
    theta_dot: Float[ArrayLike, "*t n"],
    force: Float[ArrayLike, "*t n"],
    *,
    path: Literal["auto", "arrays"] = "auto",
    forward_mode_only: bool = False,
) -> Float[Array, "*t n"]:
    """Hinge accelerations ``θ̈ = M⁻¹ (f − C θ̇ − G)`` (paper Eq. 11), the simulator's right-hand side.

    ``f`` is every torque but inertia: for the paper's model ``f = τ − K θ − B θ̇|θ̇|`` (input, hinge
    springs, drag; see `hinge_torque` and `origami_jax.system.FoldingSystem.generalized_force`).

    Recursive path: composite-rigid-body ``M``, Newton–Euler ``C θ̇ (+ G)``, a Cholesky solve; in two
    dimensions for a planar chain (`Chain.planar`: every hinge axis parallel, e.g. the accordion), which
    is the same model with ~5× fewer operations.

    **Arguments:**
    - `theta` (rad), `theta_dot` (rad/time), `force` (torque per hinge): shape `(n,)`, or `(t, n)`
      for `t` states of the same chain (e.g. the samples of a trajectory), one row each.
    - `path`: `"auto"` (default) evaluates chains of up to six hinges on scalars (planar ones in two
      dimensions), ~4.6× faster under `vmap` on the CPU for a spatial chain, and differentiates
      through a custom JVP (the planar form's autodiff in planar directions, else the array form's);
      `"arrays"` always uses the spatial array form. Both give the same answer to rounding.
    - `forward_mode_only`: for a single state on the scalar path, differentiate by a complex step
      through the inverse dynamics instead of autodiff (same derivatives to rounding, ~2× faster for
      a forward-mode solve of one trajectory; see `_forward_dynamics_scalar_and_tangent`).
      Only forward mode (`jax.jvp`, `jax.jacfwd`) is then available: reverse mode fails. `simulate`
      sets it for its right-hand side under `diffrax.ForwardMode`. Rows of states ignore it.

    **Returns:** ``θ̈``, the shape of `theta`, rad/time².
    """
    theta = jnp.asarray(theta)
    theta_dot = jnp.asarray(theta_dot)
    applied = jnp.asarray(force)
    if path not in ("auto", "arrays"):
        raise ValueError(f"path must be 'auto' or 'arrays', got {path!r}.")
    check_still_planar(chain)
    n = chain.n_joints
    if (
        theta.ndim not in (1, 2)
        or theta.shape[-1] != n
        or applied.shape != theta.shape
        or theta_dot.shape != theta.shape
    ):
        raise ValueError(
            f"theta, theta_dot and force must have shape ({n},) or (t, {n}) for this {n}-hinge "
            f"chain, got {theta.shape}, {theta_dot.shape} and {jnp.shape(force)}."
        )
    scalar = path == "auto" and n <= _SCALAR_FORWARD_MAX
    if theta.ndim == 2:
        if scalar:
            # Rows keep the default (autodiff) rule even with `forward_mode_only`: vmapped over a
            # trajectory's samples the spatial complex-step kernel doubled the design fit's compile
            # time (5.5 → 13.7 s) to save ~4 ms per forward-mode solve.
            return _forward_dynamics_scalar_samples(chain, theta, theta_dot, applied)
        return _forward_dynamics_arrays_samples(chain, theta, theta_dot, applied)
    if scalar:
        single = _forward_dynamics_scalar_forward if forward_mode_only else _forward_dynamics_scalar
        return single(chain, theta, theta_dot, applied)
    return _forward_dynamics_arrays(chain, theta, theta_dot, applied)


# Jitted (a nested jit is inlined by XLA: the compiled program is the same) so that it is traced once
# per chain structure and its jaxpr reused: `simulate` evaluates it in the right-hand side and again,
# vmapped over the rows, at the samples (half of the samples' tracing, ~0.08 s of a first call).
@jax.jit
def _forward_dynamics_scalar_value(
    chain: "Chain", theta: Array, theta_dot: Array, applied: Array
) -> Array:
    return _forward_dynamics_scalar_and_tangent(chain, theta, theta_dot, applied, None)[0]


def _planar_solve(chain: "Chain", sin_cos, theta_dot, applied) -> tuple[list[Array], CholeskyLists]:
    """``θ̈`` of a planar chain (`_planar`) as n scalars, and the Cholesky factor of ``M``."""
    n = chain.n_joints
    bodies = PlanarBodies(chain, sin_cos)  # shared by M and the bias
    factor = cholesky_lists(planar_mass_matrix_lists(bodies))
    bias = planar_inverse_dynamics_lists(bodies, theta_dot, None)
    acc = cholesky_solve_factored(factor, [applied[..., i] - bias[i] for i in range(n)])
    # A chain whose axes were replaced after it was built (`eqx.tree_at`) may no longer be planar:
    # NaN rather than a wrong answer (a few operations, fused with the rest).
    bent = axes_parallel_error(chain.axes) > PARALLEL_TOLERANCE**2
    return [jnp.where(bent, jnp.nan, x) for x in acc], factor


def _forward_dynamics_scalar_and_tangent(chain, theta, theta_dot, applied, tangents):
    """``θ̈`` on scalars and, given `tangents` ``(d chain, dθ, dθ̇, d applied)``, its directional
    derivative ``dθ̈`` (else `None`).

    Differentiating ``M θ̈ + c(θ, θ̇) = applied`` with ``θ̈`` held: ``M dθ̈ = d applied − d ID``, where
    ``d ID`` is the derivative of the inverse dynamics ``ID(θ, θ̇, θ̈) = M θ̈ + c`` in the direction
    ``(dθ, dθ̇, d chain)`` at the solved ``θ̈``; the Cholesky factor of ``M`` is the primal's.

    ``d ID`` is taken by a complex step: ``ID(θ + i h dθ, θ̇ + i h dθ̇; chain + i h d chain)`` has
    imaginary part ``h d ID + O(h³)``, and the inverse dynamics are a polynomial in the twists, the
    inertias, ``sin θ`` and ``cos θ`` (no division, root or comparison), so with ``h = 1e-100`` the
    derivative is exact in floating point, like forward-mode autodiff, but it is one complex
    evaluation of the same scalar graph. XLA:CPU then fuses it into one kernel: measured in a loop on
    one accordion state with 2 tangent lanes, 2.9 µs per evaluation against 4.8 µs for forward-mode
    autodiff through the array form (114 kernels) and 8.5 µs through the scalar form (180 kernels).

    A planar chain (`Chain.planar`) is solved and differentiated in two dimensions (`_planar`); a
    tangent that tilts its axes leaves the planar chains, and is taken through the spatial inverse
    dynamics (at the planar solution and with its factor, which are the spatial ones to round-off).
    """
    n = chain.n_joints
    sines, cosines = sin_cos_once(theta)
    if chain.planar:
        acc, factor = _planar_solve(chain, (sines, cosines), theta_dot, applied)
    else:
        bodies = ScalarBodies(chain, theta, (sines, cosines))  # shared by M and the bias
        factor = cholesky_lists(mass_matrix_lists(bodies))
        bias = newton_euler_lists(bodies, chain.gravity, theta_dot, None)
        acc = cholesky_solve_factored(factor, [applied[..., i] - bias[i] for i in range(n)])
    if tangents is None:
        return _assemble(acc), None
    d_chain, d_theta, d_theta_dot, d_applied = tangents
    step = _COMPLEX_STEP
    chain_leaves, chain_tree = jax.tree_util.tree_flatten(chain)
    d_chain_leaves = jax.tree_util.tree_leaves(d_chain, is_leaf=_is_zero)
    chain_c = chain_tree.unflatten(
        [_complex_step(x, dx) for x, dx in zip(chain_leaves, d_chain_leaves, strict=True)]
    )
    if _is_zero(d_theta):
        sin_cos = (sines, cosines)
    else:
        d = step * d_theta
        sin_cos = (jax.lax.complex(sines, d * cosines), jax.lax.complex(cosines, -d * sines))
    theta_dot_c = _complex_step(theta_dot, d_theta_dot)
    # A tangent that tilts the axes leaves the planar chains: differentiate the spatial algebra then.
    if chain.planar and (d_chain is None or _is_zero(d_chain.axes)):
        planar_c = PlanarBodies(chain_c, sin_cos)
        id_c = planar_inverse_dynamics_lists(planar_c, theta_dot_c, acc)
    else:
        bodies_c = ScalarBodies(chain_c, theta, sin_cos)
        id_c = newton_euler_lists(bodies_c, chain_c.gravity, theta_dot_c, acc)
    d_id = [jnp.imag(x) / step for x in id_c]
    if not _is_zero(d_applied):
        d_id = [d_applied[..., i] - d_id[i] for i in range(n)]
    else:
        d_id = [-x for x in d_id]
    d_acc = cholesky_solve_factored(factor, d_id)
    return _assemble(acc), _assemble(d_acc)


# Complex step of `_forward_dynamics_scalar_and_tangent`: the O(h²) terms it drops are ~1e-200
# relative, and products of h with tangents and physical scales keep ~200 decades above float64's
# smallest normal number (2.2e-308), so nothing underflows for any plausible unit system.
_COMPLEX_STEP = 1e-100


def _is_zero(tangent) -> bool:
    return tangent is None or isinstance(tangent, jax.custom_derivatives.SymbolicZero)


def _complex_step(x, dx):
    if _is_zero(dx) or not jnp.issubdtype(jnp.result_type(x), jnp.floating):
        return x
    return jax.lax.complex(jnp.asarray(x), _COMPLEX_STEP * dx)


_forward_dynamics_scalar = jax.custom_jvp(_forward_dynamics_scalar_value)


# The default rule (see `_planar_or_arrays_jvp`).
def _forward_dynamics_scalar_jvp(primals, tangents):
    return _planar_or_arrays_jvp(primals, tangents, rows=False)


_forward_dynamics_scalar.defjvp(_forward_dynamics_scalar_jvp, symbolic_zeros=True)


def _scalar_rows(chain: "Chain", theta: Array, theta_dot: Array, applied: Array) -> Array:
    # Many states of one chain (leading axis), the custom JVP outside the vmap: `vmap` of
    # `_forward_dynamics_scalar` differentiated by `jax.jacfwd` through a forward-mode diffrax solve
    # returned tangents with the sample and joint axes swapped (jax 0.10.2; "select cases must have
    # the same shapes, (301, 3) and (3, 301)"), which this ordering avoids.
    return jax.vmap(_forward_dynamics_scalar_value, in_axes=(None, 0, 0, 0))(
        chain, theta, theta_dot, applied
    )


_forward_dynamics_scalar_samples = jax.custom_jvp(_scalar_rows)


def _forward_dynamics_scalar_samples_jvp(primals, tangents):
    return _planar_or_arrays_jvp(primals, tangents, rows=True)


def _planar_or_arrays_jvp(primals, tangents, *, rows: bool):
    """The default rule: forward-mode autodiff (which reverse mode can transpose) of the planar form
    for a planar chain in directions that keep it planar, else of the array form.

    The planar form has ~5x fewer operations than the array form. It is differentiated in
    ``sin θ`` and ``cos θ``, whose tangents are taken by hand (the CPU's polynomial sine and cosine
    are accurate to 2 ulp, their derivatives less so), and only chain fields with a tangent are
    differentiated; the rest stay constants.
    """
    filled, zero, treedef = _split_zeros(primals, tangents)
    chain, theta, theta_dot, applied = primals
    if not (chain.planar and _is_zero(tangents[0].axes)):
        arrays = _forward_dynamics_arrays_samples if rows else _forward_dynamics_arrays
        return jax.jvp(arrays, primals, treedef.unflatten(filled))
    chain_leaves, chain_tree = jax.tree_util.tree_flatten(chain)
    n_chain = len(chain_leaves)
    live = [not z for z in zero[:n_chain]]
    d_live = [t for t, keep in zip(filled[:n_chain], live, strict=True) if keep]
    live_leaves = [x for x, keep in zip(chain_leaves, live, strict=True) if keep]
    d_theta, d_theta_dot, d_applied = filled[n_chain:]

    def planar(live_leaves, sines, cosines, theta_dot, applied):
        given = iter(live_leaves)
        rebuilt = chain_tree.unflatten(
            [next(given) if keep else x for x, keep in zip(chain_leaves, live, strict=True)]
        )

        def one(sines, cosines, theta_dot, applied):
            return _assemble(_planar_solve(rebuilt, (sines, cosines), theta_dot, applied)[0])

        return (
            jax.vmap(one)(sines, cosines, theta_dot, applied)
            if rows
            else one(sines, cosines, theta_dot, applied)
        )

    sines, cosines = sin_cos_once(theta)
    return jax.jvp(
        planar,
        (live_leaves, sines, cosines, theta_dot, applied),
        (d_live, cosines * d_theta, -sines * d_theta, d_theta_dot, d_applied),
    )


_forward_dynamics_scalar_samples.defjvp(_forward_dynamics_scalar_samples_jvp, symbolic_zeros=True)


def _split_zeros(primals, tangents):
    """Tangent leaves with symbolic zeros instantiated, which leaves were zero, and the tree."""
    leaves, treedef = jax.tree_util.tree_flatten(tangents, is_leaf=_is_zero)
    zero = tuple(_is_zero(t) for t in leaves)
    primal_leaves = jax.tree_util.tree_leaves(primals)
    filled = [
        jnp.zeros_like(p) if z else t for p, t, z in zip(primal_leaves, leaves, zero, strict=True)
    ]
    return filled, zero, treedef


def _marked(zero, treedef, leaves):
    # `None` marks a zero tangent for `_forward_dynamics_scalar_and_tangent`.
    return treedef.unflatten([None if z else t for z, t in zip(zero, leaves, strict=True)])


# Forward mode only (`forward_mode_only=True`): the complex-step rule. Its tangent is not linear in
# the input tangents as traced (complex products of perturbed values), so it cannot be transposed.
# Differentiated once more (nested forward mode: an implicit solver's Jacobian inside a forward-mode
# solve), it goes through the array form's second derivatives instead: forward mode through the
# complex scalar graph compiled 6× slower (29 s against 4.7 s for the accordion's Hessian).
@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _complex_step_jvp(zero, treedef, primals, tangent_leaves):
    chain, theta, theta_dot, applied = primals
    tangents = _marked(zero, treedef, tangent_leaves)
    return _forward_dynamics_scalar_and_tangent(chain, theta, theta_dot, applied, tangents)


@_complex_step_jvp.defjvp
def _complex_step_jvp_jvp(zero, treedef, primals_in, tangents_in):
    (primals, tangent_leaves), (d_primals, d_tangent_leaves) = primals_in, tangents_in
    tangents = treedef.unflatten(tangent_leaves)
    d_tangents = treedef.unflatten(d_tangent_leaves)
    return jax.jvp(
        lambda p, t: jax.jvp(_forward_dynamics_arrays, p, t),
        (primals, tangents),
        (d_primals, d_tangents),
    )


def _forward_dynamics_scalar_forward_jvp(primals, tangents):
    filled, zero, treedef = _split_zeros(primals, tangents)
    return _complex_step_jvp(zero, treedef, primals, filled)


_forward_dynamics_scalar_forward = jax.custom_jvp(_forward_dynamics_scalar_value)
_forward_dynamics_scalar_forward.defjvp(_forward_dynamics_scalar_forward_jvp, symbolic_zeros=True)


def _forward_dynamics_arrays(
    chain: "Chain", theta: Array, theta_dot: Array, applied: Array
) -> Array:
    # The same algorithm on (n, 3) arrays, for long chains; `applied` is τ − N.
    bodies = _Bodies(chain, theta)  # shared by M and the bias, so kinematics run once
    bias = _newton_euler(bodies, chain.gravity, theta_dot, jnp.zeros_like(theta_dot))
    return _solve_spd(_composite_mass_matrix(bodies), applied - bias)


# Rows of states `(t, n)` of one chain.
_forward_dynamics_arrays_samples = jax.vmap(_forward_dynamics_arrays, in_axes=(None, 0, 0, 0))
