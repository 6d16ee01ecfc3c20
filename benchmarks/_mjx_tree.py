"""MJX (MuJoCo in JAX, `mujoco.mjx` from the `mujoco-mjx` package) rollouts of the models of
`benchmarks._mujoco_tree`: the accelerator peer of the nets benchmark.

One compiled program steps a batch of the same net whose members differ in their hinge springs
(the actuators' gains, as `bench_net.scattered_mujoco` sets them in the C models) and release times
(each hinge's control switches from 0 to 1 at its release, as `release_controls` gives the C
rollout), at the C models' fixed step and integrator. MJX is optional: `available()` says whether it
imports, and the benchmark skips its row otherwise.
"""

import numpy as np


def available() -> bool:
    """Whether `mujoco.mjx` imports (the `mujoco-mjx` package, the same release line as `mujoco`)."""
    try:
        from mujoco import mjx  # noqa: F401
    except ImportError:
        return False
    return True


def batched_rollout(model, nstep: int):
    """A function ``(gains (b, nu, 3), release (b, nu)) -> final hinge angles (b, h)`` that rolls
    `model` (a C `MjModel`, its hinges named ``h0 … h{h-1}``) out from flat at rest for `nstep`
    steps, member by member with its own actuator gains (the first three `actuator_gainprm`
    entries) and release times (time units). Pure JAX: `jax.jit` it, and lower it apart to time
    its compilation."""
    import jax
    import jax.numpy as jnp
    from mujoco import mjx

    mx = mjx.put_model(model)
    dt = float(model.opt.timestep)
    order = np.array([int(model.joint(f"h{i}").qposadr[0]) for i in range(model.njnt)])

    def member(gains, release):
        m = mx.replace(actuator_gainprm=mx.actuator_gainprm.at[:, :3].set(gains))

        def step(data, s):
            # The C rollout applies control row s before step s, at time s dt.
            data = data.replace(ctrl=(s * dt >= release).astype(data.qpos.dtype))
            return mjx.step(m, data), None

        data, _ = jax.lax.scan(step, mjx.make_data(m), jnp.arange(nstep))
        return data.qpos[order]

    return jax.vmap(member)


def gains_of(models) -> np.ndarray:
    """The first three actuator gains of each C model, `(b, nu, 3)`: what `batched_rollout` takes."""
    return np.stack([np.asarray(m.actuator_gainprm[:, :3]) for m in models])
