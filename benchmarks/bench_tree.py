"""Forward dynamics of a 20-panel tree over many states: `jax.vmap` of ours vs Pinocchio's ABA in a loop.

The tree is random (`tests.tree_cases`: every panel hangs from one of the four before it, random
non-parallel hinge axes, frames and inertias, gravity). Ours: `jax.vmap(tree.forward_dynamics)` over
10,000 states, jitted (CRBA, RNEA and the tree-sparse LᵀL solve); Pinocchio: `pin.aba` called from
Python once per state, as a user would loop over states. Answers are compared first (all states,
relative to the largest acceleration); times are per state. Run: ``python -m benchmarks --only tree``
from the repository root, or ``python -m benchmarks.bench_tree``.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pinocchio as pin
from tests.tree_cases import random_parents, random_states, random_tree, to_pinocchio

from ._harness import Result, compile_jitted, time_calls


def run(quick: bool) -> list[Result]:
    n, count = 20, 1000 if quick else 10_000
    repeats = 3 if quick else 7
    tree = random_tree(random_parents(n, seed=0), seed=2)
    q, v, tau = random_states(n, count, seed=3)
    model, order = to_pinocchio(tree)
    data = model.createData()
    back = np.argsort(order)
    rows_pin = [
        (
            np.ascontiguousarray(a[order]),
            np.ascontiguousarray(b[order]),
            np.ascontiguousarray(c[order]),
        )
        for a, b, c in zip(q, v, tau, strict=True)
    ]

    def peer():
        out = np.empty((count, n))
        for k, (qk, vk, tk) in enumerate(rows_pin):
            out[k] = pin.aba(model, data, qk, vk, tk)
        return out

    def ours(tree, q, v, tau):
        return jax.vmap(tree.forward_dynamics)(q, v, tau)

    args = tuple(jnp.asarray(x) for x in (q, v, tau))
    compiled, compile_s, flops = compile_jitted(ours, tree, *args)
    mine = np.asarray(compiled(tree, *args))
    theirs = peer()[:, back]
    scale = float(np.max(np.abs(theirs)))
    difference = float(np.max(np.abs(mine - theirs)))
    if difference > 1e-9 * scale:
        raise AssertionError(f"answers differ by {difference:.3e} (scale {scale:.3g})")
    return [
        Result(
            name=f"20-panel tree forward dynamics, vmap over {count} states vs pin.aba loop",
            ours=time_calls(lambda: compiled(tree, *args), repeats=repeats),
            peer_name="pinocchio.aba (Python loop)",
            peer=time_calls(peer, repeats=max(repeats // 2, 2)),
            compile_s=compile_s,
            max_abs_difference=difference,
            flops=flops,
            per_item=count,
            notes=f"|q̈| scale {scale:.3g}; parents {tree.parents}",
        )
    ]


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    for row in run(quick=False):
        print(row.line())
