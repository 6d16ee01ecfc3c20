"""The contact barrier and the contact's defaults (stiffness, damping), shared by both contact models
(`PanelContact`, `PlateContact`)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._exported import exported_jit
from .._validate import is_traced
from ..system import rest_inertia

# The contact's damping ratio at half its activation gap (`with_default_damping`): enough to take a
# landing's energy out over a few rebounds without holding panels apart.
DEFAULT_DAMPING_RATIO = 0.5
_X_MIN = 0.1  # below this fraction of the activation gap the barrier continues as a quadratic
_LOG_X_MIN = float(np.log(_X_MIN))
_B_MIN = -((_X_MIN - 1) ** 2) * _LOG_X_MIN
_DB_MIN = -2 * (_X_MIN - 1) * _LOG_X_MIN - (_X_MIN - 1) ** 2 / _X_MIN
_D2B_MIN = -2 * _LOG_X_MIN - 4 * (_X_MIN - 1) / _X_MIN + (_X_MIN - 1) ** 2 / _X_MIN**2
# B''(½), the contact's curvature half-way into the activation gap (default damping).
_D2B_HALF = -2 * float(np.log(0.5)) - 4 * (0.5 - 1) / 0.5 + (0.5 - 1) ** 2 / 0.5**2


def barrier(x: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
    """IPC barrier ``B(x) = −(x − 1)² ln x`` for ``x_min ≤ x < 1``, 0 for ``x ≥ 1``, its second-order
    Taylor polynomial below ``x_min = 0.1`` (finite for any ``x``, C² everywhere)."""
    x = jnp.asarray(x)
    inside = (x > _X_MIN) & (x < 1)
    safe = jnp.where(inside, x, 0.5)
    log_barrier = -((safe - 1) ** 2) * jnp.log(safe)
    dx = x - _X_MIN
    taylor = _B_MIN + _DB_MIN * dx + 0.5 * _D2B_MIN * dx**2
    return jnp.where(x >= 1, 0.0, jnp.where(inside, log_barrier, taylor))


def smoothstep(x: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
    """C² step from 0 (``x ≤ 0``) to 1 (``x ≥ 1``): ``x³(10 − 15x + 6x²)``."""
    x = jnp.clip(x, 0.0, 1.0)
    return x**3 * (10 - 15 * x + 6 * x**2)


def _barrier_slope(x):
    """``B'(x)`` of `barrier` (its derivative, piece by piece)."""
    inside = (x > _X_MIN) & (x < 1)
    safe = jnp.where(inside, x, 0.5)
    log_slope = -2 * (safe - 1) * jnp.log(safe) - (safe - 1) ** 2 / safe
    taylor = _DB_MIN + _D2B_MIN * (x - _X_MIN)
    return jnp.where(x >= 1, 0.0, jnp.where(inside, log_slope, taylor))


def smoothstep_slope(x: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
    """The derivative of `smoothstep`: ``30 x² (1 − x)²`` on ``[0, 1]``, 0 outside."""
    x = jnp.clip(x, 0.0, 1.0)
    return 30 * x**2 * (1 - x) ** 2


def _barrier_curvature(x):
    """``B''(x)`` of `barrier` (piece by piece; 0 beyond the activation gap)."""
    inside = (x > _X_MIN) & (x < 1)
    safe = jnp.where(inside, x, 0.5)
    log_curvature = -2 * jnp.log(safe) - 4 * (safe - 1) / safe + (safe - 1) ** 2 / safe**2
    return jnp.where(x >= 1, 0.0, jnp.where(inside, log_curvature, _D2B_MIN))


def _ramp_integral(x):
    """``∫₀ˣ smoothstep``: 0 for ``x ≤ 0``, ``x⁴(5/2 − 3x + x²)`` on ``[0, 1]``, ``x − ½`` beyond (C³)."""
    inside = jnp.clip(x, 0.0, 1.0)
    return inside**4 * (2.5 - 3 * inside + inside**2) + jnp.maximum(x - 1, 0.0)


def released_energy(hinge_stiffness, hinge_target) -> Array:
    """``Σ ½ k θ_target²``: the energy the hinges can release, the contact's default stiffness."""
    return jnp.sum(0.5 * jnp.asarray(hinge_stiffness) * jnp.asarray(hinge_target) ** 2)


def with_default_contact(
    cls, mechanism, hinge_stiffness, hinge_target, damping_ratio: float, thickness, kwargs: dict
):
    """`cls.from_mechanism(mechanism, thickness=thickness, stiffness=κ, damping=c, **kwargs)` with
    the defaults of a contact model's `for_system`: ``κ`` the energy the hinges can release
    (`released_energy`), ``c`` from `damping_ratio` (`with_default_damping`)."""
    energy = released_energy(hinge_stiffness, hinge_target)
    probe = cls.from_mechanism(
        mechanism, thickness=thickness, stiffness=energy, damping=0.0, **kwargs
    )
    return with_default_damping(probe, mechanism, damping_ratio)


def host_rest_poses(mechanism, tables: str, tables_for: str) -> np.ndarray:
    """The bodies' rest poses on the host, for a contact model's geometry tables; `ValueError`
    when the mechanism's arrays are traced (`tables`: the tables' class, `tables_for`: the method
    that builds them outside)."""
    try:
        return np.asarray(_rest_poses(mechanism))
    except jax.errors.TracerArrayConversionError as error:
        raise ValueError(
            "contact needs the panels' geometry before compilation, but this mechanism was built "
            f"from traced values (under jit, vmap or grad): build its {tables} outside "
            f"({tables_for}) and pass tables=, or vary hinge parameters only."
        ) from error


def with_base_pose(tables, poses: Array) -> Array:
    """The moving bodies' world poses `(b, 4, 4)` with the fixed base's after them when the contact
    `tables` have a base (`(b + 1, 4, 4)`), else as they are."""
    if not tables.has_base:
        return poses
    return jnp.concatenate([poses, jnp.asarray(tables.base_pose, poses.dtype)[None]], axis=0)


def half_thicknesses(mechanism, thickness, base_thickness) -> tuple[Array, Array]:
    """Each panel's thickness `(b,)` (a scalar broadcast) and the half-thicknesses of the panels
    and the base after them `(b + 1,)` (the base's default: the thickest panel's)."""
    dtype = jnp.result_type(float)
    thickness = jnp.broadcast_to(jnp.asarray(thickness, dtype), (mechanism.n_bodies,))
    base = jnp.max(thickness) if base_thickness is None else base_thickness
    return thickness, jnp.concatenate([thickness, jnp.asarray(base, dtype)[None]]) / 2


def with_default_damping(contact, mechanism, damping_ratio: float):
    """`contact` (with `stiffness`, `activation`, `tables.scale`) with its default damping
    ``c = 2 ζ sqrt(k_c m)``: ``k_c = κ B''(½)/ĝ²`` the contact's stiffness half-way into the
    activation gap, ``m`` the lightest panel's mass (the smallest diagonal entry of ``M(0)`` over
    its squared lever arm, the largest panel's size), ``ζ`` = `damping_ratio`. Traceable."""
    contact_stiffness = contact.stiffness * _D2B_HALF / contact.activation**2
    mass = jnp.min(rest_inertia(mechanism)) / contact.tables.scale**2
    damping = 2 * damping_ratio * jnp.sqrt(contact_stiffness * mass)
    return eqx.tree_at(lambda c: c.damping, contact, damping.astype(contact.damping.dtype))


# One compiled program (op by op, every new shape would compile its own): the rest poses for the
# host geometry (the mass matrix's diagonal for the default damping is `rest_inertia`'s). Under an
# outer trace it is traced inline; in a command, its program and executable are kept on disk and
# quickly compiled (`exported_jit`: it runs once).
@exported_jit("rest_poses")
def _rest_poses(mechanism):
    return mechanism.body_poses(mechanism.rest_state()[0])


def check_known_values(label: str, values) -> None:
    """Refuse (one line, before anything compiles) a known contact parameter that is not finite or
    not positive: `values` are ``(name, value, strict)``, ``strict`` for ``> 0`` (else ``>= 0``);
    traced values are left to the model. `label` prefixes the name in the message (``"contact "``,
    ``"Adhesion."``)."""
    for name, value, strict in values:
        if is_traced(value):
            continue
        host = np.asarray(value)
        if not (np.all(np.isfinite(host)) and np.all(host > 0 if strict else host >= 0)):
            raise ValueError(
                f"{label}{name} must be finite and {'> 0' if strict else '>= 0'}, got {host}."
            )


def check_contact_numbers(thickness, stiffness, damping, activation, *more) -> None:
    """`check_known_values` of a contact model's shared numbers (thickness and activation gap
    ``> 0``, stiffness and damping ``>= 0``) and `more` ``(name, value, strict)``."""
    check_known_values(
        "contact ",
        (
            ("thickness", thickness, True),
            ("stiffness", stiffness, False),
            ("damping", damping, False),
            ("activation", activation, True),
            *more,
        ),
    )
