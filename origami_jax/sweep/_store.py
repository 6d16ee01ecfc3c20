"""On-disk store of a sweep: a folder of NetCDF chunk files and a manifest.

Layout of `out/`:

- `sweep.json`: the manifest: what is being swept (kernel name and settings, the design space's
  description and a SHA-256 of its values, output names, shapes and units). `resume=True` refuses to
  continue when the new sweep's manifest differs.
- `.lock`: held (an advisory `flock`) by the process that writes the store for as long as the sweep
  runs, so that a second sweep on the same folder (a `--resume` started while the first still runs)
  is refused instead of computing the same designs again. The operating system releases it when the
  process ends, killed or not; it names the holder (process id, host, start time) for the message.
- `chunks/part-<first design>-<count>.nc`: one NetCDF4 file (h5netcdf) per finished chunk, written to
  a temporary name and renamed into place, so a file either holds a whole chunk or does not exist.
  Killing the process at any moment therefore loses at most the chunk being computed.
- `sweep.nc`: all chunks gathered, sorted by design index; written when the sweep completes.

Every file is encoded in memory and then written with plain file operations: a write that fails (a
full disk, Ctrl-C) removes its temporary file and leaves no HDF5 handle open (an open handle to a
half-written file crashed the interpreter at exit).

When a sweep resumes, the stored chunks are checked before anything is computed: a file that cannot
be read, or whose designs are not the sweep's (wrong indices or parameter values) or are already in
another file, is moved aside as `chunks/<name>.bad` with a warning naming it, and its designs are
computed again. The gathered dataset is checked to hold every design exactly once.

Why a folder of files rather than one growing file: HDF5 files are not crash-safe while open for
writing (a kill during a write can corrupt the whole file), and NetCDF has no atomic append. A rename
is atomic on POSIX file systems, including the shared ones multi-host runs write to.
"""

import json
import logging
import os
import uuid
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .._folder_lock import FolderBusyError, lock_folder
from ._space import config_equal

MANIFEST = "sweep.json"
CHUNKS = "chunks"
RESULT = "sweep.nc"
ENGINE = "h5netcdf"
BAD_SUFFIX = ".bad"

logger = logging.getLogger("origami_jax.sweep")


class SweepBusyError(FolderBusyError):
    """The output folder is in use by another running sweep or command (it holds the folder's
    lock)."""


def write_atomic(path: Path, data: bytes | str) -> Path:
    """Write `data` to `path` through a temporary file in the same folder and a rename; on any
    failure the temporary file is removed and the error re-raised (with the path in its message)."""
    path = Path(path)
    tmp = path.with_name(f".tmp-{os.getpid()}-{uuid.uuid4().hex}-{path.name}")
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        with open(tmp, "wb") as handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except OSError as error:
        tmp.unlink(missing_ok=True)
        raise OSError(
            error.errno,
            f"could not write {path}: {error.strerror or error}. Whatever was stored before is "
            "intact; free the space (or fix the folder) and resume the sweep",
        ) from error
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def netcdf_bytes(dataset: xr.Dataset) -> bytes:
    """`dataset` as NetCDF4 bytes, written without the encodings it was read with (a string
    coordinate read from a chunk carries that chunk's fixed width, which truncated longer labels)."""
    dataset = dataset.copy()
    for variable in dataset.variables.values():
        variable.encoding = {}
    return bytes(dataset.to_netcdf(engine=ENGINE))


def _differences(old: Mapping[str, Any], new: Mapping[str, Any], prefix: str = "") -> list[str]:
    keys = sorted(set(old) | set(new))
    lines = []
    for key in keys:
        where = f"{prefix}{key}"
        if key not in old or key not in new:
            lines.append(f"{where}: only in the {'stored' if key in old else 'new'} sweep")
        elif isinstance(old[key], Mapping) and isinstance(new[key], Mapping):
            lines += _differences(old[key], new[key], prefix=f"{where}.")
        elif not config_equal({"v": old[key]}, {"v": new[key]}):
            stored, given = json.dumps(old[key]), json.dumps(new[key])
            if len(stored) + len(given) > 200:
                stored, given = stored[:90] + "...", given[:90] + "..."
            lines.append(f"{where}: stored {stored}, new {given}")
    return lines


# What a difference of the design space's digest means to a user (its other entries name the
# parameters, ranges and counts).
_SPACE_VALUES = "space.sha256"


def _summary(lines: list[str], limit: int = 3) -> str:
    """The differences of `_differences` on one line: the design space's digest as what it is (its
    values differ), at most `limit` of them, then how many more."""
    lines = [
        "the design space's values differ: for a yield estimate, --samples, --seed, --scatter, "
        "--process or the release times"
        if line.startswith(f"{_SPACE_VALUES}:")
        else line
        for line in lines
    ]
    shown = "; ".join(lines[:limit])
    return shown + (f"; and {len(lines) - limit} more" if len(lines) > limit else "")


def _lock(root: Path):
    """Take the folder's lock (see the module docstring; the same lock every command that writes
    results takes, `origami_jax._folder_lock`); return it (`close()` releases it)."""
    return lock_folder(root, command="sweep", error=SweepBusyError)


class Store:
    """A sweep's folder (see the module docstring). Created by `Store.open`; `close()` releases the
    folder's lock."""

    def __init__(self, root: Path, manifest: Mapping[str, Any], lock=None):
        self.root = root
        self.manifest = dict(manifest)
        self.chunks = root / CHUNKS
        self._lock = lock

    @classmethod
    def open(
        cls, root: str | os.PathLike, manifest: Mapping[str, Any], *, resume: bool, writer: bool
    ) -> "Store":
        """Open or create the store, checking an existing one against `manifest`. The writer takes
        the folder's lock first.

        **Raises:**
        - `SweepBusyError` if another sweep holds the folder (writer only).
        - `FileExistsError` if the folder already holds a sweep and `resume` is False.
        - `ValueError` if `resume` is True and the stored sweep is a different one.
        """
        root = Path(root)
        manifest = json.loads(json.dumps(manifest))
        path = root / MANIFEST
        lock = None
        if writer:
            if root.exists() and not root.is_dir():
                raise FileExistsError(f"{root} is a file, not a folder: choose an output folder.")
            root.mkdir(parents=True, exist_ok=True)
            lock = _lock(root)
        try:
            if path.exists():
                try:
                    stored = json.loads(path.read_text())
                except ValueError as error:
                    raise ValueError(
                        f"{path} is not readable JSON ({error}); it is not a sweep's manifest."
                    ) from None
                if not resume:
                    raise FileExistsError(
                        f"{root} already holds a sweep. Pass resume=True (CLI: --resume) to "
                        "continue it, or choose another output folder."
                    )
                if not config_equal(stored, manifest):
                    raise ValueError(
                        f"cannot resume: {root} holds a different sweep "
                        f"({_summary(_differences(stored, manifest))}); resume with the same model, "
                        "settings and design space, or choose another output folder."
                    )
            elif writer:
                write_atomic(path, json.dumps(manifest, indent=2, sort_keys=True))
            store = cls(root, manifest, lock)
            if writer:
                store.chunks.mkdir(parents=True, exist_ok=True)
                for stale in store.chunks.glob(".tmp-*"):
                    stale.unlink(missing_ok=True)
                for stale in root.glob(".tmp-*"):
                    stale.unlink(missing_ok=True)
        except BaseException:
            if lock is not None:
                lock.close()
            raise
        return store

    def close(self) -> None:
        """Release the folder's lock (the writer's)."""
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def chunk_files(self) -> list[Path]:
        return sorted(self.chunks.glob("part-*.nc"))

    def scan(self, columns: Mapping[str, np.ndarray], *, repair: bool) -> np.ndarray:
        """Boolean mask of the designs stored, shape `(n_designs,)`, from chunk files that are
        readable, hold designs of this sweep (indices in range, parameter values equal to
        `columns`') and no design of an earlier file. With `repair`, the others are moved aside as
        `<name>.bad`, with a warning naming them; their designs count as not stored."""
        n_designs = len(next(iter(columns.values())))
        done = np.zeros(n_designs, dtype=bool)
        for path in self.chunk_files():
            problem = None
            try:
                designs, values = _read_index(path, list(columns))
            except Exception as error:  # any unreadable file: HDF5, NetCDF or missing variables
                problem = f"unreadable ({type(error).__name__}: {str(error).splitlines()[0]})"
            else:
                problem = _foreign(designs, values, columns, done)
            if problem is None:
                done[designs] = True
                continue
            if repair:
                bad = path.with_name(path.name + BAD_SUFFIX)
                os.replace(path, bad)
                logger.warning(
                    "sweep: chunk file %s is %s; moved aside to %s, its designs will be computed "
                    "again.",
                    path,
                    problem,
                    bad.name,
                )
        return done

    def done_mask(self, n_designs: int) -> np.ndarray:
        """Boolean mask of the designs stored in readable chunk files, shape `(n_designs,)`."""
        done = np.zeros(n_designs, dtype=bool)
        for path in self.chunk_files():
            try:
                designs, _ = _read_index(path, [])
            except Exception:
                continue
            done[designs[(designs >= 0) & (designs < n_designs)]] = True
        return done

    def chunk_sizes(self) -> set[int]:
        """The compiled chunk sizes the stored designs were computed with (each file's
        `chunk_size` attribute; files written before it was recorded, or unreadable, give none)."""
        import h5netcdf

        sizes = set()
        for path in self.chunk_files():
            try:
                with h5netcdf.File(path, "r") as file:
                    size = file.attrs.get("chunk_size")
            except Exception:
                continue
            if size is not None:
                sizes.add(int(np.asarray(size).reshape(-1)[0]))
        return sizes

    def write_chunk(self, chunk: xr.Dataset) -> Path:
        """Write one finished chunk atomically; return its path."""
        designs = chunk["design"].values
        name = f"part-{int(designs[0]):09d}-{len(designs):06d}.nc"
        return write_atomic(self.chunks / name, netcdf_bytes(chunk))

    def gather(self, *, write: bool, columns: Mapping[str, np.ndarray] | None = None) -> xr.Dataset:
        """All stored chunks as one dataset sorted by design; written to `sweep.nc` if `write`.
        With `columns`, checked to hold every design of the sweep exactly once, with its
        parameter values."""
        dataset = gather([xr.load_dataset(p, engine=ENGINE) for p in self.chunk_files()])
        if columns is not None:
            check_complete(dataset, columns, where=str(self.chunks))
        if write:
            write_atomic(self.root / RESULT, netcdf_bytes(dataset))
        return dataset


def store_result(out: str | os.PathLike, dataset: xr.Dataset) -> Path:
    """Write `dataset` as the store `out`'s `sweep.nc`, atomically: for a caller that ran some of
    a finished sweep's designs again (a longer run, a larger step budget) and merged them in, so
    that the store's gathered file holds the results as reported. The chunks are left as they
    are (a resumed sweep gathers them again). Returns the file's path."""
    return write_atomic(Path(out) / RESULT, netcdf_bytes(dataset))


def _read_index(path: Path, names: list[str]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    import h5netcdf

    with h5netcdf.File(path, "r") as file:
        designs = np.asarray(file.variables["design"][:], dtype=np.int64)
        values = {name: np.asarray(file.variables[name][:]) for name in names}
    return designs, values


def _same(stored: np.ndarray, expected: np.ndarray) -> bool:
    if expected.dtype.kind == "U":
        stored = np.asarray([s.decode() if isinstance(s, bytes) else str(s) for s in stored])
        return bool(np.array_equal(stored, expected))
    return bool(np.array_equal(stored.astype(expected.dtype), expected, equal_nan=True))


def _foreign(
    designs: np.ndarray,
    values: Mapping[str, np.ndarray],
    columns: Mapping[str, np.ndarray],
    done: np.ndarray,
) -> str | None:
    """Why a chunk's designs are not this sweep's (or already stored), or `None`."""
    n_designs = len(done)
    if designs.ndim != 1 or len(designs) == 0:
        return "empty"
    if (
        np.any(designs < 0)
        or np.any(designs >= n_designs)
        or len(np.unique(designs)) < len(designs)
    ):
        return f"not a chunk of this sweep (design indices outside 0..{n_designs - 1} or repeated)"
    for name, column in columns.items():
        if not _same(values[name], column[designs]):
            return f"not a chunk of this sweep (its {name!r} values differ)"
    if np.any(done[designs]):
        return "a duplicate (its designs are already in another chunk file)"
    return None


def check_complete(dataset: xr.Dataset, columns: Mapping[str, np.ndarray], where: str) -> None:
    """`dataset` holds designs `0 .. n-1` exactly once each, with the parameter values of
    `columns`; a `ValueError` naming what is wrong otherwise."""
    n_designs = len(next(iter(columns.values())))
    designs = np.asarray(dataset["design"].values, dtype=np.int64)
    unique, counts = np.unique(designs, return_counts=True)
    repeated = unique[counts > 1]
    missing = np.setdiff1d(np.arange(n_designs), unique)
    extra = unique[(unique < 0) | (unique >= n_designs)]
    if len(repeated) or len(missing) or len(extra):
        parts = []
        if len(repeated):
            parts.append(f"{len(repeated)} designs stored more than once (e.g. {repeated[:5]})")
        if len(missing):
            parts.append(f"{len(missing)} designs missing (e.g. {missing[:5]})")
        if len(extra):
            parts.append(f"{len(extra)} design indices outside the sweep (e.g. {extra[:5]})")
        raise ValueError(
            f"the chunks in {where} do not hold each of the {n_designs} designs exactly once: "
            + "; ".join(parts)
            + ". Resume the sweep to recompute what is missing."
        )
    for name, column in columns.items():
        if not _same(np.asarray(dataset[name].values), column[designs]):
            raise ValueError(
                f"the chunks in {where} hold {name!r} values that are not this sweep's; resume the "
                "sweep to check and recompute its chunks."
            )


def gather(chunks: Iterable[xr.Dataset], *, path: Path | None = None) -> xr.Dataset:
    """Concatenate chunk datasets along `design`, sort by design index, optionally write."""
    chunks = list(chunks)
    if not chunks:
        raise ValueError("no chunks to gather: the sweep computed nothing.")
    dataset = xr.concat(
        chunks, dim="design", data_vars="all", coords="minimal", compat="override", join="exact"
    )
    dataset = dataset.sortby("design")
    if path is not None:
        write_atomic(path, netcdf_bytes(dataset))
    return dataset
