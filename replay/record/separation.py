"""``/vehicle/separation`` where it says something new (recording format 2): which samples of a
batch of separations are written, and what each message holds.

A message (:func:`separation_doc`) holds the nearest active threat (``nearest_m``, ``nearest``),
the nearest danger zone (``zone_m``, ``zone``), the run's margin and ``threats``, the (at most)
four nearest active threats by id -- the message format 1 wrote at every state sample.  Far from
everything these change slowly; format 2 writes a sample of the state log's ticks only where
(:func:`kept_rows`):

- ``nearest_m`` or ``zone_m`` left its *band*: the bands are ``BAND_ABS_M`` wide near zero and
  widen with the distance (``BAND_REL`` of it), so between two written samples each stays in the
  band of the first (:func:`band`): within about ``BAND_ABS_M + BAND_REL * |value|`` of it;
- which threat or zone is nearest changed;
- ``nearest_m`` or ``zone_m`` crossed the margin (the sample before and the sample after are
  written: the violation intervals of the written samples are the full record's);
- a threat's or zone's least shown separation in the batch is there (so the least separation
  of each shown, over the whole record, is a written one), and the local minima of
  ``nearest_m`` and ``zone_m``;
- the first and last sample of each batch, and the first of each ``MAX_GAP_S`` window.

What the run's metrics, ``inspect``, ``view`` and the pictures say about separations is
computed from the flight itself (:class:`replay.metrics.MetricsTracker`, the states), not from
this topic: it is for Foxglove's plots.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numba as nb
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

SHOWN = 4  # threats in a message
BAND_ABS_M = 1.0
BAND_REL = 0.01
MAX_GAP_S = 10.0


def band(values: npt.ArrayLike) -> FloatArray:
    """The band of each separation (m): ``floor(sign(v) ln(1 + BAND_REL |v| / BAND_ABS_M) /
    BAND_REL)``, bands ``BAND_ABS_M + BAND_REL |v|`` wide; NaN where not finite."""
    v = np.asarray(values, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.floor(np.sign(v) * np.log1p(BAND_REL * np.abs(v) / BAND_ABS_M) / BAND_REL)


def nearest(
    threats: FloatArray, zones: FloatArray
) -> tuple[IntArray, FloatArray, IntArray, FloatArray]:
    """Per sample: the columns of the (at most) ``SHOWN`` nearest active threats of
    ``threats`` (K, Nt) in order (K, SHOWN) (-1 past the active ones) and their separations
    (NaN there) -- the smallest finite values of each row by (value, column): an equal
    separation is listed by its column (:func:`_nearest_columns`, compiled; twin
    :func:`nearest_columns_numpy`);
    the column of the nearest zone of ``zones`` (K, Nz) (-1: none) and its separation."""
    k = threats.shape[0]
    cols, shown = _nearest_columns(np.ascontiguousarray(threats, dtype=np.float64), SHOWN)
    if zones.shape[1]:
        zlive = np.where(np.isfinite(zones), zones, np.inf)
        zcol = np.argmin(zlive, axis=1)
        zval = zlive[np.arange(k), zcol]
        zcol = np.where(np.isfinite(zval), zcol, -1)
        zval = np.where(zcol >= 0, zval, np.nan)
    else:
        zcol, zval = np.full(k, -1), np.full(k, np.nan)
    return cols, shown, zcol.astype(np.int64), zval


@nb.njit(cache=True, nogil=True)
def _nearest_columns(values: FloatArray, m: int) -> tuple[IntArray, FloatArray]:  # pragma: no cover
    """The ``m`` smallest finite values of each row of ``values`` (K, N) by (value, column):
    their columns (K, m), -1 past the finite ones, and values, NaN there.  One pass a row,
    each value inserted into the row's sorted few (issue 38: ``argpartition`` and ``lexsort``
    of a minute's 600 samples of 100 threats took 0.8 ms, 3 % of an 8-hour recorded run)."""
    k, n = values.shape
    cols = np.full((k, m), -1, dtype=np.int64)
    vals = np.full((k, m), np.nan)
    for i in range(k):
        count = 0
        for j in range(n):
            v = values[i, j]
            if not np.isfinite(v) or (count == m and v >= vals[i, m - 1]):
                continue
            q = count if count < m else m - 1  # the last of a full row drops out
            while q > 0 and vals[i, q - 1] > v:  # an equal value keeps its earlier column first
                vals[i, q] = vals[i, q - 1]
                cols[i, q] = cols[i, q - 1]
                q -= 1
            vals[i, q] = v
            cols[i, q] = j
            if count < m:
                count += 1
    return cols, vals


def nearest_columns_numpy(values: FloatArray, m: int) -> tuple[IntArray, FloatArray]:
    """:func:`_nearest_columns` in numpy (the tests compare them): a stable sort of each row
    with the non-finite values last."""
    live = np.where(np.isfinite(values), values, np.inf)
    order = np.argsort(live, axis=1, kind="stable")[:, :m]
    shown = np.take_along_axis(live, order, axis=1)
    cols = np.where(np.isfinite(shown), order, -1).astype(np.int64)
    shown = np.where(cols >= 0, shown, np.nan)
    if cols.shape[1] < m:  # fewer columns than asked: padded
        pad = m - cols.shape[1]
        cols = np.pad(cols, ((0, 0), (0, pad)), constant_values=-1)
        shown = np.pad(shown, ((0, 0), (0, pad)), constant_values=np.nan)
    return cols, shown


def kept_rows(
    ns: IntArray,
    cols: IntArray,
    shown: FloatArray,
    zcol: IntArray,
    zval: FloatArray,
    margin: float,
    n_threats: int,
    n_zones: int,
) -> BoolArray:
    """Which samples of a batch are written (module docstring): ``ns`` (K,) their times,
    ``cols``, ``shown``, ``zcol``, ``zval`` what :func:`nearest` gives."""
    k = len(ns)
    keep = np.zeros(k, dtype=bool)
    keep[0] = keep[-1] = True
    if k < 3:
        return keep | True
    values = np.column_stack([shown[:, 0], zval])  # what Foxglove plots: nearest_m, zone_m
    ids = np.column_stack([cols[:, 0], zcol])
    bands = np.nan_to_num(band(values), nan=np.inf)
    below = values < margin
    change = (
        (ids[1:] != ids[:-1]).any(axis=1)
        | (bands[1:] != bands[:-1]).any(axis=1)
        | (below[1:] != below[:-1]).any(axis=1)
    )
    keep[1:] |= change
    cross = np.flatnonzero((below[1:] != below[:-1]).any(axis=1))
    keep[cross] = True  # the sample before a crossing too
    window = ns // round(MAX_GAP_S * 1e9)
    keep[1:] |= window[1:] != window[:-1]
    # the least shown separation of each threat and zone in the batch
    for ids_j, vals_j, n in ((cols, shown, n_threats), (zcol[:, None], zval[:, None], n_zones)):
        if n:
            keep[_least_rows(np.ascontiguousarray(ids_j), np.ascontiguousarray(vals_j), n)] = True
    # local minima of the nearest threat's and zone's separations
    for v in (shown[:, 0], zval):
        inner = (v[1:-1] <= v[:-2]) & (v[1:-1] <= v[2:])
        keep[1:-1] |= inner
    return keep


@nb.njit(cache=True, nogil=True)
def _least_rows(ids: IntArray, vals: FloatArray, n: int) -> IntArray:  # pragma: no cover - jit
    """The row of the least value of each of the ``n`` columns that ``ids`` (K, S) name (-1:
    none), the first such row where it is least in several: the rows (as ``np.argmin`` over a
    (K, n) table of the values, infinite elsewhere, gives them -- without the table)."""
    best = np.full(n, np.inf)
    row = np.full(n, -1, dtype=np.int64)
    for i in range(ids.shape[0]):
        for s in range(ids.shape[1]):
            c = ids[i, s]
            if c >= 0 and vals[i, s] < best[c]:
                best[c] = vals[i, s]
                row[c] = i
    return row[row >= 0]


def separation_doc(
    margin: float,
    names: Sequence[str],
    threat_cols: IntArray,
    zone_cols: IntArray,
    cols: Sequence[int],
    shown: Sequence[float],
    zcol: int,
    zval: float,
) -> dict[str, Any]:
    """One message: ``cols``/``shown`` the row's shown threats (columns of ``threat_cols``,
    -1 past the active ones), ``zcol``/``zval`` its nearest zone (column of ``zone_cols``)."""
    doc: dict[str, Any] = {"margin_m": margin, "threats": {}}
    if cols and cols[0] >= 0:
        doc["nearest_m"] = round(float(shown[0]), 2)
        doc["nearest"] = names[int(threat_cols[cols[0]])]
        doc["threats"] = {
            names[int(threat_cols[j])]: round(float(v), 2)
            for j, v in zip(cols, shown, strict=True)
            if j >= 0
        }
    if zcol >= 0:
        doc["zone_m"] = round(float(zval), 2)
        doc["zone"] = names[int(zone_cols[zcol])]
    return doc


__all__ = ["band", "kept_rows", "nearest", "nearest_columns_numpy", "separation_doc"]
