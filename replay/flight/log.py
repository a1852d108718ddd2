"""The flight log every flight stack returns: what a compiled ``fly`` loop flew (the final state,
samples of the states, controls and guidance, the leg changes), and the recorder its buffers are
kept in (shared by the fixed wing's autopilot and the multirotor's stack)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from replay.frames import N_CONTROLS, N_STATES

FloatArray = npt.NDArray[np.float64]


# ---- results ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class WaypointReached:
    """A leg change: waypoint ``index`` was reached at ``t`` at horizontal ``distance``;
    ``how`` is ``"radius"`` (within the switching distance), ``"plane"`` (its perpendicular
    plane was passed) or ``"fillet"`` (the turn fillet into the next leg began)."""

    index: int
    t: float
    distance: float
    how: str


@dataclass(frozen=True, eq=False)
class FlightLog:
    """What :meth:`Autopilot.fly` flew: the final state and time, the last controls, and the
    samples taken every ``record_every`` steps (before each recorded step): ``times`` (m,),
    ``states`` (m, 12), ``controls`` (m, 4), ``guidance`` (m, 9) = course_cmd, bank_cmd,
    altitude_cmd, climb_rate_cmd, pitch_cmd, airspeed_cmd, cross_track, along_track,
    distance_to_next, and ``next_index`` (m,); ``reached`` lists the leg changes."""

    x: FloatArray
    t: float
    u: FloatArray
    times: FloatArray
    states: FloatArray
    controls: FloatArray
    guidance: FloatArray
    next_index: npt.NDArray[np.int64]
    reached: tuple[WaypointReached, ...]
    steps: int


class FlightRecorder:
    """The buffers a compiled ``fly`` loop records into, and the :class:`FlightLog` made of them
    (shared by :meth:`Autopilot.fly` and the multirotor stack's ``fly``).

    ``n_total`` steps of ``dt`` from grid step ``k = round(t / dt)`` (``t0_grid`` the remainder),
    a sample every ``record_every`` steps (none for 0); the kernel writes into ``x[n:]``,
    ``u[n:]``, ``g[n:]`` and :meth:`add` stamps the times and leg indices of what it wrote."""

    def __init__(
        self, n_total: int, record_every: int, t0_grid: float, dt: float, n_guidance: int
    ) -> None:
        self.every = int(record_every)
        cap = n_total // self.every + 2 if self.every > 0 else 1
        self.x = np.zeros((cap, N_STATES))
        self.u = np.zeros((cap, N_CONTROLS))
        self.g = np.zeros((cap, n_guidance))
        self.t = np.zeros(cap)
        self.i = np.zeros(cap, dtype=np.int64)
        self.n = 0
        self._t0_grid = t0_grid
        self._dt = dt

    def add(self, k: int, steps: int, nr: int, next_index: int) -> None:
        """The kernel flew ``steps`` steps from grid step ``k`` and recorded ``nr`` samples."""
        if nr:
            ks = np.arange(k, k + steps + 1)
            ks = ks[ks % self.every == 0][:nr]
            self.t[self.n : self.n + nr] = self._t0_grid + ks * self._dt
            self.i[self.n : self.n + nr] = next_index
            self.n += nr

    def log(
        self,
        x: FloatArray,
        t: float,
        u: FloatArray,
        reached: tuple[WaypointReached, ...],
        steps: int,
    ) -> FlightLog:
        n = self.n
        return FlightLog(
            x=x,
            t=t,
            u=u,
            times=self.t[:n],
            states=self.x[:n],
            controls=self.u[:n],
            guidance=self.g[:n],
            next_index=self.i[:n],
            reached=reached,
            steps=steps,
        )


GUIDANCE_COLUMNS = (
    "course_cmd",
    "bank_cmd",
    "altitude_cmd",
    "climb_rate_cmd",
    "pitch_cmd",
    "airspeed_cmd",
    "cross_track",
    "along_track",
    "distance_to_next",
)


__all__ = ["GUIDANCE_COLUMNS", "FlightLog", "FlightRecorder", "WaypointReached"]
