"""Read a recorded run back (:func:`load_run`) and describe it (:func:`summary`).

The file is what :class:`replay.record.recorder.RunRecorder` writes (topics in :mod:`replay.record.topics`)::

    /vehicle/state           terrapath.VehicleState  -> RunRecord.times_ns, states, controls, extras
                                                        (format 2: protobuf; format 1: JSON)
    /mission/waypoint_list   terrapath.WaypointList  -> RunRecord.waypoints (WaypointChange)
    /threats/list            terrapath.ThreatList    -> RunRecord.threats (ThreatUpdate)
    /radar/detection_list    terrapath.DetectionList -> RunRecord.detections (DetectionScan)
    /avoidance/decision      terrapath.Decision      -> RunRecord.decisions (Decision)
    /log                     foxglove.Log            -> RunRecord.logs (LogEntry)
    /metrics                 terrapath.Metrics       -> RunRecord.metrics (else metadata "metrics")
    metadata "terrapath"                             -> RunRecord.metadata (text; .seed, .dem)
    attachments                                      -> RunRecord.attachments, attachment_types

The Foxglove display topics (``/tf``, ``/vehicle/pose``, ``/map/terrain``, the scene updates) are
counted in ``topic_counts`` (from the summary statistics) but not decoded: what they show is in the
data topics, which the recorder keeps in chunks of their own, so they are not even decompressed.

Formats (the metadata's ``terrapath`` key, :data:`replay.record.topics.READABLE_FORMATS`): 1 wrote
``/vehicle/state`` as JSON text, 2 as protobuf; both are read.

Integrity: the whole file is checked before anything is believed -- the footer and closing magic
must be there, the data-section CRC (which also covers attachments and metadata) and the summary
CRC must match, and every chunk is read with CRC validation (``make_reader(f,
validate_crcs=True)``).  A truncated, corrupt or non-MCAP file raises :class:`DataFileError`
``'run.mcap': not a complete terrapath run (...)``; a valid MCAP file without the ``terrapath``
metadata record raises ``'x.mcap': not a terrapath run (...)``.  No other exception escapes.
"""

from __future__ import annotations

import io
import json
import math
import operator
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from os import PathLike
from typing import IO, Any

import numpy as np
import numpy.typing as npt
from foxglove_schemas_protobuf.Log_pb2 import Log
from mcap.reader import make_reader

from replay.record import topics as T
from terrain.errors import DataFileError

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

_MAGIC = b"\x89MCAP0\r\n"
_FOOTER = struct.Struct("<BQQQI")  # opcode, length, summary start, summary offset start, crc
_DATA_END = struct.Struct("<BQI")  # opcode, length, data section crc
_LEVELS = {v: k.lower() for k, v in Log.Level.items()}


@dataclass(frozen=True)
class WaypointChange:
    """The waypoint list (W, 3) map metres from time ``t_ns`` on, and why it changed."""

    t_ns: int
    waypoints: FloatArray
    reason: str
    active_index: int

    @property
    def t(self) -> float:
        return self.t_ns / 1e9


@dataclass(frozen=True)
class ThreatUpdate:
    """The threats present from ``t_ns`` on (dicts as given to ``write_threats``, normalised) and
    the ids that appeared, changed (moved) or were removed at that time."""

    t_ns: int
    threats: tuple[dict[str, Any], ...]
    appeared: tuple[str, ...]
    changed: tuple[str, ...]
    removed: tuple[str, ...]

    @property
    def t(self) -> float:
        return self.t_ns / 1e9


@dataclass(frozen=True)
class DetectionScan:
    """One radar scan: the detections (dicts with id, position, kind, moving, range)."""

    t_ns: int
    detections: tuple[dict[str, Any], ...]

    @property
    def t(self) -> float:
        return self.t_ns / 1e9


@dataclass(frozen=True)
class Decision:
    """One avoidance decision (algorithm, compute_s, and what the avoider recorded)."""

    t_ns: int
    decision: dict[str, Any]

    @property
    def t(self) -> float:
        return self.t_ns / 1e9

    @property
    def compute_s(self) -> float:
        return float(self.decision["compute_s"])


@dataclass(frozen=True)
class LogEntry:
    t_ns: int
    level: str
    text: str

    @property
    def t(self) -> float:
        return self.t_ns / 1e9


@dataclass(frozen=True)
class RunRecord:
    """Everything a run recorded.  Times are integer nanoseconds of simulated time (``times``
    and the events' ``t`` give seconds).  ``extras`` holds one (K,) array per name, NaN where a
    sample did not have it."""

    path: str
    times_ns: IntArray
    states: FloatArray
    controls: FloatArray
    extras: dict[str, FloatArray]
    waypoints: tuple[WaypointChange, ...]
    threats: tuple[ThreatUpdate, ...]
    detections: tuple[DetectionScan, ...]
    decisions: tuple[Decision, ...]
    logs: tuple[LogEntry, ...]
    metrics: dict[str, Any]
    metadata: dict[str, str]
    attachments: dict[str, bytes] = field(repr=False)
    attachment_types: dict[str, str]
    topic_counts: dict[str, int]
    start_ns: int
    end_ns: int
    state_stride: int = 1  # the states decoded are every state_stride-th recorded (max_states)

    @property
    def times(self) -> FloatArray:
        return self.times_ns / 1e9

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    @property
    def seed(self) -> int | None:
        """The run's seed (MCAP metadata is text: converted here), None when none was recorded."""
        return _int(self.metadata.get("seed"))

    @property
    def dem(self) -> list[str]:
        """The DEM tiles the run flew over (absolute paths when it was recorded), [] for none."""
        try:
            tiles = json.loads(self.metadata.get("dem", "[]"))
        except json.JSONDecodeError:
            return []
        return [str(t) for t in tiles] if isinstance(tiles, list) else []


class _Incomplete(Exception):
    """The file is not a complete MCAP file (reason in the message)."""


def load_run(
    path: str | PathLike[str], *, with_states: bool = True, max_states: int | None = None
) -> RunRecord:
    """Read and check a recorded run (see the module docstring); raises DataFileError.

    ``with_states=False`` skips decoding the state samples (``times``/``states`` come back
    empty): what ``inspect`` and re-flying need, several times faster on long runs.
    ``max_states`` decodes at most about that many, a regular stride of them (what a picture
    draws); the rest are skipped undecoded. The whole file's CRCs are checked either way."""
    name = str(path)
    try:
        f = open(path, "rb")
    except OSError as err:
        raise DataFileError(f"{name!r}: cannot open ({err.strerror or err})") from None
    try:
        with f:
            _check_integrity(f)
            return _read(f, name, with_states, max_states)
    except DataFileError:
        raise
    except Exception as err:  # anything a damaged file can make the parsers raise
        reason = str(err) or type(err).__name__
        if not isinstance(err, _Incomplete):
            reason = f"{type(err).__name__}: {reason}"
        reason = " ".join(reason.split())[:160]
        raise DataFileError(f"{name!r}: not a complete terrapath run ({reason})") from None


def _check_integrity(f: IO[bytes]) -> None:
    """Magic at both ends, footer, data-section CRC and summary CRC (the CRCs the recorder writes;
    chunk CRCs are checked as chunks are read)."""
    size = f.seek(0, io.SEEK_END)
    tail = len(_MAGIC) + _FOOTER.size
    f.seek(0)
    if f.read(len(_MAGIC)) != _MAGIC:
        raise _Incomplete("not an MCAP file")
    if size < len(_MAGIC) + tail:
        raise _Incomplete(f"truncated: {size} bytes")
    f.seek(size - tail)
    footer = f.read(tail)
    if footer[-len(_MAGIC) :] != _MAGIC:
        raise _Incomplete("truncated: no closing magic")
    opcode, length, summary_start, _, summary_crc = _FOOTER.unpack(footer[: _FOOTER.size])
    if opcode != 0x02 or length != 20:
        raise _Incomplete("truncated: no footer")
    footer_start = size - tail
    if not _DATA_END.size <= summary_start <= footer_start:
        raise _Incomplete("no summary section")
    data_end = summary_start - _DATA_END.size
    f.seek(data_end)
    opcode, length, data_crc = _DATA_END.unpack(f.read(_DATA_END.size))
    if opcode != 0x0F or length != 4:
        raise _Incomplete("no data end record before the summary")
    if data_crc and _crc(f, 0, data_end) != data_crc:
        raise _Incomplete("data section CRC mismatch")
    if summary_crc:
        crc = _crc(f, summary_start, footer_start)
        crc = zlib.crc32(footer[: _FOOTER.size - 4], crc)
        if crc != summary_crc:
            raise _Incomplete("summary CRC mismatch")
    f.seek(0)


def _check_metadata(run: dict[str, str], name: str) -> None:
    """The run metadata that is JSON must be the JSON the recorder writes: ``map_origin`` three
    finite numbers, ``dem`` a list of paths (a tampered file: a DataFileError naming it)."""
    expected = {"map_origin": "a JSON list of 3 numbers [x, y, z]", "dem": "a JSON list of paths"}
    for key, what in expected.items():
        if key not in run:
            continue
        try:
            value = json.loads(run[key])
        except (ValueError, RecursionError):
            value = None
        if key == "map_origin":
            ok = (
                isinstance(value, list)
                and len(value) == 3
                and all(
                    isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                    for v in value
                )
            )
        else:
            ok = isinstance(value, list) and all(isinstance(v, str) for v in value)
        if not ok:
            raise DataFileError(
                f"{name!r}: metadata {T.RUN_METADATA!r} field {key!r}: expected {what}"
            )


def _crc(f: IO[bytes], start: int, end: int) -> int:
    f.seek(start)
    crc, left = 0, end - start
    while left > 0:
        block = f.read(min(left, 1 << 22))
        if not block:
            raise _Incomplete("truncated")
        crc = zlib.crc32(block, crc)
        left -= len(block)
    return crc


def _read(
    f: IO[bytes], name: str, with_states: bool = True, max_states: int | None = None
) -> RunRecord:
    reader = make_reader(f, validate_crcs=True)
    metadata: dict[str, dict[str, str]] = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    run = metadata.get(T.RUN_METADATA)
    if run is None:
        raise DataFileError(
            f"{name!r}: not a terrapath run (no {T.RUN_METADATA!r} metadata record)"
        )
    version = run.get("terrapath", "")
    if version not in T.READABLE_FORMATS:
        raise DataFileError(
            f"{name!r}: terrapath run format {version!r} is not supported (this version reads "
            f"{', '.join(map(repr, T.READABLE_FORMATS))})"
        )
    _check_metadata(run, name)
    attachments: dict[str, bytes] = {}
    media: dict[str, str] = {}
    for att in reader.iter_attachments():
        attachments[att.name] = bytes(att.data)
        media[att.name] = att.media_type

    summary = reader.get_summary()
    if summary is None or summary.statistics is None:
        raise _Incomplete("no statistics in the summary")
    counts: dict[str, int] = {}
    for channel_id, n in summary.statistics.channel_message_counts.items():
        topic = summary.channels[channel_id].topic
        counts[topic] = counts.get(topic, 0) + n
    start, end = summary.statistics.message_start_time, summary.statistics.message_end_time
    times: list[int] = []
    rows: list[list[float]] = []
    extras: list[dict[str, Any]] = []
    waypoints: list[WaypointChange] = []
    threats: list[ThreatUpdate] = []
    detections: list[DetectionScan] = []
    decisions: list[Decision] = []
    logs: list[LogEntry] = []
    metrics: dict[str, Any] | None = None
    keys = (*T.STATE_FIELDS, *T.CONTROL_FIELDS)
    wanted = T.DATA_TOPICS if with_states else [t for t in T.DATA_TOPICS if t != T.VEHICLE_STATE]
    n_states = counts.get(T.VEHICLE_STATE, 0)
    stride = max(1, -(-n_states // max_states)) if max_states else 1
    seen = -1
    state = _state_decoder(version)
    for _schema, channel, message in reader.iter_messages(wanted, log_time_order=False):
        topic, ns = channel.topic, message.log_time
        if topic == T.VEHICLE_STATE:
            seen += 1
            if seen % stride:
                continue
            row, extra = state(message.data)
            times.append(ns)
            rows.append(row)
            extras.append(extra)
        elif topic == T.WAYPOINT_LIST:
            doc = json.loads(message.data)
            wps = np.asarray(doc["waypoints"], dtype=np.float64).reshape(-1, 3)
            waypoints.append(WaypointChange(ns, wps, str(doc["reason"]), int(doc["active_index"])))
        elif topic == T.THREAT_LIST:
            doc = json.loads(message.data)
            threats.append(
                ThreatUpdate(
                    ns,
                    tuple(doc["threats"]),
                    tuple(doc["appeared"]),
                    tuple(doc["changed"]),
                    tuple(doc["removed"]),
                )
            )
        elif topic == T.DETECTION_LIST:
            detections.append(DetectionScan(ns, tuple(json.loads(message.data)["detections"])))
        elif topic == T.DECISION:
            decisions.append(Decision(ns, dict(json.loads(message.data))))
        elif topic == T.LOG:
            log = Log.FromString(message.data)
            logs.append(LogEntry(ns, _LEVELS.get(log.level, "unknown"), log.message))
        elif topic == T.METRICS:
            metrics = dict(json.loads(message.data))
    if metrics is None:
        metrics = {k: json.loads(v) for k, v in metadata.get(T.METRICS_METADATA, {}).items()}

    t = np.asarray(times, dtype=np.int64)
    order = np.argsort(t, kind="stable")
    values = np.asarray(rows, dtype=np.float64).reshape(-1, len(keys))[order]
    names = sorted({k for e in extras for k in e})
    extra_arrays = {
        k: np.asarray([e.get(k) for e in extras], dtype=np.float64)[order] for k in names
    }

    def by_time(events: list[Any]) -> tuple[Any, ...]:
        return tuple(sorted(events, key=lambda e: e.t_ns))

    return RunRecord(
        path=name,
        times_ns=t[order],
        states=values[:, : len(T.STATE_FIELDS)],
        controls=values[:, len(T.STATE_FIELDS) :],
        extras=extra_arrays,
        waypoints=by_time(waypoints),
        threats=by_time(threats),
        detections=by_time(detections),
        decisions=by_time(decisions),
        logs=by_time(logs),
        metrics=metrics,
        metadata=run,
        attachments=attachments,
        attachment_types=media,
        topic_counts=dict(sorted(counts.items())),
        start_ns=start,
        end_ns=end,
        state_stride=stride,
    )


StateDecoder = Callable[[bytes], tuple[list[Any], dict[str, Any]]]


def _state_decoder(version: str) -> StateDecoder:
    """The /vehicle/state message's numbers (the 12 states and 4 controls in order) and extras:
    format 1 JSON text (a number not finite was written ``null``), format 2 protobuf
    (``terrapath.VehicleState``: an extra is there when its field is)."""
    keys = (*T.STATE_FIELDS, *T.CONTROL_FIELDS)
    if version == "1":

        def from_json(data: bytes) -> tuple[list[Any], dict[str, Any]]:
            doc = json.loads(data)
            return [doc[k] for k in keys], doc.get("extras") or {}

        return from_json
    from replay.record.messages import VehicleState

    parse, values = VehicleState.FromString, operator.attrgetter(*keys)

    def from_protobuf(data: bytes) -> tuple[list[Any], dict[str, Any]]:
        msg = parse(data)
        extra: dict[str, Any] = {}
        for desc, value in msg.extras.ListFields():
            if desc.name == "other":
                extra.update((e.name, e.value) for e in value)
            else:
                extra[desc.name] = value
        return list(values(msg)), extra

    return from_protobuf


def summary(record: RunRecord) -> dict[str, Any]:
    """What ``terrapath inspect`` shows: JSON-ready facts about a run."""
    md = record.metadata
    compute = [d.compute_s for d in record.decisions]
    return {
        "path": record.path,
        "duration_s": record.duration_s,
        "samples": record.topic_counts.get(T.VEHICLE_STATE, len(record.times_ns)),
        "log_rate_hz": _float(md.get("log_rate_hz")),
        "seed": record.seed,
        "software_version": md.get("software_version", ""),
        "started_utc": md.get("started_utc", ""),
        "command": md.get("command", ""),
        "avoid": md.get("avoid", ""),
        "crs": md.get("crs", ""),
        "map_origin": json.loads(md["map_origin"]) if "map_origin" in md else None,
        "source": md.get("source", ""),
        "vehicle": md.get("vehicle", ""),
        "dem": record.dem,
        "topics": dict(record.topic_counts),
        # the first list is the mission's (reason "initial"); changes are the ones after it
        "waypoint_changes": sum(1 for w in record.waypoints if w.reason != "initial"),
        "threat_updates": len(record.threats),
        "radar_scans": len(record.detections),
        "decisions": len(record.decisions),
        "decision_compute_s": {"total": sum(compute), "max": max(compute, default=0.0)},
        "warnings": sum(1 for e in record.logs if e.level in ("warning", "error", "fatal")),
        "metrics": dict(record.metrics),
        "attachments": [
            {"name": n, "media_type": record.attachment_types.get(n, ""), "bytes": len(b)}
            for n, b in record.attachments.items()
        ],
    }


def _int(text: str | None) -> int | None:
    try:
        return int(text) if text is not None else None
    except ValueError:
        return None


def _float(text: str | None) -> float | None:
    try:
        value = float(text) if text is not None else math.nan
    except ValueError:
        return None
    return value if math.isfinite(value) else None


__all__ = [
    "Decision",
    "DetectionScan",
    "LogEntry",
    "RunRecord",
    "ThreatUpdate",
    "WaypointChange",
    "load_run",
    "summary",
]
