"""On-disk store of a sweep: a folder of NetCDF chunk files and a manifest.

Layout of `out/`:

- `sweep.json`: the manifest: what is being swept (kernel name and settings, the design space's
  description and a SHA-256 of its values, output names, shapes and units). `resume=True` refuses to
  continue when the new sweep's manifest differs.
- `chunks/part-<first design>-<count>.nc`: one NetCDF4 file (h5netcdf) per finished chunk, written to
  a temporary name and renamed into place, so a file either holds a whole chunk or does not exist.
  Killing the process at any moment therefore loses at most the chunk being computed.
- `sweep.nc`: all chunks gathered, sorted by design index; written when the sweep completes.

Why a folder of files rather than one growing file: HDF5 files are not crash-safe while open for
writing (a kill during a write can corrupt the whole file), and NetCDF has no atomic append. A rename
is atomic on POSIX file systems, including the shared ones multi-host runs write to.
"""

import json
import os
import uuid
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._space import config_equal

MANIFEST = "sweep.json"
CHUNKS = "chunks"
RESULT = "sweep.nc"
ENGINE = "h5netcdf"


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".tmp-{os.getpid()}-{uuid.uuid4().hex}-{path.name}")
    tmp.write_text(text)
    os.replace(tmp, path)


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


class Store:
    """A sweep's folder (see the module docstring). Created by `Store.open`."""

    def __init__(self, root: Path, manifest: Mapping[str, Any]):
        self.root = root
        self.manifest = dict(manifest)
        self.chunks = root / CHUNKS

    @classmethod
    def open(
        cls, root: str | os.PathLike, manifest: Mapping[str, Any], *, resume: bool, writer: bool
    ) -> "Store":
        """Open or create the store, checking an existing one against `manifest`.

        **Raises:**
        - `FileExistsError` if the folder already holds a sweep and `resume` is False.
        - `ValueError` if `resume` is True and the stored sweep is a different one.
        """
        root = Path(root)
        manifest = json.loads(json.dumps(manifest))
        path = root / MANIFEST
        if path.exists():
            stored = json.loads(path.read_text())
            if not resume:
                raise FileExistsError(
                    f"{root} already holds a sweep. Pass resume=True (CLI: --resume) to continue "
                    "it, or choose another output folder."
                )
            if not config_equal(stored, manifest):
                lines = "\n  ".join(_differences(stored, manifest))
                raise ValueError(
                    f"cannot resume: {root} holds a different sweep. Differences:\n  {lines}\n"
                    "Resume with the same model, settings and design space, or choose another "
                    "output folder."
                )
        elif writer:
            root.mkdir(parents=True, exist_ok=True)
            _atomic_write_text(path, json.dumps(manifest, indent=2, sort_keys=True))
        store = cls(root, manifest)
        if writer:
            store.chunks.mkdir(parents=True, exist_ok=True)
            for stale in store.chunks.glob(".tmp-*"):
                stale.unlink(missing_ok=True)
        return store

    def chunk_files(self) -> list[Path]:
        return sorted(self.chunks.glob("part-*.nc"))

    def done_mask(self, n_designs: int) -> np.ndarray:
        """Boolean mask of the designs already stored, shape `(n_designs,)`."""
        import h5netcdf

        done = np.zeros(n_designs, dtype=bool)
        for path in self.chunk_files():
            with h5netcdf.File(path, "r") as file:
                done[np.asarray(file.variables["design"][:], dtype=np.int64)] = True
        return done

    def write_chunk(self, chunk: xr.Dataset) -> Path:
        """Write one finished chunk atomically; return its path."""
        designs = chunk["design"].values
        name = f"part-{int(designs[0]):09d}-{len(designs):06d}.nc"
        path = self.chunks / name
        tmp = self.chunks / f".tmp-{os.getpid()}-{uuid.uuid4().hex}.nc"
        chunk.to_netcdf(tmp, engine=ENGINE)
        os.replace(tmp, path)
        return path

    def gather(self, *, write: bool) -> xr.Dataset:
        """All stored chunks as one dataset sorted by design; written to `sweep.nc` if `write`."""
        return gather(
            [xr.load_dataset(p, engine=ENGINE) for p in self.chunk_files()],
            path=self.root / RESULT if write else None,
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
        tmp = path.with_name(f".tmp-{os.getpid()}-{uuid.uuid4().hex}-{path.name}")
        dataset.to_netcdf(tmp, engine=ENGINE)
        os.replace(tmp, path)
    return dataset
