"""The peer of the extended model's point-hinge rows: Pinocchio with the fluid's viscous drag and inertia.

Written from the physics, not from `origami_jax` (numpy, scipy and Pinocchio only; the design's
numbers are read, nothing else): the accordion of ``n`` flaps (``L × w``, thickness ``t``, density
``ρ``) on point hinges along ``x`` at ``y = 0, L, 2L, …``, each flap's centre ``L/2`` past its
hinge, springs ``k (θ_target − θ)`` (the step's torque ``k θ_target``), the paper's hinge drag
``b θ̇|θ̇|`` and, on every flap, the fluid of a plate oscillating in a viscous fluid:

- strip-theory added inertia of a rectangle per unit fluid density about its centre, body frame
  (``x`` along the hinge, ``y`` along the chord, ``z`` normal), twists ``(v, ω)``:
  ``A = diag(0, 0, πa²w, πa⁴w/8, πa²w³/12, 0)`` with ``a = L/2`` (Newman, *Marine
  Hydrodynamics*, 1977, §4.13);
- Sader's hydrodynamic function of a thin rectangle (J. Appl. Phys. 84 (1998) 64, Eqs. 20–21):
  ``Γ = Ω(Re) Γ_circ(Re)``, ``Γ_circ = 1 + 4 K₁(z) / (z K₀(z))``, ``z = −i √(i Re)``, with
  `scipy.special.kv` for the Bessel functions of complex argument; ``Re = ρ_f ω c² / (4 μ)``,
  ``c = L``;
- viscous damping ``C_b = C_a ρ_f ω_b Im Γ(Re_b) A`` and added inertia ``C_a ρ_f Re Γ(Re_b) A``
  at each flap's hinge frequency ``ω_b = √(k_b / M_bb)``, ``M`` the mass matrix half-way to the
  fold targets (`pinocchio.crba`, plus the fluid's part with added inertia: `fluid_terms`),
  ``C_a`` the design's added-mass coefficient.

Pinocchio takes external forces in each joint's local frame about the joint's origin (`aba`'s
`fext`), and its local Jacobians and spatial velocities are in the same frames: here the joint frame
of hinge ``b`` has the flap's orientation and its origin on the hinge, ``r = (0, L/2, 0)`` from the
flap's centre, so the fluid's matrices are shifted there: ``Xᵀ C X`` with
``X = [[I, −[r]×], [0, I]]`` (the centre's twist from the joint's; ``Xᵀ`` carries the wrench back,
adding ``r × f`` to the moment).
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


def flap_size(design) -> tuple[float, float]:
    """The accordion's flap length and width in the design's units: the pattern's default, the
    paper's 200 µm squares (`origami_jax.chain.flap_size`)."""
    from origami_jax.chain import flap_size as size

    length, width = size(design.units)
    return float(length), float(width)


def accordion_model(design, n: int):
    """Pinocchio model of the accordion of `n` flaps from the design's numbers (module docstring)."""
    import pinocchio as pin

    length, width = flap_size(design)
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


def viscous_rhs(design, n: int, k, b, targets):
    """``f(t, y)`` of the accordion step with the paper's hinge drag and the fluid's viscous drag,
    ``y = (θ, θ̇)``; also returns `fluid_terms`' dict (no added inertia)."""
    import pinocchio as pin

    model = accordion_model(design, n)
    data = model.createData()
    k, b, targets = (np.asarray(x, dtype=float) for x in (k, b, targets))
    terms = fluid_terms(design, model, k, targets, added_mass=False)
    damping = terms["damping"]
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

    return rhs, terms


def fluid_terms(design, model, stiffness, targets, *, added_mass: bool, passes: int = 60) -> dict:
    """The fluid's added inertia and viscous damping of every flap in its joint frame, at the
    frequencies ``ω_b = √(k_b / M_bb)`` (module docstring). With added inertia ``M_bb`` includes the
    fluid's: the rigid ``M`` from `pinocchio.crba` plus ``Re Γ_b`` times the fluid part ``Σ Jᵀ A J``
    of the diagonal (``A`` at ``Γ = 1``, all flaps; the flap's own ``Re Γ_b`` weights it), half-way
    to the targets; ``Re Γ`` depends on ``ω``, so the pair is iterated to its fixed point (`passes`
    substitutions, each shrinking the error ~10×). Returns ``{"inertia": (n, 6, 6) or None,
    "damping": (n, 6, 6), "frequency", "reynolds", "gamma"}`` (joint frames)."""
    import pinocchio as pin

    n = model.nq
    data = model.createData()
    middle = 0.5 * np.asarray(targets, dtype=float)
    own = np.diag(pin.crba(model, data, middle)).copy()
    length, width = flap_size(design)
    rho_f, mu = float(design.fluid.density), float(design.fluid.viscosity)
    r = np.array([0.0, length / 2, 0.0])
    unit = shift_to_joint(rectangle_added_inertia(length, width), r)
    scale = float(design.added_mass_coefficient) * rho_f
    fluid = np.zeros(n)
    if added_mass:
        pin.computeJointJacobians(model, data, middle)
        for i in range(n):
            jacobian = pin.getJointJacobian(model, data, i + 1, pin.LOCAL)
            fluid += np.diag(jacobian.T @ (scale * unit) @ jacobian)
    stiffness = np.asarray(stiffness, dtype=float)

    def at(real):
        frequency = np.sqrt(stiffness / (own + real * fluid))
        reynolds = rho_f * frequency * length**2 / (4 * mu)
        return frequency, reynolds, sader_gamma(reynolds)

    real = np.ones(n)
    for _ in range(passes if added_mass else 0):
        real = at(real)[2].real
    frequency, reynolds, gamma = at(real)
    inertia = (scale * real)[:, None, None] * unit if added_mass else None
    damping = (scale * frequency * gamma.imag)[:, None, None] * unit
    return dict(
        inertia=inertia, damping=damping, frequency=frequency, reynolds=reynolds, gamma=gamma
    )


def added_mass_rhs(design, n: int, k, b, targets, *, viscous: bool = False):
    """``f(t, y)`` of the accordion step with the paper's hinge drag and the fluid's added inertia
    (and its viscous drag when `viscous`), ``y = (θ, θ̇)``. The added inertia ``A_b`` (joint frame)
    is a body-fixed generalised inertia: its wrench on the flap is Kirchhoff's
    ``A a_b + v_b ×* (A v_b)`` (``v_b``, ``a_b`` the flap's spatial velocity and acceleration in
    its joint frame), so ``M_total = crba + Σ J_bᵀ A_b J_b`` (local joint Jacobians) and the bias
    adds ``Σ J_bᵀ (A_b a_b⁰ + v_b ×* A_b v_b)`` (``a_b⁰`` the acceleration at ``q̈ = 0``); solved
    by Cholesky. Also returns `fluid_terms`' dict."""
    import pinocchio as pin

    model = accordion_model(design, n)
    data = model.createData()
    k, b, targets = (np.asarray(x, dtype=float) for x in (k, b, targets))
    terms = fluid_terms(design, model, k, targets, added_mass=True)
    inertia, damping = terms["inertia"], terms["damping"]
    tau0 = k * targets
    zero = np.zeros(n)

    def rhs(t, y):
        q, v = y[:n], y[n:]
        mass = pin.crba(model, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        bias = pin.nonLinearEffects(model, data, q, v).copy()
        pin.forwardKinematics(model, data, q, v, zero)
        pin.computeJointJacobians(model, data, q)
        for i in range(n):
            jacobian = pin.getJointJacobian(model, data, i + 1, pin.LOCAL)
            velocity = data.v[i + 1]
            momentum = inertia[i] @ velocity.vector
            wrench = inertia[i] @ data.a[i + 1].vector + velocity.cross(pin.Force(momentum)).vector
            if viscous:
                wrench = wrench + damping[i] @ velocity.vector
            mass += jacobian.T @ inertia[i] @ jacobian
            bias += jacobian.T @ wrench
        torque = tau0 - k * q - b * v * np.abs(v) - bias
        factor = np.linalg.cholesky(mass)
        return np.concatenate([v, np.linalg.solve(factor.T, np.linalg.solve(factor, torque))])

    return rhs, terms


def lsoda_fluid_peer(design, n: int, ts: np.ndarray, repeats: int, *, added_mass: bool):
    """The step-response peer of the point-hinge accordion with the paper's hinge drag and the
    fluid's viscous drag (`viscous_rhs`) or added inertia (`added_mass_rhs`, `added_mass=True`):
    scipy's LSODA from flat at rest over `ts` at `bench_simulate`'s tolerances, the design's
    stiffness and hinge drag, the alternating targets ``±θ_final``. Returns its solution and its
    timing (the fluid's terms are built inside the timed call: they depend on the design), and the
    angles `(t, n)` of the same model solved tightly (DOP853, rtol 1e-12, atol 1e-14; untimed): at
    rtol 1e-8 the three flaps' ringing amplifies the solvers' local errors past 1e-5 rad by 500 µs
    with added inertia (LSODA 2.0e-5, DOP853 3.8e-5 from the tight solve; ours 1.0e-6), so answers
    are compared against the tight solve."""
    from scipy.integrate import solve_ivp

    from ._harness import time_calls
    from .bench_simulate import ATOL, RTOL

    theta = float(design.theta_final)
    targets = np.array([theta if i % 2 == 0 else -theta for i in range(n)])
    k, b = np.asarray(design.stiffness(n)), np.asarray(design.drag(n, *flap_size(design)))
    build = added_mass_rhs if added_mass else viscous_rhs

    def peer():
        rhs, _ = build(design, n, k, b, targets)
        return solve_ivp(
            rhs, (0.0, ts[-1]), np.zeros(2 * n), method="LSODA", t_eval=ts, rtol=RTOL, atol=ATOL
        )

    reference = peer()
    if not reference.success:
        raise RuntimeError(f"LSODA failed: {reference.message}")
    rhs, _ = build(design, n, k, b, targets)
    tight = solve_ivp(
        rhs, (0.0, ts[-1]), np.zeros(2 * n), method="DOP853", t_eval=ts, rtol=1e-12, atol=1e-14
    )
    if not tight.success:
        raise RuntimeError(f"DOP853 failed: {tight.message}")
    return reference, time_calls(peer, repeats=repeats, warmup=0), tight.y[:n].T
