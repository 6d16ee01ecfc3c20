"""One lock per output folder, taken by everything that writes results into it: a sweep's store
(`origami_jax.sweep`) and every command line run (`fold`, `simulate`, `yield`, ...).

The lock is an advisory `flock` on the folder's `.lock` file, held for as long as the writer runs,
so that two runs into one folder cannot interleave their files (the second is refused with one
line naming the first). The operating system releases it when the process ends, killed or not. The
file names its holder (command, process id, host, start time) for the message; it is not removed
(removing a lock file while another process opens it would let two processes hold two locks),
except by a command line run that created its folder and leaves it holding nothing else: it removes
the lock file and the folder while it still holds the lock (`cli._common.OutputFolder`).

A command that holds its folder for its whole run may lend the lock to the library calls it makes
in the same process (`lend=True`: `yield` holds its folder and its estimates open their sweep store
there); a lock taken without lending refuses every other taker, in this process too.
"""

from __future__ import annotations

import os
import socket
import threading
import time
from pathlib import Path

LOCK = ".lock"


class FolderBusyError(RuntimeError):
    """The folder is in use by another run (it holds the folder's lock)."""


# Locks this process holds, by the folder's real path: [open file, holders, lent].
_held: dict[str, list] = {}
_guard = threading.Lock()


class FolderLock:
    """A held folder lock; `close()` releases it (the last holder's close unlocks the file)."""

    def __init__(self, key: str):
        self._key: str | None = key

    def close(self) -> None:
        with _guard:
            key, self._key = self._key, None
            entry = None if key is None else _held.get(key)
            if entry is None:
                return
            entry[1] -= 1
            if entry[1] <= 0:
                entry[0].close()
                del _held[key]

    def __enter__(self) -> FolderLock:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def lock_folder(
    root: str | os.PathLike, *, command: str, lend: bool = False, error=FolderBusyError
) -> FolderLock:
    """Take the lock of the folder `root` (which must exist) for `command` (named in the message
    another taker gets).

    **Arguments:**
    - `lend`: let later takers in this process share it (module docstring).
    - `error`: the exception class raised when the folder is busy.

    **Raises:** `error` (one line naming the holder) when another run holds the folder.
    """
    import fcntl

    root = Path(root)
    key = os.path.realpath(root)
    with _guard:
        entry = _held.get(key)
        if entry is not None:
            if entry[2]:
                entry[1] += 1
                return FolderLock(key)
            raise error(_busy(root, _holder(entry[0])))
        handle = open(root / LOCK, "a+")  # noqa: SIM115 (held open while the lock is held)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = _holder(handle)
            handle.close()
            raise error(_busy(root, holder)) from None
        handle.seek(0)
        handle.truncate()
        handle.write(
            f"{command}, pid {os.getpid()} on {socket.gethostname()}, since "
            f"{time.strftime('%Y-%m-%d %H:%M:%S')}\n"
        )
        handle.flush()
        _held[key] = [handle, 1, lend]
        return FolderLock(key)


def _holder(handle) -> str:
    handle.seek(0)
    return handle.read().strip() or "another process"


def _busy(root: Path, holder: str) -> str:
    command = holder.split(",")[0] if "," in holder else "other"
    return (
        f"{root} is in use by another {command} run ({holder}); wait for it to finish, or choose "
        "another output folder."
    )
