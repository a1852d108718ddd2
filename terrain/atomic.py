"""Write outputs under a temporary name and rename them into place only when complete."""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

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
    parent = output_folder(final)
    prefix = f".{final.name}.{os.getpid()}."
    tmp: Path | None = None
    fd = -1
    try:
        # the ending signals (terrapath.cli turns them into an exception) are held while the file
        # is made and its name known, then raised here: one landing between mkstemp and this
        # handler once left the .part behind
        with _ending_signals_held():
            fd, tmp_name = tempfile.mkstemp(prefix=prefix, suffix=".part", dir=parent)
            tmp = Path(tmp_name)
        os.close(fd)
        fd = -1
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs get the usual permissions
        yield tmp
        os.replace(tmp, final)
    except BaseException as exc:
        if fd >= 0:
            os.close(fd)
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        if isinstance(exc, OSError) and exc.errno in _NO_ROOM:
            raise NoRoomError(
                f"{str(final)!r}: cannot be written: {exc.strerror or exc} (nothing was written)"
            ) from None
        raise


_ENDING = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


@contextlib.contextmanager
def _ending_signals_held() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP noted, not handled, inside the block; on leaving it the
    handlers are put back and each noted signal handed to its own (which may raise). Python runs
    handlers in the main thread only, so elsewhere nothing is changed. (Not a signal mask: a
    process with other threads, a pytest-xdist worker, takes a signal on another thread and the
    main thread's handler runs at once.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[tuple[int, Any]] = []
    previous = {sig: signal.signal(sig, lambda s, f: noted.append((s, f))) for sig in _ENDING}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig, frame in noted:
            handler = previous[sig]
            if callable(handler):
                handler(sig, frame)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), sig)  # the default action, now that it is back


def output_folder(path: str | os.PathLike[str], *, create: bool = True) -> Path:
    """The folder ``path`` (an output file) is written in, with its missing parents created, as
    ``mkdir -p`` does; with ``create`` False only checked that they could be (a command checks
    before its work, creates when it writes).

    When the folder cannot be made -- a file in the way, no permission -- a one-line
    :class:`DataFileError` names the output, the folder and why.
    """
    final = Path(path)
    parent = final.parent if str(final.parent) else Path(".")
    make_folder(parent, create=create, output=final)
    return parent


def make_folder(
    folder: str | os.PathLike[str],
    *,
    create: bool = True,
    output: str | os.PathLike[str] | None = None,
) -> Path:
    """``folder`` with its missing parents created (``mkdir -p``); with ``create`` False only
    checked that they could be.  ``output``: the file written there, named in the error (else
    the folder itself is)."""
    folder = Path(folder)
    named = str(output if output is not None else folder)

    def refused(why: str) -> DataFileError:
        return DataFileError(f"{named!r}: cannot create the output folder {str(folder)!r}: {why}")

    if folder.is_dir():
        return folder
    # the nearest part of the folder's path that exists decides whether the rest can be made
    existing = folder
    while not existing.exists() and not existing.is_symlink() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        what = "a broken link" if not existing.exists() else "a file"
        raise refused(f"{str(existing)!r} is {what}, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise refused(f"no permission to create folders in {str(existing)!r}")
    if create:
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise refused(exc.strerror or str(exc)) from None
    return folder


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
