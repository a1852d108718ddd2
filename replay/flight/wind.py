"""The air mass a replay flies in (issue 36): a steady wind, a wind that grows with the height
over the ground, and winds aloft by layers -- the velocity of the air (NED, m/s) at a point,
which the 6-DOF models subtract from their velocity for the aerodynamics (the air-relative
velocity) while the navigation keeps the ground velocity.

Conventions, as pilots and forecasts give wind:

- **Direction**: ``from_deg``, the direction the wind blows *from*, degrees clockwise from
  north: a wind "from 270" (westerly) moves the air east.  ``up`` (m/s) is an optional vertical
  component of the air, positive upwards (a ridge's lift, a downdraft < 0).
- **Uniform** (``--wind SPEED,FROM_DEG[,UP]``): the wind the aircraft flies in, the same at every
  height.
- **Profile** (``profile="power"`` or ``"log"``): ``speed`` is the surface wind as a METAR
  reports it, measured :data:`REF_HEIGHT_M` (10 m) above the ground, and grows with the height
  ``h`` above the ground under the aircraft up to :data:`GRADIENT_HEIGHT_M` (300 m, the top of a
  neutral surface layer over open country), constant above:

  - power law (Hellmann): ``V(h) = V_ref (h / h_ref)^alpha`` with ``alpha`` =
    :data:`POWER_ALPHA` = 1/7 (neutral stability, open terrain);
  - logarithmic: ``V(h) = V_ref ln(h / z0) / ln(h_ref / z0)`` with the roughness length ``z0`` =
    :data:`LOG_Z0_M` = 0.03 m (open flat terrain, grass; WMO / Davenport class).

  Both at most 1.7 x the surface wind at 300 m (power 1.63 x, log 1.59 x), and at least
  :data:`MIN_HEIGHT_M` high (the aircraft on the ground sees the 1 m wind).
- **Winds aloft** (a wind file, :func:`load_wind_file`): layers by altitude AMSL, each a speed
  and a direction, as forecasts (FD / winds-aloft tables, GRIB levels) give them; between two
  layers the wind vector is interpolated linearly in altitude, below the lowest and above the
  highest it is that layer's.

A file::

    terrapath: 1
    wind:
      layers:                     # m AMSL; speed m/s; from: degrees, where the wind comes from
        - {altitude: 3000, speed: 8, from: 250}
        - {altitude: 4500, speed: 15, from: 270}
      up: 0                       # optional vertical air velocity, m/s

Every bad value is a one-line error naming the file and the field.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.docfile import check_header, finite_number, found, read_document
from terrain.errors import InputError, where

FloatArray = npt.NDArray[np.float64]

PROFILES = ("uniform", "power", "log")
REF_HEIGHT_M = 10.0  # the surface wind's height above the ground (METAR, WMO)
GRADIENT_HEIGHT_M = 300.0  # the profile holds its value above this height over the ground
POWER_ALPHA = 1.0 / 7.0  # Hellmann exponent, neutral stability over open terrain
LOG_Z0_M = 0.03  # roughness length of open flat terrain (grass)
MIN_HEIGHT_M = 1.0  # the profile below this height is the 1 m wind


@dataclass(frozen=True)
class WindLayer:
    """One layer of winds aloft: at ``altitude`` m AMSL the wind blows at ``speed`` m/s from
    ``from_deg`` degrees (clockwise from north)."""

    altitude: float
    speed: float
    from_deg: float


def _vector(speed: float, from_deg: float) -> tuple[float, float]:
    """(north, east) velocity of the air for a wind of ``speed`` from ``from_deg``."""
    a = math.radians(from_deg)
    return -speed * math.cos(a), -speed * math.sin(a)


def _check(value: Any, what: str, low: float = 0.0, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{what} must be a number; got {value!r}")
    if not low <= float(value) <= high:
        raise InputError(f"{what} must be within [{low:g}, {high:g}]; got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Wind:
    """The air's velocity everywhere in a replay (module docstring): ``speed`` m/s from
    ``from_deg`` (with ``profile`` "uniform", "power" or "log": at every height, or the surface
    wind growing with the height over the ground), ``up`` m/s vertical, or ``layers`` of winds
    aloft (then ``speed`` and ``from_deg`` are unused).  ``source`` names the file it came from."""

    speed: float = 0.0
    from_deg: float = 0.0
    up: float = 0.0
    profile: str = "uniform"
    layers: tuple[WindLayer, ...] = ()
    source: str | None = None

    def __post_init__(self) -> None:
        _check(self.speed, "wind speed (m/s)", 0.0, 200.0)
        _check(self.from_deg, "wind direction (degrees it blows from)", 0.0, 360.0)
        _check(self.up, "vertical wind (m/s)", -50.0, 50.0)
        if self.profile not in PROFILES:
            raise InputError(
                f"unknown wind profile {self.profile!r}; choose one of {', '.join(PROFILES)}"
            )
        alts = [la.altitude for la in self.layers]
        if any(b <= a for a, b in itertools.pairwise(alts)):
            raise InputError(f"wind layers must go up in altitude; got {alts}")

    @property
    def calm(self) -> bool:
        """No air motion anywhere."""
        if self.layers:
            return self.up == 0.0 and all(la.speed == 0.0 for la in self.layers)
        return self.speed == 0.0 and self.up == 0.0

    def factor(self, height: npt.ArrayLike) -> FloatArray:
        """The profile's speed over the surface wind at ``height`` m over the ground (1 for a
        uniform wind)."""
        h = np.clip(np.asarray(height, dtype=np.float64), MIN_HEIGHT_M, GRADIENT_HEIGHT_M)
        if self.profile == "power":
            return np.asarray((h / REF_HEIGHT_M) ** POWER_ALPHA)
        if self.profile == "log":
            return np.asarray(np.log(h / LOG_Z0_M) / math.log(REF_HEIGHT_M / LOG_Z0_M))
        return np.ones_like(h)

    def velocity(self, altitude: npt.ArrayLike, height: npt.ArrayLike | None = None) -> FloatArray:
        """The air's velocity (..., 3) NED m/s at ``altitude`` (m AMSL) ``height`` m above the
        ground (needed by a profile; ignored otherwise)."""
        z = np.asarray(altitude, dtype=np.float64)
        out = np.zeros((*z.shape, 3))
        out[..., 2] = -self.up
        if self.layers:
            za = np.array([la.altitude for la in self.layers])
            vn, ve = np.array([_vector(la.speed, la.from_deg) for la in self.layers]).T
            out[..., 0] = np.interp(z, za, vn)
            out[..., 1] = np.interp(z, za, ve)
            return out
        n, e = _vector(self.speed, self.from_deg)
        f = self.factor(z if height is None else height) if self.profile != "uniform" else 1.0
        out[..., 0] = n * f
        out[..., 1] = e * f
        return out

    def strongest(self, low: float, high: float) -> float:
        """The fastest horizontal wind (m/s) anywhere between ``low`` and ``high`` m AMSL (a
        profile: at its gradient height)."""
        if self.layers:
            zs = [low, high, *(la.altitude for la in self.layers if low <= la.altitude <= high)]
            return float(np.hypot(*self.velocity(np.array(zs))[:, :2].T).max())
        return self.speed * float(self.factor(GRADIENT_HEIGHT_M))

    def describe(self) -> str:
        """One line for reports: ``10 m/s from 270 deg (power profile, surface wind)``."""
        up = f", {self.up:+g} m/s vertical" if self.up else ""
        if self.layers:
            parts = ", ".join(
                f"{la.speed:g} m/s from {la.from_deg:g} deg at {la.altitude:,.0f} m"
                for la in self.layers
            )
            return f"winds aloft: {parts}{up}"
        kind = {
            "uniform": "",
            "power": " (surface wind at 10 m, power-law profile to 300 m)",
            "log": " (surface wind at 10 m, logarithmic profile to 300 m)",
        }[self.profile]
        return f"{self.speed:g} m/s from {self.from_deg:g} deg{kind}{up}"

    def to_dict(self) -> dict[str, Any]:
        """The wind as the file format and the recordings keep it."""
        d: dict[str, Any] = {}
        if self.layers:
            d["layers"] = [
                {"altitude": la.altitude, "speed": la.speed, "from": la.from_deg}
                for la in self.layers
            ]
        else:
            d.update(speed=self.speed, **{"from": self.from_deg}, profile=self.profile)
        if self.up:
            d["up"] = self.up
        return d


CALM = Wind()


def parse_wind(text: str, profile: str = "uniform") -> Wind:
    """``--wind SPEED,FROM_DEG[,UP]`` (m/s, degrees it blows from, m/s up): a :class:`Wind`."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) not in (2, 3):
        raise InputError(
            f"--wind {text!r}: expected SPEED,FROM_DEG (m/s and the direction it blows from, "
            "degrees clockwise from north), optionally ,UP (m/s), e.g. --wind 10,270"
        )
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError(f"--wind {text!r}: expected numbers, e.g. --wind 10,270") from None
    speed, from_deg = values[0], values[1] % 360.0 if math.isfinite(values[1]) else values[1]
    try:
        return Wind(speed, from_deg, values[2] if len(values) == 3 else 0.0, profile)
    except InputError as exc:
        raise InputError(f"--wind {text!r}: {exc}") from None


def _number(value: Any, path: Path, fld: str) -> float:
    try:
        return finite_number(value, "")
    except InputError:
        raise InputError(f"{where(path, fld)}expected a number, found {found(value)}") from None


def _fields(value: Any, path: Path, fld: str, allowed: tuple[str, ...]) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise InputError(f"{where(path, fld)}expected a mapping, found {found(value)}")
    unknown = [str(k) for k in value if k not in allowed]
    if unknown:
        raise InputError(
            f"{where(path, fld)}unknown key(s) {', '.join(map(repr, unknown))}; "
            f"allowed: {', '.join(allowed)}"
        )
    return value


def load_wind_file(path: str | Path) -> Wind:
    """A wind file (module docstring): winds aloft by layers, or one wind with a profile."""
    p = Path(path)
    doc = check_header(read_document(p, "a wind file"), p, "wind", ("terrapath", "wind"), "wind")
    body = _fields(doc["wind"], p, "wind", ("layers", "speed", "from", "profile", "up"))
    up = _number(body.get("up", 0.0), p, "wind.up")
    raw = body.get("layers")
    try:
        if raw is None:
            return Wind(
                _number(body.get("speed"), p, "wind.speed"),
                _number(body.get("from"), p, "wind.from") % 360.0,
                up,
                str(body.get("profile", "uniform")),
                source=str(p),
            )
        if not isinstance(raw, list) or not raw:
            raise InputError(
                f"{where(p, 'wind.layers')}expected a list of layers, found {found(raw)}"
            )
        layers = []
        for k, la in enumerate(raw):
            fld = f"wind.layers[{k}]"
            m = _fields(la, p, fld, ("altitude", "speed", "from"))
            speed = _number(m.get("speed"), p, f"{fld}.speed")
            if not 0 <= speed <= 200:
                raise InputError(
                    f"{where(p, fld + '.speed')}expected m/s in [0, 200], found {speed:g}"
                )
            layers.append(
                WindLayer(
                    _number(m.get("altitude"), p, f"{fld}.altitude"),
                    speed,
                    _number(m.get("from"), p, f"{fld}.from") % 360.0,
                )
            )
        return Wind(up=up, layers=tuple(layers), source=str(p))
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(where(p)) else f"{where(p, 'wind')}{msg}") from None
