"""A `PanelTree` as a MuJoCo model: the same bodies, hinges, springs and (optionally) panel contact.

Body ``i`` becomes a MuJoCo body at its hinge point (world-aligned at rest, like the tree's flat
state), with the tree's mass, CG and full inertia and one hinge joint on the tree's axis. Hinge
springs are *switched* springs, so that each hinge can be released at its own time as the etch does:
an `affine` actuator on each joint with gain ``k θ_target − k θ`` and no bias, whose control is 0
before release and 1 after (torque ``ctrl · k (θ_target − θ)``). Fluid drag is linear joint damping
(MuJoCo has no panel drag of ours). With `contact=True` every panel is a thin convex mesh (its
outline extruded by the membrane's thickness), the base too, frictionless (`condim 1`), with the
soft-constraint time constant a few steps long; parent and child never collide (MuJoCo's default
parent filter), as hinged panels in ours do not.
"""

import mujoco
import numpy as np


def _f(values) -> str:
    return " ".join(f"{v:.17g}" for v in np.ravel(values))


def _prism(outline: np.ndarray, thickness: float, inset: float) -> np.ndarray:
    """The outline (a planar polygon, any orientation) moved `inset` towards its centroid and
    extruded by ± thickness/2 along its normal: `(2k, 3)` mesh vertices."""
    centre = outline.mean(axis=0)
    normal = np.cross(outline[1] - outline[0], outline[2] - outline[0])
    normal = normal / np.linalg.norm(normal)
    towards = centre - outline
    towards = towards / np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-300)
    shrunk = outline + inset * towards
    return np.concatenate([shrunk + 0.5 * thickness * normal, shrunk - 0.5 * thickness * normal])


def tree_mjcf(
    tree,
    *,
    stiffness: np.ndarray,
    target: np.ndarray,
    damping: np.ndarray,
    dt: float,
    thickness: float | None = None,
    springs: str = "switched",
    equality: str = "",
) -> str:
    """MJCF of `tree` (a `PanelTree`) with joint `damping`, step `dt`; panel contact when
    `thickness` is given (length units). `springs`: `"switched"` (one actuator per hinge, in hinge
    order, released by its control) or `"joint"` (MuJoCo's joint springs, on from the start);
    `equality`: the model's `<equality>` entries (e.g. loop-closing `connect`s)."""
    if springs not in ("switched", "joint"):
        raise ValueError(f"springs must be 'switched' or 'joint', got {springs!r}")
    parents = tree.parents
    points = np.asarray(tree.points)
    axes = np.asarray(tree.axes)
    frames = np.asarray(tree.frames)
    masses = np.asarray(tree.masses)
    cgs = np.asarray(tree.cgs)
    inertias = np.asarray(tree.inertias)
    outlines = tree.outlines()
    # Panels that meet edge on edge (a closing seam) must not jam on their thickness: each panel's
    # collision prism is inset by a thickness (ours insets each face by 2δ and rounds its rim).
    inset = 0 if thickness is None else thickness
    children: dict[int, list[int]] = {}
    for i, p in enumerate(parents):
        children.setdefault(p, []).append(i)
    assets = []

    def body(i: int) -> str:
        parent_point = points[parents[i]] if parents[i] >= 0 else np.zeros(3)
        rotation = frames[i, :3, :3]
        cg = frames[i, :3, 3] + rotation @ cgs[i] - points[i]
        inertia = rotation @ inertias[i] @ rotation.T
        full = (inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2])
        full = (*full, inertia[1, 2])
        geom = ""
        if thickness is not None:
            world = outlines[i] @ rotation.T + frames[i, :3, 3] - points[i]
            assets.append(f'<mesh name="m{i}" vertex="{_f(_prism(world, thickness, inset))}"/>')
            geom = f'<geom type="mesh" mesh="m{i}" condim="1" contype="1" conaffinity="1"/>'
        inner = "".join(body(c) for c in children.get(i, []))
        spring = ""
        if springs == "joint":
            spring = f'stiffness="{stiffness[i]:.17g}" springref="{target[i]:.17g}" '
        return (
            f'<body name="b{i}" pos="{_f(points[i] - parent_point)}">'
            f'<inertial pos="{_f(cg)}" mass="{masses[i]:.17g}" fullinertia="{_f(full)}"/>'
            f'<joint name="h{i}" type="hinge" axis="{_f(axes[i])}" pos="0 0 0" {spring}'
            f'damping="{damping[i]:.17g}"/>{geom}{inner}</body>'
        )

    bodies = "".join(body(c) for c in children.get(-1, []))
    base = ""
    base_outline = tree.base_outline()
    if thickness is not None and base_outline is not None:
        assets.append(f'<mesh name="base" vertex="{_f(_prism(base_outline, thickness, inset))}"/>')
        base = '<geom type="mesh" mesh="base" condim="1" contype="1" conaffinity="1"/>'
    actuators = "".join(
        f'<general joint="h{i}" gaintype="affine" '
        f'gainprm="{stiffness[i] * target[i]:.17g} {-stiffness[i]:.17g} 0" '
        f'ctrlrange="0 1" ctrllimited="true"/>'
        for i in range(len(parents))
        if springs == "switched"
    )
    contact_flag = "" if thickness is not None else '<flag contact="disable"/>'
    return (
        (
            '<mujoco><compiler angle="radian"/>'
            f'<option timestep="{dt:.17g}" integrator="implicitfast" gravity="0 0 0">'
            f"{contact_flag}</option>"
            f'<default><geom solref="{4 * dt:.17g} 1" margin="0"/></default>'
            f"<asset>{''.join(assets)}</asset>"
            f"<worldbody>{base}{bodies}</worldbody>"
            f"<actuator>{actuators}</actuator><equality>{equality}</equality></mujoco>"
        )
        .replace("<asset></asset>", "")
        .replace("<actuator></actuator>", "")
        .replace("<equality></equality>", "")
    )


def tree_model(tree, **kwargs) -> mujoco.MjModel:
    """`tree_mjcf` compiled."""
    return mujoco.MjModel.from_xml_string(tree_mjcf(tree, **kwargs))


def release_controls(release: np.ndarray, nstep: int, dt: float) -> np.ndarray:
    """Controls `(b, nstep, h)`: hinge `j` of member `b` switched on from `release[b, j]`."""
    release = np.atleast_2d(release)
    times = np.arange(nstep) * dt
    return (times[None, :, None] >= release[:, None, :]).astype(float)


def hinge_period_step(tree, stiffness: np.ndarray, fraction: int = 200) -> float:
    """MuJoCo's fixed step for a tree: `fraction`-th of the shortest hinge period, each hinge alone
    with its own diagonal inertia in the flat state (time units). The same rule for every benchmark
    against MuJoCo, so that no peer is run at a step finer than its physics needs."""
    inertia = np.diagonal(np.asarray(tree.mass_matrix(np.zeros(len(tree.parents)))))
    return float(np.min(2 * np.pi * np.sqrt(inertia / np.asarray(stiffness))) / fraction)


def critical_damping(tree, stiffness: np.ndarray, ratio: float = 1.0) -> np.ndarray:
    """Linear joint damping at `ratio` of critical for each hinge alone (its own diagonal inertia
    in the flat state)."""
    inertia = np.diagonal(np.asarray(tree.mass_matrix(np.zeros(len(tree.parents)))))
    return 2 * ratio * np.sqrt(stiffness * inertia)
