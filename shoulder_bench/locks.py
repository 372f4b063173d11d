"""An exclusive per-folder lock, so that two processes never write the same outputs (a training run folder, a
folder of FEM tables)."""
from __future__ import annotations

import fcntl
import os
import socket
import time
from pathlib import Path

LOCK = ".lock"


class FolderLock:
    """An exclusive OS lock (flock) on `<folder>/.lock`, naming its holder; ValueError if another process has it.
    `what`: how the error names the folder; `hint`: what the user can do instead of waiting."""

    def __init__(self, folder: Path, what: str = "run folder", hint: str = "choose another --out"):
        self.path = Path(folder) / LOCK
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(self.fd, 4096, 0).decode(errors="replace").strip() or "another process"
            os.close(self.fd)
            raise ValueError(f"{what} {folder} is in use by {holder}; wait for it to finish or stop it, "
                             f"or {hint}") from None
        os.ftruncate(self.fd, 0)
        os.pwrite(self.fd, f"pid {os.getpid()} on {socket.gethostname()} since {time.strftime('%Y-%m-%d %H:%M:%S')}"
                           .encode(), 0)

    def release(self, remove: bool = False) -> None:
        """Release the lock (closing the descriptor releases it); `remove`: also delete the lock file."""
        if self.fd is not None:
            if remove:
                self.path.unlink(missing_ok=True)
            os.close(self.fd)
            self.fd = None
