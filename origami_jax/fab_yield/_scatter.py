"""`Scatter`: how the fabricated nets differ from the drawn one, and the samples drawn from it.

A `Spread` says how one parameter scatters (distribution, width, relative or absolute, per crease
or one draw for the whole net); a `Scatter` holds one `Spread` per parameter. Samples are drawn on
the host with NumPy from a seed, one generator per parameter (`numpy.random.default_rng([seed, i])`
with `i` the parameter's place in `PARAMETERS`), as *standard* draws mapped onto each parameter's
nominal value: changing one parameter's width or nominal value leaves every other parameter's draws
as they were (common random numbers), so two yield estimates that differ in one setting are
compared on the same fabricated nets.
"""

import dataclasses
import math
import os
import tomllib
from collections.abc import Mapping
from typing import Any

import numpy as np

DISTRIBUTIONS = ("normal", "lognormal", "uniform")

# Parameter -> (unit of an absolute width, may vary per crease, may be one draw for the whole net).
# Order matters: a parameter's generator is seeded with its index here.
PARAMETERS: dict[str, tuple[str, bool, bool]] = {
    "misfit_strain": ("1", True, True),
    "t_hinge": ("um", True, True),
    "hinge_width": ("um", True, True),
    "t_structural": ("um", False, True),
    "drag_coefficient": ("1", False, True),
    "release": ("us", True, False),
}


@dataclasses.dataclass(frozen=True)
class Spread:
    """How one parameter scatters about its nominal value ``x₀`` (standard draws ``z ~ N(0, 1)`` or
    ``u ~ U[0, 1)``, width ``w``):

    | distribution | relative (`relative=True`) | absolute (in the parameter's unit) |
    |---|---|---|
    | `"normal"` | ``x₀ (1 + w z)`` | ``x₀ + w z`` |
    | `"lognormal"` | ``x₀ exp(w z)`` (median ``x₀``) | refused |
    | `"uniform"` | ``x₀ (1 + w (2u − 1))`` | ``x₀ + w (2u − 1)`` |

    so `width` is the standard deviation (normal), the standard deviation of ``ln x`` (lognormal) or
    the half-width (uniform).

    **Fields:**
    - `distribution`: `"normal"` (default), `"lognormal"` or `"uniform"`.
    - `width`: ``w >= 0``; 0 switches the parameter's scatter off.
    - `relative`: the width as a fraction of the nominal value, or in the parameter's own unit
      (`None`: the parameter's usual choice, relative except for `release`, µs).
    - `per`: `"crease"` (an independent draw for every crease) or `"net"` (one draw per sample,
      shared by every crease: wafer-scale variation, the same on every hinge of one die); `None`:
      the parameter's usual choice (`"crease"` where it can vary per crease).

    **Raises:** `ValueError` for an unknown distribution or `per`, a negative or non-finite width,
    or an absolute lognormal.
    """

    distribution: str = "normal"
    width: float = 0.0
    relative: bool | None = None
    per: str | None = None

    def __post_init__(self):
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(
                f"distribution must be one of {DISTRIBUTIONS}, got {self.distribution!r}."
            )
        width = self.width
        if isinstance(width, bool) or not isinstance(width, int | float):
            raise ValueError(f"width must be a number, got {width!r}.")
        if not (math.isfinite(width) and width >= 0):
            raise ValueError(
                f"width must be finite and >= 0 (0 switches the scatter off), got {width!r}."
            )
        object.__setattr__(self, "width", float(width))
        if self.relative is not None and not isinstance(self.relative, bool):
            raise ValueError(f"relative must be true or false, got {self.relative!r}.")
        if self.per not in (None, "crease", "net"):
            raise ValueError(f"per must be 'crease' or 'net', got {self.per!r}.")
        if self.distribution == "lognormal" and self.relative is False:
            raise ValueError(
                "a lognormal spread is relative (x0 exp(w z)); use relative = true or a normal or "
                "uniform spread."
            )

    def transform(self, nominal: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The values from the nominal ones and the standard draws `z` (normal draws; for a uniform
        spread `z` is mapped to ``u = Φ(z)``, so every distribution uses the same normal draws)."""
        w = self.width
        if self.distribution == "normal":
            step = w * z
        elif self.distribution == "uniform":
            from scipy.special import ndtr

            step = w * (2 * ndtr(z) - 1)
        else:
            return nominal * np.exp(w * z)
        return nominal * (1 + step) if self.relative else nominal + step

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def _resolved(name: str, spread: Spread) -> Spread:
    unit, per_crease, per_net = PARAMETERS[name]
    per = spread.per or ("crease" if per_crease else "net")
    relative = spread.relative if spread.relative is not None else name != "release"
    if per == "crease" and not per_crease:
        raise ValueError(
            f"scatter of {name}: per = 'crease' is not possible, the model has one {name} for the "
            "whole net; use per = 'net'."
        )
    if per == "net" and not per_net:
        raise ValueError(
            f"scatter of {name}: per = 'net' would shift every crease's release together, which "
            "only moves the time origin; use per = 'crease'."
        )
    if spread.distribution == "lognormal" and not relative:
        raise ValueError(f"scatter of {name}: a lognormal spread must be relative.")
    return dataclasses.replace(spread, per=per, relative=relative)


# Defaults: see `Scatter`'s docstring for the sources.
_DEFAULTS = {
    "misfit_strain": Spread("normal", 0.05),
    "t_hinge": Spread("normal", 0.025, per="net"),
    "hinge_width": Spread("normal", 0.5, relative=False),
    "t_structural": Spread("normal", 0.025),
    "drag_coefficient": Spread("normal", 0.0),
    "release": Spread("uniform", 0.0),
}


def _default(name: str) -> Spread:
    return _DEFAULTS[name]


@dataclasses.dataclass(frozen=True)
class Scatter:
    """Fabrication scatter of a net's hinges: one `Spread` per parameter (a dict with the same keys
    is accepted). `Scatter.none()` has every width 0.

    **Parameters** (units of absolute widths in brackets) and their defaults:

    - `misfit_strain` (1): the hinge film's misfit strain ``ε = σ / E₂'``, so a relative spread of
      the film *stress* is the same relative spread of ``ε``. Default: normal, 5 % (1σ), per crease.
    - `t_hinge` (µm): the stressed film's thickness. Default: normal, 2.5 %, one draw per net.
    - `hinge_width` (µm): Default: normal, 0.5 µm absolute, per crease.
    - `t_structural` (µm): the membrane's thickness (one per net: the model has one). Default:
      normal, 2.5 %.
    - `drag_coefficient` (1): ``C_D`` (one per net). Default: off.
    - `release` (µs): each crease's release time, added to the nominal release times; when a draw
      would start a crease before ``t = 0`` the sample's times are shifted together so the earliest
      is 0 (only the delays between creases matter). Default: off (see below).

    **Where the defaults come from.** Deposited films are not uniform across a wafer: foundry
    process catalogues list within-wafer non-uniformities of a few per cent (MEMS Exchange process
    catalogue: LPCVD stoichiometric silicon nitride 2.5 %, PECVD silicon nitride ±7 %), the
    thickness defaults. Thickness varies over millimetres, so it is drawn once per net (one die);
    the film stress default (5 %, per crease) is an assumed figure of the same order, per crease to
    include local variation (grain size, edges); measure yours from wafer-curvature maps (Stoney's
    equation) or test hinges. The hinge width's 0.5 µm is an assumed lithography edge tolerance.
    Release is off by default because its scale is not the fold's: at the paper's KOH etch rate
    (1.5 µm/min, "Ramp Input") a micrometre of difference in undercut delays a hinge by about 40 s,
    while a net folds in about a millisecond, so real release scatter makes the creases fold one
    after another in a random order. Model that with a uniform `release` spread, absolute, whose
    width is several fold times (the folding only depends on the order once the delays exceed the
    time a fold takes to settle).

    **Raises:** `ValueError` for an entry that is not a `Spread` (or a dict of one) or that the
    parameter cannot take (e.g. `t_structural` per crease), and for unknown parameters.
    """

    misfit_strain: Spread = dataclasses.field(default_factory=lambda: _default("misfit_strain"))
    t_hinge: Spread = dataclasses.field(default_factory=lambda: _default("t_hinge"))
    hinge_width: Spread = dataclasses.field(default_factory=lambda: _default("hinge_width"))
    t_structural: Spread = dataclasses.field(default_factory=lambda: _default("t_structural"))
    drag_coefficient: Spread = dataclasses.field(
        default_factory=lambda: _default("drag_coefficient")
    )
    release: Spread = dataclasses.field(default_factory=lambda: _default("release"))

    def __post_init__(self):
        for name in PARAMETERS:
            value = getattr(self, name)
            if isinstance(value, Mapping):
                value = _spread_from_mapping(name, value)
            if not isinstance(value, Spread):
                raise ValueError(
                    f"scatter of {name} must be a Spread (or a table of one), got "
                    f"{type(value).__name__}."
                )
            object.__setattr__(self, name, _resolved(name, value))

    @classmethod
    def none(cls) -> "Scatter":
        """No scatter at all: every sample is the nominal net."""
        return cls(**{name: Spread("normal", 0.0) for name in PARAMETERS})

    @classmethod
    def from_mapping(cls, config: Mapping[str, Any], *, defaults: bool = True) -> "Scatter":
        """A scatter from a mapping `{parameter: {distribution, width, relative, per}}` (a TOML
        file's tables); parameters not named keep the defaults (or no scatter with
        `defaults=False`). A top-level `defaults = false` in the mapping does the same.

        **Raises:** `ValueError` for unknown parameters or fields, with the known ones.
        """
        if not isinstance(config, Mapping):
            raise ValueError(f"a scatter config must be a table, got {type(config).__name__}.")
        config = dict(config)
        flag = config.pop("defaults", defaults)
        if not isinstance(flag, bool):
            raise ValueError(f"defaults must be true or false, got {flag!r}.")
        unknown = sorted(set(config) - set(PARAMETERS))
        if unknown:
            raise ValueError(
                f"unknown scatter parameter(s) {unknown}; the known ones are {list(PARAMETERS)}."
            )
        base = cls() if flag else cls.none()
        return dataclasses.replace(
            base, **{name: _spread_from_mapping(name, value) for name, value in config.items()}
        )

    def scaled(self, factor: float) -> "Scatter":
        """The same scatter with every width multiplied by `factor` (> 0): the distributions, the
        relative/absolute choice and `per` unchanged, and the same standard draws behind the
        samples, so `yield_estimate` at several factors compares the same fabricated nets made
        more or less carefully.

        **Raises:** `ValueError` for a factor that is not a positive finite number."""
        if isinstance(factor, bool) or not isinstance(factor, int | float | np.floating):
            raise ValueError(f"a scatter's scale factor must be a number, got {factor!r}.")
        if not (math.isfinite(factor) and factor > 0):
            raise ValueError(f"a scatter's scale factor must be positive and finite, got {factor}.")
        return dataclasses.replace(
            self,
            **{n: dataclasses.replace(s, width=s.width * float(factor)) for n, s in self.items()},
        )

    def active(self) -> dict[str, Spread]:
        """The parameters that scatter (width > 0)."""
        return {n: s for n, s in self.items() if s.width > 0}

    def items(self):
        return ((name, getattr(self, name)) for name in PARAMETERS)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        return {name: spread.to_dict() for name, spread in self.items()}


def _spread_from_mapping(name: str, value: Any) -> Spread:
    if isinstance(value, Spread):
        return value
    if not isinstance(value, Mapping):
        raise ValueError(
            f"scatter of {name} must be a table with distribution, width, relative, per; got "
            f"{value!r}."
        )
    fields = [f.name for f in dataclasses.fields(Spread)]
    unknown = sorted(set(value) - set(fields))
    if unknown:
        raise ValueError(f"scatter of {name}: unknown field(s) {unknown}; the fields are {fields}.")
    # The TOML's types, checked here with the field named (before the dataclass sees them).
    kinds = {"distribution": (str,), "width": (int, float), "relative": (bool,), "per": (str,)}
    for key, item in value.items():
        if isinstance(item, bool) and key == "width" or not isinstance(item, kinds[key]):
            raise ValueError(
                f"scatter of {name}: {key} must be "
                + {"distribution": "a name", "width": "a number", "relative": "true or false"}.get(
                    key, "'crease' or 'net'"
                )
                + f", got {item!r}."
            )
    value = dict(value)
    if "width" in value:
        value["width"] = float(value["width"])  # TOML integers are widths too
    try:
        return Spread(**value)
    except ValueError as error:
        raise ValueError(f"scatter of {name}: {error}") from None


def load_scatter(path: str | os.PathLike) -> Scatter:
    """Read a `Scatter` from a TOML file: one table per parameter, e.g.

    ```toml
    [misfit_strain]
    distribution = "normal"
    width = 0.05          # 5 % (1 sigma) of the nominal film stress
    per = "crease"

    [release]
    distribution = "uniform"
    width = 200.0         # µs, absolute
    ```

    Parameters not named keep their defaults; `defaults = false` at the top switches them off.

    **Raises:** `ValueError` for a file that is not TOML or a bad config (one line saying what);
    `OSError` if it cannot be read.
    """
    try:
        with open(path, "rb") as handle:
            config = tomllib.load(handle)
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{path} is not valid TOML: {error}") from None
    return Scatter.from_mapping(config)


def standard_draws(seed: int, n_samples: int, n_creases: int) -> dict[str, np.ndarray]:
    """The standard normal draws behind every sample: `(n_samples, n_creases)` per parameter (a
    per-net spread uses column 0), from the generator `default_rng([seed, i])` of parameter `i`."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}.")
    return {
        name: np.random.default_rng([int(seed), i]).standard_normal((n_samples, n_creases))
        for i, name in enumerate(PARAMETERS)
    }


def noise_seeds(seed: int, n_samples: int) -> np.ndarray:
    """Each sample's noise seed for an agitated pattern, `(n_samples,)` whole numbers in
    ``[0, 2³¹)`` as floats (a sweep column): from the generator `default_rng([seed, len(PARAMETERS)])`,
    the one after the parameters', so the first `n` of a longer draw are those of `n`."""
    generator = np.random.default_rng([int(seed), len(PARAMETERS)])
    return generator.integers(0, 2**31, size=n_samples).astype(float)


def sample_values(
    scatter: Scatter,
    nominal: Mapping[str, np.ndarray],
    draws: Mapping[str, np.ndarray],
) -> dict[str, np.ndarray]:
    """Each parameter's values per sample, `(n_samples, n_creases)`: `nominal[name]` (shape
    `(n_creases,)`) scattered by `scatter` with the standard `draws` (`standard_draws`). Release
    times are shifted per sample so that none is negative."""
    values = {}
    for name, spread in scatter.items():
        z = draws[name]
        if spread.per == "net":
            z = np.repeat(z[:, :1], z.shape[1], axis=1)
        x0 = np.broadcast_to(np.asarray(nominal[name], dtype=float), z.shape[1:])
        x = spread.transform(x0[None, :], z) if spread.width > 0 else np.tile(x0, (len(z), 1))
        if name == "release":
            x = x - np.minimum(0.0, x.min(axis=1, keepdims=True))
        values[name] = x
    return values
