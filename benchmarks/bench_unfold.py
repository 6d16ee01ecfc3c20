"""Unfolding the corner cube and the waterbomb base: our compiled descent against a SciPy SLSQP
sequence of constrained steps (the paper used MATLAB's constrained optimiser), same stopping rule;
and a vmapped batch of random vertices."""

import time

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks._harness import Result, Timing, loop_flops, time_calls
from origami_jax import vertex
from origami_jax.vertex._descent import DescentSettings
from origami_jax.vertex._unfold import _compiled, _settings_arrays


def _numpy_energy_and_grad(x, arcs, pairs, p):
    """Separable energy Eq. 1 and its gradient in plain NumPy (for SLSQP)."""
    x = x.reshape(-1, 3)
    s = x[arcs[:, 0]] + x[arcs[:, 1]]
    s_norm = np.linalg.norm(s, axis=1, keepdims=True)
    m = s / s_norm
    v, e = pairs[:, 0], pairs[:, 1]
    a, b = x[v], m[e]
    cross = np.cross(a, b)
    c = np.linalg.norm(cross, axis=1)
    dot = np.sum(a * b, axis=1)
    d = np.arctan2(c, dot)
    energy = np.sum(d ** (-p))
    dU_dd = -p * d ** (-p - 1)
    # d(atan2(|a×b|, a·b)) = (dot * d|a×b| - |a×b| d(dot)) / (|a×b|² + dot²)
    denom = c**2 + dot**2
    dc_da = np.cross(b, cross / c[:, None])
    dc_db = np.cross(cross / c[:, None], a)
    dd_da = (dot[:, None] * dc_da - c[:, None] * b) / denom[:, None]
    dd_db = (dot[:, None] * dc_db - c[:, None] * a) / denom[:, None]
    grad = np.zeros_like(x)
    np.add.at(grad, v, dU_dd[:, None] * dd_da)
    gm = np.zeros_like(m)
    np.add.at(gm, e, dU_dd[:, None] * dd_db)
    # through m = s/|s|
    gs = (gm - m * np.sum(gm * m, axis=1, keepdims=True)) / s_norm
    np.add.at(grad, arcs[:, 0], gs)
    np.add.at(grad, arcs[:, 1], gs)
    return energy, grad.ravel()


def slsqp_unfold(vertex_, *, p=2.0, step=0.05, max_steps=2000):
    """The peer: a sequence of SLSQP solves, each minimising U within a trust ball of radius
    `step` around the current state subject to G = 0; stops on the same verdict criteria."""
    from scipy.optimize import minimize

    top = vertex.topology(vertex_.n, vertex_.closed)
    arcs, pairs = top.arcs, top.node_arc_pairs
    cos_alpha = np.cos(np.asarray(vertex_.sector_angles))
    x = np.asarray(vertex_.directions).ravel()

    def eq(y):
        y = y.reshape(-1, 3)
        return np.concatenate(
            [np.sum(y * y, 1) - 1, np.sum(y[arcs[:, 0]] * y[arcs[:, 1]], 1) - cos_alpha]
        )

    fold_fn = jax.jit(lambda y: vertex._geometry.fold_angles_of(y, vertex_.closed))
    steps = 0
    for steps in range(1, max_steps + 1):
        centre = x.copy()
        res = minimize(
            lambda y: _numpy_energy_and_grad(y, arcs, pairs, p),
            centre,
            jac=True,
            method="SLSQP",
            constraints=[
                {"type": "eq", "fun": eq},
                {"type": "ineq", "fun": lambda y, c=centre: step**2 - np.sum((y - c) ** 2)},
            ],
            options={"maxiter": 50, "ftol": 1e-12},
        )
        x = res.x
        sigma = np.linalg.svd(x.reshape(-1, 3), compute_uv=False)[-1]
        if sigma < 1e-4 and np.max(np.abs(np.asarray(fold_fn(x.reshape(-1, 3))))) < np.deg2rad(1):
            return x.reshape(-1, 3), steps, True
    return x.reshape(-1, 3), steps, False


def run(quick: bool) -> list[Result]:
    rows = []
    settings = _settings_arrays(DescentSettings())
    repeats = 3 if quick else 10
    for name, make in (
        ("corner cube", vertex.corner_cube),
        ("waterbomb base", vertex.waterbomb_base),
    ):
        v = make()
        compiled, compile_s = _compiled(v.n, v.closed, "separable", 2000, True, None)
        args = (v.directions, v.sector_angles, jnp.asarray(2.0), settings)
        out = compiled(*args)
        ours = time_calls(lambda c=compiled, a=args: c(*a), repeats=repeats)
        start = time.perf_counter()
        x_peer, peer_steps, peer_flat = slsqp_unfold(v)
        peer_s = time.perf_counter() - start
        if not quick:
            peer_s = min(peer_s, *(_timed(slsqp_unfold, v) for _ in range(2)))
        rows.append(
            Result(
                name=f"unfold {name} (separable p=2)",
                ours=ours,
                peer_name="scipy SLSQP steps",
                peer=Timing(peer_s, peer_s, peer_s, 1 if quick else 3),
                compile_s=compile_s,
                flops=_descent_flops(v.directions, v.closed, int(out.n_accepted)),
                notes=(
                    f"ours: status {int(out.status._value)} (1 = flat) in {int(out.n_accepted)} steps; "
                    f"SLSQP: flat={peer_flat} in {peer_steps} steps; {_FLOP_NOTE}"
                ),
            )
        )
    count = 100 if quick else 1000
    batch = vertex.random_vertices(jax.random.key(0), count, 6, closed=True)
    compiled, compile_s = _compiled(6, True, "separable", 500, False, count)
    x, s = jnp.asarray(batch.directions), jnp.asarray(batch.sector_angles)
    out = compiled(x, s, jnp.asarray(2.0), settings)
    flat = float(np.mean(np.asarray(out.status == vertex.RESULTS.flat_unfolded)))
    timing = time_calls(
        lambda: compiled(x, s, jnp.asarray(2.0), settings), repeats=1 if not quick else 2
    )
    rows.append(
        Result(
            name=f"unfold_batch {count} random closed degree-6 vertices (vmapped)",
            ours=timing,
            compile_s=compile_s,
            per_item=count,
            flops=_descent_flops(x[0], True, int(np.sum(np.asarray(out.n_accepted)))),
            notes=(
                f"flat without escapes: {flat:.1%}; whole batch {timing.median:.2f} s; {_FLOP_NOTE}"
            ),
        )
    )
    return rows


_FLOP_NOTE = "FLOP = XLA count of one energy value and gradient x accepted steps (lower bound)"


def _descent_flops(directions, closed: bool, accepted_steps: int) -> float | None:
    """Lower bound of a descent's FLOPs: one energy value-and-gradient per accepted step (the
    projection, restoration and rejected steps are left out); see `loop_flops`."""
    from origami_jax.vertex._energy import energy

    def value_and_gradient(x):
        return jax.value_and_grad(lambda y: energy(y, closed=closed, p=2.0))(x)

    return loop_flops(value_and_gradient, jnp.asarray(directions), evaluations=accepted_steps)


def _timed(fn, *args):
    start = time.perf_counter()
    fn(*args)
    return time.perf_counter() - start


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    for row in run(quick=True):
        print(row.line(), "|", row.notes)
