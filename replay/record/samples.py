"""The vehicle's samples of many log ticks at once: ``/tf``, ``/vehicle/pose``, ``/vehicle/state``
and ``/vehicle/fix`` of K samples as MCAP message records, built with numpy
(:class:`replay.record.wire.Rows`), one batch at a time (:func:`sample_records`).

What each message says is what :meth:`replay.record.recorder.RunRecorder.write_state` documents:
the pose and transform of ``base_link`` in ``map`` (ENU, relative to the map origin), the state
(:data:`replay.record.messages.VehicleState`: the 12 states, the altitude, the speed through the
air, alpha, beta, the controls, the extras) and the WGS84 fix.  The Foxglove messages are the
bytes protobuf's ``SerializeToString`` gives (the tests compare them).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.record import topics as T
from replay.record.messages import (
    EXTRAS_FIELD_NUMBERS,
    EXTRAS_OTHER_FIELD,
    STATE_DOUBLES,
    STATE_EXTRAS_FIELD,
    STATE_FIELD_NUMBERS,
    STATE_KEYS,
    STATE_TIMESTAMP_FIELD,
)
from replay.record.wire import Rows, tag, varint

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
I64 = npt.NDArray[np.int64]
WIND = ("wind_n", "wind_e", "wind_d")
_S = np.sqrt(0.5)


@dataclass(frozen=True)
class Samples:
    """K vehicle samples: times (ns), states (K, 12), controls (K, 4) and extras: name ->
    (values (K,), present (K,)), in the order first given."""

    ns: I64
    states: FloatArray
    controls: FloatArray
    extras: dict[str, tuple[FloatArray, BoolArray]]


def quaternions_map(phi: FloatArray, theta: FloatArray, psi: FloatArray) -> FloatArray:
    """(K, 4) x, y, z, w: :func:`replay.record.scene.quaternion_map` for arrays."""
    cr, sr = np.cos(0.5 * phi), np.sin(0.5 * phi)
    cp, sp = np.cos(0.5 * theta), np.sin(0.5 * theta)
    cy, sy = np.cos(0.5 * psi), np.sin(0.5 * psi)
    w0 = cr * cp * cy + sr * sp * sy
    x0 = sr * cp * cy - cr * sp * sy
    y0 = cr * sp * cy + sr * cp * sy
    z0 = cr * cp * sy - sr * sp * cy
    return np.stack([_S * (x0 + y0), _S * (x0 - y0), _S * (w0 - z0), _S * (w0 + z0)], axis=1)


def air_data(s: FloatArray, extras: Mapping[str, tuple[FloatArray, BoolArray]]) -> FloatArray:
    """(K, 3) airspeed, alpha, beta: the body velocity less the wind in body axes (where a
    sample has any of ``wind_n``, ``wind_e``, ``wind_d``; an absent one is 0).  A value that is
    not finite gives NaN, silently (it is recorded as it is)."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _air_data(s, extras)


def _air_data(s: FloatArray, extras: Mapping[str, tuple[FloatArray, BoolArray]]) -> FloatArray:
    u, v, w = s[:, 3], s[:, 4], s[:, 5]
    if any(name in extras for name in WIND):
        k = len(s)
        wn, we, wd = (
            np.where(extras[n][1], extras[n][0], 0.0) if n in extras else np.zeros(k) for n in WIND
        )
        cf, sf = np.cos(s[:, 6]), np.sin(s[:, 6])
        ct, st = np.cos(s[:, 7]), np.sin(s[:, 7])
        cp, sp = np.cos(s[:, 8]), np.sin(s[:, 8])
        # the wind in body axes: R(body -> NED)^T @ wind
        bu = ct * cp * wn + ct * sp * we - st * wd
        bv = (sf * st * cp - cf * sp) * wn + (sf * st * sp + cf * cp) * we + sf * ct * wd
        bw = (cf * st * cp + sf * sp) * wn + (cf * st * sp - sf * cp) * we + cf * ct * wd
        windy = np.zeros(k, dtype=bool)
        for n in WIND:
            if n in extras:
                windy |= extras[n][1]
        u = np.where(windy, u - bu, u)
        v = np.where(windy, v - bv, v)
        w = np.where(windy, w - bw, w)
    va = np.sqrt(u * u + v * v + w * w)
    alpha = np.arctan2(w, u)
    beta = np.where(va > 0, np.arcsin(np.clip(v / va, -1.0, 1.0)), 0.0)
    return np.stack([va, alpha, beta], axis=1)


def state_rows(b: Samples) -> Rows:
    """The ``terrapath.VehicleState`` messages of the samples."""
    s = b.states
    k = len(s)
    air = air_data(s, b.extras)
    columns = {
        **{name: s[:, j] for j, name in enumerate(T.STATE_FIELDS)},
        "alt": -s[:, 2],
        "airspeed": air[:, 0],
        "alpha": air[:, 1],
        "beta": air[:, 2],
        **{name: b.controls[:, j] for j, name in enumerate(T.CONTROL_FIELDS)},
    }
    rows = Rows(k).timestamp(STATE_TIMESTAMP_FIELD, b.ns)
    for key in STATE_KEYS:
        number = STATE_FIELD_NUMBERS[key]
        if key in STATE_DOUBLES:
            rows.double(number, columns[key], keep=None)
        else:
            rows.float32(number, columns[key])
    extras = Rows(k)
    known = sorted((EXTRAS_FIELD_NUMBERS[n], n) for n in b.extras if n in EXTRAS_FIELD_NUMBERS)
    for number, name in known:
        values, present = b.extras[name]
        extras.float32(number, values, None if present.all() else present)
    for name, (values, present) in b.extras.items():
        if name not in EXTRAS_FIELD_NUMBERS:
            extras.raw(*_other(name, values, present))
    return rows.message(STATE_EXTRAS_FIELD, extras)


def _other(name: str, values: FloatArray, present: BoolArray) -> tuple[npt.NDArray[np.uint8], I64]:
    """``extras.other`` entries {name, value} where ``present``: (K, w) bytes and lengths."""
    text = name.encode()
    body = tag(1, 2) + varint(len(text)) + text + tag(2, 1)
    head = tag(EXTRAS_OTHER_FIELD, 2) + varint(len(body) + 8) + body
    k = len(values)
    out = np.empty((k, len(head) + 8), dtype=np.uint8)
    out[:, : len(head)] = np.frombuffer(head, dtype=np.uint8)
    out[:, len(head) :] = np.ascontiguousarray(values, dtype="<f8").view(np.uint8).reshape(k, 8)
    return out, np.where(present, out.shape[1], 0).astype(np.int64)


def pose_rows(ns: I64, xyz: FloatArray, q: FloatArray) -> tuple[Rows, Rows]:
    """``/tf`` (map -> base_link) and ``/vehicle/pose`` (in map) of positions (K, 3) relative to
    the map origin and attitudes (K, 4)."""
    k = len(ns)
    tf = (
        Rows(k)
        .timestamp(1, ns)
        .text(2, T.MAP_FRAME)
        .text(3, T.VEHICLE_FRAME)
        .message(4, Rows(k).doubles(1, xyz))
        .message(5, Rows(k).doubles(1, q))
    )
    pose = Rows(k).message(1, Rows(k).doubles(1, xyz)).message(2, Rows(k).doubles(1, q))
    in_frame = Rows(k).timestamp(1, ns).text(2, T.MAP_FRAME).message(3, pose)
    return tf, in_frame


def fix_rows(ns: I64, lon: FloatArray, lat: FloatArray, alt: FloatArray) -> Rows:
    """``/vehicle/fix`` (foxglove.LocationFix of base_link)."""
    k = len(ns)
    rows = Rows(k).double(1, lat).double(2, lon).double(3, alt)
    return rows.timestamp(6, ns).text(7, T.VEHICLE_FRAME)


LonLat = Callable[[Any, Any], tuple[Any, Any]]


def lonlats(to_lonlat: LonLat, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``to_lonlat`` of many points: called with the arrays, or point by point when it does not
    take arrays."""
    try:
        lon, lat = to_lonlat(x, y)
        lon_a = np.asarray(lon, dtype=np.float64).reshape(-1)
        lat_a = np.asarray(lat, dtype=np.float64).reshape(-1)
        if lon_a.shape == lat_a.shape == x.shape:
            return lon_a, lat_a
    except (TypeError, ValueError):
        pass
    pairs = [to_lonlat(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)]
    return (
        np.array([float(p[0]) for p in pairs], dtype=np.float64),
        np.array([float(p[1]) for p in pairs], dtype=np.float64),
    )


def sample_records(
    b: Samples,
    channels: Mapping[str, int],
    origin: Sequence[float],
    to_lonlat: LonLat | None,
) -> tuple[FloatArray, list[tuple[int, bytes, I64, I64]]]:
    """The positions (K, 3) relative to the map origin, and the (channel, records, lengths,
    log times) of the samples' ``/tf``, ``/vehicle/pose``, ``/vehicle/state`` (and
    ``/vehicle/fix`` with ``to_lonlat``), each in the order of its records."""
    s = b.states
    ox, oy, oz = (float(v) for v in origin)
    xyz = np.stack([s[:, 1] - ox, s[:, 0] - oy, -s[:, 2] - oz], axis=1)
    q = quaternions_map(s[:, 6], s[:, 7], s[:, 8])
    tf, pose = pose_rows(b.ns, xyz, q)
    out = [
        (channels[T.TF], *tf.records(channels[T.TF], b.ns)),
        (channels[T.VEHICLE_POSE], *pose.records(channels[T.VEHICLE_POSE], b.ns)),
        (channels[T.VEHICLE_STATE], *state_rows(b).records(channels[T.VEHICLE_STATE], b.ns)),
    ]
    if to_lonlat is not None:
        lon, lat = lonlats(to_lonlat, s[:, 1], s[:, 0])
        fix = fix_rows(b.ns, lon, lat, -s[:, 2])
        out.append((channels[T.VEHICLE_FIX], *fix.records(channels[T.VEHICLE_FIX], b.ns)))
    return xyz, out


__all__ = ["Samples", "air_data", "quaternions_map", "sample_records", "state_rows"]
