"""Forward dynamics of one state and of many: the layout and chunking that make many states fast.

`_dynamics` computes with the bodies along the first axis and the states along the last,
`(n, *batch)`. Two things make many states of one tree fast on the CPU (measured for a 20-panel
tree on a shared 2-core machine, per state):

1. **States minor.** `jax.vmap` of a single-state function puts the states first, `(t, n)`, so every
   operation works on short rows of a few bodies; `rows` transposes to `(n, t)` instead. `single`
   is a `jax.custom_batching.custom_vmap` whose batching rule is `rows`, so a user's
   `jax.vmap(tree.forward_dynamics)` takes the fast layout too (when the tree itself is not batched;
   a batch of trees falls back to plain `vmap`).
2. **Chunks that fit in cache.** The algorithm is ~300 elementwise kernels, each streaming its
   operands through memory; at 10,000 states an operand is 1.6 MB and every kernel misses the
   caches (21 µs per state), at 256 states it stays in L2 (5–7 µs per state), below ~100 states the
   per-kernel overhead dominates. `rows` therefore loops (`lax.map`) over chunks of `CHUNK` states.

Derivatives: `single` is also a `jax.custom_jvp` (`custom_vmap` alone has no reverse mode). Its
rule differentiates the inverse dynamics at the computed acceleration and solves with the forward
pass's factorization, ``M dq̈ = d force − ∂ID/∂(tree, q, v) · (d tree, dq, dv)``: exact, linear in
the tangents (so reverse mode transposes it), and smaller than autodiff of the whole algorithm
(the mass matrix and its factorization are not differentiated). For a cube net's tree: the
reverse-mode program compiles in about half the time and runs ~2× faster per state. Under `vmap`
the rule is batched the plain way: derivatives are exact, just not in the fast layout.
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from . import _dynamics

CHUNK = 256
"""States per chunk of `rows` (module docstring, item 2)."""


def _plain(tree, q, v, force):
    return _dynamics.forward_dynamics(tree, q, v, force)


def rows(tree, q: Float[Array, "t n"], v: Float[Array, "t n"], force: Float[Array, "t n"]):
    """``q̈`` of `t` states of one tree, `(t, n)`, in chunks of `CHUNK` with the states minor."""
    t, n = q.shape
    if t <= CHUNK:
        return _plain(tree, q.T, v.T, force.T).T
    chunks = -(-t // CHUNK)
    pad = chunks * CHUNK - t

    def split(x):
        # Padding repeats the last state (a valid one: no NaN from a zero mass matrix).
        x = jnp.concatenate([x, jnp.broadcast_to(x[-1:], (pad, n))]) if pad else x
        return jnp.swapaxes(x.reshape(chunks, CHUNK, n), 1, 2)  # (chunks, n, CHUNK)

    out = jax.lax.map(lambda args: _plain(tree, *args), (split(q), split(v), split(force)))
    return jnp.swapaxes(out, 1, 2).reshape(chunks * CHUNK, n)[:t]


@jax.custom_batching.custom_vmap
def _single_vmappable(tree, q, v, force):
    return _plain(tree, q, v, force)


@_single_vmappable.def_vmap
def _single_vmap_rule(axis_size, in_batched, tree, q, v, force):
    tree_batched, *state_batched = in_batched
    if any(jax.tree_util.tree_leaves(tree_batched)):
        axes = jax.tree_util.tree_map(lambda b: 0 if b else None, tree_batched)
        in_axes = (axes, *(0 if b else None for b in state_batched))
        return jax.vmap(_plain, in_axes=in_axes)(tree, q, v, force), True
    q, v, force = (
        x if b else jnp.broadcast_to(x, (axis_size, *x.shape))
        for x, b in zip((q, v, force), state_batched, strict=True)
    )
    return rows(tree, q, v, force), True


@jax.custom_jvp
def _single(tree, q, v, force):
    return _single_vmappable(tree, q, v, force)


@_single.defjvp
def _single_jvp(primals, tangents):
    # From the inverse dynamics at the computed acceleration: ID(tree, q, v, q̈) = force, so
    # M dq̈ = d force − ∂ID/∂(tree, q, v) · (d tree, dq, dv), solved on the forward pass's own
    # factorization. Linear in the tangents (reverse mode transposes it into one RNEA pullback
    # and one solve, instead of the pullback of the mass matrix, its factorization and the bias).
    tree, q, v, force = primals
    d_tree, d_q, d_v, d_force = tangents
    out, solve = _dynamics.forward_dynamics_and_solve(tree, q, v, force)
    _, d_id = jax.jvp(
        lambda t, q, v: _dynamics.inverse_dynamics(t, q, v, out), (tree, q, v), (d_tree, d_q, d_v)
    )
    return _batch_axis_first(out), _batch_axis_first(solve(d_force - d_id))


def _batch_axis_first(x: Array) -> Array:
    """`x` unchanged, but under `vmap` with its batch axis first (a reshape's batching rule moves
    it there). jax 0.10.2 batches a `custom_jvp` around a `custom_vmap` inside `jit` assuming the
    rule's outputs are batched where the `custom_vmap` rule's are (first); the plain algorithm's
    outputs may be batched along another axis, and `jax.jvp(jax.vmap(jax.jit(f)))` then returned
    them transposed."""
    return jax.lax.reshape(jax.lax.reshape(x, (*x.shape, 1)), x.shape)


def single(tree, q: Float[Array, " n"], v: Float[Array, " n"], force: Float[Array, " n"]):
    """``q̈`` of one state, `(n,)`; under `jax.vmap` it runs as `rows` (module docstring)."""
    return _single(tree, q, v, force)
