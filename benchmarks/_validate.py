"""Model-independent pieces of ``validate_jsbsim.py``: searches over a flight model's feasibility,
mode fitting from a time series, turn geometry, and the comparison table.

Nothing here knows JSBSim or terrapath's vehicle: a model enters only as a callable, a time series
or a number, so the tests exercise it on synthetic cases with known answers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

FloatArray = npt.NDArray[np.float64]

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


# --- searches ------------------------------------------------------------------------------------


def boundary(ok: Callable[[float], bool], inside: float, outside: float, tol: float) -> float:
    """The edge of the set where ``ok`` holds, between ``inside`` (ok) and ``outside`` (not ok), by
    bisection to ``tol``; returns the last value found inside. ``ok(inside)`` is assumed, not asked.
    If ``ok(outside)`` holds the set reaches past the bracket and ``outside`` is returned."""
    if ok(outside):
        return outside
    a, b = float(inside), float(outside)
    while abs(b - a) > tol:
        mid = 0.5 * (a + b)
        if ok(mid):
            a = mid
        else:
            b = mid
    return a


class Optimum(NamedTuple):
    x: float
    value: float


def maximise(f: Callable[[float], float], lo: float, hi: float, n: int, tol: float) -> Optimum:
    """Maximum of ``f`` over [lo, hi]: a scan of ``n`` points, then golden-section search in the
    two cells beside the best point, to ``tol`` in x. ``f`` may return -inf or nan where it is not
    defined (an infeasible point); if it is nowhere defined the result is (nan, nan)."""
    xs = np.linspace(lo, hi, n)
    fs = np.array([_finite_or_minus_inf(f(float(x))) for x in xs])
    if not np.isfinite(fs).any():
        return Optimum(math.nan, math.nan)
    i = int(np.argmax(fs))
    best = Optimum(float(xs[i]), float(fs[i]))
    a, b = float(xs[max(i - 1, 0)]), float(xs[min(i + 1, n - 1)])
    c, d = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
    fc, fd = _finite_or_minus_inf(f(c)), _finite_or_minus_inf(f(d))
    while b - a > tol:
        if fc >= fd:
            b, d, fd = d, c, fc
            c = b - GOLDEN * (b - a)
            fc = _finite_or_minus_inf(f(c))
        else:
            a, c, fc = c, d, fd
            d = a + GOLDEN * (b - a)
            fd = _finite_or_minus_inf(f(d))
    for x, fx in ((c, fc), (d, fd)):
        if fx > best.value:
            best = Optimum(x, fx)
    return best


def _finite_or_minus_inf(v: float) -> float:
    return float(v) if math.isfinite(v) else -math.inf


# --- time series ---------------------------------------------------------------------------------


class Mode(NamedTuple):
    """A damped oscillation: natural frequency (rad/s), damping ratio, damped period (s)."""

    omega_n: float
    zeta: float
    period: float


def fit_mode(t: npt.ArrayLike, y: npt.ArrayLike, trend: bool = True) -> Mode:
    """The dominant damped oscillation in ``y(t)``: a least-squares fit of::

        y = c0 + c1 t + exp(-sigma t) (a cos(wd t) + b sin(wd t))

    (``c1`` only with ``trend``) by variable projection: (sigma, wd) are searched, the linear
    coefficients solved for each. omega_n = sqrt(sigma^2 + wd^2), zeta = sigma / omega_n,
    period = 2 pi / wd. Started from a spread of frequencies between one cycle over the window and
    a quarter of the sampling rate; the fit with the smallest residual is kept."""
    tt = np.asarray(t, dtype=np.float64)
    yy = np.asarray(y, dtype=np.float64)
    if tt.shape != yy.shape or tt.ndim != 1 or tt.size < 8:
        raise ValueError(f"fit_mode needs two equal 1-D series of >= 8 samples, got {tt.shape}")
    tt = tt - tt[0]
    span = float(tt[-1])
    dt = float(np.median(np.diff(tt)))

    def design(p: FloatArray) -> FloatArray:
        sigma, wd = p
        e = np.exp(-sigma * tt)
        cols = [np.ones_like(tt)]
        if trend:
            cols.append(tt)
        cols += [e * np.cos(wd * tt), e * np.sin(wd * tt)]
        return np.column_stack(cols)

    def residual(p: FloatArray) -> FloatArray:
        a = design(p)
        coef, *_ = np.linalg.lstsq(a, yy, rcond=None)
        return np.asarray(a @ coef - yy)

    w_lo = 2.0 * math.pi / span
    w_hi = 0.25 * math.pi / dt
    best: tuple[float, FloatArray] | None = None
    for wd0 in np.geomspace(w_lo, w_hi, 16):
        for zeta0 in (0.1, 0.5):
            p0 = np.array([zeta0 * wd0, wd0])
            sol = least_squares(residual, p0, bounds=([-5.0 / span, 0.5 * w_lo], [np.inf, w_hi]))
            cost = float(sol.cost)
            if best is None or cost < best[0]:
                best = (cost, sol.x)
    assert best is not None
    sigma, wd = (float(v) for v in best[1])
    omega_n = math.hypot(sigma, wd)
    return Mode(omega_n, sigma / omega_n, 2.0 * math.pi / wd)


def first_crossing(t: npt.ArrayLike, y: npt.ArrayLike, level: float) -> float:
    """The first time |y| reaches ``level`` (linear between samples), or nan if it never does."""
    tt = np.asarray(t, dtype=np.float64)
    ay = np.abs(np.asarray(y, dtype=np.float64))
    above = np.nonzero(ay >= level)[0]
    if above.size == 0:
        return math.nan
    k = int(above[0])
    if k == 0:
        return float(tt[0])
    f = (level - ay[k - 1]) / (ay[k] - ay[k - 1])
    return float(tt[k - 1] + f * (tt[k] - tt[k - 1]))


def turn_radius(t: npt.ArrayLike, course: npt.ArrayLike, ground_speed: npt.ArrayLike) -> float:
    """Radius (m) of a steady turn from sampled course (rad) and horizontal speed (m/s): mean
    speed over the course rate (the slope of a straight-line fit to the unwrapped course)."""
    tt = np.asarray(t, dtype=np.float64)
    chi = np.unwrap(np.asarray(course, dtype=np.float64))
    rate = float(np.polyfit(tt, chi, 1)[0])
    return float(np.mean(np.asarray(ground_speed, dtype=np.float64))) / abs(rate)


def physics_turn_radius(airspeed: float, bank: float, g: float) -> float:
    """V^2 / (g tan(phi)) (m): the radius of a level coordinated turn at bank ``phi`` (rad)."""
    return airspeed * airspeed / (g * math.tan(abs(bank)))


# --- the comparison table ------------------------------------------------------------------------


@dataclass(frozen=True)
class Target:
    """How a figure is judged. ``kind``:

    - ``ratio``: ours / reference within [1 - tol, 1 + tol];
    - ``difference``: |ours - reference| <= tol (in the figure's unit);
    - ``none``: shown, not judged.
    """

    kind: str
    tol: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("ratio", "difference", "none"):
            raise ValueError(f"target kind must be ratio, difference or none, found {self.kind!r}")

    def passes(self, ours: float, reference: float) -> bool | None:
        if self.kind == "none":
            return None
        if not (math.isfinite(ours) and math.isfinite(reference)):
            return False
        if self.kind == "ratio":
            return reference != 0 and abs(ours / reference - 1.0) <= self.tol + 1e-12
        return abs(ours - reference) <= self.tol + 1e-12

    def describe(self, unit: str) -> str:
        if self.kind == "ratio":
            return f"ratio {1 - self.tol:.2f}–{1 + self.tol:.2f}"
        if self.kind == "difference":
            return f"within {self.tol:g} {unit}".rstrip()
        return ""


NO_TARGET = Target("none")


@dataclass(frozen=True)
class Comparison:
    """One row: a figure measured on our model (``subject_name``) and on the reference
    (``reference_name``)."""

    figure: str
    unit: str
    ours: float
    reference: float
    target: Target = NO_TARGET
    digits: int = 2
    reference_name: str = "JSBSim"
    subject_name: str = "ours"
    note: str = ""

    @property
    def ratio(self) -> float:
        if not (math.isfinite(self.ours) and math.isfinite(self.reference)) or self.reference == 0:
            return math.nan
        return self.ours / self.reference

    @property
    def verdict(self) -> bool | None:
        return self.target.passes(self.ours, self.reference)

    def row(self) -> tuple[str, str, str]:
        """(figure, value, target) for ``_record.record``."""
        u = f" {self.unit}" if self.unit else ""
        value = (
            f"{self.subject_name} {_num(self.ours, self.digits)}{u}, {self.reference_name} "
            f"{_num(self.reference, self.digits)}{u}, ratio {_num(self.ratio, 3)}"
        )
        if self.target.kind == "difference":
            value += f", difference {_num(self.ours - self.reference, self.digits, sign=True)}{u}"
        if self.note:
            value += f" ({self.note})"
        verdict = {True: "PASS", False: "FAIL", None: ""}[self.verdict]
        target = self.target.describe(self.unit)
        return self.figure, value, f"{target}: {verdict}" if target else ""


def _num(v: float, digits: int, sign: bool = False) -> str:
    if not math.isfinite(v):
        return "n/a"
    return f"{v:+.{digits}f}" if sign else f"{v:.{digits}f}"


def table_rows(comparisons: Sequence[Comparison]) -> list[tuple[str, str, str]]:
    return [c.row() for c in comparisons]


def tally(comparisons: Sequence[Comparison]) -> tuple[int, int]:
    """(passed, judged) over the rows that have a target."""
    judged = [c.verdict for c in comparisons if c.verdict is not None]
    return sum(1 for v in judged if v), len(judged)
