"""The peer of the extended model's point-hinge rows: Pinocchio's `aba` with the fluid's viscous drag.

Written from the physics, not from `origami_jax` (numpy, scipy and Pinocchio only; the design's
numbers are read, nothing else): the accordion of ``n`` flaps (``L × w``, thickness ``t``, density
``ρ``) on point hinges along ``x`` at ``y = 0, L, 2L, …``, each flap's centre ``L/2`` past its
hinge, springs ``k (θ_target − θ)`` (the step's torque ``k θ_target``), the paper's hinge drag
``b θ̇|θ̇|`` and, on every flap, the viscous drag of a plate oscillating in a viscous fluid:

- strip-theory added inertia of a rectangle per unit fluid density about its centre, body frame
  (``x`` along the hinge, ``y`` along the chord, ``z`` normal), twists ``(v, ω)``:
  ``diag(0, 0, πa²w, πa⁴w/8, πa²w³/12, 0)`` with ``a = L/2`` (Newman, *Marine Hydrodynamics*, 1977,
  §4.13);
- Sader's hydrodynamic function of a thin rectangle (J. Appl. Phys. 84 (1998) 64, Eqs. 20–21):
  ``Γ = Ω(Re) Γ_circ(Re)``, ``Γ_circ = 1 + 4 K₁(z) / (z K₀(z))``, ``z = −i √(i Re)``, with
  `scipy.special.kv` for the Bessel functions of complex argument; ``Re = ρ_f ω c² / (4 μ)``,
  ``c = L``;
- the damping ``C_b = C_a ρ_f ω_b Im Γ(Re_b) A_b`` at each flap's hinge frequency
  ``ω_b = √(k_b / M_bb)``, ``M`` the mass matrix half-way to the fold targets (`pinocchio.crba`),
  ``C_a`` the design's added-mass coefficient.

Pinocchio takes external forces in each joint's local frame about the joint's origin (`aba`'s
`fext`): here the joint frame of hinge ``b`` has the flap's orientation and its origin on the hinge,
``r = (0, L/2, 0)`` from the flap's centre, so the damping is shifted there: ``C_joint = Xᵀ C X``
with ``X = [[I, −[r]×], [0, I]]`` (the centre's twist from the joint's; ``Xᵀ`` carries the wrench
back, adding ``r × f`` to the moment).
"""

import numpy as np

# Sader (1998) Eq. 21: Ω(Re) = Ω_r + i Ω_i, τ = log10 Re; coefficients in ascending powers of τ.
_OMEGA_R = (
    (0.91324, -0.48274, 0.46842, -0.12886, 0.044055, -0.0035117, 0.00069085),
    (1.0, -0.56964, 0.48690, -0.13444, 0.045155, -0.0035862, 0.00069085),
)
_OMEGA_I = (
    (-0.024134, -0.029256, 0.016294, -0.00010961, 0.000064577, -0.000044510),
    (1.0, -0.59702, 0.55182, -0.18357, 0.079156, -0.014369, 0.0028361),
)


def sader_gamma(reynolds) -> np.ndarray:
    """Sader's complex hydrodynamic function of a thin rectangle at Reynolds numbers `reynolds`."""
    from numpy.polynomial import polynomial as P
    from scipy.special import kv

    re = np.asarray(reynolds, dtype=float)
    if np.any(re < 1e-6) or np.any(re > 1e4):
        raise ValueError(f"Reynolds numbers {re} are outside Sader's fit (1e-6 to 1e4)")
    tau = np.log10(re)
    omega = P.polyval(tau, _OMEGA_R[0]) / P.polyval(tau, _OMEGA_R[1]) + 1j * (
        P.polyval(tau, _OMEGA_I[0]) / P.polyval(tau, _OMEGA_I[1])
    )
    z = -1j * np.sqrt(1j * re)
    return omega * (1.0 + 4.0 * kv(1, z) / (z * kv(0, z)))


def rectangle_added_inertia(chord: float, span: float) -> np.ndarray:
    """Strip-theory added inertia per unit fluid density of a rectangle about its centre (module
    docstring), 6×6 on ``(v, ω)``."""
    a = 0.5 * chord
    return np.diag(
        [0.0, 0.0, np.pi * a**2 * span, np.pi * a**4 * span / 8, np.pi * a**2 * span**3 / 12, 0.0]
    )


def _cross(r) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def shift_to_joint(damping: np.ndarray, r) -> np.ndarray:
    """A 6×6 damping on twists about a body point, moved to the point ``−r`` from it (the joint's
    origin, same orientation): ``Xᵀ C X``, ``X = [[I, −[r]×], [0, I]]`` (module docstring)."""
    x = np.eye(6)
    x[:3, 3:] = -_cross(r)
    return x.T @ damping @ x


def accordion_model(design, n: int):
    """Pinocchio model of the accordion of `n` flaps from the design's numbers (module docstring)."""
    import pinocchio as pin

    length, width = float(design.flap_length), float(design.flap_width)
    thickness, density = float(design.t_structural), float(design.structural.density)
    mass = density * length * width * thickness
    inertia = (
        mass
        / 12
        * np.diag([length**2 + thickness**2, width**2 + thickness**2, length**2 + width**2])
    )
    model = pin.Model()
    parent = 0
    for i in range(n):
        offset = np.zeros(3) if i == 0 else np.array([0.0, length, 0.0])
        joint = model.addJoint(parent, pin.JointModelRX(), pin.SE3(np.eye(3), offset), f"hinge_{i}")
        model.appendBodyToJoint(
            joint, pin.Inertia(mass, np.array([0.0, length / 2, 0.0]), inertia), pin.SE3.Identity()
        )
        parent = joint
    model.gravity = pin.Motion.Zero()
    return model


def viscous_damping(design, model, stiffness, targets) -> dict:
    """Each flap's viscous damping in its joint frame (module docstring), with the frequencies,
    Reynolds numbers and ``Γ`` it was evaluated at: ``{"joint": (n, 6, 6), "centre": (n, 6, 6),
    "frequency", "reynolds", "gamma"}``."""
    import pinocchio as pin

    data = model.createData()
    mass_matrix = pin.crba(model, data, 0.5 * np.asarray(targets, dtype=float))
    mass_matrix = np.triu(mass_matrix) + np.triu(mass_matrix, 1).T
    frequency = np.sqrt(np.asarray(stiffness, dtype=float) / np.diag(mass_matrix))
    length, width = float(design.flap_length), float(design.flap_width)
    rho_f, mu = float(design.fluid.density), float(design.fluid.viscosity)
    reynolds = rho_f * frequency * length**2 / (4 * mu)
    gamma = sader_gamma(reynolds)
    unit = rectangle_added_inertia(length, width)
    scale = float(design.added_mass_coefficient) * rho_f * frequency * gamma.imag
    centre = scale[:, None, None] * unit
    r = np.array([0.0, length / 2, 0.0])
    joint = np.stack([shift_to_joint(c, r) for c in centre])
    return dict(joint=joint, centre=centre, frequency=frequency, reynolds=reynolds, gamma=gamma)


def viscous_rhs(design, n: int, k, b, targets):
    """``f(t, y)`` of the accordion step with the paper's hinge drag and the fluid's viscous drag,
    ``y = (θ, θ̇)``; also returns the damping dict of `viscous_damping`."""
    import pinocchio as pin

    model = accordion_model(design, n)
    data = model.createData()
    k, b, targets = (np.asarray(x, dtype=float) for x in (k, b, targets))
    damping = viscous_damping(design, model, k, targets)["joint"]
    tau0 = k * targets
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())

    def rhs(t, y):
        q, v = y[:n], y[n:]
        pin.forwardKinematics(model, data, q, v)
        for i in range(n):
            fext[i + 1] = pin.Force(-damping[i] @ data.v[i + 1].vector)
        torque = tau0 - k * q - b * v * np.abs(v)
        return np.concatenate([v, pin.aba(model, data, q, v, torque, fext)])

    return rhs, damping


def lsoda_viscous_peer(design, n: int, ts: np.ndarray, repeats: int):
    """The step-response peer of the point-hinge accordion with the fluid's viscous drag: scipy's
    LSODA on `viscous_rhs` (the design's stiffness and hinge drag, the alternating targets
    ``±θ_final``), from flat at rest over `ts`, at `bench_simulate`'s tolerances. Returns its solution
    and its timing (the damping is built inside the timed call: it depends on the design)."""
    from scipy.integrate import solve_ivp

    from ._harness import time_calls
    from .bench_simulate import ATOL, RTOL

    theta = float(design.theta_final)
    targets = np.array([theta if i % 2 == 0 else -theta for i in range(n)])
    k, b = np.asarray(design.stiffness(n)), np.asarray(design.drag(n))

    def peer():
        rhs, _ = viscous_rhs(design, n, k, b, targets)
        return solve_ivp(
            rhs, (0.0, ts[-1]), np.zeros(2 * n), method="LSODA", t_eval=ts, rtol=RTOL, atol=ATOL
        )

    reference = peer()
    if not reference.success:
        raise RuntimeError(f"LSODA failed: {reference.message}")
    return reference, time_calls(peer, repeats=repeats, warmup=0)
