"""Tree-aware comparisons and other shared pieces for tests."""

import json
import subprocess
import sys
import textwrap

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np


def _leaf_allclose(x, y, rtol: float, atol: float) -> bool:
    if eqx.is_array_like(x) and eqx.is_array_like(y):
        x, y = np.asarray(x), np.asarray(y)
        if x.shape != y.shape or x.dtype.kind != y.dtype.kind:
            return False
        if x.dtype.kind in "fc":
            return bool(np.allclose(x, y, rtol=rtol, atol=atol, equal_nan=False))
        return bool(np.array_equal(x, y))
    return x == y


def tree_allclose(x, y, *, rtol: float = 1e-5, atol: float = 1e-8) -> bool:
    """True when two pytrees have the same structure and all leaves are close (NaN never equals)."""
    x_leaves, x_tree = jax.tree_util.tree_flatten(x)
    y_leaves, y_tree = jax.tree_util.tree_flatten(y)
    if x_tree != y_tree:
        return False
    return all(_leaf_allclose(a, b, rtol, atol) for a, b in zip(x_leaves, y_leaves, strict=True))


def max_relative_error(actual, expected, *, floor: float = 0.0) -> float:
    """Largest |actual - expected| / max(|expected|_max, floor) over all leaves of two pytrees."""
    errors = []
    for a, e in zip(
        jax.tree_util.tree_leaves(actual), jax.tree_util.tree_leaves(expected), strict=True
    ):
        a, e = jnp.asarray(a), jnp.asarray(e)
        scale = max(float(jnp.max(jnp.abs(e))), floor)
        errors.append(float(jnp.max(jnp.abs(a - e))) / (scale if scale > 0 else 1.0))
    return max(errors, default=0.0)


def make_system(chain, stiffness, drag, target=None, radius=1.0, release_time=None):
    """A `FoldingSystem` around a bare chain: per-hinge stiffness, the paper's hinge drag, fold targets
    (default: π on every hinge), bending radius (only the etch ramp reads it)."""
    from origami_jax.system import FoldingSystem, HingeDrag, Hinges

    n = chain.n_hinges
    target = jnp.full(n, jnp.pi) if target is None else jnp.asarray(target, dtype=float)
    hinges = Hinges(
        jnp.broadcast_to(jnp.asarray(stiffness, dtype=float), (n,)), target, radius, release_time
    )
    drag = jnp.broadcast_to(jnp.asarray(drag, dtype=float), (n,))
    return FoldingSystem(chain, hinges, HingeDrag(drag))


def run_python(code: str, env: dict[str, str], *argv: str):
    """Run `code` (dedented) in a fresh Python process with environment `env` and arguments `argv`;
    its last line of output, read as JSON (the process must succeed within 5 minutes)."""
    process = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code), *argv],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert process.returncode == 0, process.stderr[-3000:]
    return json.loads(process.stdout.strip().splitlines()[-1])


def stepped_energy_balance(system, trajectory):
    """The energy balance of a step-released folding whose drags are `system.drag.parts`:
    `(balance, lost, scale, rates)`. ``balance`` = kinetic + spring energy − the step input's work
    ``Σ k θ_target θ`` + the work the drags took out so far, ``∫ Σ_parts (−q̇ᵀ f) dt`` (`lost`,
    composite Simpson's rule over each pair of the trajectory's evenly spaced samples; `balance`
    and `lost` at every other sample), constant when no energy is gained or lost elsewhere;
    ``scale`` = ``Σ k θ_target²``; ``rates`` each part's dissipation at the samples."""
    q, v, t = trajectory.theta, trajectory.theta_dot, np.asarray(trajectory.times)
    energy = jax.vmap(system.energy)(q, v) - q @ (system.hinges.stiffness * system.hinges.target)
    rates = [
        np.asarray(jax.vmap(lambda a, b, p=p: p.dissipation(system.mechanism, a, b))(q, v))
        for p in system.drag.parts
    ]
    power = sum(rates)
    h = t[1] - t[0]
    lost = np.concatenate(
        [[0.0], np.cumsum(h / 3 * (power[:-2:2] + 4 * power[1:-1:2] + power[2::2]))]
    )
    balance = np.asarray(energy)[::2] + lost
    scale = float(np.sum(system.hinges.stiffness * system.hinges.target**2))
    return balance, lost, scale, rates


def solve_programs(name: str, jitted) -> int:
    """How many programs of a top-level solve are compiled: those compiled in memory under `name`
    (`origami_jax._exported.exported_call`, with its compiler options) and those of `jitted`, its
    `jax.jit` (where the key cannot vouch for the solve's static parts)."""
    from origami_jax import _exported

    in_memory = sum(1 for memo in _exported._IN_MEMORY if memo[0] == name)
    return jitted._cached._cache_size() + in_memory
