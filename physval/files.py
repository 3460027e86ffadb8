"""Atomic file writes: every file is written to a temporary name beside its target and
moved into place, so an interrupt never leaves a half-written file (and no temporary file
stays behind); and the lock by which one command at a time writes into an output folder.
Kept apart from the report kit so that the row store needs neither pandas nor matplotlib."""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


def write_atomic(path: Path, data: str | bytes) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode() if isinstance(data, str) else data)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a report is for reading
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


LOCK_FILE = ".physval.lock"


class FolderBusy(RuntimeError):
    """Another process holds the folder's lock: `pid` is its process id ("" if not yet written)."""

    def __init__(self, folder: Path, pid: str):
        super().__init__(f"{folder} is held by process {pid or '(unknown)'}")
        self.folder, self.pid = folder, pid


@contextmanager
def folder_lock(folder: Path):
    """Hold `folder` for this process alone: an advisory lock (flock) on LOCK_FILE in it,
    which holds this process's id. FolderBusy at once if another process holds it. Released
    on every way out, and by the system when the process dies however it dies; the file is
    removed on release (a process that opened it meanwhile finds that, and opens it anew).
    Without fcntl (Windows) nothing is locked."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    path = Path(folder) / LOCK_FILE
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                pid = os.read(fd, 32).decode(errors="replace").strip()
            finally:
                os.close(fd)
            raise FolderBusy(Path(folder), pid) from None
        except BaseException:
            os.close(fd)
            raise
        try:  # the lock of a file its last holder removed meanwhile holds nothing
            current = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            current = False
        if current:
            break
        os.close(fd)
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield
    finally:
        try:
            os.unlink(path)  # before the unlock: whoever locks it next checks it is still there
        except OSError:
            pass
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)
