"""Write outputs under a temporary name and rename them into place only when complete."""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from terrain.errors import DataFileError, NoRoomError


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    If the body raises, the temporary file is removed and ``path`` is left untouched, so a reader
    never sees a half-written output.  The temporary name holds the writer's process id, so that
    one left by a killed process can be told from one still being written
    (:func:`remove_stale_parts`).
    """
    final = Path(path)
    parent = final.parent if str(final.parent) else Path(".")
    if not parent.is_dir():
        raise DataFileError(f"{str(final)!r}: output folder {str(parent)!r} does not exist")
    prefix = f".{final.name}.{os.getpid()}."
    fd, tmp_name = tempfile.mkstemp(prefix=prefix, suffix=".part", dir=parent)
    os.close(fd)
    tmp = Path(tmp_name)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs get the usual permissions
    try:
        yield tmp
        os.replace(tmp, final)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        if isinstance(exc, OSError) and exc.errno in _NO_ROOM:
            raise NoRoomError(
                f"{str(final)!r}: cannot be written: {exc.strerror or exc} (nothing was written)"
            ) from None
        raise


def remove_stale_parts(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files :func:`atomic_output` left in ``folder`` when its process was
    killed (SIGKILL, a power cut: no cleanup ran); those of processes still alive (another
    campaign writing to the same folder) are kept. Returns the files removed."""
    removed = []
    for p in Path(folder).glob(".*.part"):
        pid = p.name[: -len(".part")].rsplit(".", 2)
        if len(pid) != 3 or not pid[1].isdigit() or _alive(int(pid[1])):
            continue
        with contextlib.suppress(FileNotFoundError):
            p.unlink()
            removed.append(p)
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    try:  # a zombie (killed, not yet reaped: PID 1 in a container may never reap it) is dead
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):  # no /proc (not Linux), or it has just gone
        return True


# What a write answers when the disk (or the quota, or the file size limit) leaves no room: the
# output is named, since the error itself names no file.
_NO_ROOM = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
