"""A progress bar for long commands: drawn on an interactive terminal only (stderr), and redrawn
at most ten times a second, since drawing costs more than a planner iteration."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator

import click

Report = Callable[[int, str | None], None]


@contextlib.contextmanager
def progress_bar(length: int, label: str) -> Iterator[Report | None]:
    """Yield ``report(position, label=None)`` — or None when stderr is not a terminal. A position
    lower than the last one (a restart) starts the bar again; the bar ends full."""
    if not sys.stderr.isatty():
        yield None
        return
    with click.progressbar(
        length=length, label=label, file=sys.stderr, show_pos=True, width=30
    ) as bar:
        state = {"pos": 0, "drawn": 0.0}

        def report(position: int, text: str | None = None) -> None:
            now = time.monotonic()
            if state["pos"] <= position < length and now - state["drawn"] < 0.1:
                return
            state["drawn"] = now
            if position < state["pos"]:
                bar.pos = 0
                state["pos"] = 0
            if text is not None:
                bar.label = text
            bar.update(max(0, position - int(state["pos"])))
            state["pos"] = position

        yield report
        bar.update(max(0, length - int(state["pos"])))
