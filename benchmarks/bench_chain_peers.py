"""Mass matrix and forward dynamics of the 3-flap accordion: ours vs MuJoCo and modern_robotics (issue #9).

- MuJoCo: the same chain written as MJCF (nested bodies, hinge joints, full inertia), with joint stiffness
  and *linear* damping (MuJoCo has no quadratic joint drag), compared on ``mj_forward``'s ``qacc``. Our side
  adds the same linear damping torque to the input, so both integrate the same ODE.
- modern_robotics: the numpy product-of-exponentials code closest to the paper's method (``MassMatrix``,
  ``ForwardDynamics``), hinge torques applied as input.

Answers are compared first; then median times per call (MuJoCo and modern_robotics are called from Python, as a
user would call them; MuJoCo's ``mj_forward`` also runs collision and constraint stages, empty here).
"""

import jax
import jax.numpy as jnp
import modern_robotics as mr
import mujoco
import numpy as np

import origami_jax.chain as oc
import origami_jax.system as osys

from ._harness import Result, compile_jitted, time_calls


def _mjcf(chain: oc.Chain, stiffness: np.ndarray, damping: np.ndarray) -> str:
    """Nested MJCF bodies: body i's frame is world-aligned at hinge point q_i at θ = 0."""
    body_xml = ""
    previous = np.zeros(3)
    for i in range(chain.n_joints):
        point = np.asarray(chain.points[i])
        rotation = np.asarray(chain.cg_poses[i, :3, :3])
        inertia = rotation @ np.asarray(chain.inertias[i]) @ rotation.T
        cg = np.asarray(chain.cg_poses[i, :3, 3]) - point
        full = " ".join(
            f"{v:.17g}"
            for v in (
                inertia[0, 0],
                inertia[1, 1],
                inertia[2, 2],
                inertia[0, 1],
                inertia[0, 2],
                inertia[1, 2],
            )
        )
        pos = " ".join(f"{v:.17g}" for v in point - previous)
        axis = " ".join(f"{v:.17g}" for v in np.asarray(chain.axes[i]))
        body_xml += (
            f'<body name="flap{i}" pos="{pos}">'
            f'<joint name="hinge{i}" type="hinge" axis="{axis}" pos="0 0 0" '
            f'stiffness="{stiffness[i]:.17g}" damping="{damping[i]:.17g}" limited="false"/>'
            f'<inertial pos="{" ".join(f"{v:.17g}" for v in cg)}" mass="{float(chain.masses[i]):.17g}" '
            f'fullinertia="{full}"/>'
        )
        previous = point
    body_xml += "</body>" * chain.n_joints
    return (
        '<mujoco model="accordion"><option gravity="0 0 0" integrator="RK4"/>'
        f"<worldbody>{body_xml}</worldbody></mujoco>"
    )


def _modern_robotics_model(chain: oc.Chain):
    """Mlist (CG frame i-1 -> CG frame i at home), Glist (6x6, angular first), Slist (6xn, (ω, v))."""
    poses = [np.eye(4)] + [np.asarray(p) for p in chain.cg_poses] + [np.asarray(chain.cg_poses[-1])]
    m_list = [mr.TransInv(poses[i]) @ poses[i + 1] for i in range(chain.n_joints + 1)]
    g_list = []
    for i in range(chain.n_joints):
        g = np.zeros((6, 6))
        g[:3, :3] = np.asarray(chain.inertias[i])
        g[3:, 3:] = float(chain.masses[i]) * np.eye(3)
        g_list.append(g)
    axes, points = np.asarray(chain.axes), np.asarray(chain.points)
    s_list = np.concatenate([axes, -np.cross(axes, points)], axis=1).T
    return m_list, g_list, s_list


def run(quick: bool) -> list[Result]:
    repeats = 50 if quick else 500
    design = osys.HingeDesign.literature()
    chain = oc.accordion_system(design, 3).mechanism
    n = chain.n_joints
    k = np.asarray(design.stiffness(n))
    # A linear damping coefficient with the quadratic drag's magnitude at 1 rad/µs (torque·time/rad).
    c = np.asarray(design.drag(n, *oc.flap_size(design.units)))
    rng = np.random.default_rng(1)
    theta = rng.uniform(-np.pi, np.pi, n)
    theta_dot = rng.normal(scale=0.05, size=n)
    tau = rng.normal(scale=1e3, size=n)

    # --- ours -------------------------------------------------------------------------------------
    def ours_mass(chain, q):
        return oc.mass_matrix(chain, q)

    def ours_accel(chain, q, v, t):
        # Linear damping and the hinge springs as part of the generalized force.
        return oc.forward_dynamics(chain, q, v, t - c * v - jnp.asarray(k) * q)

    args = (jnp.asarray(theta), jnp.asarray(theta_dot), jnp.asarray(tau))
    mass_c, mass_compile, mass_flops = compile_jitted(ours_mass, chain, args[0])
    accel_c, accel_compile, accel_flops = compile_jitted(ours_accel, chain, *args)
    ours_m = np.asarray(mass_c(chain, args[0]))
    ours_a = np.asarray(accel_c(chain, *args))

    # --- MuJoCo -----------------------------------------------------------------------------------
    model = mujoco.MjModel.from_xml_string(_mjcf(chain, k, c))
    data = mujoco.MjData(model)
    data.qpos[:] = theta
    data.qvel[:] = theta_dot
    data.qfrc_applied[:] = tau
    mujoco.mj_forward(model, data)
    mj_m = np.zeros((n, n))
    mujoco.mj_fullM(model, data, mj_m)  # MuJoCo >= 3.4 signature: (model, data, dst)
    mj_a = data.qacc.copy()

    def mujoco_forward():
        mujoco.mj_forward(model, data)
        return data.qacc

    # --- modern_robotics --------------------------------------------------------------------------
    m_list, g_list, s_list = _modern_robotics_model(chain)
    hinge = k * theta + c * theta_dot
    mr_m = mr.MassMatrix(theta, m_list, g_list, s_list)
    mr_a = mr.ForwardDynamics(
        theta, theta_dot, tau - hinge, np.zeros(3), np.zeros(6), m_list, g_list, s_list
    )

    rows = [
        Result(
            name="accordion3 mass_matrix (jit) vs MuJoCo mj_fullM after mj_forward",
            ours=time_calls(lambda: mass_c(chain, args[0]), repeats=repeats),
            peer_name="mujoco.mj_forward",
            peer=time_calls(mujoco_forward, repeats=repeats),
            compile_s=mass_compile,
            max_abs_difference=float(np.max(np.abs(ours_m - mj_m))),
            flops=mass_flops,
            notes=f"|M| scale {np.max(np.abs(mj_m)):.3g} ng·µm²",
        ),
        Result(
            name="accordion3 forward dynamics, stiffness + linear damping (jit)",
            ours=time_calls(lambda: accel_c(chain, *args), repeats=repeats),
            peer_name="mujoco.mj_forward (qacc)",
            peer=time_calls(mujoco_forward, repeats=repeats),
            compile_s=accel_compile,
            max_abs_difference=float(np.max(np.abs(ours_a - mj_a))),
            flops=accel_flops,
            notes=f"|θ̈| scale {np.max(np.abs(mj_a)):.3g} rad/µs²",
        ),
        Result(
            name="accordion3 forward dynamics (jit) vs modern_robotics (numpy PoE)",
            ours=time_calls(lambda: accel_c(chain, *args), repeats=repeats),
            peer_name="modern_robotics.ForwardDynamics",
            peer=time_calls(
                lambda: mr.ForwardDynamics(
                    theta, theta_dot, tau - hinge, np.zeros(3), np.zeros(6), m_list, g_list, s_list
                ),
                repeats=max(repeats // 5, 5),
            ),
            compile_s=accel_compile,
            max_abs_difference=float(np.max(np.abs(ours_a - mr_a))),
            flops=accel_flops,
            notes=f"mass-matrix diff vs modern_robotics {np.max(np.abs(ours_m - mr_m)):.1e}",
        ),
    ]
    scale_a = float(np.max(np.abs(mj_a)))
    for row in rows[1:]:
        if row.max_abs_difference > 1e-8 * scale_a:
            raise AssertionError(
                f"{row.name}: answers differ by {row.max_abs_difference:.3e} (scale {scale_a:.3g})"
            )
    return rows


if __name__ == "__main__":
    jax.config.update("jax_enable_x64", True)
    for row in run(quick=True):
        print(row.line())
