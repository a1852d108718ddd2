"""Results remembered on disk between processes: pure, costly computations kept as their exact
bytes (a trim's least-squares solve, the filled holes of a map), so that every later process --
another replay, a campaign's worker, the test suite's other worker -- reads them instead of
computing again.

The folder is ``TERRAPATH_CACHE_DIR`` when set (``make`` sets ``build/cache``; an empty value turns
the memo off), else ``$XDG_CACHE_HOME/terrapath`` or ``~/.cache/terrapath``, like numba's
compiled kernels (``NUMBA_CACHE_DIR``).  A result is found by the SHA-256 of its question (the
caller's bytes) and of the *code* that answers it (the source files it names, the versions of
numpy, scipy and numba): editing the code, or another numpy, asks again.  Entries are written
under a temporary name and renamed when complete; an entry that cannot be read or written (no
room, a read-only home, a truncated file) is computed as if it were not there, never an error.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

ENV = "TERRAPATH_CACHE_DIR"


def cache_dir() -> Path | None:
    """The memo's folder (see the module docstring); None when ``TERRAPATH_CACHE_DIR`` is empty."""
    set_to = os.environ.get(ENV)
    if set_to is not None:
        return Path(set_to) if set_to.strip() else None
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "terrapath"


class DiskMemo:
    """Answers of a known size remembered per question, as bytes, in ``<cache>/<name>/``.

    ``sources`` are the files whose text is the code answering (read once, on first use): with
    numpy's, scipy's and numba's versions and ``versions`` (other libraries the code calls) they
    make the memo's *version*, part of every key.  The folder holds about ``max_bytes`` of disk
    at most: a process's first write, and every ``PRUNE_EVERY``-th after it, removes the entries
    used longest ago beyond it (a read marks an entry used; an entry counts its disk blocks).
    """

    PRUNE_EVERY = 1000

    def __init__(
        self,
        name: str,
        sources: Sequence[str | os.PathLike[str]],
        versions: str = "",
        max_bytes: int = 256 * 2**20,
    ) -> None:
        self.name = name
        self.sources = tuple(Path(s) for s in sources)
        self.versions = versions
        self.max_bytes = int(max_bytes)
        self._version: bytes | None = None
        self._writes = 0

    def version(self) -> bytes:
        if self._version is None:
            import numba
            import scipy

            h = hashlib.sha256()
            for src in self.sources:
                h.update(src.read_bytes())
            h.update(f"numpy {np.__version__} scipy {scipy.__version__}".encode())
            h.update(f" numba {numba.__version__} {self.versions}".encode())
            self._version = h.digest()
        return self._version

    def _path(self, question: bytes) -> Path | None:
        root = cache_dir()
        if root is None:
            return None
        try:
            version = self.version()
        except OSError:  # the code's source cannot be read (a frozen install): not kept
            return None
        key = hashlib.sha256(version + question).hexdigest()
        return root / self.name / key[:2] / f"{key[2:]}.bin"

    def get(self, question: bytes, compute: Callable[[], bytes], size: int) -> bytes:
        """The remembered answer to ``question`` (``size`` bytes), else ``compute()``'s (then
        remembered when it has that size)."""
        path = self._path(question)
        if path is not None:
            with contextlib.suppress(OSError):
                data = path.read_bytes()
                if len(data) == size:
                    with contextlib.suppress(OSError):  # (a read-only folder still answers)
                        os.utime(path)  # used now: kept longest
                    return data
        answer = compute()
        if path is not None and len(answer) == size:
            self._put(path, answer)
            if self._writes % self.PRUNE_EVERY == 0:
                self._prune(path.parent.parent)
            self._writes += 1
        return answer

    def floats(self, question: bytes, compute: Callable[[], FloatArray], n: int) -> FloatArray:
        """:meth:`get` of ``n`` float64 values."""
        data = self.get(question, lambda: np.asarray(compute(), dtype=np.float64).tobytes(), 8 * n)
        return np.frombuffer(data, dtype=np.float64).copy()

    def _prune(self, folder: Path) -> None:
        """Remove the entries used longest ago until the folder holds at most ``max_bytes``."""
        try:
            entries = []
            for sub in os.scandir(folder):
                if sub.is_dir():
                    for e in os.scandir(sub.path):
                        if e.name.endswith(".bin"):
                            st = e.stat()
                            used = getattr(st, "st_blocks", 0) * 512 or st.st_size
                            entries.append((st.st_mtime_ns, used, e.path))
        except OSError:
            return
        total = sum(size for _, size, _ in entries)
        for _, size, path in sorted(entries):
            if total <= self.max_bytes:
                break
            with contextlib.suppress(OSError):
                os.unlink(path)
                total -= size

    @staticmethod
    def _put(path: Path, data: bytes) -> None:
        tmp = None
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        except OSError:
            if tmp is not None:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
