"""Writing files so that a kill at any moment leaves either the old file or the new one."""

from __future__ import annotations

import contextlib
import os
import re
import stat
import tempfile
from pathlib import Path

#: names of the temporary files :func:`write_atomic` makes (``.NAME.RANDOM.tmp``)
TEMPORARY = re.compile(r"^\..+\.[A-Za-z0-9_]+\.tmp$")


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory.

    The temporary file is flushed to disk and renamed over ``path`` (atomic on POSIX), so
    a reader never sees half a file. A kill between creating and renaming it can leave the
    temporary file behind; :func:`remove_stale_temporaries` clears those. A symlink at
    ``path`` is replaced, never followed; the permissions (read/write/execute bits only)
    of a regular file there are kept, else the umask's default.
    """
    directory = path.parent
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        try:
            existing = path.lstat()
        except FileNotFoundError:
            existing = None
        if existing is not None and stat.S_ISREG(existing.st_mode):
            mode = existing.st_mode & 0o777
        else:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def remove_stale_temporaries(directory: Path) -> list[Path]:
    """Delete the temporary files an interrupted :func:`write_atomic` left in ``directory``."""
    removed = []
    for entry in directory.iterdir():
        if entry.is_file() and TEMPORARY.match(entry.name):
            with contextlib.suppress(FileNotFoundError):
                entry.unlink()
                removed.append(entry)
    return removed
