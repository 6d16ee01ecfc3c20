"""Synthetic trajectories for tests that judge or draw a folding without simulating one."""

import jax.numpy as jnp


def held_trajectory(system, theta, result=None, n: int = 11):
    """A `Trajectory` of `system` that sits at `theta` (rad, `(h,)`) for `n` samples over 100 time
    units (rates and torques zero; `result` default successful)."""
    import origami_jax.simulation as sim

    theta = jnp.broadcast_to(jnp.asarray(theta), (n, system.n_hinges))
    zeros = jnp.zeros_like(theta)
    return sim.Trajectory(
        times=jnp.linspace(0.0, 100.0, n),
        theta=theta,
        theta_dot=zeros,
        theta_ddot=zeros,
        tau=zeros,
        target=system.hinges.target,
        stats={},
        result=sim.RESULTS.successful if result is None else result,
    )
