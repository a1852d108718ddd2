"""Seeded synthetic terrain: peaks, ridges, valleys and fractal noise on a metric grid.

For tests and for map sizes beyond the reference DEMs.  The field is the sum of

- ``peaks`` isotropic gaussian bumps (centre anywhere on the map, sigma 4-12 % of the map size S,
  amplitude 0.5-1.0), evaluated exactly as separable outer products;
- ``ridges`` elongated bumps along random line segments (length 30-80 % of S, any direction): height
  ``A exp(-d^2 / (2 w^2))`` from the distance d to the segment, width w 2-6 % of S, amplitude 0.3-0.7;
- ``valleys``: the same with negative amplitude (-0.2 to -0.5) and width 3-8 % of S;
- a fractal noise field by spectral synthesis (white gaussian noise filtered by a power-law amplitude
  spectrum ``|f|^-(H+1)``, H = 0.8, with numpy's real FFT), scaled to a peak-to-peak range of
  ``roughness`` times that of the features (or to 1 when there are no features);

then linearly mapped onto ``[base, base + relief]``: the lowest cell is exactly ``base`` and the
highest exactly ``base + relief`` (up to float32 rounding of those two numbers).  A flat field (no
features and roughness 0, or relief 0) is ``base`` everywhere.  S is ``max(width, height)`` in metres.
Ridge and valley kernels are evaluated in a window of 6 w around their segment (the kernel is below
1.6e-8 of its amplitude outside it), which keeps large grids fast.

Conventions: ``origin`` is the (x, y) of the south-west outer corner of the grid, so the bounds are
``(x0, y0, x0 + cols * cell_size, y0 + rows * cell_size)``; cells are square.  ``crs`` None gives a
local grid (plain metres).  All randomness comes from one ``numpy.random.default_rng(seed)`` (a
Generator passed in is used as is and advanced); the feature parameters are drawn first, in a fixed
order, then the noise.  The same seed gives bit-identical heights with the same numpy build.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
import numpy.typing as npt
from affine import Affine
from rasterio.crs import CRS

from terrain.errors import InputError
from terrain.grid import HeightGrid

FloatArray = npt.NDArray[np.float64]

HURST = 0.8
KERNEL_WINDOW = 6.0  # ridge/valley kernels are evaluated within this many widths of the segment


def _count(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _real(name: str, value: Any, *, minimum: float | None = None, strict: bool = False) -> float:
    ok = not isinstance(value, bool) and isinstance(value, numbers.Real)
    v = float(value) if ok else math.nan
    if not math.isfinite(v) or (minimum is not None and (v <= minimum if strict else v < minimum)):
        bound = "" if minimum is None else f" {'>' if strict else '>='} {minimum:g}"
        raise InputError(f"{name} must be a finite number{bound}; got {value!r}")
    return v


def _rng(seed: int | np.random.Generator) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be an integer >= 0 or a numpy Generator; got {seed!r}")
    return np.random.default_rng(int(seed))


def _segment_bump(
    field: FloatArray,
    xs: FloatArray,
    ys: FloatArray,
    a: tuple[float, float],
    b: tuple[float, float],
    width: float,
    amplitude: float,
) -> None:
    """Add ``amplitude * exp(-d^2 / (2 width^2))`` (d: distance to segment a-b) to ``field``."""
    reach = KERNEL_WINDOW * width
    c0, c1 = np.searchsorted(xs, [min(a[0], b[0]) - reach, max(a[0], b[0]) + reach])
    # ys run north to south (row 0 = north), so search the reversed (ascending) array.
    n = ys.size
    lo, hi = np.searchsorted(ys[::-1], [min(a[1], b[1]) - reach, max(a[1], b[1]) + reach])
    r0, r1 = n - hi, n - lo
    if c0 >= c1 or r0 >= r1:
        return
    px = xs[None, c0:c1] - a[0]
    py = ys[r0:r1, None] - a[1]
    ux, uy = b[0] - a[0], b[1] - a[1]
    s = np.clip((px * ux + py * uy) / (ux * ux + uy * uy), 0.0, 1.0)
    dx = px - s * ux
    dy = py - s * uy
    field[r0:r1, c0:c1] += amplitude * np.exp(-(dx * dx + dy * dy) / (2.0 * width * width))


def _fractal_noise(rng: np.random.Generator, rows: int, cols: int, cell: float) -> FloatArray:
    """Zero-mean power-law noise, ``|f|^-(HURST + 1)`` amplitude spectrum, by real FFT."""
    white = rng.standard_normal((rows, cols))
    fy = np.fft.fftfreq(rows, d=cell)[:, None]
    fx = np.fft.rfftfreq(cols, d=cell)[None, :]
    f = np.hypot(fx, fy)
    f[0, 0] = 1.0
    gain = f ** -(HURST + 1.0)
    gain[0, 0] = 0.0
    return np.asarray(np.fft.irfft2(np.fft.rfft2(white) * gain, s=(rows, cols)), dtype=np.float64)


def _span(a: FloatArray) -> float:
    return float(a.max() - a.min())


def synthetic_terrain(
    rows: int = 256,
    cols: int = 256,
    cell_size: float = 30.0,
    *,
    seed: int | np.random.Generator = 0,
    peaks: int = 6,
    ridges: int = 3,
    valleys: int = 2,
    base: float = 200.0,
    relief: float = 1500.0,
    roughness: float = 0.15,
    origin: tuple[float, float] = (0.0, 0.0),
    crs: CRS | str | int | None = None,
) -> HeightGrid:
    """A seeded synthetic :class:`HeightGrid` (see the module docstring for the model)."""
    rows = _count("rows", rows, 2)
    cols = _count("cols", cols, 2)
    cell = _real("cell_size", cell_size, minimum=0.0, strict=True)
    n_peaks = _count("peaks", peaks, 0)
    n_ridges = _count("ridges", ridges, 0)
    n_valleys = _count("valleys", valleys, 0)
    base_v = _real("base", base)
    relief_v = _real("relief", relief, minimum=0.0)
    rough = _real("roughness", roughness, minimum=0.0)
    try:
        x0, y0 = (_real("origin", v) for v in origin)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"origin must be two finite numbers (x, y); got {origin!r}") from None
    grid_crs: CRS | None = None
    if crs is not None:
        try:
            grid_crs = CRS.from_user_input(crs)
        except Exception as exc:  # rasterio raises CRSError; any failure means a bad value
            raise InputError(f"crs: not a coordinate reference system: {crs!r} ({exc})") from None
    rng = _rng(seed)

    width, height = cols * cell, rows * cell
    size = max(width, height)
    xs: FloatArray = (np.arange(cols, dtype=np.float64) + 0.5) * cell  # cell centres from origin
    ys: FloatArray = height - (np.arange(rows, dtype=np.float64) + 0.5) * cell  # row 0 = north

    # Feature parameters, drawn in a fixed order.
    peak_params = [
        (
            rng.uniform(0, width),
            rng.uniform(0, height),
            rng.uniform(0.04, 0.12),
            rng.uniform(0.5, 1),
        )
        for _ in range(n_peaks)
    ]
    line_params = []
    for amp_range, width_range, count in (
        ((0.3, 0.7), (0.02, 0.06), n_ridges),
        ((-0.5, -0.2), (0.03, 0.08), n_valleys),
    ):
        for _ in range(count):
            ax, ay = rng.uniform(0, width), rng.uniform(0, height)
            angle = rng.uniform(0, 2 * math.pi)
            length = rng.uniform(0.3, 0.8) * size
            b = (ax + length * math.cos(angle), ay + length * math.sin(angle))
            w = rng.uniform(*width_range) * size
            line_params.append(((ax, ay), b, w, rng.uniform(*amp_range)))

    features = np.zeros((rows, cols), dtype=np.float64)
    for px, py, sigma_frac, amp in peak_params:
        sigma = sigma_frac * size
        gx = np.exp(-((xs - px) ** 2) / (2 * sigma * sigma))
        gy = np.exp(-((ys - py) ** 2) / (2 * sigma * sigma))
        features += amp * np.outer(gy, gx)
    for a, b, w, amp in line_params:
        _segment_bump(features, xs, ys, a, b, w, amp)

    total = features
    if rough > 0:
        noise = _fractal_noise(rng, rows, cols, cell)
        feature_span = _span(features)
        noise_span = _span(noise)
        if noise_span > 0:
            scale = rough * (feature_span if feature_span > 0 else 1.0) / noise_span
            total = features + scale * noise

    lowest, span = float(total.min()), _span(total)
    if span > 0 and relief_v > 0:
        heights = base_v + relief_v * ((total - lowest) / span)
    else:
        heights = np.full((rows, cols), base_v)
    transform = Affine(cell, 0.0, x0, 0.0, -cell, y0 + height)
    label = f"{seed}" if not isinstance(seed, np.random.Generator) else "generator"
    source = (
        f"synthetic(seed={label}, rows={rows}, cols={cols}, cell_size={cell:g}, peaks={n_peaks}, "
        f"ridges={n_ridges}, valleys={n_valleys}, roughness={rough:g})"
    )
    return HeightGrid(heights.astype(np.float32), transform, grid_crs, (source,))
