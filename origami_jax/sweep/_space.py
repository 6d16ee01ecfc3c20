"""Design spaces: which designs a sweep visits.

A design space is host-side configuration, not something JAX traces, so the spaces are frozen
dataclasses holding NumPy arrays rather than `equinox.Module`s. Every space answers the same
questions:

- `names`: the parameter names, in order;
- `size`: the number of designs;
- `columns()`: one 1-D NumPy array per parameter, all of length `size` (design `i` is row `i`);
- `units`: unit string per parameter (`""` where dimensionless or unknown);
- `static`: names whose values fix array shapes (e.g. a flap count). The engine groups designs by
  their static values and compiles one call per group; static values reach the kernel as Python
  scalars, the others as batched JAX scalars;
- `to_config()`: a JSON-able description, stored next to the results so `resume=True` can check it
  continues the same sweep.

Categorical parameters (e.g. `fluid = ["air", "koh"]`) are columns of strings. Unless static, they
reach the kernel as an `int32` index into `categories(name)`; the dataset keeps the labels.
"""

import abc
import dataclasses
import hashlib
import json
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np

Scale = Literal["linear", "log"]


def _as_column(name: str, values: Any) -> np.ndarray:
    array = np.asarray(values)
    if array.ndim != 1 or array.size == 0:
        raise ValueError(
            f"parameter {name!r}: expected a non-empty 1-D list of values, got shape {array.shape}."
        )
    if array.dtype.kind in "US":
        return array.astype(str)
    if array.dtype.kind == "b":
        return array.astype(np.int64)
    if array.dtype.kind in "iu":
        return array.astype(np.int64)
    if array.dtype.kind == "f":
        array = array.astype(np.float64)
        if not np.all(np.isfinite(array)):
            raise ValueError(f"parameter {name!r}: values must be finite, got {array}.")
        return array
    raise ValueError(
        f"parameter {name!r}: values must be numbers or strings, got dtype {array.dtype}."
    )


# A parameter name: an identifier, optionally indexed (`misfit_strain[3]`: crease 3's value).
_PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\[[0-9]+\])?")


def _check_names(names: Sequence[str], static: Sequence[str], units: Mapping[str, str]) -> None:
    if len(set(names)) != len(names):
        raise ValueError(f"parameter names must be unique, got {list(names)}.")
    for name in names:
        if not isinstance(name, str) or not _PARAMETER_NAME.fullmatch(name):
            raise ValueError(
                f"parameter name {name!r} must be a Python identifier, or one with an entry "
                "index such as 'misfit_strain[3]' (one crease's value)."
            )
        if name in ("design", "result"):
            raise ValueError(f"parameter name {name!r} is reserved by the sweep dataset.")
    for name in list(static) + list(units):
        if name not in names:
            raise ValueError(f"{name!r} is not one of the parameters {list(names)}.")


def _digest(columns: Mapping[str, np.ndarray]) -> str:
    sha = hashlib.sha256()
    for name in sorted(columns):
        column = columns[name]
        sha.update(name.encode())
        if column.dtype.kind == "U":
            sha.update("\x00".join(column.tolist()).encode())
        else:
            sha.update(np.ascontiguousarray(column).tobytes())
    return sha.hexdigest()


def _jsonable(values: np.ndarray) -> list:
    return values.tolist()


class AbstractDesignSpace(abc.ABC):
    """What `Grid`, `Samples`, `Table` and `Product` share (see the module docstring): a space is
    its `size`, its `columns` and its description (`to_config`)."""

    names: tuple[str, ...]
    units: Mapping[str, str]
    static: tuple[str, ...]

    @property
    @abc.abstractmethod
    def size(self) -> int:
        """The number of designs."""

    @abc.abstractmethod
    def columns(self) -> dict[str, np.ndarray]:
        """Every parameter's value per design, `(size,)` each."""

    @abc.abstractmethod
    def _describe(self) -> dict[str, Any]:
        """The JSON-able description of the space (`to_config` adds its size and digest)."""

    def to_config(self) -> dict[str, Any]:
        """JSON-able description plus a SHA-256 of every generated value (so a change of NumPy's
        generator or of the code that expands the space is caught on resume)."""
        return {**self._describe(), "size": self.size, "sha256": _digest(self.columns())}

    def categories(self, name: str) -> tuple[str, ...]:
        """The sorted distinct labels of a categorical (string) parameter."""
        column = self.columns()[name]
        if column.dtype.kind != "U":
            raise ValueError(f"parameter {name!r} is not categorical.")
        return tuple(sorted(set(column.tolist())))

    def unit(self, name: str) -> str:
        return self.units.get(name, "")

    def __len__(self) -> int:
        return self.size

    def __mul__(self, other: "AbstractDesignSpace") -> "Product":
        return Product((self, other))


@dataclasses.dataclass(frozen=True, eq=False)
class Grid(AbstractDesignSpace):
    """Full-factorial grid: every combination of the given values.

    Design order is C order (the last parameter varies fastest), so a grid over
    `{"w": [1, 2], "e": [10, 20, 30]}` gives `(1,10), (1,20), (1,30), (2,10), ...`.

    **Arguments:**
    - `axes`: parameter name → 1-D values (numbers or strings). Use `linspace`/`logspace` helpers or
      NumPy to build ranges.
    - `units`: parameter name → unit string, stored as the coordinate's `units` attribute.
    - `static`: names of shape-fixing parameters (see the module docstring).
    """

    axes: Mapping[str, Any]
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    static: Sequence[str] = ()

    def __post_init__(self):
        axes = {name: _as_column(name, values) for name, values in self.axes.items()}
        if not axes:
            raise ValueError("a Grid needs at least one parameter.")
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "static", tuple(self.static))
        object.__setattr__(self, "units", dict(self.units))
        _check_names(self.names, self.static, self.units)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.axes)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.axes.values())

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def columns(self) -> dict[str, np.ndarray]:
        mesh = np.meshgrid(*self.axes.values(), indexing="ij")
        return {name: m.reshape(-1) for name, m in zip(self.axes, mesh, strict=True)}

    def _describe(self) -> dict[str, Any]:
        return {
            "kind": "grid",
            "axes": {n: _jsonable(v) for n, v in self.axes.items()},
            "units": dict(self.units),
            "static": list(self.static),
        }


@dataclasses.dataclass(frozen=True)
class Range:
    """A continuous parameter range for `Samples`: `[low, high]` on a linear or log scale."""

    low: float | int
    high: float | int
    scale: str = "linear"  # Scale, checked with a ValueError

    def __post_init__(self):
        object.__setattr__(self, "low", float(self.low))
        object.__setattr__(self, "high", float(self.high))
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise ValueError(f"Range needs finite low < high, got [{self.low}, {self.high}].")
        if self.scale not in ("linear", "log"):
            raise ValueError(f"Range scale must be 'linear' or 'log', got {self.scale!r}.")
        if self.scale == "log" and self.low <= 0:
            raise ValueError(f"a log-scale Range needs low > 0, got {self.low}.")

    def transform(self, u: np.ndarray) -> np.ndarray:
        """Map `u` in [0, 1) to the range."""
        if self.scale == "log":
            return np.exp(np.log(self.low) + u * (np.log(self.high) - np.log(self.low)))
        return self.low + u * (self.high - self.low)


@dataclasses.dataclass(frozen=True, eq=False)
class Samples(AbstractDesignSpace):
    """Seeded random designs: Latin hypercube (`method="lhs"`, default) or independent uniform.

    Latin hypercube: for each parameter the unit interval is cut into `n` equal strata and every
    stratum holds exactly one design (a random point inside it); strata are paired across
    parameters by independent random permutations. The stratification holds in the unit variable
    `u`, i.e. in `log(value)` for log-scale ranges.

    **Arguments:**
    - `ranges`: parameter name → `Range` (or a `(low, high)` tuple, linear scale).
    - `n`: number of designs.
    - `seed`: seed of NumPy's PCG64 generator; the same seed gives the same designs.
    - `method`: `"lhs"` or `"uniform"`.
    - `units`, `static`: as for `Grid` (a static sampled parameter is unusual but allowed).
    """

    ranges: Mapping[str, Any]
    n: int
    seed: int = 0
    method: str = "lhs"  # "lhs" or "uniform", checked with a ValueError
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    static: Sequence[str] = ()

    def __post_init__(self):
        ranges = {name: r if isinstance(r, Range) else Range(*r) for name, r in self.ranges.items()}
        if not ranges:
            raise ValueError("Samples needs at least one parameter range.")
        if int(self.n) < 1:
            raise ValueError(f"Samples needs n >= 1, got {self.n}.")
        if self.method not in ("lhs", "uniform"):
            raise ValueError(f"Samples method must be 'lhs' or 'uniform', got {self.method!r}.")
        object.__setattr__(self, "ranges", ranges)
        object.__setattr__(self, "static", tuple(self.static))
        object.__setattr__(self, "units", dict(self.units))
        _check_names(self.names, self.static, self.units)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.ranges)

    @property
    def size(self) -> int:
        return int(self.n)

    def unit_samples(self) -> np.ndarray:
        """The samples in the unit cube, shape `(n, n_parameters)`."""
        rng = np.random.default_rng(self.seed)
        d = len(self.ranges)
        if self.method == "uniform":
            return rng.random((self.n, d))
        jitter = rng.random((self.n, d))
        strata = np.stack([rng.permutation(self.n) for _ in range(d)], axis=1)
        return (strata + jitter) / self.n

    def columns(self) -> dict[str, np.ndarray]:
        u = self.unit_samples()
        return {
            name: r.transform(u[:, j]).astype(np.float64)
            for j, (name, r) in enumerate(self.ranges.items())
        }

    def _describe(self) -> dict[str, Any]:
        return {
            "kind": "samples",
            "method": self.method,
            "n": int(self.n),
            "seed": int(self.seed),
            "ranges": {n: [r.low, r.high, r.scale] for n, r in self.ranges.items()},
            "units": dict(self.units),
            "static": list(self.static),
        }


@dataclasses.dataclass(frozen=True, eq=False)
class Table(AbstractDesignSpace):
    """An explicit list of designs: parameter name → one value per design (all the same length)."""

    designs: Mapping[str, Any]
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    static: Sequence[str] = ()

    def __post_init__(self):
        designs = {name: _as_column(name, values) for name, values in self.designs.items()}
        if not designs:
            raise ValueError("a Table needs at least one parameter.")
        lengths = {name: len(v) for name, v in designs.items()}
        if len(set(lengths.values())) != 1:
            raise ValueError(f"every Table column needs the same length, got {lengths}.")
        object.__setattr__(self, "designs", designs)
        object.__setattr__(self, "static", tuple(self.static))
        object.__setattr__(self, "units", dict(self.units))
        _check_names(self.names, self.static, self.units)

    @classmethod
    def from_records(
        cls,
        records: Sequence[Mapping[str, Any]],
        *,
        units: Mapping[str, str] | None = None,
        static: Sequence[str] = (),
    ) -> "Table":
        """Build a table from a list of `{name: value}` designs (all with the same names)."""
        if not records:
            raise ValueError("a Table needs at least one design.")
        names = list(records[0])
        for i, record in enumerate(records):
            if list(record) != names and set(record) != set(names):
                raise ValueError(f"design {i} has parameters {list(record)}, expected {names}.")
        return cls(
            {n: [r[n] for r in records] for n in names},
            units=dict(units or {}),
            static=tuple(static),
        )

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.designs)

    @property
    def size(self) -> int:
        return len(next(iter(self.designs.values())))

    def columns(self) -> dict[str, np.ndarray]:
        return dict(self.designs)

    def _describe(self) -> dict[str, Any]:
        return {
            "kind": "table",
            "units": dict(self.units),
            "static": list(self.static),
        }


@dataclasses.dataclass(frozen=True, eq=False)
class Product(AbstractDesignSpace):
    """Outer product of design spaces (`a * b`): every design of `a` with every design of `b`,
    the last space varying fastest. E.g. `Grid({"n_flaps": [2, 3]}, static=("n_flaps",)) *
    Samples(...)`."""

    spaces: tuple[AbstractDesignSpace, ...]

    def __post_init__(self):
        flat: list[AbstractDesignSpace] = []
        for space in self.spaces:
            flat.extend(space.spaces if isinstance(space, Product) else [space])
        object.__setattr__(self, "spaces", tuple(flat))
        _check_names(self.names, self.static, self.units)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for s in self.spaces for n in s.names)

    @property
    def units(self) -> dict[str, str]:  # type: ignore[override]
        return {k: v for s in self.spaces for k, v in s.units.items()}

    @property
    def static(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(n for s in self.spaces for n in s.static)

    @property
    def size(self) -> int:
        return math.prod(s.size for s in self.spaces)

    def columns(self) -> dict[str, np.ndarray]:
        sizes = [s.size for s in self.spaces]
        out: dict[str, np.ndarray] = {}
        for k, space in enumerate(self.spaces):
            outer = math.prod(sizes[:k])
            inner = math.prod(sizes[k + 1 :])
            for name, column in space.columns().items():
                out[name] = np.tile(np.repeat(column, inner), outer)
        return out

    def _describe(self) -> dict[str, Any]:
        return {"kind": "product", "spaces": [s.to_config() for s in self.spaces]}


def config_equal(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    """Compare two JSON-able configs after a JSON round trip (tuples vs lists, key order)."""
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
