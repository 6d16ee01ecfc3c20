"""Free parameters of a design and their bounds, enforced by a smooth reparametrisation.

The optimiser works on unconstrained variables ``z ∈ ℝᵖ``. Each physical parameter ``x`` is a sigmoid of
its ``z`` between its bounds — in log space for positive quantities (``x = exp(log lo + (log hi − log lo)
σ(z))``, so a factor of 10 is the same distance everywhere), linearly otherwise (``x = lo + (hi − lo)
σ(z)``). The bounds can therefore never be violated, and no gradient is cut as a clip would cut it; a
parameter pushed to a bound shows up as ``σ(z)`` close to 0 or 1 (see `ParameterSpace.at_bound`).

Parameters are named by their field in `origami_jax.system.HingeDesign`, with a dot for the fields of its
materials and fluid (``"fluid.density"``, ``"hinge.youngs_modulus"``), or by a field of the pattern's
geometry (``"flap_length"``, ``"flap_width"``: the accordion's flaps, `origami_jax.chain.Accordion`), which
the fit replaces in the pattern (`ParameterSpace.apply_pattern`) rather than in the design.
"""

import re
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..chain import ACCORDION_GEOMETRY
from ..system import HingeDesign

# Scalar fields of the pattern's geometry that may be freed (a pattern with them has `geometry(units)`
# and `with_geometry(**values)`, as `Accordion` does), with their physical unit (the design's units).
_PATTERN = dict(ACCORDION_GEOMETRY)
# Scalar fields of `HingeDesign` that may be freed, with their physical unit (in the design's `units`).
_TOP_LEVEL = {
    "hinge_width": "length",
    "t_structural": "length",
    "t_hinge": "length",
    "misfit_strain": "",
    "theta_final": "rad",
    "drag_coefficient": "",
    "k_scale": "",
    "b_scale": "",
    "added_mass_coefficient": "",
}
_NESTED = {
    "fluid.density": "mass/length³",
    "fluid.viscosity": "mass/(length·time)",
    "structural.youngs_modulus": "stress",
    "structural.poisson_ratio": "",
    "structural.density": "mass/length³",
    "hinge.youngs_modulus": "stress",
    "hinge.poisson_ratio": "",
    "hinge.density": "mass/length³",
}
_ALIASES = {"fluid_density": "fluid.density", "fluid_viscosity": "fluid.viscosity"}
# Where each field is physical (`HingeDesign` refuses the rest): strictly positive, Poisson's ratios
# in (-1, 0.5). Bounds must lie within (the reparametrisation never reaches them), so that no value
# the optimiser can try is refused at run time.
_DOMAIN = {"structural.poisson_ratio": (-1.0, 0.5), "hinge.poisson_ratio": (-1.0, 0.5)}
PARAMETER_NAMES = tuple(_TOP_LEVEL) + tuple(_PATTERN) + tuple(_NESTED)
"""Every name `ParameterSpace` accepts (plus the aliases ``fluid_density`` and ``fluid_viscosity``)."""

# Default bounds: a factor of 100 either side of the start (log-scaled parameters).
_DEFAULT_FACTOR = 100.0
# σ(z) this close to 0 or 1 counts as "at the bound" in reports; within `_NEAR_BOUND` it counts when
# the cost still decreases outwards (the sigmoid flattens there, so an optimiser creeps to the bound).
_AT_BOUND = 1e-3
_NEAR_BOUND = 0.03
# Starts exactly on a bound are moved inside by this fraction of the (log) range: σ⁻¹ is infinite there.
_INSIDE = 1e-6


def _split(name: str) -> tuple[str, int | None]:
    """``"hinge_width[2]"`` → ``("hinge_width", 2)``; ``"k_scale"`` → ``("k_scale", None)``."""
    match = re.fullmatch(r"(.+)\[(\d+)\]", name.strip())
    if match is None:
        return name.strip(), None
    return match.group(1), int(match.group(2))


def _canonical(name: str) -> str:
    field, index = _split(name)
    field = _ALIASES.get(field, field)
    if field in _PATTERN and index is not None:
        raise ValueError(f"{name!r}: {field} is one value for the whole pattern; free {field}.")
    if field not in _TOP_LEVEL and field not in _NESTED and field not in _PATTERN:
        raise ValueError(
            f"{name!r} is not a free parameter of HingeDesign or of the pattern's geometry. Choose "
            "among: "
            f"{', '.join(PARAMETER_NAMES)} (aliases: fluid_density, fluid_viscosity), or one hinge's entry of a "
            "per-hinge field as NAME[i] (e.g. hinge_width[2])."
        )
    return field if index is None else f"{field}[{index}]"


def _field_getter(field: str):
    parts = field.split(".")

    def get(hinge):
        value = hinge
        for part in parts:
            value = getattr(value, part)
        return value

    return get


def _getter(name: str):
    field, index = _split(name)
    get = _field_getter(field)
    if index is None:
        return get
    return lambda hinge: get(hinge)[index]


def parameter_unit(name: str) -> str:
    """The kind of unit of a parameter (``"length"``, ``"stress"``, ``""`` for dimensionless, …)."""
    field, _ = _split(_canonical(name))
    return _TOP_LEVEL.get(field, _PATTERN.get(field, _NESTED.get(field, "")))


def _pattern_geometry(pattern, units, name: str):
    """The value of the pattern's geometry field `name` in `units` (`pattern.geometry(units)`).
    **Raises:** `ValueError` when the pattern has no such geometry (a net: its panels are fixed)."""
    geometry = getattr(pattern, "geometry", None)
    values = {} if geometry is None else geometry(units)
    if name not in values:
        raise ValueError(
            f"{name} is the accordion's flap geometry (origami_jax.chain.Accordion); "
            f"{type(pattern).__name__} has none to free."
        )
    return values[name]


class ParameterSpace(eqx.Module):
    """The free parameters of a design, their bounds and the map from unconstrained ``z`` to them.

    **Fields:**
    - `names`: parameter names (static), e.g. ``("k_scale", "b_scale")``.
    - `lower`, `upper`: bounds, shape `(p,)`, in the design's units (`HingeDesign.units`).
    - `log`: per parameter, whether the sigmoid runs in log space (static; positive bounds only).

    Build it with [`origami_jax.design.parameter_space`][].
    """

    names: tuple[str, ...] = eqx.field(static=True)
    lower: Float[Array, " p"]
    upper: Float[Array, " p"]
    log: tuple[bool, ...] = eqx.field(static=True)

    @property
    def size(self) -> int:
        return len(self.names)

    def _ends(self, xp=jnp):
        log = xp.asarray(self.log)
        lower, upper = xp.asarray(self.lower), xp.asarray(self.upper)
        lo = xp.where(log, xp.log(xp.where(log, lower, 1.0)), lower)
        hi = xp.where(log, xp.log(xp.where(log, upper, 1.0)), upper)
        return log, lo, hi

    def to_physical(self, z: Float[Array, " p"]) -> Float[Array, " p"]:
        """Unconstrained ``z`` → parameter values strictly inside the bounds."""
        log, lo, hi = self._ends()
        u = lo + (hi - lo) * jax.nn.sigmoid(z)
        return jnp.where(log, jnp.exp(jnp.where(log, u, 0.0)), u)

    def to_physical_jacobian(
        self, z: Float[ArrayLike, " p"], xp=jnp
    ) -> Float[Array, " p"] | Float[np.ndarray, " p"]:
        """``∂x/∂z`` of `to_physical` at `z`: the map acts parameter by parameter, so its Jacobian is
        diagonal and this returns the diagonal, shape `(p,)`. `xp=numpy` computes on the host.

        With ``σ = σ(z)`` and the (log) range ``Δ = hi − lo``: ``Δ σ (1 − σ)`` for a linearly scaled
        parameter, ``x Δ σ (1 − σ)`` for a log-scaled one.
        """
        log, lo, hi = self._ends(xp)
        sigma = 1.0 / (1.0 + xp.exp(-xp.asarray(z)))
        du_dz = (hi - lo) * sigma * (1.0 - sigma)
        u = lo + (hi - lo) * sigma
        return xp.where(log, xp.exp(xp.where(log, u, 0.0)) * du_dz, du_dz)

    def to_unconstrained(
        self, x: Float[ArrayLike, " p"], xp=jnp
    ) -> Float[Array, " p"] | Float[np.ndarray, " p"]:
        """Parameter values (inside or on the bounds) → ``z``; values on a bound are nudged inside.
        `xp=numpy` computes on the host (no device round trips for a handful of numbers)."""
        log, lo, hi = self._ends(xp)
        u = xp.where(log, xp.log(xp.where(log, x, 1.0)), x)
        s = xp.clip((u - lo) / (hi - lo), _INSIDE, 1 - _INSIDE)
        return xp.log(s) - xp.log1p(-s)

    def fraction(
        self, x: Float[ArrayLike, " p"], xp=jnp
    ) -> Float[Array, " p"] | Float[np.ndarray, " p"]:
        """Where each value sits between its bounds, 0 (lower) to 1 (upper), in the sigmoid's scale."""
        log, lo, hi = self._ends(xp)
        u = xp.where(log, xp.log(xp.where(log, x, 1.0)), x)
        return (u - lo) / (hi - lo)

    def at_bound(self, x, gradient=None) -> np.ndarray:
        """Per parameter: -1 at the lower bound, +1 at the upper bound, 0 inside (host NumPy).

        `gradient`: the cost's gradient with respect to each parameter's sigmoid variable (optional); a
        parameter within 3 % of a bound whose gradient points outwards counts as pinned there too.
        """
        s = self.fraction(np.asarray(x), xp=np)
        lower = s < _AT_BOUND
        upper = s > 1 - _AT_BOUND
        if gradient is not None:
            g = np.asarray(gradient)
            lower |= (s < _NEAR_BOUND) & (g > 0)
            upper |= (s > 1 - _NEAR_BOUND) & (g < 0)
        return np.where(lower, -1, np.where(upper, 1, 0))

    def read(self, hinge: HingeDesign, pattern=None) -> Float[Array, " p"]:
        """The current values of the free parameters in `hinge` (and, for the pattern's geometry,
        in `pattern`), shape `(p,)`."""
        return jnp.stack(
            [
                jnp.asarray(
                    _pattern_geometry(pattern, hinge.units, n)
                    if n in _PATTERN
                    else _getter(n)(hinge),
                    dtype=float,
                )
                for n in self.names
            ]
        )

    def apply_pattern(self, pattern, x: Float[ArrayLike, " p"] | Sequence[float]):
        """`pattern` with its free geometry (``"flap_length"``, …) replaced by `x` (shape `(p,)`;
        the values may be traced); `pattern` itself when no geometry is free."""
        geometry = {n: x[i] for i, n in enumerate(self.names) if n in _PATTERN}
        return pattern.with_geometry(**geometry) if geometry else pattern

    def apply(self, hinge: HingeDesign, x: Float[Array, " p"]) -> HingeDesign:
        """`hinge` with its free parameters replaced by `x` (shape `(p,)`); differentiable in `x`.
        Entries of a per-hinge field (``"hinge_width[2]"``) replace that hinge's value only; the
        pattern's geometry is left to `apply_pattern`."""
        fields: dict[str, object] = {}
        for i, name in enumerate(self.names):
            if name in _PATTERN:
                continue
            field, index = _split(name)
            if index is None:
                fields[field] = x[i]
            else:
                current = fields.get(field, _field_getter(field)(hinge))
                fields[field] = jnp.asarray(current).at[index].set(x[i])
        if not fields:
            return hinge
        getters = [_field_getter(f) for f in fields]
        return eqx.tree_at(lambda h: tuple(g(h) for g in getters), hinge, tuple(fields.values()))


def parameter_space(
    hinge: HingeDesign,
    free: Sequence[str],
    bounds: Mapping[str, tuple[float, float]] | None = None,
    *,
    scale: Mapping[str, str] | None = None,
    pattern=None,
) -> ParameterSpace:
    """Free parameters of `hinge` (and of `pattern`'s geometry) and their bounds.

    **Arguments:**
    - `hinge`: the design that supplies every fixed value and the start of the free ones.
    - `pattern`: the pattern whose geometry (``"flap_length"``, ``"flap_width"`` of an
      `origami_jax.chain.Accordion`) starts the free geometry, if any is free.
    - `free`: names of the free parameters (see `PARAMETER_NAMES`), e.g. ``["k_scale", "b_scale"]``,
      or single hinges' entries of a per-hinge field, ``"hinge_width[0]"`` … (the field must then hold
      one value per hinge).
    - `bounds`: ``{name: (lower, upper)}`` in the design's units (MICRO: µm, MPa, ng/µm³); a parameter not
      listed gets a factor of 100 either side of its value in `hinge`, within its physical range.
    - `scale`: ``{name: "log" | "linear"}``; default log when the lower bound is positive.

    **Returns:** a [`origami_jax.design.ParameterSpace`][].

    **Raises:** `ValueError` for unknown or repeated names, per-joint (non-scalar) fields, bounds that are
    not ordered or reach outside the parameter's physical range (positive; Poisson's ratios in
    (-1, 0.5)), log scale with a non-positive bound, or a start in `hinge` outside its bounds.
    """
    bounds = {} if bounds is None else {_canonical(k): v for k, v in bounds.items()}
    scale = {} if scale is None else {_canonical(k): v for k, v in scale.items()}
    names = tuple(_canonical(n) for n in free)
    if not names:
        raise ValueError("free is empty: name at least one parameter to fit.")
    if len(set(names)) != len(names):
        raise ValueError(f"free parameters must be unique, got {list(free)}.")
    for name in list(bounds) + list(scale):
        if name not in names:
            raise ValueError(
                f"bounds/scale given for {name!r}, which is not in free={list(names)}."
            )
    lower, upper, log = [], [], []
    for name in names:
        field, index = _split(name)
        if field in _PATTERN:
            whole = np.asarray(_pattern_geometry(pattern, hinge.units, field), dtype=float)
        else:
            whole = np.asarray(_field_getter(field)(hinge), dtype=float)
        if index is not None and (whole.ndim != 1 or index >= whole.shape[0]):
            raise ValueError(
                f"{name}: {field} has shape {whole.shape} in this HingeDesign; give it one value "
                f"per hinge (e.g. HingeDesign.literature({field}=jnp.full(n, value))) to free "
                "single hinges' entries."
            )
        if index is None and whole.ndim != 0:
            raise ValueError(
                f"{name} has shape {whole.shape} in this HingeDesign; free single hinges' entries "
                f"as {name}[i], or give it one scalar value."
            )
        start = float(whole if index is None else whole[index])
        default_hi = start * _DEFAULT_FACTOR
        if name == "theta_final":  # a fold angle: at most π (see HingeDesign)
            default_hi = min(default_hi, max(float(np.pi), start))  # float32 π is above π
        low, high = _DOMAIN.get(field, (0.0, np.inf))
        default_lo = max(start / _DEFAULT_FACTOR, low)
        lo, hi = bounds.get(name, (default_lo, min(default_hi, high)))
        lo, hi = float(lo), float(hi)
        if name == "theta_final" and hi > np.pi * (1 + 1e-6):
            raise ValueError(
                f"bounds of theta_final must lie within (0, π] rad (a fold angle), got ({lo}, {hi})."
            )
        if start <= 0 and name not in bounds:
            raise ValueError(f"{name} starts at {start}; give explicit bounds for it.")
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ValueError(
                f"bounds of {name} must be finite with lower < upper, got ({lo}, {hi})."
            )
        if lo < low or hi > high:
            raise ValueError(
                f"bounds of {name} must lie within its physical range ({low:g}, {high:g}), got "
                f"({lo}, {hi})."
            )
        kind = scale.get(name, "log" if lo > 0 else "linear")
        if kind not in ("log", "linear"):
            raise ValueError(f"scale of {name} must be 'log' or 'linear', got {kind!r}.")
        if kind == "log" and lo <= 0:
            raise ValueError(f"log scale needs a positive lower bound for {name}, got {lo}.")
        # Round-off of a unit conversion (200e-6 m in µm) must not put a start on a bound outside it.
        slack = 1e-9 * max(abs(lo), abs(hi))
        if not lo - slack <= start <= hi + slack:
            raise ValueError(
                f"{name} starts at {start:.6g}, outside its bounds ({lo:.6g}, {hi:.6g}); widen the "
                "bounds or start inside them."
            )
        lower.append(lo)
        upper.append(hi)
        log.append(kind == "log")
    return ParameterSpace(names, jnp.asarray(lower), jnp.asarray(upper), tuple(log))
