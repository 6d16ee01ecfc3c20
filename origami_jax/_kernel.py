"""`Kernel`: a per-design function plus what a sweep needs to label and check its results, and the
small helpers every kernel builder shares (settings checked before anything compiles, a design's
fields as settings and replaced by swept values, the result code of an invalid design).

It sits at the bottom of the package (docs/development.md, "Layers"): a pattern's sweep kernel is
part of the pattern contract (`origami_jax.system.AbstractPattern.kernel`), so the packages that
implement patterns (`chain`, `net`, `loops`) build their kernels beside them, and the sweep engine
above runs them. Its public face is `origami_jax.sweep` (`Kernel`).
"""

import dataclasses
import math
from collections.abc import Callable, Mapping
from typing import Any

import equinox as eqx
import jax
import numpy as np

# Result code for a design whose parameters are outside the model's domain (non-positive or
# non-finite lengths, strains...). The kernel then computes a harmless stand-in design and marks it.
INVALID_INPUT = -1

# The fluids a kernel's `fluid` setting or parameter names, in the order of its category index.
FLUIDS = ("air", "koh")


@dataclasses.dataclass(frozen=True)
class Kernel:
    """A function of one design, with the metadata that makes its sweep self-describing.

    `fn` maps a dict of scalar parameters to a flat dict of outputs (JAX scalars or fixed-shape
    arrays). It must be traceable (`jax.jit`, `jax.vmap`) in its non-static parameters and must not
    raise on bad values: a batch kernel calls its solvers with `throw=False` and returns their result
    code under `result_key` (0 = success, anything else = this member failed, see
    `result_messages`). Non-static parameters arrive as JAX scalars (float, int, or an `int32`
    category index for string-valued parameters); static ones as Python values.

    **Arguments:**
    - `fn`: `fn(params: dict[str, scalar]) -> dict[str, Array]`.
    - `name`: the model's name, stored in the dataset and checked on resume.
    - `settings`: JSON-able settings that change the answers (solver, tolerances, run length...);
      stored in the manifest and checked on resume.
    - `parameters`: accepted parameter names → units. `None` accepts any name.
    - `static`: parameters that fix array shapes (e.g. `n_flaps`): always treated as static.
    - `output_units`: output name → unit string.
    - `output_dims`: output name → names of its trailing axes (e.g. `("joint",)`); outputs of
      different static groups may differ in those sizes and are padded (NaN, or -1 for integers).
    - `result_key`: the output that holds the result code.
    - `result_messages`: result code → short explanation, stored as CF `flag_values` /
      `flag_meanings`.
    - `categories`: categorical parameter → the labels the kernel knows, in the order of the index it
      receives (e.g. `{"fluid": ("air", "koh")}`). A kernel that lists its `parameters` takes labels
      only for the parameters listed here (a label given for a number is refused before anything
      runs); without `parameters`, a string-valued parameter is indexed into the design space's
      sorted labels.
    - `prepare`: optional host-side step, `prepare(columns, static) -> dict[str, ndarray]`, called
      per chunk with the chunk's parameter values (NumPy, labels as strings) and the group's static
      values; each returned array has a leading axis of one entry per design and reaches `fn` as an
      extra entry of `params` (sliced per design). For inputs that cannot be traced, such as
      random geometry drawn by rejection sampling from a seed.
    - `cost`: optional estimate of each design's relative work, `cost(params) -> scalar`, traced like
      `fn` (same `params`) and evaluated vmapped over all pending designs before the first chunk.
      Pending designs are then taken in increasing cost, so each chunk holds designs of similar cost:
      a vmapped adaptive solver iterates until the slowest member of its chunk is done, so mixing a
      stiff design with easy ones makes the easy ones pay the stiff one's steps. Only the order of
      computation changes; every design's result is the same. Non-finite costs go last.
    - `cpu_chunk_size`: designs per compiled call (per device) that `sweep` picks on a CPU when its
      caller gives no `chunk_size`; `None` lets it pick (large chunks). For kernels whose designs'
      costs spread widely and cannot be estimated ahead (adaptive solvers through contact): a
      vmapped chunk runs until its slowest member is done, and on a CPU a wider batch buys little,
      so small chunks computed side by side (`sweep`'s `workers`) finish sooner.
    - `cpu_workers`: at most this many chunks computed at once on a CPU when its caller gives no
      `workers` (`None`: one per core). For a kernel whose compiled chunks cannot run side by side.
    - `program`, `inputs`: for settings a user changes between sweeps of one model (the verdict's
      tolerances, the nominal design) without compiling again. `program` is the function `fn`
      is made of, `fn(params) == program({**inputs, **params})`, and `inputs` the values every
      design takes (a dict of numbers, arrays, or pytrees of them such as a whole `HingeDesign`).
      The sweep engine runs `program` with `inputs` as data of the compiled program, not
      constants: kernels of the same `program` (by identity) whose inputs differ in value, not in
      shape, share its traces and compiled programs. Record what the inputs mean in `settings`
      too (the engine stores `settings`, not `inputs`). Swept parameters may not take their
      names. Default: no program (the engine runs `fn`), no inputs.
    - `program_key`: a value that decides `program` whole (what it is made of and everything it
      closes over, by value: a pattern, its solver's options), for a program built by this
      package. Where the command line keeps its programs on disk, `sweep` keeps the kernel's
      compiled chunks and output shapes under it (with this package's source, the libraries'
      versions and the machine), so that a later process neither traces nor compiles them; a key
      holding code from outside this package and its libraries is refused (traced as usual).
      Default `None`: traced and compiled in every process (JAX's compilation cache aside).
    - `compiler_options`: XLA compiler options for the kernel's compiled chunks (default `None`:
      XLA's). The accordion's kernel and the net fold kernel with an adaptive solver give
      `SOLVE_COMPILE` (XLA's loop emitters): a chunk of cube nets compiles in about 60 % of the
      time and runs as fast, the accordion's in 70–90 %.
    - `replay`: optional, one design's simulation kept whole, `replay(params) -> (system,
      trajectory)` (the same `params` as `fn`, `inputs` included): what `fn` reduces to its
      outputs, for a look at one design of a sweep (`origami_jax.fab_yield.YieldEstimate.
      sample_fold`). Default `None`: the kernel has none.
    - `never_raises`: `True` for a kernel that turns every bad value into its result code itself
      (as the built-in ones do), so that no `equinox.error_if` inside it can fire. `sweep` then
      traces it with equinox's checks turned into NaN: the compiled program calls nothing back into
      Python, and the compilation cache keeps it for the next process (a cube net's yield program
      compiles in about 20 s). Default `False`: a kernel that raises is reported as such.
    """

    fn: Callable[..., Any]
    name: str
    settings: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    parameters: Mapping[str, str] | None = None
    static: tuple[str, ...] = ()
    output_units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    output_dims: Mapping[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    result_key: str = "result"
    result_messages: Mapping[int, str] = dataclasses.field(default_factory=dict)
    categories: Mapping[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    prepare: Callable[..., Mapping[str, Any]] | None = None
    cost: Callable[..., Any] | None = None
    cpu_chunk_size: int | None = None
    cpu_workers: int | None = None
    never_raises: bool = False
    program: Callable[..., Any] | None = None
    inputs: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    program_key: Any = None
    compiler_options: Mapping[str, Any] | None = None
    replay: Callable[..., Any] | None = None

    def __post_init__(self):
        if self.inputs and self.program is None:
            raise ValueError(
                f"model {self.name!r}: inputs go to a program (Kernel(program=..., inputs=...), "
                "with fn(params) == program({**inputs, **params}))."
            )

    def __call__(self, params: Mapping[str, Any]) -> Any:
        return self.fn(params)

    @property
    def traced(self) -> Callable[..., Any]:
        """The function the sweep engine traces and compiles: `program` (its `inputs` as data),
        else `fn`."""
        return self.fn if self.program is None else self.program


def as_kernel(fn: Callable[..., Any] | Kernel) -> Kernel:
    """Wrap a plain function in a `Kernel` named after it (module and qualified name)."""
    if isinstance(fn, Kernel):
        return fn
    if not callable(fn):
        raise ValueError(f"sweep needs a callable or a Kernel, got {type(fn).__name__}.")
    module = getattr(fn, "__module__", None) or ""
    qualname = getattr(fn, "__qualname__", None) or type(fn).__name__
    return Kernel(fn=fn, name=f"{module}.{qualname}".lstrip("."))


def structure_key(value) -> tuple:
    """A hashable key of `value`'s shape, not its numbers: its tree structure (static fields
    included) and each leaf's shape and dtype. Two values with one structure key pass through the
    same traced program as data (a kernel's `inputs`)."""
    leaves, structure = jax.tree_util.tree_flatten(value)
    dtypes = (x.dtype if hasattr(x, "dtype") else np.asarray(x).dtype for x in leaves)
    return structure, tuple((np.shape(x), str(d)) for x, d in zip(leaves, dtypes, strict=True))


class KeptKernels:
    """The last `size` kernels or kernel programs built, by a key of their pattern and settings:
    the sweep engine traces and compiles once per program (`Kernel.traced`), so a builder that
    returns what it built before for the same settings compiles nothing again (each program holds
    its compiled calls, hundreds of MB: few are kept)."""

    def __init__(self, size: int = 4):
        self.size = size
        self._kernels: dict[Any, Any] = {}

    def get(self, key, build: Callable[[], Any]) -> Any:
        """The kernel kept under `key`, else `build()` kept under it (the oldest dropped)."""
        if key not in self._kernels:
            kernel = build()
            self._kernels[key] = kernel
            while len(self._kernels) > self.size:
                self._kernels.pop(next(iter(self._kernels)))
        return self._kernels[key]


def check_setting(
    value: Any,
    name: str,
    *,
    low: float | int,
    integer: bool = False,
    high: float | int | None = None,
) -> Any:
    """A numeric model setting, checked before anything compiles: a number (not a string or a
    boolean), finite, `> low` (or `>= low` for integers) and at most `high`."""
    kind = "an integer" if integer else "a number"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"setting {name} must be {kind}, got {value!r}.")
    if integer and not float(value).is_integer():
        raise ValueError(f"setting {name} must be an integer, got {value!r}.")
    ok = math.isfinite(value) and (value >= low if integer else value > low)
    if high is not None:
        ok = ok and value <= high
    if not ok:
        span = f">= {low}" if integer else f"> {low:g}"
        span += "" if high is None else f" and <= {high}"
        raise ValueError(f"setting {name} must be finite and {span}, got {value!r}.")
    return int(value) if integer else float(value)


def design_settings(design) -> dict[str, Any]:
    """A `HingeDesign` (or any equinox module) as JSON-able settings: every field by name, arrays
    as numbers or lists, nested modules as dictionaries, static values as text."""
    out: dict[str, Any] = {}
    for field in dataclasses.fields(design):
        value = getattr(design, field.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out[field.name] = design_settings(value)
        elif value is None or isinstance(value, bool | int | float | str):
            out[field.name] = value
        elif hasattr(value, "shape"):
            out[field.name] = np.asarray(value, dtype=float).tolist()
        else:
            out[field.name] = str(value)
    return out


def replace_fields(design, values: Mapping[str, Any]):
    """`design` (an equinox module) with the named top-level fields replaced (traced values
    welcome)."""
    names = list(values)
    return eqx.tree_at(
        lambda d: tuple(getattr(d, n) for n in names), design, tuple(values[n] for n in names)
    )
