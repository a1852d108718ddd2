"""The pool's worker processes live no longer than the campaign that started them.

A campaign killed with SIGKILL runs no cleanup, and its pool workers (forked children) used to
fly on: two were found alive 51 minutes later.  :func:`bind_to_parent`, run first in each worker,
asks Linux to send the worker SIGTERM when its parent dies (``prctl(PR_SET_PDEATHSIG)``); on
other systems a daemon thread polls ``os.getppid()`` once a second.  SIGTERM and SIGHUP get their
default action back in the worker (the campaign's own handlers, inherited with the fork, would
turn them into an exception the pool catches and reports instead of ending the worker).  When
the campaign itself ends early (SIGTERM, Ctrl-C, an error), :func:`end_workers` terminates the
workers it started instead of waiting for their runs.  The ``.part`` file a killed worker leaves
is removed when the campaign is resumed (:func:`terrain.atomic.remove_stale_parts`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Iterable
from typing import Any

PR_SET_PDEATHSIG = 1  # linux/prctl.h


def bind_to_parent(parent: int) -> None:
    """End this process (SIGTERM) when ``parent`` -- the campaign -- dies."""
    for name in ("SIGTERM", "SIGHUP"):  # SIGHUP is POSIX only
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    if sys.platform.startswith("linux") and _pdeathsig(signal.SIGTERM):
        if os.getppid() != parent:  # the parent died before the request was made
            os.kill(os.getpid(), signal.SIGTERM)
        return
    threading.Thread(target=_watch, args=(parent,), daemon=True, name="parent-watch").start()


def _pdeathsig(sig: int) -> bool:
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return bool(libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0)
    except (OSError, AttributeError):  # pragma: no cover - no libc prctl
        return False


def _watch(parent: int) -> None:  # pragma: no cover - the Linux path is the tested one
    while os.getppid() == parent:
        time.sleep(1.0)
    os.kill(os.getpid(), signal.SIGTERM)


def end_workers(processes: Iterable[Any], timeout: float = 5.0) -> None:
    """Terminate the worker ``processes`` (multiprocessing Process objects) and reap them."""
    procs = [p for p in processes if p.is_alive()]
    for p in procs:
        with contextlib.suppress(OSError):
            p.terminate()
    deadline = time.monotonic() + timeout
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            with contextlib.suppress(OSError):
                p.kill()
            p.join(1.0)
