"""Traced programs kept on disk: a warm command skips tracing its solve, not only compiling it.

JAX's persistent compilation cache (`origami_jax._cache`) stores compiled programs, but a new process
still traces and lowers every program before it can look one up: for the simulation's solve that is
most of a warm command's own time. `exported_call` keeps the traced program itself, exported with
`jax.export` (StableHLO), under a key of everything that decides it: the arguments' static parts and
array shapes, the versions of JAX and of the libraries traced through, this package's source, and
the configuration flags that change a trace. Beside it, the program compiled (``.xla``, under
that key and the machine's: its instruction set, the backend's version and devices, XLA's
flags): a later process with the same key loads the executable and runs it, neither tracing,
lowering nor compiling. Lowering even a deserialised program to look it up in the compilation
cache cost a warm fold a tenth of its time. Where no executable is kept (another machine), the
exported program is compiled again and kept.

The executables are compiled here, outside JAX's compilation cache: one that cache reads back
serialises without its machine code (XLA keeps none once loaded), and would fail when run. A
compilation the cache served anyway is not kept (`_persistent_cache_hits`), and a kept one that
fails when run is removed, the call traced as usual.

A wrong hit would silently run another program, so the key refuses what it cannot vouch for: any
function or class from outside the libraries whose versions or source it records (a user's torque
function, say) makes `exported_call` trace as usual. Programs that call back into Python (progress
meters, `equinox.error_if` unless ``EQX_ON_ERROR=nan``) cannot be exported and are traced as usual.

Off unless `enable_exported_programs` was called: the command line does it, in the compilation
cache's folder (``exported/``). A program given compiler options (`QUICK_COMPILE`) is compiled with
them whether or not it is kept, in memory where it is not (the library, or runtime errors that
raise): the numbers do not depend on which. Used for the solve
(`origami_jax.simulation.simulate` called outside any transformation: the default solver's
explicit phase, or a named solver's whole solve), the program a warm command would otherwise spend
most of its own time tracing, and through `exported_jit` for the smaller programs a command runs
once each (a net's fluid loads, the verdict, its seam tolerances, the contact's defaults and the
points where panels touch).

`remembered` keeps a value a command builds on the host the same way (pickled, under a key of its
inputs' values and the same versions, source and flags): a net's folding system, whose build is
seconds of host geometry and small programs that a warm command would otherwise repeat.
"""

from __future__ import annotations

import copyreg
import functools
import hashlib
import io
import os
import pickle
import re
import sys
import tempfile
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ._runtime_errors import on_error

_FOLDER: Path | None = None
_REFUSED: set[str] = set()  # programs found not exportable in this process (a callback, ...)
_LOADED: dict[Path, tuple] = {}  # (compiled, extra) this process has read or built, by file
_READING: dict[Path, Any] = {}  # executables being read in the background (`prefetch`), by file
_USED: dict[Path, None] = {}  # executables this process ran, in order (`note_programs_used`)
_ANCHOR: Path | None = None  # the value that started a command's work (`prefetch_after`)
_HINT: Path | None = None  # the command line's own note of what it ran (`prefetch_for_command`)
_READER = None  # the executor of `prefetch`'s background thread, made at its first use
_OWN_KEY = {"xla_embed_ir_in_executable": False}  # XLA's default, set: see `_compiled_here`
# A LAPACK routine's name as a custom call's target in a serialised executable (`lapack_dsyevd_ffi`,
# in the program it holds), not a function name in its locations (a test of "lapack_is…").
_LAPACK_CALL = re.compile(rb"lapack_[sdcz][a-z0-9]*(?:_ffi)?\b")

QUICK_COMPILE = {
    "xla_cpu_use_fusion_emitters": False,
    "xla_backend_optimization_level": 0,
    "xla_cpu_parallel_codegen_split_count": 1,
}
"""Compiler options for a program run once per command (a net's fluid loads, its verdict, the
points where its panels touch): XLA's loop emitters instead of its MLIR fusion emitters, no LLVM
optimisation, and the program's code generated as one module rather than split for parallel
compilation (whose overhead outweighs it on programs this small). These programs compile in about
a third of the time (a cube net's eight: 6.0 s against 2.1 s on two cores), and their code, slower
per step, runs once (a warm fold no slower).
Both change the numbers in their last bits, so `exported_jit` compiles with them wherever it
compiles (a command's kept executable, a library call outside any trace): the command line and
the library give the same bits. Inside a trace the program is inlined, compiled with the
enclosing one."""

SOLVE_COMPILE = {"xla_cpu_use_fusion_emitters": False}
"""Compiler options for a top-level adaptive solve (`simulate` called outside any transformation
with a diffrax solver: a command's fold, a script's first result, both phases of the default
solver) and for the sweep kernels that run one (`Kernel.compiler_options`): XLA's loop emitters
instead of its MLIR fusion emitters, LLVM's optimisation kept. A cube net's fold (plate
contact, Tsit5) compiles in about two thirds of the time (8.8 s against 12.8 s, 7.4 against 10.9
on two loaded cores) and runs within a few per cent as fast (0–7 %, measured interleaved). The
fixed-step engine (`ImplicitStep`) keeps XLA's defaults: its programs compiled no sooner with
these and ran 7–10 % slower. Like `QUICK_COMPILE`, applied wherever the solve compiles at the top
level, the command line's kept executable and the library's call alike, so both give the same
bits."""

_IN_MEMORY: dict[tuple, tuple] = {}  # programs compiled with options outside a command, by key
_IN_MEMORY_LIMIT = 64  # the oldest is dropped past this many (a process folding many patterns)

# Code the key vouches for: this package by its source, the others by their versions.
_LIBRARIES = ("jax", "jaxlib", "equinox", "diffrax", "optimistix", "lineax", "jaxtyping", "numpy")
_VOUCHED = frozenset(
    {"origami_jax", *_LIBRARIES, "numpy", "builtins", "typing", "functools", "collections"}
)


def enable_exported_programs(folder: str | os.PathLike | None) -> Path | None:
    """Keep exported programs in `folder` (created if missing); `None` turns it off."""
    global _FOLDER
    if folder is None:
        _FOLDER = None
        return None
    path = Path(folder).expanduser()
    path.mkdir(parents=True, exist_ok=True)
    _FOLDER = path
    return path


def _flags() -> bytes:
    """The configuration that changes a trace: float64, the backend, equinox's runtime errors."""
    import jax

    return f"x64={jax.config.jax_enable_x64};{jax.default_backend()};{on_error()}".encode()


@functools.cache
def _environment() -> bytes:
    """Versions and this package's source: what, besides the arguments and `_flags`, decides a
    trace."""
    import importlib.metadata

    parts = [sys.version]
    for name in _LIBRARIES:
        try:
            parts.append(f"{name}={importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            parts.append(f"{name}=absent")
    digest = hashlib.sha256("\n".join(parts).encode())
    root = Path(__file__).resolve().parent
    for source in sorted(root.rglob("*.py")):
        digest.update(str(source.relative_to(root)).encode())
        digest.update(source.read_bytes())
    return digest.digest()


class _Unvouched(Exception):
    pass


class _KeyPickler(pickle.Pickler):
    """Pickles the arguments' static parts, refusing functions and classes whose code the key does
    not cover (pickle names them by module and name only: edited code would keep its key)."""

    def reducer_override(self, obj):
        module = getattr(obj, "__module__", None) if callable(obj) else type(obj).__module__
        if module is not None and module.split(".")[0] not in _VOUCHED:
            raise _Unvouched(module)
        # Values a `functools.cached_property` has filled in since (contact tables' packed pairs)
        # are derived from the rest: left out, so that a second call has the first one's key.
        cached = _cached_properties(type(obj))
        state = getattr(obj, "__dict__", None)
        if cached and isinstance(state, dict) and not cached.isdisjoint(state):
            kept = {name: value for name, value in state.items() if name not in cached}
            return copyreg.__newobj__, (type(obj),), kept
        return NotImplemented


@functools.cache
def _cached_properties(cls: type) -> frozenset[str]:
    """The names of `cls`'s `functools.cached_property` attributes."""
    return frozenset(
        name
        for klass in cls.__mro__
        for name, value in vars(klass).items()
        if isinstance(value, functools.cached_property)
    )


def _vouched_digest(name: str, obj):
    """A running SHA-256 of the versions, source and flags, `name` and `obj` pickled, or `None`
    when `obj` holds code the key cannot vouch for."""
    buffer = io.BytesIO()
    pickler = _KeyPickler(buffer, protocol=pickle.HIGHEST_PROTOCOL)
    # No memo: a value pickles alike whichever of its parts are one object (a field name a
    # module built in this process shares with its class, but one read back from disk does not).
    pickler.fast = True
    try:
        pickler.dump(obj)
    except Exception:  # unvouched code, a value that does not pickle, a cycle (no memo)
        return None
    digest = hashlib.sha256(_environment() + _flags())
    digest.update(name.encode())
    digest.update(buffer.getvalue())
    return digest


def _key(name: str, dynamic_leaves, static) -> str | None:
    """The entry's key (hex), or `None` when `static` holds code the key cannot vouch for."""
    digest = _vouched_digest(name, static)
    if digest is None:
        return None
    # Shapes and dtypes only: the export traces on `ShapeDtypeStruct`s, which carry no weak type,
    # so a leaf's weak type (a scalar a fresh trace returns weakly typed and an exported program
    # strongly: a solve's step counts) does not change the program and must not change its key.
    for leaf in dynamic_leaves:
        digest.update(f"{leaf.shape}{leaf.dtype}".encode())
    return digest.hexdigest()


def _equinox_missing():
    from equinox._module._flatten import MISSING

    return MISSING


class _RecordPickler(pickle.Pickler):
    """Pickles tree definitions, keeping equinox's "missing" sentinel the one object it is (its
    tree definitions test it by identity; a plain pickle would make a copy)."""

    def reducer_override(self, obj):
        if type(obj).__name__ == "_Missing" and type(obj).__module__.startswith("equinox"):
            return _equinox_missing, ()
        return NotImplemented


def _record(*parts) -> bytes:
    """`parts` pickled, tree definitions with equinox's sentinel (`_RecordPickler`)."""
    buffer = io.BytesIO()
    _RecordPickler(buffer, protocol=pickle.HIGHEST_PROTOCOL).dump(parts)
    return buffer.getvalue()


def _write_atomically(path: Path, data: bytes) -> None:
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
    try:
        with os.fdopen(handle, "wb") as file:
            file.write(data)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def exported_call(name: str, fn, jitted, *args, options: dict | None = None) -> Any:
    """`jitted(*args)`, through a program exported to disk when `enable_exported_programs` is on
    and the arguments' static parts can be vouched for (module docstring); with `options` and
    nothing kept on disk, compiled with them in memory (`_compiled_in_memory`), so that the
    numbers are the kept executable's.

    **Arguments:** `name`: the program's name (part of the key); `fn`: the plain function (traced
    for the export); `jitted`: its `equinox.filter_jit` version (the fallback); `args`: its
    arguments (pytrees of arrays and static values); `options`: XLA compiler options
    (`QUICK_COMPILE` for a program run once; default none: `jitted`'s).
    """
    import equinox as eqx
    import jax

    # Raised runtime errors call back into Python, which no exported program can.
    exporting = _FOLDER is not None and name not in _REFUSED and on_error() in ("nan", "off")
    if not (exporting or options):
        return jitted(*args)
    dynamic, static = eqx.partition(args, eqx.is_array)
    leaves, in_tree = jax.tree.flatten(dynamic)
    key = _key(name, leaves, (in_tree, static))
    if key is None:
        return jitted(*args)
    if not exporting:
        return _compiled_in_memory(name, key, fn, in_tree, static, leaves, options)
    path = _FOLDER / f"{name}-{key[:32]}.bin"
    options = options or {}
    compiled_path = _FOLDER / f"{name}-{_machine_key(key, options)}.xla"
    loaded = _loaded(compiled_path)
    if loaded is None:
        program, structure = _read_or_export(path, fn, in_tree, static, leaves)
        if program is None:
            _REFUSED.add(name)
            return exported_call(name, fn, jitted, *args, options=options)
        hits = _persistent_cache_hits()
        try:
            compiled = _compiled_here(program, leaves, options)
        except Exception:  # an entry this process cannot run (it should not happen)
            _REFUSED.add(name)
            return exported_call(name, fn, jitted, *args, options=options)
        # An executable read back from JAX's compilation cache serialises without its machine
        # code (`_compiled_here` keeps out of that cache; this guards it): kept only where
        # compiled here.
        if _persistent_cache_hits() == hits:
            _write_compiled(compiled_path, compiled, structure)
        loaded = compiled, structure
    _LOADED[compiled_path] = loaded
    try:
        return _run(*loaded, leaves)
    except Exception:  # an entry this process cannot run (it should not happen): trace as usual
        _LOADED.pop(compiled_path, None)
        compiled_path.unlink(missing_ok=True)
        _REFUSED.add(name)
        return exported_call(name, fn, jitted, *args, options=options)


def _run(compiled, structure, leaves):
    """The outputs of `compiled` (a flat program, `_flat_function`) on `leaves`, in the output
    structure `structure` it recorded."""
    import jax

    out_tree, constants = structure
    # An exported program's outputs are committed to its device, and a committed argument is
    # compiled into every program it reaches (its sharding annotated): the same values built by
    # `jitted`, or read back from disk (`remembered`), are not, and would make those programs
    # compile again under another key. Uncommitted copies (a few kB; waits for the results,
    # which the caller reads next, so that a kept executable that cannot run fails here).
    arrays = iter([_uncommitted(x) for x in compiled(*leaves)])
    out_leaves = [
        constants[i] if i in constants else next(arrays) for i in range(out_tree.num_leaves)
    ]
    return jax.tree.unflatten(out_tree, out_leaves)


def _compiled_in_memory(name: str, key: str, fn, in_tree, static, leaves, options: dict):
    """`fn` on the arguments (`leaves` in `in_tree`, with `static`) through a program compiled
    with `options`, kept in this process under `(name, key, options)`: what a command's kept
    executable computes, for a call with nothing kept on disk (the library, or runtime errors
    that raise)."""
    import jax

    memo = (name, key, tuple(sorted(options.items())))
    entry = _IN_MEMORY.pop(memo, None)
    if entry is None:
        flat, structure = _flat_function(fn, in_tree, static)
        shapes = [jax.ShapeDtypeStruct(leaf.shape, leaf.dtype) for leaf in leaves]
        entry = compiled_with(jax.jit(flat).lower(*shapes), options), structure
    _IN_MEMORY[memo] = entry  # the most recent last
    while len(_IN_MEMORY) > _IN_MEMORY_LIMIT:
        del _IN_MEMORY[next(iter(_IN_MEMORY))]
    compiled, structure = entry
    return _run(compiled, structure, leaves)


def _flat_function(fn, in_tree, static):
    """`fn` as a function of its arguments' array leaves returning a list of its output's array
    leaves, and its output structure `(out_tree, constants)` (filled in when it is traced; leaves
    that are Python constants, such as a flag diffrax keeps as a bool, ride in `constants`)."""
    import equinox as eqx
    import jax

    structure = [None, {}]

    def flat(*flat_leaves):
        dynamic_args = jax.tree.unflatten(in_tree, flat_leaves)
        out = fn(*eqx.combine(dynamic_args, static))
        # The output's structure by its tree definition (static fields are its auxiliary data);
        # pickled modules do not come back whole (equinox's enumerations).
        out_leaves, out_tree = jax.tree.flatten(out)
        constants = structure[1]
        for i, leaf in enumerate(out_leaves):
            if not eqx.is_array(leaf):
                if not isinstance(leaf, (bool, int, float, complex, str)):
                    raise TypeError(f"an output leaf is a {type(leaf).__name__}")
                constants[i] = leaf
        structure[0] = out_tree
        return [leaf for i, leaf in enumerate(out_leaves) if i not in constants]

    # Named after `fn`: the program's name in JAX's compilation cache (`jit__solve-...`), its
    # logs and profiles.
    flat.__name__ = flat.__qualname__ = getattr(fn, "__name__", "flat")
    return flat, structure


def _read_or_export(path: Path, fn, in_tree, static, leaves):
    """The exported program under `path` and its output structure, read back or traced (and kept);
    `(None, None)` where the function cannot be exported (host callbacks, unpicklable outputs)."""
    import jax

    if path.exists():
        try:
            blob, structure = pickle.loads(path.read_bytes())
            return jax.export.deserialize(blob), structure
        except Exception:  # a damaged or foreign entry: trace again and replace it
            pass
    flat, structure = _flat_function(fn, in_tree, static)
    shapes = [jax.ShapeDtypeStruct(leaf.shape, leaf.dtype) for leaf in leaves]
    try:
        program = jax.export.export(jax.jit(flat))(*shapes)
        structure = tuple(structure)
        record = _record(program.serialize(), structure)
    except Exception:  # host callbacks, unpicklable outputs, no serialiser: trace as usual
        return None, None
    try:
        _write_atomically(path, record)
    except OSError:  # an unwritable folder costs the next process a trace, not this result
        pass
    return program, structure


def _compiled_here(program, leaves, options: dict):
    """`program` compiled by XLA in this process for `leaves` with the compiler `options`: neither
    read from JAX's persistent compilation cache nor written to it (the kept executable is the one
    copy; an executable that cache reads back cannot be kept, as it serialises without its
    machine code). An explicit default option gives the compilation a key of its own, apart from
    entries an earlier version wrote there; the cache's threshold, raised for this call, keeps it
    out. Options this XLA does not know are dropped (compiled with its defaults)."""
    import jax

    return _compiled_outside_cache(jax.jit(program.call).lower(*leaves), options)


_CACHE_HIT_EVENT = "/jax/compilation_cache/cache_hits"
_cache_hits = [0]


def _count_cache_hit(event: str, **_) -> None:
    if event == _CACHE_HIT_EVENT:
        _cache_hits[0] += 1


@functools.cache
def _listen_for_cache_hits() -> None:
    import jax

    jax.monitoring.register_event_listener(_count_cache_hit)


def _persistent_cache_hits() -> int:
    """How many programs this process has read from JAX's persistent compilation cache."""
    _listen_for_cache_hits()
    return _cache_hits[0]


@functools.cache
def _machine() -> bytes:
    """What a compiled program is built for, besides its source: the processor's instruction set
    extensions (an executable built for others may not run here), the backend's version, its
    devices and XLA's flags."""
    import platform

    import jax

    features = platform.processor()
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            features = next((line for line in cpuinfo if line.startswith("flags")), features)
    except OSError:
        pass
    device = jax.devices()[0]
    parts = (
        platform.machine(),
        features,
        device.client.platform_version,
        device.device_kind,
        str(jax.device_count()),
        os.environ.get("XLA_FLAGS", ""),
    )
    return "\n".join(parts).encode()


def _machine_key(key: str, options: dict) -> str:
    """The compiled program's key: the traced program's, the compiler options and the machine's
    (`_machine`)."""
    digest = hashlib.sha256(key.encode() + _machine())
    digest.update(repr(sorted(options.items())).encode())
    return digest.hexdigest()[:32]


def _loaded(path: Path):
    """The executable kept under `path` as `_read_compiled` gives it: already in this process,
    being read in the background (`prefetch`: waited for), or read now. Noted as used."""
    _USED.setdefault(path)
    if path in _LOADED:
        return _LOADED[path]
    reading = _READING.pop(path, None)
    if reading is not None:
        try:
            return reading.result()
        except Exception:  # read here instead
            pass
    return _read_compiled(path)


def prefetch(paths) -> None:
    """Start reading the kept executables `paths` on a background thread, in order (XLA rebuilds
    each one's HLO module as it loads it, 0.1-1.5 s apiece on two cores, without holding Python's
    lock): a command that knows what it will run loads it while it builds, solves and judges.
    Those already read or being read are skipped."""
    import concurrent.futures

    global _READER
    todo = [p for p in paths if p not in _LOADED and p not in _READING and p.exists()]
    if not todo:
        return
    if _READER is None:
        _READER = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="origami-prefetch")
    for path in todo:
        _READING[path] = _READER.submit(_read_compiled, path)


def _uses_path(anchor: Path) -> Path:
    return anchor.with_suffix(".uses")


def note_programs_used() -> None:
    """Record, beside the value this process last `remembered` with `prefetch_after` (a command's
    system), the kept executables it has run since, in order, so that a later process reading that
    value back prefetches them (`prefetch`); and the same under the command line's words where
    `prefetch_for_command` was called (without such a value: every executable the process ran).
    Off where neither applies or nothing is kept."""
    if _FOLDER is None or (_ANCHOR is None and _HINT is None):
        return
    names = "\n".join(p.name for p in _USED).encode()
    beside = None if _ANCHOR is None else _uses_path(_ANCHOR)
    for path in filter(None, (beside, _HINT)):
        try:
            _write_atomically(path, names)
        except OSError:
            pass


def prefetch_for_command(argv) -> None:
    """`prefetch` what the last run of the same command line (`argv`, every word) ran, as
    `note_programs_used` noted it: called as soon as JAX is imported, before the command builds
    anything, so that a rerun reads its executables while it imports and sets up. A hint only (a
    command line whose inputs changed since names executables it may not run: read for nothing,
    in the background). The output folder (`--out`) is not part of the command line's key: it
    decides where results go, not what runs (a yield or sweep is rerun into a new folder). Off
    where nothing is kept."""
    global _HINT
    if _FOLDER is None:
        return
    words = _without_output_folder(list(map(str, argv)))
    digest = hashlib.sha256("\0".join(words).encode() + _environment()).hexdigest()
    _HINT = _FOLDER / f"command-{digest[:32]}.uses"
    _prefetch_listed(_HINT)


def _without_output_folder(words: list[str]) -> list[str]:
    """A command line's words without its ``--out FOLDER`` (or ``--out=FOLDER``)."""
    kept, skip = [], False
    for word in words:
        if skip:
            skip = False
        elif word == "--out":
            skip = True
        elif not word.startswith("--out="):
            kept.append(word)
    return kept


def _prefetch_listed(path: Path) -> None:
    """`prefetch` the executables a `.uses` file at `path` lists (file names in `_FOLDER`)."""
    try:
        names = path.read_text().split()
    except OSError:
        return
    prefetch([_FOLDER / name for name in names if name.endswith(".xla") and "/" not in name])


def _read_compiled(path: Path):
    """The compiled program `_write_compiled` kept under `path` and what was kept with it, or
    `None` (none kept, or damaged: compiled again and replaced)."""
    if not path.exists():
        return None
    import jax
    from jax._src.lax import linalg
    from jax.experimental import serialize_executable

    try:
        record = pickle.loads(zlib.decompress(path.read_bytes()))
        executable, in_tree, out_tree, uses_lapack, extra = record
        # Programs solving linear systems on the CPU call LAPACK through handlers that JAX sets
        # up while lowering one; a program read back was never lowered in this process. Only
        # those: setting them up imports SciPy's BLAS (0.15-0.2 s of a warm command).
        if uses_lapack:
            linalg.initialize_lapack()
        device = jax.devices()[0]
        compiled = serialize_executable.deserialize_and_load(
            executable, in_tree, out_tree, device.client, [device]
        )
    except Exception:
        return None
    return compiled, extra


def _write_compiled(path: Path, compiled, extra=None) -> None:
    """Keep `compiled` (a `jax.stages.Compiled` on one device) under `path`, with its argument and
    output tree definitions, whether it calls LAPACK (a custom call's target in its executable)
    and `extra` (an exported program's output structure); a program that does not serialise, or
    an unwritable folder, costs the next process its compilation only."""
    from jax.experimental import serialize_executable

    try:
        executable, in_tree, out_tree = serialize_executable.serialize(compiled)
        uses_lapack = _LAPACK_CALL.search(executable) is not None
        record = _record(executable, in_tree, out_tree, uses_lapack, extra)
        _write_atomically(path, zlib.compress(record))  # machine code: an eighth of its size
    except Exception:
        pass


def _uncommitted(x):
    """An uncommitted copy of the array `x` (itself where it has no host copy: a typed PRNG key)."""
    import jax
    import numpy as np

    try:
        return jax.device_put(np.asarray(x))
    except TypeError:
        return x


def kept_compiled(name: str, identity, lower, options: Mapping[str, Any] | None = None) -> Any:
    """`lower().compile()` (`lower` returns a `jax.stages.Lowered` for one device), with the
    compiler options `options` (`compiled_with`), kept on disk where `enable_exported_programs`
    keeps the programs: a later process with the same `identity` and options reads the executable
    back without tracing, lowering or compiling.

    **Arguments:** `name`: what is kept (part of the key); `identity`: everything that decides the
    program besides this package's source, the libraries' versions, the configuration flags and
    the machine (its function's inputs, static settings and argument shapes), pickled for the key
    and refused like `exported_call`'s static parts where it holds code the key cannot vouch for
    (then compiled as usual, nothing kept); `lower`: makes the lowering (traces the program);
    `options`: XLA compiler options (default none: XLA's defaults).

    **Returns:** a callable like the compiled program (its calls, `memory_analysis`), which, should
    a kept executable fail when run, removes it and compiles the program again.
    """
    options = dict(options or {})
    digest = None if _FOLDER is None else _vouched_digest(name, identity)
    if digest is None:
        return compiled_with(lower(), options)
    path = _FOLDER / f"{name}-{_machine_key(digest.hexdigest(), options)}.xla"
    loaded = _loaded(path)
    if loaded is None:
        lowered = lower()
        hits = _persistent_cache_hits()
        loaded = _compiled_outside_cache(lowered, options), None
        if _persistent_cache_hits() == hits:  # see `exported_call`
            _write_compiled(path, loaded[0])
    _LOADED[path] = loaded
    return _KeptCall(loaded[0], path, lambda: compiled_with(lower(), options))


class _KeptCall:
    """A compiled program read from (or written to) disk by `kept_compiled`; one that fails when
    run is removed and replaced by a fresh compilation, once, for every thread calling it."""

    def __init__(self, compiled, path: Path, compile_again):
        import threading

        self._compiled, self._path, self._compile_again = compiled, path, compile_again
        self._lock = threading.Lock()
        self._replaced = False

    def __call__(self, *args):
        compiled = self._compiled
        try:
            return compiled(*args)
        except Exception:  # a kept executable this process cannot run (it should not happen)
            if self._replaced:
                raise
        with self._lock:
            if self._compiled is compiled:
                _LOADED.pop(self._path, None)
                self._path.unlink(missing_ok=True)
                self._compiled = self._compile_again()
                self._replaced = True
        return self._compiled(*args)

    def memory_analysis(self):
        return self._compiled.memory_analysis()


def _compiled_outside_cache(lowered, options: dict):
    """`lowered` compiled with `options` (those this XLA does not know dropped), neither read from
    JAX's persistent compilation cache nor written to it (`_compiled_here` says why)."""
    import jax

    threshold = jax.config.jax_persistent_cache_min_compile_time_secs
    jax.config.update("jax_persistent_cache_min_compile_time_secs", float("inf"))
    try:
        return compiled_with(lowered, options, base=_OWN_KEY)
    finally:
        jax.config.update("jax_persistent_cache_min_compile_time_secs", threshold)


def compiled_with(lowered, options: Mapping[str, Any] | None, base: dict | None = None):
    """`lowered` (a `jax.stages.Lowered`) compiled with the compiler options `base` and `options`,
    or, where this XLA does not know one of `options`, with `base` alone (its defaults)."""
    options = dict(options or {})
    try:
        return lowered.compile(compiler_options={**(base or {}), **options})
    except Exception:
        if not options:
            raise
        return lowered.compile(compiler_options=base)


def remembered(name: str, build, *inputs, prefetch_after: bool = False) -> Any:
    """`build()`, or the value an earlier process built under the same key, read from disk where
    `enable_exported_programs` keeps the programs (off: `build()`).

    `prefetch_after`: the value starts a command's work (its system): the kept executables a
    process runs after it are noted beside it (`note_programs_used`), and a later process that
    reads it back starts reading them at once, in the background (`prefetch`).

    **Arguments:** `name`: what is kept (part of the key); `build`: makes the value, a
    deterministic function of `inputs` that pickles (one that does not is built each time);
    `inputs`: everything that decides it, pickled for the key (arrays by their contents), and
    refused like `exported_call`'s static parts where they hold code the key cannot vouch for
    (then `build()` is called and nothing is kept).
    """
    global _ANCHOR
    digest = None if _FOLDER is None else _vouched_digest(name, inputs)
    if _FOLDER is None or digest is None:
        return build()
    path = _FOLDER / f"{name}-{digest.hexdigest()[:32]}.pkl"
    if prefetch_after:  # what runs from here on is what this value's next reader will need
        _ANCHOR = path
        _USED.clear()
    if path.exists():
        try:
            value = pickle.loads(path.read_bytes())
        except Exception:  # a damaged or foreign entry: build again and replace it
            pass
        else:
            if prefetch_after:
                _prefetch_listed(_uses_path(path))
            return value
    value = build()
    try:
        _write_atomically(path, pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))
    except Exception:  # an unwritable folder, a value that does not pickle: the next process builds
        pass
    return value


def exported_jit(name: str, *, by_value: bool = False):
    """A decorator: the function compiled with `QUICK_COMPILE` (a program run once per command),
    called outside any trace through `exported_call` under `name` (its traced program read from
    disk where the command line keeps them, else compiled in memory; with arguments the key cannot
    vouch for, `equinox.filter_jit`'s compilation); inside a trace (`jit`, `vmap`, `grad`) it is
    the `equinox.filter_jit` function, traced inline, the decorated one's `jitted` attribute.

    `by_value`: where the command line keeps its programs, a call's value is kept too, under its
    arguments' values (`remembered`), and a later process given the same arguments reads it
    instead of loading and running the program (loading a kept executable costs about 0.1-0.3 s
    on two cores, rebuilding its HLO module). For programs of a pattern and its design, which a
    command reruns alike whatever its run (a net's masses at rest, its seams' tolerances); the
    value is the program's own, the same bits."""
    import equinox as eqx
    import jax
    import numpy as np

    def decorate(fn):
        jitted = eqx.filter_jit(fn)

        def computed(*args):
            return exported_call(name, fn, jitted, *args, options=QUICK_COMPILE)

        def kept(*args):
            def build():  # kept on the host: read back, it is put on no device
                return jax.tree.map(np.asarray, computed(*args))

            # Put on the device, not converted (`jnp.asarray` compiles a program per shape).
            return jax.device_put(remembered(name, build, *args))

        @functools.wraps(fn)
        def call(*args):
            if any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(args)):
                return jitted(*args)
            if by_value and _FOLDER is not None:
                return kept(*args)
            return computed(*args)

        call.jitted = jitted
        return call

    return decorate
