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
    turbulence: str | None = None  # "light", "moderate", "severe" (Dryden) or None

    def __post_init__(self) -> None:
        if self.turbulence is not None and self.turbulence not in SEVERITIES:
            raise InputError(
                f"unknown turbulence {self.turbulence!r}; choose one of {', '.join(SEVERITIES)}"
            )
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
        if self.turbulence is not None:
            return False
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
        if self.turbulence:
            up += f", {self.turbulence} turbulence (Dryden)"
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
        if self.turbulence:
            d["turbulence"] = self.turbulence
        return d


CALM = Wind()

# -- Dryden turbulence (MIL-F-8785C) ----------------------------------------------------------
SEVERITIES = ("light", "moderate", "severe")
FT = 0.3048
KT = 1852.0 / 3600.0
# the wind 20 ft above the ground that sets the low-altitude intensity (MIL-F-8785C 3.7.2.3)
W20_KT = {"light": 15.0, "moderate": 30.0, "severe": 45.0}
# medium and high altitude: the intensity (ft/s) exceeded with probability 1e-2 (light), 1e-3
# (moderate), 1e-5 (severe), MIL-F-8785C Figure 7, at these altitudes (ft)
POE_ALTITUDES_FT = (500, 1750, 3750, 7500, 15000, 25000, 35000, 45000, 55000, 65000, 75000, 80000)
POE_SIGMA_FTPS = {
    "light": (6.6, 6.9, 7.4, 6.7, 4.6, 2.7, 0.4, 0.0, 0.0, 0.0, 0.0, 0.0),
    "moderate": (8.6, 9.6, 10.6, 10.1, 8.0, 6.6, 5.0, 4.2, 2.7, 0.0, 0.0, 0.0),
    "severe": (15.6, 17.6, 23.0, 23.6, 22.1, 20.0, 16.0, 15.1, 12.1, 7.9, 6.2, 5.1),
}


def dryden_scales(severity: str, height: float) -> tuple[float, float, float, float, float, float]:
    """``(L_u, L_v, L_w, sigma_u, sigma_v, sigma_w)`` (m, m/s) of MIL-F-8785C's Dryden form at
    ``height`` m above the ground (at least 10 ft): below 1,000 ft the low-altitude model
    (``L_w = h``, ``L_u = L_v = h / (0.177 + 0.000823 h)^1.2``, ``sigma_w = 0.1 W20``,
    ``sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4``, h in ft), above 2,000 ft the
    medium/high-altitude one (every scale 1,750 ft, every intensity Figure 7's at the
    severity's probability of exceedance), linear in between."""
    h = max(float(height) / FT, 10.0)

    def low(hf: float) -> tuple[float, ...]:
        k = 0.177 + 0.000823 * hf
        sw = 0.1 * W20_KT[severity] * KT / FT  # ft/s
        return hf / k**1.2, hf / k**1.2, hf, sw / k**0.4, sw / k**0.4, sw

    def high(hf: float) -> tuple[float, ...]:
        sig = float(np.interp(hf, POE_ALTITUDES_FT, POE_SIGMA_FTPS[severity]))
        return 1750.0, 1750.0, 1750.0, sig, sig, sig

    if h <= 1000.0:
        out = low(h)
    elif h >= 2000.0:
        out = high(h)
    else:
        f = (h - 1000.0) / 1000.0
        out = tuple(a + f * (b - a) for a, b in zip(low(1000.0), high(2000.0), strict=True))
    return tuple(v * FT for v in out)  # type: ignore[return-value]


def tustin(num: list[float], den: list[float], fs: float) -> tuple[FloatArray, FloatArray]:
    """The digital filter (b, a) of the analogue ``num(s) / den(s)`` (coefficients from the
    highest power) by the bilinear (Tustin) transform ``s = 2 fs (z - 1) / (z + 1)``: what
    ``scipy.signal.bilinear`` returns (the same sums; ``a[0]`` = 1), in plain arithmetic -- the
    Dryden filters change with the speed and the height every tick, and scipy's general
    polynomial code cost ~20 % of a turbulent flight (issue 38)."""
    m = max(len(num), len(den)) - 1

    def mapped(c: list[float]) -> list[float]:
        # sum_i c_i s^i with s^i (z + 1)^m / ... : (2 fs)^i (z - 1)^i (z + 1)^(m - i)
        n = len(c) - 1
        out = [0.0] * (m + 1)
        for i in range(n + 1):
            coef = c[n - i] * (2.0 * fs) ** i
            for k in range(i + 1):
                for j in range(m - i + 1):
                    out[k + j] += coef * math.comb(i, k) * math.comb(m - i, j) * (-1) ** k
        return out

    b, a = mapped(num), mapped(den)
    return np.array(b) / a[0], np.array(a) / a[0]


class Dryden:
    """Dryden turbulence (MIL-F-8785C, continuous forms, as MATLAB's Aerospace Blockset and
    Beard & McLain ch. 4 give them) for an aircraft of wingspan ``span`` m, seeded: the gusts
    of a run are the same for the same seed.

    Linear gusts, white noise of unit one-sided spectral density through
    ``H_u = sigma_u sqrt(2 L_u / (pi V)) / (1 + L_u s / V)``,
    ``H_v = sigma_v sqrt(L_v / (pi V)) (1 + sqrt(3) L_v s / V) / (1 + L_v s / V)^2`` (``H_w``
    alike), so that each has the Dryden spectrum ``Phi(omega)`` of variance ``sigma^2``;
    rotational gusts ``H_p = sigma_w sqrt(0.8 / V) (pi / 4b)^(1/6) / (L_w^(1/3) (1 + 4 b s /
    (pi V)))`` on its own noise, ``q_g = (s / V) / (1 + 4 b s / (pi V)) w_g`` and
    ``r_g = -(s / V) / (1 + 3 b s / (pi V)) v_g`` (the upper signs of the specification).
    Discretised by Tustin's rule at the integrator's step; the filters' states carry over from
    call to call (their coefficients follow the airspeed and the height)."""

    def __init__(self, severity: str, span: float, seed: Any) -> None:
        if severity not in SEVERITIES:
            raise InputError(
                f"unknown turbulence {severity!r}; choose one of {', '.join(SEVERITIES)}"
            )
        if not (math.isfinite(span) and span > 0):
            raise InputError(f"a wingspan must be > 0 m; got {span!r}")
        self.severity = severity
        self.span = float(span)
        self.rng = np.random.default_rng(seed)
        self._state: dict[str, FloatArray] = {}
        self._warm = False

    def _filters(self, v: float, h: float, dt: float) -> dict[str, tuple[FloatArray, FloatArray]]:
        lu, lv, lw, su, sv, sw = dryden_scales(self.severity, h)
        b = self.span
        fs = 1.0 / dt
        tv, tw = lv / v, lw / v
        cont = {
            "u": ([su * math.sqrt(2.0 * lu / (math.pi * v))], [lu / v, 1.0]),
            "v": (
                [
                    sv * math.sqrt(lv / (math.pi * v)) * math.sqrt(3.0) * tv,
                    sv * math.sqrt(lv / (math.pi * v)),
                ],
                [tv * tv, 2.0 * tv, 1.0],
            ),
            "w": (
                [
                    sw * math.sqrt(lw / (math.pi * v)) * math.sqrt(3.0) * tw,
                    sw * math.sqrt(lw / (math.pi * v)),
                ],
                [tw * tw, 2.0 * tw, 1.0],
            ),
            "p": (
                [
                    sw
                    * math.sqrt(0.8 / v)
                    * (math.pi / (4.0 * b)) ** (1.0 / 6.0)
                    / lw ** (1.0 / 3.0)
                ],
                [4.0 * b / (math.pi * v), 1.0],
            ),
            "q": ([1.0 / v, 0.0], [4.0 * b / (math.pi * v), 1.0]),
            "r": ([-1.0 / v, 0.0], [3.0 * b / (math.pi * v), 1.0]),
        }
        return {k: tustin(num, den, fs) for k, (num, den) in cont.items()}

    def _run(self, filt: dict[str, tuple[FloatArray, FloatArray]], n: int, dt: float) -> FloatArray:
        from scipy.signal import lfilter

        noise = self.rng.standard_normal((4, n)) * math.sqrt(math.pi / dt)
        out = np.empty((6, n))
        for j, (key, src) in enumerate((("u", 0), ("v", 1), ("w", 2), ("p", 3))):
            b, a = filt[key]
            zi = self._state.get(key, np.zeros(max(len(a), len(b)) - 1))
            out[j], self._state[key] = lfilter(b, a, noise[src], zi=zi)
        for j, (key, src) in ((4, ("q", 2)), (5, ("r", 1))):
            b, a = filt[key]
            zi = self._state.get(key, np.zeros(max(len(a), len(b)) - 1))
            out[j], self._state[key] = lfilter(b, a, out[src], zi=zi)
        return out

    def gusts(
        self, n: int, dt: float, airspeed: float, height: float, heading: float
    ) -> FloatArray:
        """The next ``n`` steps of ``dt`` s of turbulence, (n, 6): gust velocity NED (m/s; u
        along the ``heading``, v to its right, w down) and rotational gusts p, q, r (rad/s), at
        ``airspeed`` m/s ``height`` m above the ground."""
        v = max(float(airspeed), 1.0)
        filt = self._filters(v, float(height), dt)
        if not self._warm:  # start in the filters' steady state: ten of their longest times
            lu, lv, lw, *_ = dryden_scales(self.severity, float(height))
            self._run(filt, int(10.0 * max(lu, lv, lw) / v / dt), dt)
            self._warm = True
        g = self._run(filt, int(n), dt)
        c, s_ = math.cos(heading), math.sin(heading)
        out = np.empty((int(n), 6))
        out[:, 0] = c * g[0] - s_ * g[1]
        out[:, 1] = s_ * g[0] + c * g[1]
        out[:, 2] = g[2]
        out[:, 3:] = g[3:].T
        return out


def parse_wind(text: str, profile: str = "uniform", turbulence: str | None = None) -> Wind:
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
        return Wind(
            speed, from_deg, values[2] if len(values) == 3 else 0.0, profile, turbulence=turbulence
        )
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
    body = _fields(
        doc["wind"], p, "wind", ("layers", "speed", "from", "profile", "up", "turbulence")
    )
    turb = body.get("turbulence")
    if turb is not None and turb not in SEVERITIES:
        raise InputError(
            f"{where(p, 'wind.turbulence')}expected one of {', '.join(SEVERITIES)}, found {found(turb)}"
        )
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
                turbulence=turb,
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
        return Wind(up=up, layers=tuple(layers), source=str(p), turbulence=turb)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(where(p)) else f"{where(p, 'wind')}{msg}") from None
