"""`sweep`: one compiled, vmapped, device-sharded call per chunk of designs, stored as it goes.

How a sweep runs:

1. Plan (`_plan`): the design space is expanded on the host into one column per parameter. Designs
   are grouped by their *static* parameters (shape-fixing ones such as a flap count); each group is
   one compiled function, so a sweep compiles once per distinct static value, never once per chunk.
2. Compile (`_Compiler`): the kernel is `jax.vmap`-ed over designs and `jax.jit`-ed with its
   inputs and outputs sharded along the batch axis (`NamedSharding` over a 1-D `Mesh` of the
   devices, `jax.local_devices()` unless given); XLA's SPMD partitioner splits the batch, each device
   computing its slice. Trade-off, measured on this code base: `jax.shard_map` would let each device
   leave an adaptive while-loop (ODE solver, Newton) as soon as *its* members are done, whereas
   under SPMD partitioning the vmapped loop's condition is reduced over the whole batch, so every
   device iterates until the slowest member of the chunk finishes (the same holds within one device
   for any vmapped batch). But lineax's linear solves inside diffrax's implicit solvers fail to trace
   under `shard_map` in jax 0.10.2 ("pytree does not match out_structure"), so the sharded `jit` is
   used for every kernel.
3. Run chunks (`_schedule`, `_run_chunks`): pending designs of a group are taken in the order of the
   kernel's `cost` estimate when it has one (similar designs share a chunk, so fewer members wait on
   a slow one), else in design order. Every chunk has the same size (a multiple of the device
   count), the last one padded by repeating its last design; padded members are discarded. Up to
   `workers` chunks are computed at once, each compiled call from its own thread (XLA releases
   the GIL while it computes): on a CPU, where a vmapped adaptive solver runs its chunk in
   lockstep until the slowest member is done, several small chunks side by side keep every core
   busy without making members wait on each other (a kernel can ask for small CPU chunks, see
   `Kernel.cpu_chunk_size`). Each chunk's results are copied to the host as soon as it finishes,
   labelled and written to `out/chunks/` (see `_store.py`), small chunks together (`store_every`:
   one file holds at least that many designs, or what finished within 30 s); the order of
   finishing changes nothing in the results, which are the same as computed one chunk after
   another.
4. Gather (`_gather`): at the end the chunks are gathered into one `xarray.Dataset` (written to
   `out/sweep.nc`).

**Multi-host.** Call `jax.distributed.initialize()` in every process before `sweep` (on SLURM or
TPU pods it finds its peers from the environment; elsewhere pass `coordinator_address`,
`num_processes` and `process_id`), give every process the same `out` folder on a shared file
system, and run the same script everywhere. Process 0 opens (and locks) the folder and checks the
stored chunks; every process receives its list of stored designs, takes every
`jax.process_count()`-th chunk of the remaining work and runs it on its own `jax.local_devices()`;
at the end process 0 gathers `sweep.nc` (checking that every design is there exactly once) and the
others read it back. `resume=True` works the same way. The test suite runs this with two processes
on one machine (a localhost coordinator, CPU devices), including a process killed midway and the
sweep resumed.
"""

import concurrent.futures
import dataclasses
import json
import math
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import xarray as xr
from jax.sharding import Mesh, NamedSharding
from jax.sharding import PartitionSpec as P

from .._exported import compiled_with, kept_compiled, remembered
from .._kernel import Kernel, as_kernel, structure_key
from .._runtime_errors import checks_as_nan
from ._space import AbstractDesignSpace
from ._store import RESULT, Store, SweepBusyError, gather, logger

AXIS = "design"
"""The dimension of a sweep's dataset along which its designs lie (coordinate: their indices)."""
# Default chunk sizing (see `_default_chunk_size`).
MIN_CHUNKS = 8
PER_DEVICE_CAP = {"cpu": 256}
PER_DEVICE_CAP_ACCELERATOR = 8192
MEMORY_FRACTION = 0.5
# Storing small chunks (see `sweep`'s `store_every`): at least this many designs per file when the
# chunk size is the sweep's choice, and finished designs held at most this long before a write.
STORE_MIN_DESIGNS = 64
STORE_EVERY_SECONDS = 30.0


def _canonical(column: np.ndarray) -> np.ndarray:
    kind = "float" if column.dtype.kind == "f" else "int"
    dtype = jax.dtypes.canonicalize_dtype(np.float64 if kind == "float" else np.int64)
    return np.asarray(column, dtype=dtype)


def _python_scalar(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value


def _default_chunk_size(
    n_designs: int, n_devices: int, platform: str, cpu_chunk_size: int | None = None
) -> int:
    """Designs per chunk when the caller gives none.

    At least `MIN_CHUNKS` chunks (so an interruption loses at most ~1/8 of the work and the progress
    bar moves), at most `PER_DEVICE_CAP` designs per device (256 on CPU, where a larger vmapped batch
    is no faster; 8192 on accelerators), always a multiple of the device count; on a CPU, the
    kernel's `cpu_chunk_size` per device when it asks for one. The memory check in `_fit_memory`
    may then shrink it.
    """
    if platform == "cpu" and cpu_chunk_size is not None:
        return max(1, min(int(cpu_chunk_size), math.ceil(n_designs / n_devices))) * n_devices
    cap = PER_DEVICE_CAP.get(platform, PER_DEVICE_CAP_ACCELERATOR)
    per_device = max(1, min(cap, math.ceil(n_designs / (n_devices * MIN_CHUNKS))))
    return per_device * n_devices


def _check_count(value: Any, name: str, meaning: str) -> None:
    """Refuse an optional count that is not a whole number >= 1 (`None` passes)."""
    if value is not None and (
        isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1
    ):
        raise ValueError(f"{name} must be a whole number >= 1 ({meaning}), got {value!r}.")


def _default_workers(devices: Sequence[Any]) -> int:
    """Chunks computed at once when the caller gives none: one per usable CPU core on a single
    CPU device (XLA computes a small vmapped solve on one core), else 1 (an accelerator, or CPU
    devices already splitting each chunk)."""
    if len(devices) != 1 or devices[0].platform != "cpu":
        return 1
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


# `jax.Device` is re-exported as a plain assignment, which pyright does not take for a class.
def _device_memory(device: jax.Device) -> int | None:  # pyright: ignore[reportInvalidTypeForm]
    try:
        stats = device.memory_stats()
    except Exception:  # CPU devices may not report; treated as unknown
        stats = None
    if stats and stats.get("bytes_limit"):
        return int(stats["bytes_limit"])
    if device.platform == "cpu":
        try:
            return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            return None
    return None


def _compiled_bytes(compiled: Any) -> int | None:
    try:
        stats = compiled.memory_analysis()
        return int(
            stats.temp_size_in_bytes + stats.argument_size_in_bytes + stats.output_size_in_bytes
        )
    except Exception:  # best effort: some backends give no analysis
        return None


class TraceCache:
    """Output shapes and compiled calls of the most recent kernels, so that sweeps of the *same*
    kernel program (e.g. yield estimates of one net at several scatter widths, or at other verdict
    tolerances, which reach the program as its `Kernel.inputs`) trace and compile it once: tracing
    a contact simulation costs tens of seconds. Keyed by the kernel's program (`Kernel.traced`: its
    `program`, else its `fn`, by identity: it is held here, so its id cannot be reused; and whether
    it raises) and the group's static values, input shapes and sharding; the least recently used
    programs are dropped beyond `size`.

    `sweep` keeps them in `TRACES`, the process's one cache, unless given another (`traces=`, e.g.
    a fresh `TraceCache()` that goes with the sweep); `TRACES.clear()` lets the kept programs go.
    """

    def __init__(self, size: int = 4):
        self.size = size
        self.entries: dict[tuple[int, bool], tuple[Callable, dict]] = {}

    def __len__(self) -> int:
        """The number of kernel programs kept."""
        return len(self.entries)

    def clear(self) -> None:
        """Drop every kept program with its traces and compiled calls."""
        self.entries.clear()

    @staticmethod
    def _program(kernel: Kernel) -> tuple[int, bool]:
        # `never_raises` changes the trace (equinox's checks as NaN), so it is part of the program.
        return id(kernel.traced), bool(kernel.never_raises)

    def get(self, kernel: Kernel, key: tuple) -> Any:
        program = self._program(kernel)
        entry = self.entries.get(program)
        if entry is None or entry[0] is not kernel.traced:
            return None
        self.entries[program] = self.entries.pop(program)  # most recently used last
        return entry[1].get(key)

    def put(self, kernel: Kernel, key: tuple, value: Any) -> None:
        program = self._program(kernel)
        entry = self.entries.get(program)
        if entry is None or entry[0] is not kernel.traced:
            entry = (kernel.traced, {})
            self.entries[program] = entry
            while len(self.entries) > self.size:
                self.entries.pop(next(iter(self.entries)))
        entry[1][key] = value


TRACES = TraceCache()
"""The traces and compiled calls `sweep` keeps between calls in this process (a `TraceCache`)."""


def _statics_key(static_values: Mapping[str, Any]) -> tuple:
    """A group's static values as a hashable key."""
    return tuple(sorted((k, repr(v)) for k, v in static_values.items()))


def _signature(group: "_Group", inputs: Mapping[str, Any], fixed: Any) -> tuple:
    """What a traced group depends on besides its kernel's program: static values, input shapes and
    dtypes, and the structure, shapes and dtypes of the kernel's fixed `inputs`."""
    shapes = tuple(sorted((k, tuple(v.shape), str(v.dtype)) for k, v in inputs.items()))
    return _statics_key(group.static_values), shapes, structure_key(fixed)


def _fixed_inputs(kernel: Kernel) -> dict[str, Any]:
    """The kernel's fixed inputs (`Kernel.inputs`) as a pytree of host arrays (numbers in JAX's
    canonical float or int type; anything else refused)."""

    def leaf(x: Any) -> np.ndarray:
        x = np.asarray(x)
        if x.dtype.kind in "fiu":
            return _canonical(x)
        if x.dtype.kind == "b":
            return x
        raise ValueError(
            f"inputs of model {kernel.name!r} must be numbers or arrays of numbers, got {x.dtype}."
        )

    if not isinstance(kernel.inputs, Mapping):
        raise ValueError(
            f"inputs of model {kernel.name!r} must be a mapping of names to values, got "
            f"{type(kernel.inputs).__name__}."
        )
    return jax.tree.map(leaf, dict(kernel.inputs))


class _Group:
    """Designs sharing the same static parameter values: one compiled function."""

    def __init__(self, static_values: dict[str, Any], indices: np.ndarray):
        self.static_values = static_values
        self.indices = indices
        self.shapes: dict[str, jax.ShapeDtypeStruct] = {}
        self.extra: dict[str, jax.ShapeDtypeStruct] = {}
        self.compiled: Callable | None = None


@dataclasses.dataclass
class _Plan:
    """What a sweep computes, settled on the host before anything compiles: the design columns
    (categories encoded as indices), the static groups with their output shapes, the dataset's
    output layout and the store's manifest."""

    kernel: Kernel
    space: AbstractDesignSpace
    traces: TraceCache
    columns: dict[str, np.ndarray]
    static_names: list[str]
    dynamic_names: list[str]
    encoded: dict[str, np.ndarray]
    groups: list[_Group]
    layout: dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]
    manifest: dict[str, Any]
    fixed: dict[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def n_designs(self) -> int:
        return self.space.size

    def member_fn(self, static_values: dict[str, Any]) -> Callable:
        """The jitted kernel of one design of the group with `static_values`, `member(params,
        fixed)` (`fixed`: the kernel's `inputs`), outputs checked: one function object per kernel
        program and static values (kept in the plan's `traces`), so that JAX traces it once for
        the shape probe and every chunk size reuses that trace."""
        kernel = self.kernel
        key = ("member", _statics_key(static_values))
        jitted = self.traces.get(kernel, key)
        if jitted is None:
            jitted = jax.jit(self._checked_member(static_values))
            self.traces.put(kernel, key, jitted)
        return jitted

    def _checked_member(self, static_values: dict[str, Any]) -> Callable:
        kernel = self.kernel

        def member(params: dict[str, Any], fixed: dict[str, Any]) -> dict[str, Any]:
            outputs = kernel.traced({**fixed, **params, **static_values})
            if not isinstance(outputs, Mapping):
                raise ValueError(
                    f"model {kernel.name!r} must return a flat dict of arrays, got "
                    f"{type(outputs).__name__}."
                )
            return {str(k): jnp.asarray(v) for k, v in outputs.items()}

        return member

    def prepared(self, group: _Group, indices: np.ndarray) -> dict[str, np.ndarray]:
        """Host-side per-design inputs (e.g. random geometry drawn by NumPy), see
        `Kernel.prepare`."""
        kernel = self.kernel
        if kernel.prepare is None:
            return {}
        host = {n: self.columns[n][indices] for n in self.dynamic_names}
        extra = {
            str(k): np.asarray(v) for k, v in kernel.prepare(host, group.static_values).items()
        }
        for name, value in extra.items():
            if name in self.encoded or value.shape[:1] != (len(indices),):
                raise ValueError(
                    f"prepare() of {kernel.name!r} returned {name!r} with shape {value.shape}; "
                    f"expected a new name and a leading axis of {len(indices)} designs."
                )
        return extra


def sweep(
    fn: Callable[..., Any] | Kernel,
    space: AbstractDesignSpace,
    *,
    chunk_size: int | None = None,
    out: str | os.PathLike | None = None,
    resume: bool = False,
    devices: Sequence[jax.Device] | None = None,  # pyright: ignore[reportInvalidTypeForm]
    workers: int | None = None,
    store_every: int | None = None,
    progress: bool = True,
    on_chunk: Callable[[int, int], None] | None = None,
    traces: TraceCache | None = None,
) -> xr.Dataset:
    """Evaluate `fn` on every design of `space`, in chunks, sharded over devices; return a dataset.

    **Arguments:**
    - `fn`: a `Kernel`, or a plain function `fn(params: dict) -> dict[str, Array]` of one design
      (see `Kernel` for the contract: traceable, no raising, result code under `"result"`).
    - `space`: a `Grid`, `Samples`, `Table` or `Product` of them.
    - `chunk_size`: designs per compiled call (`vmap`-ped; a chunk of one runs the kernel itself);
      rounded up to a multiple of the device count. `None` picks one: at least 8 chunks, at most
      256 designs per device on CPU (8192 on accelerators; on a CPU the kernel's `cpu_chunk_size`
      when it gives one), then halved until XLA's memory analysis of the compiled call, times
      `workers`, fits in half the device's memory.
    - `out`: folder to store the sweep in (created if missing). `None` keeps it in memory only.
    - `resume`: continue the sweep stored in `out`, computing only designs not stored yet. Raises
      if the stored sweep has a different kernel, settings or design space. Without `resume`, an
      `out` that already holds a sweep is an error (nothing is overwritten).
    - `devices`: devices to shard the batch axis over (default: `jax.local_devices()`).
    - `workers`: chunks computed at once, each from its own thread (>= 1). `None`: one per usable
      CPU core when the sweep runs on one CPU device, else 1. The results do not depend on it.
    - `store_every`: designs per stored chunk file (>= 1): finished chunks are held until they
      hold this many designs, or for at most 30 s, then written as one file (and on an
      interruption, what is held is written first). `None`: one file per chunk when `chunk_size`
      is given, else at least 64 designs per file (encoding and reading a NetCDF file costs
      ~0.1 s, more than a one-design chunk of a cheap kernel).
    - `progress`: show a tqdm progress bar (designs and designs/s) on stderr.
    - `on_chunk`: called as `on_chunk(done, total)` after each chunk is computed (and stored,
      unless held for a larger file).
    - `traces`: where the kernel's traces and compiled calls are kept for later sweeps of the same
      program (the same `Kernel.program`, whatever its `inputs`' values, else `Kernel.fn`; a
      `TraceCache`); `None`: `TRACES`, the process's.

    **Returns:** an `xarray.Dataset` with dimension `design` (index coordinate `design`, the design's
    row in `space.columns()`), every parameter as a coordinate along `design` (attribute `units`),
    every output as a variable (attribute `units`), and `result` (`int32`, 0 = success) with CF
    `flag_values`/`flag_meanings`. Attributes: `model`, `settings` and `space` (JSON), `n_designs`,
    `n_failed`, `chunk_size`, `workers`, `devices`, `compile_s` (seconds spent compiling in this
    call) and `run_s` (wall-clock seconds spent computing, copying and storing chunks, compilation
    excluded: the steady-state cost; with a resumed sweep, of this call's chunks only). Those two
    and `workers` are the attributes that differ between runs of the same sweep.

    **Raises:** `ValueError` for a wrong design space or kernel outputs (before any compute);
    `FileExistsError` / `ValueError` from the store (see `resume`); `RuntimeError` if a compiled
    chunk raises (a kernel that throws instead of returning a result code).
    """
    kernel = as_kernel(fn)
    if chunk_size is not None and int(chunk_size) < 1:
        raise ValueError(f"chunk_size must be >= 1, got {chunk_size}.")
    _check_count(workers, "workers", "chunks at once")
    _check_count(store_every, "store_every", "designs per file")
    plan = _plan(kernel, space, TRACES if traces is None else traces)
    devices = list(devices) if devices is not None else jax.local_devices()
    if not devices:
        raise ValueError("no devices to run on.")
    if workers is None:
        workers = _default_workers(devices)
        if kernel.cpu_workers is not None and devices[0].platform == "cpu":
            workers = min(workers, kernel.cpu_workers)
    workers = int(workers)
    if out is None and jax.process_count() > 1:
        raise ValueError(
            "a sweep over several processes needs `out`, a folder every process can write to: "
            "each process computes only its share of the chunks, and process 0 gathers them there."
        )
    sharding = NamedSharding(Mesh(np.array(devices), (AXIS,)), P(AXIS))
    process_index, process_count = jax.process_index(), jax.process_count()
    store = _open_store(out, plan.manifest, resume, process_index, process_count)
    try:
        done = np.zeros(plan.n_designs, dtype=bool)
        if store is not None and process_index == 0:
            done = store.scan(plan.columns, repair=True)
        # Every process takes its share of the same work list: process 0's view of the store.
        done = _from_process_zero(done, process_count)
        compiler = _Compiler(plan, sharding)
        size, work = _schedule(plan, done, chunk_size, devices, compiler, workers)
        if store is not None and process_index == 0 and done.any() and work:
            _warn_other_chunk_sizes(store.chunk_sizes(), size)
        chunks, run_seconds = _run_chunks(
            plan,
            work[process_index::process_count],
            size,
            sharding,
            compiler,
            store,
            n_done=int(done.sum()),
            workers=workers,
            store_every=(
                int(store_every)
                if store_every is not None
                else size
                if chunk_size is not None
                else max(size, STORE_MIN_DESIGNS)
            ),
            progress=progress,
            on_chunk=on_chunk,
        )
        _barrier("origami_jax.sweep.computed", process_count)
        return _gather(plan, store, chunks, size, devices, compiler.seconds, run_seconds, workers)
    finally:
        if store is not None:
            store.close()


def _warn_other_chunk_sizes(stored: set[int], size: int) -> None:
    """Warn when a resumed sweep computes in chunks of another size than its stored designs: the
    two sizes compile different vector code, so a design's result may differ between them by
    round-off (more where the kernel amplifies it, as contact does)."""
    other = sorted(stored - {size})
    if other:
        logger.warning(
            "sweep: resuming in chunks of %d designs, but the stored designs were computed in "
            "chunks of %s; results may differ between the two by round-off. Pass chunk_size=%d "
            "to compute the rest as they were.",
            size,
            ", ".join(map(str, other)),
            other[0],
        )


def _plan(kernel: Kernel, space: AbstractDesignSpace, traces: TraceCache) -> _Plan:
    """Stage 1: check the space against the kernel, expand it into columns, encode categories,
    group the designs by static values and trace each group once for its output shapes.

    **Raises:** `ValueError` for unknown parameters, unknown category labels, or kernel outputs
    that are not a flat dict of arrays with consistent names and ranks.
    """
    if not isinstance(space, AbstractDesignSpace):
        raise ValueError(f"space must be a Grid, Samples, Table or Product, got {type(space)}.")
    if kernel.parameters is not None:
        unknown = [n for n in space.names if n not in kernel.parameters]
        if unknown:
            raise ValueError(
                f"model {kernel.name!r} has no parameter(s) {unknown}; it accepts "
                f"{sorted(kernel.parameters)}."
            )
    fixed = _fixed_inputs(kernel)
    taken = sorted(set(fixed) & set(space.names))
    if taken:
        raise ValueError(
            f"model {kernel.name!r} takes {taken} as fixed inputs (the same for every design), "
            "not as swept parameters; build the kernel with the value instead."
        )
    columns = space.columns()
    for name in space.names:
        column = columns[name]
        if column.dtype.kind == "U" and kernel.parameters is not None:
            if name not in kernel.categories:
                unit = kernel.parameters.get(name, "")
                raise ValueError(
                    f"parameter {name!r} of model {kernel.name!r} takes numbers"
                    + (f" (in {unit})" if unit and unit != "1" else "")
                    + f", not labels such as {str(column[0])!r}; a label would be swept as a "
                    "category index. Give numbers (TOML: no quotes)."
                )
    static_names = [n for n in space.names if n in space.static or n in kernel.static]
    dynamic_names = [n for n in space.names if n not in static_names]
    encoded = _encode(kernel, space, columns, dynamic_names)
    plan = _Plan(
        kernel=kernel,
        space=space,
        traces=traces,
        columns=columns,
        static_names=static_names,
        dynamic_names=dynamic_names,
        encoded=encoded,
        groups=_make_groups(columns, static_names, space.size),
        layout={},
        manifest={},
        fixed=fixed,
    )
    example = {n: jnp.zeros((), encoded[n].dtype) for n in dynamic_names}
    for group in plan.groups:
        group.extra = {
            k: jax.ShapeDtypeStruct(v.shape[1:], v.dtype)
            for k, v in plan.prepared(group, group.indices[:1]).items()
        }
        inputs = {**example, **group.extra}
        signature = _signature(group, inputs, fixed)
        shapes = traces.get(kernel, ("shapes", signature))
        if shapes is None:
            shapes = _output_shapes(plan, group, inputs, signature)
            traces.put(kernel, ("shapes", signature), shapes)
        group.shapes = shapes
    plan.layout = _output_layout(kernel, plan.groups)
    plan.manifest = {
        "format": 1,
        "model": kernel.name,
        "settings": dict(kernel.settings),
        "space": space.to_config(),
        "static": static_names,
        "outputs": {n: [list(d), dt] for n, (d, _, dt) in plan.layout.items()},
    }
    return plan


def _output_shapes(plan: _Plan, group: _Group, inputs: dict[str, Any], signature: tuple) -> dict:
    """The shapes of one design's outputs in `group` (`jax.ShapeDtypeStruct`s by name): traced as
    the compiled kernel will be (checks included: its chunks reuse this trace), or, for a kernel
    with a `program_key`, read from where the command line keeps its programs."""
    kernel = plan.kernel

    def traced():  # {name: (shape, dtype)}: what `remembered` keeps
        with checks_as_nan(kernel.never_raises):
            shapes = jax.eval_shape(plan.member_fn(group.static_values), inputs, plan.fixed)
        return {name: (tuple(v.shape), str(v.dtype)) for name, v in shapes.items()}

    if kernel.program_key is None:
        shapes = traced()
    else:
        shapes = remembered("sweep_shapes", traced, _identity(kernel, signature))
    return {name: jax.ShapeDtypeStruct(*v) for name, v in shapes.items()}


def _identity(kernel: Kernel, signature: tuple, *more) -> tuple:
    """What decides a compiled program of `kernel` with a `program_key` (`Kernel.program_key`)
    for a group's `signature` (`_signature`), as the key of what is kept of it on disk."""
    return (kernel.program_key, bool(kernel.never_raises), signature, *more)


def _encode(
    kernel: Kernel,
    space: AbstractDesignSpace,
    columns: Mapping[str, np.ndarray],
    dynamic_names: Sequence[str],
) -> dict[str, np.ndarray]:
    """The batched (dynamic) columns as arrays: labels as `int32` indices into the kernel's (else
    the space's sorted) categories, numbers in JAX's canonical float or int type."""
    categories = {}
    for name in dynamic_names:
        if columns[name].dtype.kind == "U":
            known = kernel.categories.get(name) or space.categories(name)
            unknown = sorted(set(columns[name].tolist()) - set(known))
            if unknown:
                raise ValueError(
                    f"parameter {name!r}: model {kernel.name!r} knows {list(known)}, not {unknown}."
                )
            categories[name] = tuple(known)
        elif name in kernel.categories:
            raise ValueError(
                f"parameter {name!r} takes one of {list(kernel.categories[name])}, not numbers."
            )
    encoded: dict[str, np.ndarray] = {}
    for name in dynamic_names:
        if name in categories:
            lookup = {label: i for i, label in enumerate(categories[name])}
            encoded[name] = np.array([lookup[v] for v in columns[name]], dtype=np.int32)
        else:
            encoded[name] = _canonical(columns[name])
    return encoded


def _open_store(
    out: str | os.PathLike | None,
    manifest: Mapping[str, Any],
    resume: bool,
    process_index: int,
    process_count: int,
) -> Store | None:
    """The sweep's folder (`None`: in memory): process 0 creates or checks it, the others open it
    for reading once it exists."""
    if out is None:
        return None
    store, error = None, None
    if process_index == 0:
        try:
            store = Store.open(Path(out), manifest, resume=resume, writer=True)
        except (FileExistsError, ValueError, SweepBusyError, OSError) as caught:
            error = caught
    # The others learn whether process 0 could open the folder (else they would wait for it).
    opened = bool(_from_process_zero(np.asarray(error is None), process_count))
    if error is not None:
        raise error
    if not opened:
        raise RuntimeError(
            f"process 0 could not open the sweep folder {out}; its error message says why."
        )
    if process_index != 0:
        store = Store.open(Path(out), manifest, resume=True, writer=False)
    return store


def _from_process_zero(value: np.ndarray, process_count: int) -> np.ndarray:
    """Process 0's `value` in every process (itself on one process)."""
    if process_count == 1:
        return value
    from jax.experimental import multihost_utils

    return np.asarray(multihost_utils.broadcast_one_to_all(value))


class _Compiler:
    """Stage 2: compiles the kernel of a group for a chunk size (vmapped; a chunk of one runs it
    unbatched), sharded along the batch axis, and the cost estimate; keeps the seconds spent
    compiling."""

    def __init__(self, plan: _Plan, sharding: NamedSharding):
        self.plan = plan
        self.sharding = sharding
        self.seconds: list[float] = []

    def group(self, group: _Group, size: int) -> Callable:
        """The compiled `(size,)`-batch kernel of `group` (kept per kernel program in the plan's
        `traces`)."""
        plan, sharding = self.plan, self.sharding
        # The sharding is the jitted call's alone: on the arguments it would reach the member's
        # inputs under `vmap` too, and JAX would trace the member again instead of reusing the
        # shape probe's trace.
        args = {n: jax.ShapeDtypeStruct((size,), plan.encoded[n].dtype) for n in plan.dynamic_names}
        for name, shape in group.extra.items():
            args[name] = jax.ShapeDtypeStruct((size, *shape.shape), shape.dtype)
        options = plan.kernel.compiler_options
        # Kernels of one program share its compilations, those compiled with the same options.
        chosen = tuple(sorted((options or {}).items()))
        key = ("compiled", _signature(group, args, plan.fixed), sharding, chosen)
        compiled = plan.traces.get(plan.kernel, key)
        if compiled is not None:
            return compiled
        member = plan.member_fn(group.static_values)
        # A chunk of one design (the nets' kernel on a CPU) runs the member itself: batching its
        # traced program under `vmap` costs as much as tracing it again.
        batched = _one_design(member) if size == 1 else jax.vmap(member, in_axes=(0, None))

        def sweep_chunk(params: dict[str, Any], fixed: dict[str, Any]) -> dict[str, Any]:
            return batched(params, fixed)  # (the name the compiled program goes by)

        jitted = jax.jit(
            sweep_chunk,
            in_shardings=(sharding, _replicated(sharding)),
            out_shardings=sharding,
        )
        fixed = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), plan.fixed)

        def lower():
            with checks_as_nan(plan.kernel.never_raises):
                return jitted.lower(args, fixed)

        start = time.perf_counter()
        devices = sharding.mesh.devices.size
        if plan.kernel.program_key is None or devices != 1:
            compiled = compiled_with(lower(), options)
        else:  # one device: kept compiled where the command line keeps its programs
            platform = sharding.mesh.devices.flat[0].platform
            identity = _identity(plan.kernel, _signature(group, args, plan.fixed), platform)
            compiled = kept_compiled("sweep_chunk", identity, lower, options)
        self.seconds.append(time.perf_counter() - start)
        plan.traces.put(plan.kernel, key, compiled)
        return compiled

    def costs(self, group: _Group, todo: np.ndarray) -> np.ndarray:
        """The kernel's cost estimate of the designs `todo` of `group` (non-finite → `inf`)."""
        plan = self.plan
        estimate = plan.kernel.cost
        assert estimate is not None
        inputs = {n: plan.encoded[n][todo] for n in plan.dynamic_names}
        inputs.update(plan.prepared(group, todo))
        statics = group.static_values

        def cost(params, fixed):
            return jnp.asarray(estimate({**fixed, **params, **statics}), dtype=float).reshape(())

        def lower():
            with checks_as_nan(plan.kernel.never_raises):
                return jax.jit(jax.vmap(cost, in_axes=(0, None))).lower(inputs, plan.fixed)

        start = time.perf_counter()
        if plan.kernel.program_key is None:
            compiled_cost = lower().compile()
        else:  # on the default device: kept compiled where the command line keeps its programs
            signature = _signature(group, inputs, plan.fixed)
            identity = _identity(plan.kernel, signature, "cost", jax.default_backend())
            compiled_cost = kept_compiled("sweep_cost", identity, lower)
        self.seconds.append(time.perf_counter() - start)
        costs = np.asarray(compiled_cost(inputs, plan.fixed))
        return np.where(np.isfinite(costs), costs, np.inf)


def _replicated(sharding: NamedSharding) -> NamedSharding:
    """A whole copy on every device of `sharding`'s mesh (the kernel's fixed inputs)."""
    return NamedSharding(sharding.mesh, P())


def _one_design(member: Callable) -> Callable:
    """`member` over a batch of one design: the batch axis dropped on the way in, added back on
    the way out (the fixed inputs as they are)."""

    def batch_of_one(params: dict[str, Any], fixed: dict[str, Any]) -> dict[str, Any]:
        outputs = member(jax.tree.map(lambda x: x[0], params), fixed)
        return jax.tree.map(lambda x: x[None], outputs)

    return batch_of_one


def _schedule(
    plan: _Plan,
    done: np.ndarray,
    chunk_size: int | None,
    devices: Sequence[jax.Device],  # pyright: ignore[reportInvalidTypeForm]
    compiler: _Compiler,
    workers: int = 1,
) -> tuple[int, list[tuple[_Group, np.ndarray]]]:
    """Stage 3a: the chunk size and the work list, `(group, design indices)` chunks not stored yet,
    in the order of the kernel's cost estimate within each group (see `Kernel.cost`). A chunk size
    chosen here (not given) is then fitted to the device's memory (`workers` chunks at once), which
    compiles the first group for it."""
    n_devices = len(devices)
    if chunk_size is None:
        largest = max(int((~done[g.indices]).sum()) for g in plan.groups)
        size = _default_chunk_size(
            max(largest, 1), n_devices, devices[0].platform, plan.kernel.cpu_chunk_size
        )
    else:
        size = math.ceil(int(chunk_size) / n_devices) * n_devices
    todo_by_group = [(group, _pending(plan, group, done, compiler)) for group in plan.groups]

    def chunks(size: int) -> list[tuple[_Group, np.ndarray]]:
        work: list[tuple[_Group, np.ndarray]] = []
        for group, todo in todo_by_group:
            work += [(group, todo[i : i + size]) for i in range(0, len(todo), size)]
        return work

    work = chunks(size)
    if chunk_size is None and work:
        size = _fit_memory(work[0][0], size, n_devices, devices[0], compiler.group, workers)
        work = chunks(size)
    return size, work


def _pending(plan: _Plan, group: _Group, done: np.ndarray, compiler: _Compiler) -> np.ndarray:
    """Designs of `group` not stored yet, cheapest first when the kernel estimates costs."""
    todo = group.indices[~done[group.indices]]
    if plan.kernel.cost is None or len(todo) == 0:
        return todo
    return todo[np.argsort(compiler.costs(group, todo), kind="stable")]


def _run_chunks(
    plan: _Plan,
    work: Sequence[tuple[_Group, np.ndarray]],
    size: int,
    sharding: NamedSharding,
    compiler: _Compiler,
    store: Store | None,
    *,
    n_done: int,
    workers: int = 1,
    store_every: int = 1,
    progress: bool,
    on_chunk: Callable[[int, int], None] | None,
) -> tuple[list[xr.Dataset], float]:
    """Stage 3b: each chunk padded to `size` (repeating its last design), put on the devices and
    computed, up to `workers` at once from a thread pool (a group compiles, on this thread, before
    its first chunk is handed out). Finished chunks are copied back and held on this thread until
    they hold `store_every` designs or `STORE_EVERY_SECONDS` have passed, then labelled and stored
    as one chunk; what is held is stored on an interruption too.

    **Returns:** the chunks kept in memory (none with a store) and the seconds spent on them
    (wall-clock, compilation excluded).
    """
    from tqdm import tqdm

    kernel = plan.kernel
    bar = tqdm(
        total=plan.n_designs,
        initial=n_done,
        unit="design",
        desc=f"sweep {kernel.name}",
        disable=not progress,
        file=sys.stderr,
        dynamic_ncols=True,
    )

    fixed = jax.device_put(plan.fixed, _replicated(sharding))

    def compute(group: _Group, indices: np.ndarray) -> dict[str, np.ndarray]:
        padded = np.concatenate([indices, np.full(size - len(indices), indices[-1])])
        inputs = {n: jax.device_put(plan.encoded[n][padded], sharding) for n in plan.dynamic_names}
        for name, value in plan.prepared(group, padded).items():
            inputs[name] = jax.device_put(value, sharding)
        assert group.compiled is not None
        return jax.device_get(group.compiled(inputs, fixed))

    in_memory: list[xr.Dataset] = []
    held: list[tuple[np.ndarray, dict[str, np.ndarray]]] = []
    last_stored = time.monotonic()

    def hold(indices: np.ndarray, outputs: Mapping[str, Any]) -> None:
        n = len(indices)
        trimmed = {}
        for name, value in outputs.items():
            value = np.asarray(value)[:n]
            if name in plan.layout:  # static groups may differ in trailing sizes
                _, shape, dtype = plan.layout[name]
                value = _pad(value, shape, dtype)
            trimmed[name] = value
        held.append((indices, trimmed))

    def store_held() -> None:
        nonlocal held, last_stored
        if not held:
            return
        indices = np.concatenate([i for i, _ in held])
        order = np.argsort(indices, kind="stable")
        outputs = {n: np.concatenate([o[n] for _, o in held])[order] for n in held[0][1]}
        chunk = _label_chunk(plan.space, plan.columns, indices[order], outputs, plan.layout, kernel)
        # Recorded per file: a resumed sweep can say when it computes in chunks of another size.
        chunk.attrs["chunk_size"] = int(size)
        held = []
        last_stored = time.monotonic()
        if store is not None:
            store.write_chunk(chunk)
        else:
            in_memory.append(chunk)

    start = time.perf_counter()
    compiling = 0.0
    pending = iter(work)
    running: dict[concurrent.futures.Future, tuple[_Group, np.ndarray]] = {}
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=workers)
    completed = False
    try:

        def hand_out() -> None:
            nonlocal compiling
            while len(running) < workers:
                item = next(pending, None)
                if item is None:
                    return
                group, indices = item
                if group.compiled is None:
                    compile_start = time.perf_counter()
                    group.compiled = compiler.group(group, size)
                    compiling += time.perf_counter() - compile_start
                running[pool.submit(compute, group, indices)] = item

        hand_out()
        while running:
            finished, _ = concurrent.futures.wait(
                running, return_when=concurrent.futures.FIRST_COMPLETED
            )
            for future in sorted(finished, key=lambda f: int(running[f][1][0])):
                _, indices = running.pop(future)
                try:
                    outputs = future.result()
                except Exception as error:
                    raise RuntimeError(
                        f"model {kernel.name!r} raised while computing designs "
                        f"{int(indices[0])}..{int(indices[-1])}: {error}\nA batch kernel must not "
                        "throw: call solvers with throw=False and return their result code."
                    ) from error
                hold(indices, outputs)
                if (
                    sum(len(i) for i, _ in held) >= store_every
                    or time.monotonic() - last_stored >= STORE_EVERY_SECONDS
                ):
                    store_held()
                n_done += len(indices)
                bar.update(len(indices))
                if on_chunk is not None:
                    on_chunk(n_done, plan.n_designs)
            hand_out()
        store_held()
        completed = True
    finally:
        if not completed:
            # An error or an interruption: what was computed is stored first; chunks still
            # computing finish (a compiled call cannot be stopped) and are dropped.
            try:
                store_held()
            except Exception as error:  # the original error is the one to report
                logger.warning("sweep: could not store the last finished designs: %s", error)
        pool.shutdown(wait=True, cancel_futures=True)
        bar.close()
    return in_memory, time.perf_counter() - start - compiling


def _gather(
    plan: _Plan,
    store: Store | None,
    chunks: list[xr.Dataset],
    size: int,
    devices: Sequence[jax.Device],  # pyright: ignore[reportInvalidTypeForm]
    compile_seconds: Sequence[float],
    run_seconds: float,
    workers: int = 1,
) -> xr.Dataset:
    """Stage 4: the chunks as one dataset with the sweep's attributes; with a store, process 0
    writes it to `sweep.nc` and the other processes read it back."""

    def finish(dataset: xr.Dataset) -> xr.Dataset:
        return _finish(
            dataset,
            plan.kernel,
            plan.manifest,
            size,
            devices,
            compile_seconds,
            run_seconds,
            workers,
        )

    if store is None:
        return finish(gather(chunks))
    process_count = jax.process_count()
    error = None
    if jax.process_index() == 0:
        try:
            dataset = store.gather(write=False, columns=plan.columns)
            dataset = finish(dataset)
            gather([dataset], path=store.root / RESULT)
        except Exception as caught:  # reported by process 0, the others stop with it
            error = caught
    gathered = bool(_from_process_zero(np.asarray(error is None), process_count))
    if error is not None:
        raise error
    if not gathered:
        raise RuntimeError("process 0 could not gather the sweep; its error message says why.")
    if jax.process_index() != 0:
        dataset = xr.load_dataset(store.root / RESULT, engine="h5netcdf")
    return dataset


def _barrier(name: str, process_count: int) -> None:
    if process_count > 1:
        from jax.experimental import multihost_utils

        multihost_utils.sync_global_devices(name)


def _make_groups(
    columns: Mapping[str, np.ndarray], static_names: Sequence[str], n_designs: int
) -> list[_Group]:
    if not static_names:
        return [_Group({}, np.arange(n_designs))]
    keys = list(zip(*(columns[n].tolist() for n in static_names), strict=True))
    order: dict[tuple, list[int]] = {}
    for i, key in enumerate(keys):
        order.setdefault(key, []).append(i)
    return [
        _Group(
            {n: _python_scalar(v) for n, v in zip(static_names, key, strict=True)},
            np.asarray(idx, dtype=np.int64),
        )
        for key, idx in order.items()
    ]


def _output_layout(
    kernel: Kernel, groups: Sequence[_Group]
) -> dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]:
    """Per output: trailing dim names, their (largest over groups) sizes, and the common dtype."""
    names = list(groups[0].shapes)
    for group in groups[1:]:
        if list(group.shapes) != names:
            raise ValueError(
                f"model {kernel.name!r} returns different outputs for different static values: "
                f"{names} vs {list(group.shapes)}."
            )
    for name in names:
        if name in (AXIS,) or name in {n for g in groups for n in g.static_values}:
            raise ValueError(f"output name {name!r} clashes with a dimension or parameter.")
    dim_sizes: dict[str, int] = {}
    layout = {}
    for name in names:
        ndim = {g.shapes[name].ndim for g in groups}
        if len(ndim) != 1:
            raise ValueError(f"output {name!r} changes rank between static groups.")
        (ndim,) = ndim
        dims = tuple(kernel.output_dims.get(name, tuple(f"{name}_dim{k}" for k in range(ndim))))
        if len(dims) != ndim:
            raise ValueError(f"output {name!r} has {ndim} axes but output_dims names {dims}.")
        for k, dim in enumerate(dims):
            dim_sizes[dim] = max(
                [dim_sizes.get(dim, 0)] + [g.shapes[name].shape[k] for g in groups]
            )
        dtype = np.result_type(*[g.shapes[name].dtype for g in groups])
        layout[name] = (dims, dtype.name)
    return {n: (d, tuple(dim_sizes[x] for x in d), dt) for n, (d, dt) in layout.items()}


def _pad(values: np.ndarray, shape: tuple[int, ...], dtype: str) -> np.ndarray:
    values = values.astype(dtype, copy=False)
    if values.shape[1:] == shape:
        return values
    kind = np.dtype(dtype).kind
    fill = np.nan if kind in "fc" else (-1 if kind in "iu" else False)
    result = np.full((values.shape[0], *shape), fill, dtype=dtype)
    result[(slice(None), *(slice(0, s) for s in values.shape[1:]))] = values
    return result


def _label_chunk(
    space: AbstractDesignSpace,
    columns: Mapping[str, np.ndarray],
    indices: np.ndarray,
    outputs: Mapping[str, np.ndarray],
    layout: Mapping[str, tuple[tuple[str, ...], tuple[int, ...], str]],
    kernel: Kernel,
) -> xr.Dataset:
    n = len(indices)
    coords: dict[str, Any] = {AXIS: (AXIS, indices.astype(np.int64))}
    for name in space.names:
        coords[name] = (AXIS, columns[name][indices], {"units": space.unit(name)})
    data_vars: dict[str, Any] = {}
    for name, (dims, shape, dtype) in layout.items():
        values = _pad(np.asarray(outputs[name])[:n], shape, dtype)
        attrs = {"units": kernel.output_units.get(name, "")}
        if name == kernel.result_key:
            continue
        data_vars[name] = ((AXIS, *dims), values, attrs)
    if kernel.result_key in outputs:
        code = np.asarray(outputs[kernel.result_key])[:n].astype(np.int32)
        if code.ndim != 1:
            raise ValueError(f"result code {kernel.result_key!r} must be a scalar per design.")
    else:
        code = np.zeros(n, dtype=np.int32)
    attrs: dict[str, Any] = {"long_name": "result code (0 = success)"}
    if kernel.result_messages:
        codes = sorted(kernel.result_messages)
        attrs["flag_values"] = np.asarray(codes, dtype=np.int32)
        attrs["flag_meanings"] = " ".join(
            "_".join(kernel.result_messages[c].split()) for c in codes
        )
    data_vars["result"] = ((AXIS,), code, attrs)
    return xr.Dataset(data_vars, coords=coords)


def _fit_memory(
    group: _Group,
    size: int,
    n_devices: int,
    device: jax.Device,  # pyright: ignore[reportInvalidTypeForm]
    compile_group: Callable,
    workers: int = 1,
) -> int:
    """Halve the chunk size until `workers` compiled calls at once fit `MEMORY_FRACTION` of a
    device."""
    budget = _device_memory(device)
    while True:
        compiled = compile_group(group, size)
        needed = _compiled_bytes(compiled)
        if budget is None or needed is None or workers * needed <= MEMORY_FRACTION * budget:
            group.compiled = compiled
            return size
        if size == n_devices:
            at_once = f" × {workers} chunks at once (give fewer workers)" if workers > 1 else ""
            raise ValueError(
                f"one design per device needs {needed / 2**30:.1f} GiB{at_once}, more than "
                f"{MEMORY_FRACTION:.0%} of the {budget / 2**30:.1f} GiB the device has."
            )
        size = max(n_devices, (size // (2 * n_devices)) * n_devices)


def _finish(
    dataset: xr.Dataset,
    kernel: Kernel,
    manifest: Mapping[str, Any],
    size: int,
    devices: Sequence[jax.Device],  # pyright: ignore[reportInvalidTypeForm]
    compile_seconds: Sequence[float],
    run_seconds: float,
    workers: int = 1,
) -> xr.Dataset:
    dataset.attrs.update(
        {
            "model": kernel.name,
            "settings": json.dumps(manifest["settings"], sort_keys=True),
            "space": json.dumps(manifest["space"], sort_keys=True),
            "n_designs": int(dataset.sizes[AXIS]),
            "n_failed": int((dataset["result"].values != 0).sum()),
            "chunk_size": int(size),
            "workers": int(workers),
            "devices": ", ".join(str(d) for d in devices),
            "jax_version": jax.__version__,
            "compile_s": float(sum(compile_seconds)),
            "run_s": float(run_seconds),
        }
    )
    return dataset
