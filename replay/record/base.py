"""What the simulation loop records (:class:`Recorder`): the MCAP recorder
(:class:`replay.record.recorder.RunRecorder`) implements it; a test or a tool may record
elsewhere by implementing the same methods. Times in seconds from the start, positions in map
metres, states the 12-state NED vector of :mod:`replay.frames`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


class Recorder(Protocol):
    """The recorder the loop writes to (every call it makes)."""

    def state_due(self, t: float) -> bool: ...

    def write_state(
        self,
        t: float,
        state: Sequence[float] | FloatArray,
        controls: Sequence[float] | FloatArray,
        extras: Mapping[str, float] | None = None,
        *,
        force: bool = False,
    ) -> bool: ...

    def write_states(
        self,
        ts: npt.ArrayLike,
        states: npt.ArrayLike,
        controls: npt.ArrayLike,
        extras: Mapping[str, npt.ArrayLike] | None = None,
    ) -> None: ...

    def write_waypoints(
        self, t: float, waypoints: npt.ArrayLike, reason: str, active_index: int = 0
    ) -> None: ...

    def write_threats(self, t: float, threats: Iterable[Mapping[str, Any]]) -> bool: ...

    def write_detection_arrays(
        self,
        t: float,
        ids: Sequence[str],
        positions: npt.ArrayLike,
        ranges: npt.ArrayLike,
        terrain: npt.ArrayLike,
        moving: npt.ArrayLike,
    ) -> None: ...

    def write_beams(
        self, t: float, origin: npt.ArrayLike, ends: npt.ArrayLike, hit: npt.ArrayLike
    ) -> None: ...

    def write_separations(
        self,
        ts: npt.ArrayLike,
        ids: Sequence[str],
        separations: npt.ArrayLike,
        *,
        margin_m: float = 0.0,
    ) -> int: ...

    def write_decision(self, t: float, decision: Mapping[str, Any]) -> None: ...

    def write_log(self, t: float, level: str, text: str) -> None: ...

    def write_metrics(self, metrics: Mapping[str, Any]) -> None: ...


__all__ = ["Recorder"]
