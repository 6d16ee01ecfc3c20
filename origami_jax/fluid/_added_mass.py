"""The fluid's inertia on a panel (added mass) and its unsteady viscous correction.

**Potential flow, strip theory.** A flat plate of chord ``c = 2a`` moving in an ideal fluid of density
``ρ_f`` carries, per unit span, the added mass ``ρ_f π a²`` in translation normal to itself and the
added moment of inertia ``ρ_f π a⁴ / 8`` in rotation about its mid-chord, uncoupled (Newman, *Marine
Hydrodynamics*, MIT Press 1977, §4.13 and Table 4.3: the plate's added mass is that of the circular
cylinder circumscribing it). Rotation about one edge combines the two: ``(9/8) ρ_f π a⁴``. Strip
theory applies this section by section along the span: a panel whose hinge runs along its body ``x``
axis is cut into sections at fixed ``x`` (chord ``c(x)``, mid-chord ``y_m(x)``), each moving normal to
the panel at ``w = v_z + ω_x y_m − ω_y x`` (body-frame twist about the panel's origin) and pitching at
``ω_x``. Its kinetic energy ``½ ∫ [ρ_f π a² w² + ρ_f π a⁴ ω_x² / 8] dx`` is a quadratic form in
``(v_z, ω_x, ω_y)``: the panel's 6×6 added inertia in its body frame, zero for the in-plane motions a
zero-thickness plate does not push fluid with. For a rectangle of chord ``L`` and span ``w`` about its
centre: ``ρ_f π a² w`` (``v_z``), ``ρ_f π a⁴ w / 8`` (``ω_x``), ``ρ_f π a² w³ / 12`` (``ω_y``).

What strip theory ignores (docs/physics.md, "The fluid moves with the flap"): the flow around the
panel's side edges (a finite plate pushes less fluid: a square plate has about 0.58 of the strip value
in normal translation, DNV-RP-C205 (2010) Table A-2; the design's `added_mass_coefficient` scales it),
the panels' mutual interference (flaps folding onto each other squeeze the fluid between them), the
hinge strip's own fluid and the fluid's memory of earlier motion (the wake).

**Viscosity** (Sader, J. Appl. Phys. 84 (1998) 64). A section oscillating at frequency ``ω`` in a
viscous fluid feels ``F = (π/4) ρ_f ω² c² Γ(Re) W`` per unit span (``W`` its displacement,
``Re = ρ_f ω c² / (4 μ)``): ``Re Γ`` scales the added mass and ``Im Γ`` gives a damping
``ω Im Γ · ρ_f π a²`` per unit span. For a thin rectangular section ``Γ_rect = Ω(Re) Γ_circ(Re)`` with
Stokes's circular-cylinder function ``Γ_circ = 1 + 4 K₁(z) / (z K₀(z))``, ``z = −i √(i Re)`` (Stokes,
Trans. Camb. Phil. Soc. 9 (1851) 8), and Sader's rational fit ``Ω`` (accurate to 0.1 % for
``1e-6 ≤ Re ≤ 1e4``). `hydrodynamic_function` evaluates it, differentiably; `Γ → 1` at high ``Re``
(potential flow). Sader's theory is for small amplitudes of a long beam; a folding flap is neither
(docs/physics.md).
"""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

# Sader (1998) Eq. 21: Ω(Re) = Ω_r + i Ω_i with τ = log10 Re, coefficients in ascending powers of τ.
_OMEGA_REAL_NUMERATOR = (0.91324, -0.48274, 0.46842, -0.12886, 0.044055, -0.0035117, 0.00069085)
_OMEGA_REAL_DENOMINATOR = (1.0, -0.56964, 0.48690, -0.13444, 0.045155, -0.0035862, 0.00069085)
_OMEGA_IMAG_NUMERATOR = (-0.024134, -0.029256, 0.016294, -0.00010961, 0.000064577, -0.000044510)
_OMEGA_IMAG_DENOMINATOR = (1.0, -0.59702, 0.55182, -0.18357, 0.079156, -0.014369, 0.0028361)

# Trapezoid nodes of the Bessel integrals (`bessel_k_ratio`): the integrand's phase turns by at most
# 40 rad over the range, so 257 nodes resolve it; measured against scipy.special.kv: 1e-13 relative.
_BESSEL_NODES = 257
_BESSEL_CUTOFF = 40.0


def _polynomial(coefficients: tuple[float, ...], x: Array) -> Array:
    out = jnp.full_like(x, coefficients[-1])
    for c in coefficients[-2::-1]:
        out = out * x + c
    return out


def bessel_k_ratio(z: ArrayLike) -> Array:
    """``K₁(z) / K₀(z)`` for complex ``z`` with ``Re z > 0`` (modified Bessel functions of the second
    kind), differentiable.

    From ``K_ν(z) e^z = ∫₀^∞ exp(−z (cosh t − 1)) cosh(ν t) dt`` (Abramowitz & Stegun 9.6.24), by
    the trapezoid rule on ``[0, T]`` with ``Re z (cosh T − 1) = 40``: the integrand is even and
    analytic in ``t``, so the rule converges geometrically.
    """
    z = jnp.asarray(z, dtype=jnp.result_type(complex))
    end = jnp.arccosh(1.0 + _BESSEL_CUTOFF / jnp.real(z))
    s = jnp.linspace(0.0, 1.0, _BESSEL_NODES)
    weights = jnp.ones(_BESSEL_NODES).at[0].set(0.5).at[-1].set(0.5)
    t = end[..., None] * s
    integrand = jnp.exp(-z[..., None] * (jnp.cosh(t) - 1.0)) * weights
    k0 = jnp.sum(integrand, axis=-1)
    k1 = jnp.sum(integrand * jnp.cosh(t), axis=-1)
    return k1 / k0


def circular_hydrodynamic_function(reynolds: Float[ArrayLike, "*b"]) -> Array:
    """Stokes's ``Γ_circ(Re) = 1 + 4 K₁(z) / (z K₀(z))``, ``z = −i √(i Re)`` (complex, `(*b,)`)."""
    re = jnp.asarray(reynolds, dtype=float)
    z = -1j * jnp.sqrt(1j * re.astype(jnp.result_type(complex)))
    return 1.0 + 4.0 * bessel_k_ratio(z) / z


def rectangular_correction(reynolds: Float[ArrayLike, "*b"]) -> Array:
    """Sader's ``Ω(Re)`` (complex), the thin rectangle's hydrodynamic function over the circle's."""
    tau = jnp.log10(jnp.asarray(reynolds, dtype=float))
    real = _polynomial(_OMEGA_REAL_NUMERATOR, tau) / _polynomial(_OMEGA_REAL_DENOMINATOR, tau)
    imag = _polynomial(_OMEGA_IMAG_NUMERATOR, tau) / _polynomial(_OMEGA_IMAG_DENOMINATOR, tau)
    return real + 1j * imag


def hydrodynamic_function(
    reynolds: Float[ArrayLike, "*b"],
) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """Sader's hydrodynamic function of a thin rectangular section, ``Γ_rect = Ω Γ_circ``, as
    ``(Re Γ, Im Γ)`` (dimensionless, module docstring). `reynolds`: ``ρ_f ω c² / (4 μ)``, in
    ``[1e-6, 1e4]`` (the fit's range; higher values are clipped there, where ``Γ`` is close to
    its potential-flow limit 1: 4 % at 1e4)."""
    re = jnp.clip(jnp.asarray(reynolds, dtype=float), 1e-6, 1e4)
    gamma = rectangular_correction(re) * circular_hydrodynamic_function(re)
    return jnp.real(gamma), jnp.imag(gamma)


def reynolds_number(
    density: Float[ArrayLike, "..."],
    viscosity: Float[ArrayLike, "..."],
    frequency: Float[ArrayLike, "..."],
    chord: Float[ArrayLike, "..."],
) -> Array:
    """Sader's oscillatory Reynolds number ``Re = ρ_f ω c² / (4 μ)`` (angular frequency ``ω``, chord
    ``c``; any consistent units)."""
    return (
        jnp.asarray(density)
        * jnp.asarray(frequency)
        * jnp.asarray(chord) ** 2
        / (4 * jnp.asarray(viscosity))
    )


# Where ``(v_z, ω_x, ω_y)`` sit among a body twist's ``(v_x, v_y, v_z, ω_x, ω_y, ω_z)``.
_OUT_OF_PLANE = slice(2, 5)


def _embed(block: Array) -> Array:
    """A 3×3 form on ``(v_z, ω_x, ω_y)`` as the 6×6 on ``(v_x, v_y, v_z, ω_x, ω_y, ω_z)``."""
    out = jnp.zeros(block.shape[:-2] + (6, 6), block.dtype)
    return out.at[..., _OUT_OF_PLANE, _OUT_OF_PLANE].set(block)


def rectangle_added_inertia(
    chord: Float[ArrayLike, "*b"], span: Float[ArrayLike, "*b"], density: Float[ArrayLike, "*b"]
) -> Float[Array, "*b 6 6"]:
    """Strip-theory added inertia of a rectangular plate about its centre, in its body frame (``x``
    along the span, the hinge; ``y`` along the chord; ``z`` normal), on body twists
    ``(v_x, v_y, v_z, ω_x, ω_y, ω_z)``: ``diag(·, ·, ρπa²w, ρπa⁴w/8, ρπa²w³/12, ·)`` with
    ``a = chord/2``, ``w = span``, zero elsewhere (module docstring). Units: mass, mass·length,
    mass·length² blocks of the given units. Differentiable in every argument."""
    a = 0.5 * jnp.asarray(chord)
    w, rho = jnp.asarray(span), jnp.asarray(density)
    a, w, rho = jnp.broadcast_arrays(a, w, rho)
    translation = rho * jnp.pi * a**2 * w
    pitch = rho * jnp.pi * a**4 * w / 8
    roll = rho * jnp.pi * a**2 * w**3 / 12
    zero = jnp.zeros_like(a)
    block = jnp.stack(
        [
            jnp.stack([translation, zero, zero], axis=-1),
            jnp.stack([zero, pitch, zero], axis=-1),
            jnp.stack([zero, zero, roll], axis=-1),
        ],
        axis=-2,
    )
    return _embed(block)


def polygon_added_inertia(outline: ArrayLike, density: Float[ArrayLike, ""] = 1.0) -> Array:
    """Strip-theory added inertia of a flat convex panel about its body frame's origin, in its body
    frame (sections at fixed ``x``, the hinge direction; module docstring), `(6, 6)`.

    `outline`: the polygon in its body frame's ``x–y`` plane, `(k, 3)` (host values; its convex hull
    is used); `density`: ``ρ_f`` (may be traced: the geometry is integrated on the host, once).
    The chord ``c(x)`` is piecewise linear in ``x``, so the integrands are polynomials of degree ≤ 6
    between the corners' ``x`` values, and 4-point Gauss–Legendre on each piece is exact.
    """
    xy = np.asarray(outline, dtype=float)[:, :2]
    xs = np.unique(np.round(xy[:, 0], 12))
    if len(xs) < 2:
        raise ValueError("the panel outline has no extent along its hinge (x): zero span.")
    nodes, weights = np.polynomial.legendre.leggauss(4)
    moments = np.zeros((3, 3))
    for left, right in zip(xs[:-1], xs[1:], strict=True):
        half = 0.5 * (right - left)
        for node, weight in zip(nodes, weights, strict=True):
            x = left + half * (node + 1)
            lo, hi = _chord(xy, x)
            a, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
            # w = v_z + ω_x y_m − ω_y x: the section's normal velocity at its mid-chord.
            lever = np.array([1.0, mid, -x])
            moments += weight * half * np.pi * (a**2 * np.outer(lever, lever))
            moments[1, 1] += weight * half * np.pi * a**4 / 8
    if isinstance(density, int | float):  # on the host: no program compiled per operation
        embedded = np.zeros((6, 6))
        embedded[_OUT_OF_PLANE, _OUT_OF_PLANE] = density * moments
        return jnp.asarray(embedded)
    return _embed(jnp.asarray(density) * jnp.asarray(moments))


def _chord(xy: np.ndarray, x: float) -> tuple[float, float]:
    """The interval of ``y`` the convex hull of `xy` covers at abscissa `x`."""
    ys = []
    for (x0, y0), (x1, y1) in zip(xy, np.roll(xy, -1, axis=0), strict=True):
        if (x0 - x) * (x1 - x) <= 0 and x0 != x1:
            ys.append(y0 + (y1 - y0) * (x - x0) / (x1 - x0))
        elif x0 == x1 == x:
            ys += [y0, y1]
    if not ys:
        return 0.0, 0.0
    return min(ys), max(ys)
