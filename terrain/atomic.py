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
    # the ending signals (terrapath.cli turns them into an exception) wait while the file is made
    # and its name known: one landing between mkstemp and the handler below left the .part behind
    masked = _hold_ending_signals()
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=prefix, suffix=".part", dir=parent)
        tmp = Path(tmp_name)
        try:
            _release_signals(masked)  # a signal waiting raises here, the .part known
        finally:
            os.close(fd)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs get the usual permissions
        yield tmp
        os.replace(tmp, final)
    except BaseException as exc:
        _release_signals(masked)
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        if isinstance(exc, OSError) and exc.errno in _NO_ROOM:
            raise NoRoomError(
                f"{str(final)!r}: cannot be written: {exc.strerror or exc} (nothing was written)"
            ) from None
        raise


_ENDING = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


def _hold_ending_signals() -> set[int | signal.Signals] | None:
    """Block SIGINT, SIGTERM and SIGHUP in this thread (the main one: where Python runs its
    handlers); the mask to restore, or None where signals cannot be held (not POSIX, a thread)."""
    if (
        not hasattr(signal, "pthread_sigmask")
        or threading.current_thread() is not threading.main_thread()
    ):
        return None
    return signal.pthread_sigmask(signal.SIG_BLOCK, _ENDING)


def _release_signals(masked: set[int | signal.Signals] | None) -> None:
    """Restore the mask :func:`_hold_ending_signals` changed (again is harmless: the same mask)."""
    if masked is not None and hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_SETMASK, masked)


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
