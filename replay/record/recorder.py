"""Record one replay run as one MCAP file that Foxglove shows in 3D (:class:`RunRecorder`).

Topics (names in :mod:`replay.record.topics`; Foxglove schemas are the protobuf ones of
``foxglove-schemas-protobuf``, ``terrapath.*`` schemas are JSON Schema with JSON messages)::

    /tf                      foxglove.FrameTransform   map -> base_link, every state sample
    /tf_static               foxglove.FrameTransform   map -> world, once at t = 0
    /map/terrain             foxglove.SceneUpdate      terrain mesh coloured by height
    /vehicle/pose            foxglove.PoseInFrame      vehicle pose in ``map``
    /vehicle/state           terrapath.VehicleState    12 states, airspeed, alpha, beta, controls, extras
                                                       (protobuf; recording format 2)
    /vehicle/fix             foxglove.LocationFix      WGS84 position (only with ``to_lonlat``)
    /vehicle/separation      terrapath.Separation      nearest threat and zone, margin, where they change
                                                       (batches: later in the file)
    /vehicle/track           foxglove.SceneUpdate      track flown since the last overview
    /vehicle/track_overview  foxglove.SceneUpdate      whole track so far (decimated)
    /mission/waypoints       foxglove.SceneUpdate      waypoint line strip, spheres and labels
    /mission/waypoint_list   terrapath.WaypointList    the list, the active index, the reason
    /threats                 foxglove.SceneUpdate      threat shapes; deletions when one goes
    /threats/list            terrapath.ThreatList      current threats, appeared/changed/removed ids
    /radar/detections        foxglove.SceneUpdate      a marker per detection of the last scan
                                                       (when they differ from the markers shown)
    /radar/detection_list    terrapath.DetectionList   the detections of the last scan
    /rangefinder/beams       foxglove.SceneUpdate      the rangefinders' beams of the last scan
    /avoidance/decision      terrapath.Decision        algorithm, inputs, choice, costs, compute_s
    /avoidance/guidance      foxglove.SceneUpdate      an orbit commanded (CTGA's arc), as a circle;
                                                       FGA's collision cones, as a line list;
                                                       the priority loop's set-points, a line strip
    /log                     foxglove.Log              human-readable events
    /metrics                 terrapath.Metrics         run metrics (also metadata record "metrics")

Conventions:

- **Time**: every method takes the simulated time ``t`` in seconds (t = 0 at the start of the
  replay), converted once to integer nanoseconds (``round(t * 1e9)``) used as MCAP log and publish
  time and as the message timestamps.  The wall-clock start is the metadata key ``started_utc``.
- **Frames**: ``map`` is ENU with its origin at ``map_origin`` (map CRS metres), so the numbers
  Foxglove renders in float32 stay small; every position written to a Foxglove message is relative
  to it.  ``world`` is the map CRS itself, published as a *child* of ``map`` (translation
  ``-map_origin``) so that ``map`` stays the root of the frame tree, the frame Foxglove displays by
  default: a display frame at CRS coordinates (millions of metres) would jitter in float32.
  ``base_link`` is the vehicle (x forward, y left, z up).  ``/vehicle/state`` keeps absolute map
  coordinates (``pn``, ``pe``, ``pd``, ``alt`` as doubles; the other numbers float32: the
  protobuf schema ``terrapath.VehicleState`` of :mod:`replay.record.messages`), the JSON events
  too, in full.
- **Rates**: :meth:`RunRecorder.write_state` may be called at any rate (e.g. every 100 Hz step): the
  *recorder* drops the calls between ticks of ``log_rate_hz`` (a sample is written for the first
  call at or after each tick ``k / log_rate_hz``; ``force=True`` writes anyway) and returns whether
  it wrote; :meth:`RunRecorder.write_states` takes a flight log's samples at once (what the
  simulation uses), and the samples are encoded in batches (``STATE_BATCH``) with numpy
  (:mod:`replay.record.samples`), so their messages come later in the file than the events of
  their time.  The track is sampled from the written states at ``track_rate_hz``; the overview is
  re-published every ``track_overview_s``.  Moving threats are likewise re-drawn at most at
  ``log_rate_hz``; appearances and removals, waypoint changes, detections, decisions and logs are
  written when they happen, a scan's markers only when they are not those shown already (a
  static threat's detection stays where it was scan after scan: Foxglove keeps showing a scene
  entity without a lifetime until it is replaced, so the markers look the same at every time).
- **Threats** (:meth:`RunRecorder.write_threats`): the *current* set, a list of dicts (the shape of
  ``replay.threats.kinds.Threat.shape(t)``); the recorder compares it with the last set it wrote::

      {"id": "obs2", "kind": "sphere",   "center": [x, y, z] | [[x, y, z], ...],
                                          "radius": r | [r, ...]}
      {"id": "sam",  "kind": "cylinder", "center": [x, y] | [x, y, z], "radius": r,
                                          "bottom": z | None, "top": z | None}
      {"id": "twr",  "kind": "ellipsoid", "center": [x, y, z], "axes": [a, b, c],
                                          "exponents": [p, q, r]}        (optional, default 1)
      {"id": "b12",  "kind": "prism",    "center": [x, y] | [x, y, z], "footprint": [[x, y], ...],
                                          "bottom": z | None, "top": z}

  (``top``/``bottom`` are optional for spheres and ellipsoids and ignored there.)  An ellipsoid is
  seed 001's body ``|dx/a|^(2p) + |dy/b|^(2q) + |dz/c|^(2r) <= 1``: drawn as a scaled sphere when
  all exponents are 1, else as a triangle mesh of its surface.  An unbounded cylinder bottom is
  drawn from the lowest terrain height (0 m without terrain), an unbounded top 10 km above the
  bottom.  A prism (a building; ``center`` places its label) is drawn as a closed triangle mesh
  (walls and caps, :func:`replay.record.scene.prism_mesh`), an unbounded bottom as a cylinder's.  Unknown
  keys are refused.
- **Detections** (:meth:`RunRecorder.write_detections`): one radar scan, a list of
  ``{"id", "position": [x, y, z], "range", "kind": "threat" | "terrain", "moving": bool}`` (``id``
  and ``position`` required, ``kind`` defaults to ``"threat"``, ``moving`` to false); or
  :meth:`RunRecorder.write_detection_arrays` with the scan as arrays (what the simulation uses:
  the same messages, checked as arrays, built without a dict per detection).

This module decides *what* is recorded: the channels, the content of each message and when it is
written.  How it is written is elsewhere: the channels' schemas and the threat/detection checks
are in :mod:`replay.record.messages`, the drawing pieces in :mod:`replay.record.scene`, the hand-made encoders
of large and frequent messages (wire format, state text, radar scans) in :mod:`replay.record.encoding`,
and the file in :mod:`replay.record.writer`: written under a temporary name beside ``path`` and renamed
into place only when the ``with`` block ends cleanly (an exception, or Ctrl-C, removes the
temporary file, so a file at ``path`` is always complete), chunks zstd-compressed
(``compression="lz4"`` or ``"none"`` also work), every CRC written (chunks, data section,
summary).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from datetime import UTC, datetime
from os import PathLike
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np
import numpy.typing as npt
from foxglove_schemas_protobuf.CylinderPrimitive_pb2 import CylinderPrimitive
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.KeyValuePair_pb2 import KeyValuePair
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.SpherePrimitive_pb2 import SpherePrimitive
from foxglove_schemas_protobuf.TextPrimitive_pb2 import TextPrimitive
from foxglove_schemas_protobuf.TriangleListPrimitive_pb2 import TriangleListPrimitive
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3

from replay.avoidance.circles import cone_outline
from replay.record import topics as T
from replay.record.encoding import (
    ENTITY_LINES,
    ENTITY_TRIANGLES,
    LINE_POINTS,
    TRI_COLORS,
    TRI_INDICES,
    TRI_POINTS,
    UPDATE_ENTITIES,
    ScanEncoder,
    doubles_messages,
    dumps,
    entity_head,
    jsonable,
    ld,
    packed_fixed32,
)
from replay.record.messages import (
    JSON_SCHEMAS,
    PROTOBUF_CLASSES,
    check_finite,
    check_positive,
    check_vector,
    normalize_detection,
    normalize_threat,
)
from replay.record.samples import Samples, sample_records
from replay.record.scene import (
    FloatArray,
    color,
    decimate_mesh,
    height_colors,
    line_head,
    pose,
    prism_mesh,
    superellipsoid_mesh,
)
from replay.record.separation import kept_rows, nearest, separation_doc
from replay.record.writer import COMPRESSIONS, McapFile, McapSink, descriptor_set
from terrain.errors import InputError, where

LonLat = Callable[[float, float], tuple[float, float]]

NS_PER_S = 1_000_000_000
ORBIT_ENTITY = "guidance/orbit"  # the avoider's orbit on /avoidance/guidance
CONES_ENTITY = "guidance/cones"  # FGA's collision cones on /avoidance/guidance
SETPOINTS_ENTITY = "guidance/setpoints"  # the priority loop's set-points S on /avoidance/guidance
BEAMS_ENTITY = "rangefinder/beams"  # the rangefinders' beams on /rangefinder/beams
ORBIT_SEGMENTS = 72
UNBOUNDED_TOP_DRAW_M = 10_000.0  # an unbounded cylinder top is drawn this far above its bottom
LOG_LEVELS = ("debug", "info", "warning", "error", "fatal")
_POINT_BYTES = 2 + 3 * 9  # a LinePrimitive.points entry (doubles_messages)
STATE_BATCH = 4096  # vehicle samples kept before they are encoded and written at once

# ---------------------------------------------------------------------------------------------
# the recorder


class RunRecorder:
    """Write one replay run to ``path`` (MCAP); use as a context manager.  See the module docstring
    for topics, frames, rates and the threat/detection dicts.

    ``map_origin`` (x, y, z map metres) is the origin of the ``map`` frame (e.g. the first
    waypoint or the terrain centre).  ``to_lonlat(x, y) -> (lon, lat)`` (map metres to WGS84
    degrees) enables ``/vehicle/fix``.  ``seed``, ``command``, ``avoid``, ``crs`` and
    ``software_version`` go into the ``terrapath`` metadata record with the wall-clock start; extra
    ``metadata`` (str -> str) is added to it.
    """

    def __init__(
        self,
        path: str | PathLike[str],
        *,
        map_origin: Sequence[float] = (0.0, 0.0, 0.0),
        crs: str = "local",
        seed: int | str | None = None,
        command: str = "",
        avoid: str = "none",
        software_version: str | None = None,
        to_lonlat: LonLat | None = None,
        log_rate_hz: float = 10.0,
        track_rate_hz: float = 1.0,
        track_overview_s: float = 60.0,
        track_overview_points: int = 2048,
        marker_size_m: float = 50.0,
        max_terrain_triangles: int = 1_000_000,
        compression: str = "zstd",
        chunk_size: int = 1 << 20,
        metadata: Mapping[str, str] | None = None,
    ) -> None:
        self.path = Path(path)
        loc = where(self.path)
        self._where = loc
        self.map_origin = tuple(check_vector(map_origin, 3, f"{loc}map_origin"))
        for name, value in (
            ("log_rate_hz", log_rate_hz),
            ("track_rate_hz", track_rate_hz),
            ("track_overview_s", track_overview_s),
            ("marker_size_m", marker_size_m),
        ):
            check_positive(value, f"{loc}{name}")
        if compression not in COMPRESSIONS:
            raise InputError(
                f"{loc}compression: expected one of {COMPRESSIONS}, found {compression!r}"
            )
        if track_overview_points < 2 or max_terrain_triangles < 1 or chunk_size < 1024:
            raise InputError(
                f"{loc}track_overview_points, max_terrain_triangles or chunk_size too small"
            )
        self.log_rate_hz = float(log_rate_hz)
        self._state_period = max(1, round(NS_PER_S / log_rate_hz))
        self._track_period = max(1, round(NS_PER_S / track_rate_hz))
        self._overview_period = max(1, round(track_overview_s * NS_PER_S))
        self._overview_points = int(track_overview_points)
        self._marker = float(marker_size_m)
        size = Vector3(x=self._marker, y=self._marker, z=self._marker)
        # detection markers' size and colour fields: terrain (brown), moving threat (orange),
        # stationary threat (red)
        self._scan = ScanEncoder(
            self.map_origin,
            [
                SpherePrimitive(size=size, color=color(*rgb)).SerializeToString()
                for rgb in ((0.6, 0.4, 0.2), (1.0, 0.55, 0.0), (1.0, 0.1, 0.1))
            ],
        )
        self._max_triangles = int(max_terrain_triangles)
        self._compression = compression
        self._chunk_size = int(chunk_size)
        self._to_lonlat = to_lonlat
        if software_version is None:
            software_version = _package_version()
        self.run_metadata: dict[str, str] = {
            "terrapath": T.FORMAT_VERSION,
            "seed": "" if seed is None else str(seed),
            "software_version": software_version,
            "command": command,
            "avoid": avoid,
            "started_utc": "",
            "crs": crs,
            "map_origin": json.dumps(list(self.map_origin)),
            "log_rate_hz": repr(self.log_rate_hz),
            "time": "simulated seconds since the start of the replay, integer nanoseconds",
        }
        for key, text in (metadata or {}).items():
            if not isinstance(key, str) or not isinstance(text, str):
                raise InputError(f"{loc}metadata: keys and values must be text ({key!r})")
            self.run_metadata[key] = text
        self._sink: McapSink | None = None
        self._file: McapFile | None = None
        self._channels: dict[str, int] = {}
        self._t_max = 0
        self._last_state = -1
        self._next_state = 0
        self._next_separation = 0
        self._next_track = 0
        self._next_overview = self._overview_period
        self._next_threat_move = 0
        self._track = np.empty((1024, 3))
        self._track_n = 0
        self._setpoints_drawn = 0  # the length of the set-point list last drawn
        self._recent_from = 0  # index in the track where the recent line starts
        self._threats: dict[str, dict[str, Any]] = {}
        # vehicle samples given and not yet encoded: (times s, states, controls, extras, forced)
        self._pending: list[tuple[FloatArray, FloatArray, FloatArray, dict[str, Any], bool]] = []
        self._pending_n = 0
        self._pending_t = -1.0  # the last time given
        self._track_bytes = bytearray()  # the track's points as LinePrimitive.points entries
        self._floor_z = 0.0
        self._attachments: set[str] = set()
        self.samples_written = 0

    # -- life cycle --------------------------------------------------------------------------

    def __enter__(self) -> Self:
        if self._file is not None:
            raise InputError(f"{self._where}the recorder is already open")
        file = McapFile(
            self.path,
            compression=self._compression,
            chunk_size=self._chunk_size,
            library=f"{T.LIBRARY} {self.run_metadata['software_version']}",
        )
        try:
            self._sink = file.sink
            self._start()
        except BaseException as err:  # the temporary file goes, nothing is renamed
            file.close(type(err), err, err.__traceback__)
            raise
        self._file = file
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> bool:
        file = self._file
        if file is None:
            return False
        if exc_type is None:
            try:
                self._encode_states()
            except BaseException as err:
                self._file = self._sink = None
                file.close(type(err), err, err.__traceback__)
                raise
        self._file = self._sink = None
        return file.close(exc_type, exc, tb)

    def _start(self) -> None:
        sink = self._require()
        schema_ids: dict[str, int] = {}
        for topic, schema in T.SCHEMAS.items():
            if topic == T.VEHICLE_FIX and self._to_lonlat is None:
                continue
            if schema not in schema_ids:
                if schema in PROTOBUF_CLASSES:
                    data = descriptor_set(PROTOBUF_CLASSES[schema])
                    schema_ids[schema] = sink.add_schema(schema, T.PROTOBUF, data)
                else:
                    data = json.dumps(JSON_SCHEMAS[schema], indent=1).encode()
                    schema_ids[schema] = sink.add_schema(schema, T.JSONSCHEMA, data)
            encoding = T.PROTOBUF if schema in PROTOBUF_CLASSES else T.JSON
            group = 1 if topic in T.DATA_TOPICS else 0
            self._channels[topic] = sink.add_channel(topic, encoding, schema_ids[schema], group)
        self.run_metadata["started_utc"] = datetime.now(UTC).isoformat(timespec="milliseconds")
        sink.add_metadata(T.RUN_METADATA, self.run_metadata)
        ox, oy, oz = self.map_origin
        static = FrameTransform(
            parent_frame_id=T.MAP_FRAME,
            child_frame_id=T.WORLD_FRAME,
            translation=Vector3(x=-ox, y=-oy, z=-oz),
            rotation=Quaternion(w=1.0),
        )
        self._emit(T.TF_STATIC, 0, static.SerializeToString())

    def _require(self) -> McapSink:
        if self._sink is None:
            raise InputError(f"{self._where}the recorder is not open (use 'with RunRecorder(...)')")
        return self._sink

    def _emit(self, topic: str, ns: int, data: bytes) -> None:
        self._require().add_message(self._channels[topic], ns, data)
        if ns > self._t_max:
            self._t_max = ns

    def _ns(self, t: float) -> int:
        """Simulated seconds -> integer nanoseconds, the one conversion."""
        try:
            if isinstance(t, str):
                raise TypeError
            ns = round(float(t) * NS_PER_S)  # float(): numpy scalars' round() is slow
        except (TypeError, ValueError, OverflowError):
            raise InputError(f"{self._where}time {t!r}: expected finite seconds") from None
        if ns < 0:
            raise InputError(f"{self._where}time {t!r}: expected seconds >= 0")
        return int(ns)

    def _rel(self, xyz: Sequence[float]) -> tuple[float, float, float]:
        ox, oy, oz = self.map_origin
        return (xyz[0] - ox, xyz[1] - oy, xyz[2] - oz)

    # -- vehicle -----------------------------------------------------------------------------

    def state_due(self, t: float) -> bool:
        """Whether :meth:`write_state` at time ``t`` would write a sample (lets a caller skip
        building its arguments between ticks)."""
        self._encode_states()
        return self._ns(t) >= self._next_state

    def write_state(
        self,
        t: float,
        state: Sequence[float] | FloatArray,
        controls: Sequence[float] | FloatArray,
        extras: Mapping[str, float] | None = None,
        *,
        force: bool = False,
    ) -> bool:
        """One vehicle sample (12-state NED vector and 4 controls, :mod:`replay.frames`) with the
        caller's ``extras`` (name -> number).  Written if ``t`` reached the next log tick (or
        ``force``); returns whether it was written.  Times must not go backwards.  The messages
        are encoded with the samples around it (:meth:`write_states`)."""
        ns = self._ns(t)
        if self._pending and not self._pending[-1][4]:
            self._encode_states()  # a batch of write_states first: its samples decide the tick
        if ns < self._last_state or t < self._pending_t:
            raise InputError(f"{self._where}state time {t!r} s is before the previous sample")
        if ns < self._next_state and not force:
            return False
        s = _sample(state, 12, f"{self._where}state")
        c = _sample(controls, 4, f"{self._where}controls")
        cols = self._extras_columns(extras, 1, number=True)
        self._next_state = (ns // self._state_period + 1) * self._state_period
        self._last_state = ns
        self._queue(np.array([float(t)]), np.array([s]), np.array([c]), cols, True)
        return True

    def write_states(
        self,
        ts: npt.ArrayLike,
        states: npt.ArrayLike,
        controls: npt.ArrayLike,
        extras: Mapping[str, npt.ArrayLike] | None = None,
    ) -> None:
        """Many vehicle samples at once, as a flight log holds them: times ``ts`` (K,) s,
        increasing, ``states`` (K, 12), ``controls`` (K, 4) and ``extras`` name -> (K,).  The
        samples that :meth:`write_state` would write (the first at or after each log tick) are
        written.  The arrays are kept, not copied, until they are encoded (every
        ``STATE_BATCH`` samples, at the end, or when a sample decides something): do not write
        into them afterwards."""
        t = np.asarray(ts, dtype=np.float64).reshape(-1)
        k = len(t)
        if not k:
            return
        s = np.asarray(states, dtype=np.float64)
        c = np.asarray(controls, dtype=np.float64)
        if s.shape != (k, 12) or c.shape != (k, 4):
            raise InputError(
                f"{self._where}states: expected {k} states (K, 12) and controls (K, 4), found "
                f"shapes {s.shape} and {c.shape}"
            )
        self._ns(t[0])
        self._ns(t[-1])
        if t[0] < self._pending_t or self._ns(t[0]) < self._last_state:
            raise InputError(f"{self._where}state time {t[0]!r} s is before the previous sample")
        if k > 1 and not (t[1:] >= t[:-1]).all():
            raise InputError(f"{self._where}state times: expected increasing finite seconds")
        self._queue(t, s, c, self._extras_columns(extras, k), False)

    def _extras_columns(
        self, extras: Mapping[str, Any] | None, k: int, *, number: bool = False
    ) -> dict[str, Any]:
        """The extras as name -> (k,) float arrays (checked: text names, numbers)."""
        if not extras:
            return {}
        cols: dict[str, Any] = {}
        for name, value in extras.items():
            a = value
            if type(a) is not np.ndarray or a.dtype != np.float64 or number:
                try:
                    if number and not isinstance(value, int | float | np.number):
                        raise TypeError
                    a = np.asarray(value, dtype=np.float64).reshape(-1)
                except (TypeError, ValueError):
                    raise InputError(
                        f"{self._where}extras: expected numbers, found {extras!r:.200}"
                    ) from None
            if type(name) is not str or not name:
                raise InputError(f"{self._where}extras: names must be non-empty text ({name!r})")
            if a.shape != (k,):
                raise InputError(
                    f"{self._where}extras {name!r}: expected {k} numbers, found shape {a.shape}"
                )
            cols[name] = a
        return cols

    def _queue(
        self, t: FloatArray, s: FloatArray, c: FloatArray, cols: dict[str, Any], forced: bool
    ) -> None:
        self._pending.append((t, s, c, cols, forced))
        self._pending_n += len(t)
        self._pending_t = float(t[-1])
        if self._pending_n >= STATE_BATCH:
            self._encode_states()

    def _encode_states(self) -> None:
        """The samples given since the last time: those due at the log rate (forced ones all)
        encoded and written at once (:func:`replay.record.samples.sample_records`), and the
        track drawn from them."""
        pending = self._pending
        if not pending:
            return
        self._pending, self._pending_n = [], 0
        t = np.concatenate([p[0] for p in pending])
        ns = np.round(t * NS_PER_S).astype(np.int64)
        period = self._state_period
        tick = ns // period
        first = np.empty(len(t), dtype=bool)
        first[0] = True
        first[1:] = tick[1:] != tick[:-1]
        due = first & (tick > self._next_state // period - 1)
        offsets = np.cumsum([0] + [len(p[0]) for p in pending])
        due[[int(a) for p, a in zip(pending, offsets[:-1], strict=True) if p[4]]] = True
        rows = np.flatnonzero(due)  # (forced samples are single ones, written)
        if not len(rows):
            return
        names: dict[str, None] = {}
        for p in pending:
            names.update(dict.fromkeys(p[3]))
        extras: dict[str, tuple[FloatArray, npt.NDArray[np.bool_]]] = {}
        for name in names:
            parts = [p[3].get(name) for p in pending]
            if all(a is not None for a in parts):
                whole = np.concatenate([a for a in parts if a is not None])
                extras[name] = (whole[rows], np.ones(len(rows), dtype=bool))
                continue
            values = np.full(len(t), np.nan)
            present = np.zeros(len(t), dtype=bool)
            for a, start, stop in zip(parts, offsets[:-1], offsets[1:], strict=True):
                if a is not None:
                    values[start:stop] = a
                    present[start:stop] = True
            extras[name] = (values[rows], present[rows])
        batch = Samples(
            ns=ns[rows],
            states=np.concatenate([p[1] for p in pending])[rows],
            controls=np.concatenate([p[2] for p in pending])[rows],
            extras=extras,
        )
        last = int(batch.ns[-1])
        self._next_state = max(self._next_state, (last // period + 1) * period)
        self._last_state = max(self._last_state, last)
        sink = self._require()
        xyz, records = sample_records(batch, self._channels, self.map_origin, self._to_lonlat)
        for channel, data, lengths, times in records:
            sink.add_records(channel, times, data, lengths)
        if last > self._t_max:
            self._t_max = last
        self.samples_written += len(rows)
        # the track: the first sample written at or after each tick of the track rate
        tt = batch.ns // self._track_period
        new = np.empty(len(tt), dtype=bool)
        new[0] = True
        new[1:] = tt[1:] != tt[:-1]
        new &= batch.ns >= self._next_track
        points = np.flatnonzero(new)
        if len(points):
            self._next_track = int((tt[points[-1]] + 1) * self._track_period)
            self._track_points(batch.ns[points], xyz[points])

    def _track_points(self, ns: npt.NDArray[np.int64], xyz: FloatArray) -> None:
        """New points of the flown track: the recent line at each, the overview when due."""
        n0, k = self._track_n, len(xyz)
        while n0 + k > len(self._track):
            self._track = np.concatenate([self._track, np.empty_like(self._track)])
        self._track[n0 : n0 + k] = xyz
        self._track_bytes += doubles_messages(LINE_POINTS, xyz)
        size = _POINT_BYTES
        head = line_head((1.0, 0.9, 0.2, 1.0))
        for i, t_ns in enumerate(ns.tolist()):
            self._track_n = n = n0 + i + 1
            if t_ns >= self._next_overview:
                self._next_overview = (t_ns // self._overview_period + 1) * self._overview_period
                pts = self._track[:n]
                if n > self._overview_points:
                    stride = 1 << math.ceil(math.log2(n / (self._overview_points - 1)))
                    keep = np.arange(0, n, stride)
                    if keep[-1] != n - 1:
                        keep = np.append(keep, n - 1)
                    pts = pts[keep]
                self._line_update(
                    T.VEHICLE_TRACK_OVERVIEW, t_ns, "track/overview", pts, (0.95, 0.8, 0.1, 0.9)
                )
                self._recent_from = n - 1
            if n - self._recent_from >= 2:
                line = head + self._track_bytes[self._recent_from * size : n * size]
                entity = entity_head(t_ns, T.MAP_FRAME, "track/recent")
                self._emit(
                    T.VEHICLE_TRACK, t_ns, ld(UPDATE_ENTITIES, entity + ld(ENTITY_LINES, line))
                )

    def _line_update(
        self,
        topic: str,
        ns: int,
        ident: str,
        pts: FloatArray,
        rgba: tuple[float, float, float, float],
        *,
        segments: bool = False,
    ) -> None:
        line = line_head(rgba, segments=segments) + doubles_messages(LINE_POINTS, pts)
        entity = entity_head(ns, T.MAP_FRAME, ident) + ld(ENTITY_LINES, line)
        self._emit(topic, ns, ld(UPDATE_ENTITIES, entity))

    def _entity(self, ns: int, ident: str, **fields: Any) -> SceneEntity:
        e = SceneEntity(frame_id=T.MAP_FRAME, id=ident, **fields)
        e.timestamp.seconds, e.timestamp.nanos = divmod(ns, NS_PER_S)
        return e

    # -- scene -------------------------------------------------------------------------------

    def write_terrain(
        self,
        vertices: npt.ArrayLike,
        faces: npt.ArrayLike,
        frame: str = T.MAP_FRAME,
        t: float = 0.0,
    ) -> int:
        """The terrain mesh (vertices (N, 3) map metres, faces (M, 3) vertex indices), once at the
        start: a triangle list coloured by height, in ``frame`` (relative to the map origin),
        decimated to ``max_terrain_triangles``.  Returns the number of triangles written."""
        ns = self._ns(t)
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces)
        if v.ndim != 2 or v.shape[1] != 3 or not np.isfinite(v).all():
            raise InputError(
                f"{self._where}terrain vertices: expected finite (N, 3), found {v.shape}"
            )
        if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
            raise InputError(
                f"{self._where}terrain faces: expected integer (M, 3), found {f.shape}"
            )
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise InputError(f"{self._where}terrain faces: indices outside 0..{len(v) - 1}")
        v, f = decimate_mesh(v, f.astype(np.int64), self._max_triangles)
        if len(v):
            self._floor_z = float(v[:, 2].min())
        tri = (
            TriangleListPrimitive(pose=pose()).SerializeToString()
            + doubles_messages(TRI_POINTS, v - np.asarray(self.map_origin))
            + doubles_messages(TRI_COLORS, height_colors(v[:, 2]))
            + packed_fixed32(TRI_INDICES, f.reshape(-1))
        )
        entity = self._entity(ns, "terrain")
        entity.frame_id = frame
        data = ld(UPDATE_ENTITIES, entity.SerializeToString() + ld(ENTITY_TRIANGLES, tri))
        self._emit(T.TERRAIN, ns, data)
        return len(f)

    def write_waypoints(
        self, t: float, waypoints: npt.ArrayLike, reason: str, active_index: int = 0
    ) -> None:
        """The waypoint list (W, 3) map metres, at the start (``reason="initial"``) and after each
        change (``"avoidance: pso-ca inserted 1"``, ``"leg 3"``...)."""
        ns = self._ns(t)
        wps = np.asarray(waypoints, dtype=np.float64)
        if wps.ndim != 2 or wps.shape[1] != 3 or not np.isfinite(wps).all():
            raise InputError(f"{self._where}waypoints: expected finite (W, 3), found {wps.shape}")
        active = int(active_index)
        entity = self._entity(ns, "waypoints")
        rel = wps - np.asarray(self.map_origin)
        if len(rel) >= 2:
            entity.lines.append(
                LinePrimitive(
                    type=LinePrimitive.LINE_STRIP,
                    pose=pose(),
                    thickness=2.0,
                    scale_invariant=True,
                    color=color(0.3, 0.6, 1.0, 0.9),
                    points=[Point3(x=a, y=b, z=c) for a, b, c in rel.tolist()],
                )
            )
        size = Vector3(x=self._marker, y=self._marker, z=self._marker)
        for i, (a, b, c) in enumerate(rel.tolist()):
            rgb = (
                (0.6, 0.6, 0.6)
                if i < active
                else (0.1, 0.9, 0.3)
                if i == active
                else (0.3, 0.6, 1.0)
            )
            entity.spheres.append(SpherePrimitive(pose=pose(a, b, c), size=size, color=color(*rgb)))
            entity.texts.append(
                TextPrimitive(
                    pose=pose(a, b, c + self._marker),
                    billboard=True,
                    font_size=14.0,
                    scale_invariant=True,
                    color=color(1, 1, 1),
                    text=str(i),
                )
            )
        self._emit(T.WAYPOINTS, ns, SceneUpdate(entities=[entity]).SerializeToString())
        doc = {"waypoints": wps.tolist(), "active_index": active, "reason": str(reason)}
        self._emit(T.WAYPOINT_LIST, ns, dumps(doc))

    def write_threats(self, t: float, threats: Iterable[Mapping[str, Any]]) -> bool:
        """The current threats (module docstring).  Compared with the last set written: new ones
        are drawn, changed ones redrawn (a move at most once per log tick), missing ones deleted.
        Returns whether a message was written.  Between log ticks a call with the same ids
        returns at once; at a tick each threat costs a comparison (and a check when it changed),
        so call it at most at the log rate (e.g. when :meth:`state_due`), not every 100 Hz step."""
        ns = self._ns(t)
        items = list(threats)
        if ns < self._next_threat_move and len(items) == len(self._threats):
            try:
                if all(str(item["id"]) in self._threats for item in items):
                    return False
            except (TypeError, KeyError):
                pass  # the full check below says what is wrong
        current: dict[str, dict[str, Any]] = {}
        for i, item in enumerate(items):
            threat = self._normalized(item, i)
            if threat["id"] in current:
                raise InputError(f"{self._where}threats: duplicate id {threat['id']!r}")
            current[threat["id"]] = threat
        previous = self._threats
        appeared = [i for i in current if i not in previous]
        removed = [i for i in previous if i not in current]
        changed = [i for i in current if i in previous and current[i] != previous[i]]
        if not (appeared or removed or changed):
            return False
        if not (appeared or removed) and ns < self._next_threat_move:
            return False
        self._next_threat_move = (ns // self._state_period + 1) * self._state_period
        update = SceneUpdate()
        for ident in removed:
            deletion = SceneEntityDeletion(
                type=SceneEntityDeletion.MATCHING_ID, id=f"threat/{ident}"
            )
            deletion.timestamp.seconds, deletion.timestamp.nanos = divmod(ns, NS_PER_S)
            update.deletions.append(deletion)
        for ident in appeared + changed:
            update.entities.append(self._threat_entity(ns, current[ident]))
        self._emit(T.THREATS, ns, update.SerializeToString())
        doc = {
            "threats": list(current.values()),
            "appeared": appeared,
            "changed": changed,
            "removed": removed,
        }
        self._emit(T.THREAT_LIST, ns, dumps(doc))
        self._threats = current
        return True

    def _normalized(self, item: Any, index: int) -> dict[str, Any]:
        """normalize_threat, skipped when the item equals the normalized threat of its id."""
        try:
            prev = self._threats.get(str(item["id"]))
            if prev is not None and item == prev:
                return prev
        except (TypeError, KeyError, ValueError):  # not a mapping, no id, numpy arrays inside
            pass
        return normalize_threat(item, index)

    def _threat_entity(self, ns: int, th: dict[str, Any]) -> SceneEntity:
        e = self._entity(ns, f"threat/{th['id']}")
        e.metadata.extend(
            [KeyValuePair(key="id", value=th["id"]), KeyValuePair(key="kind", value=th["kind"])]
        )
        fill = color(0.9, 0.15, 0.1, 0.35)
        kind = th["kind"]
        if kind == "sphere":
            centers = th["center"] if isinstance(th["center"][0], list) else [th["center"]]
            radii = th["radius"] if isinstance(th["radius"], list) else [th["radius"]]
            for c, r in zip(centers, radii, strict=True):
                e.spheres.append(
                    SpherePrimitive(
                        pose=pose(*self._rel(c)),
                        size=Vector3(x=2 * r, y=2 * r, z=2 * r),
                        color=fill,
                    )
                )
            top = max(c[2] + r for c, r in zip(centers, radii, strict=True))
            label = self._rel((centers[0][0], centers[0][1], top))
        elif kind == "cylinder":
            r = th["radius"]
            bottom = (
                th["bottom"]
                if th["bottom"] is not None
                else min(self._floor_z, (th["top"] or 0.0) - 1.0)
            )
            top = th["top"] if th["top"] is not None else bottom + UNBOUNDED_TOP_DRAW_M
            cx, cy = th["center"][:2]
            e.cylinders.append(
                CylinderPrimitive(
                    pose=pose(*self._rel((cx, cy, 0.5 * (bottom + top)))),
                    size=Vector3(x=2 * r, y=2 * r, z=top - bottom),
                    bottom_scale=1.0,
                    top_scale=1.0,
                    color=fill,
                )
            )
            label = self._rel((cx, cy, top))
        elif kind == "prism":
            top = th["top"]
            bottom = th["bottom"] if th["bottom"] is not None else min(self._floor_z, top - 1.0)
            cx, cy = th["center"][:2]
            # vertices relative to the centroid at the bottom: small numbers in float32
            pts, faces = prism_mesh(np.asarray(th["footprint"]) - (cx, cy), 0.0, top - bottom)
            e.triangles.append(
                TriangleListPrimitive(
                    pose=pose(*self._rel((cx, cy, bottom))),
                    color=fill,
                    points=[Point3(x=px, y=py, z=pz) for px, py, pz in pts.tolist()],
                    indices=faces.reshape(-1).tolist(),
                )
            )
            label = self._rel((cx, cy, top))
        else:
            a, b, c = th["axes"]
            center = self._rel(th["center"])
            if all(x == 1.0 for x in th["exponents"]):
                e.spheres.append(
                    SpherePrimitive(
                        pose=pose(*center), size=Vector3(x=2 * a, y=2 * b, z=2 * c), color=fill
                    )
                )
            else:
                pts, faces = superellipsoid_mesh(th["axes"], th["exponents"])
                e.triangles.append(
                    TriangleListPrimitive(
                        pose=pose(*center),
                        color=fill,
                        points=[Point3(x=px, y=py, z=pz) for px, py, pz in pts.tolist()],
                        indices=faces.reshape(-1).tolist(),
                    )
                )
            label = (center[0], center[1], center[2] + c)
        e.texts.append(
            TextPrimitive(
                pose=pose(label[0], label[1], label[2] + self._marker),
                billboard=True,
                font_size=14.0,
                scale_invariant=True,
                color=color(1.0, 0.6, 0.6),
                text=th["id"],
            )
        )
        return e

    def write_detections(self, t: float, detections: Iterable[Mapping[str, Any]]) -> None:
        """One radar scan: a marker per detection (red: stationary threat, orange: moving, brown:
        terrain) replacing the previous scan's, and the list as JSON."""
        ns = self._ns(t)
        items = [normalize_detection(d, i) for i, d in enumerate(detections)]
        tails = [self._scan.tail(d["kind"] == "terrain", d["moving"]) for d in items]
        self._write_markers(ns, self._scan.markers([d["position"] for d in items], tails))
        self._emit(T.DETECTION_LIST, ns, dumps({"detections": items}))

    def write_detection_arrays(
        self,
        t: float,
        ids: Sequence[str],
        positions: npt.ArrayLike,
        ranges: npt.ArrayLike,
        terrain: npt.ArrayLike,
        moving: npt.ArrayLike,
    ) -> None:
        """:meth:`write_detections` with the scan as parallel arrays, as a radar picture holds it
        (ids (N,), positions (N, 3), ranges (N,), ``terrain`` and ``moving`` flags (N,)): the same
        messages, checked array by array instead of detection by detection."""
        ns = self._ns(t)
        n = len(ids)
        pos = np.asarray(positions, dtype=np.float64)
        rng = np.asarray(ranges, dtype=np.float64)
        ground = np.asarray(terrain, dtype=bool)
        mov = np.asarray(moving, dtype=bool)
        if pos.shape != (n, 3) or rng.shape != (n,) or ground.shape != (n,) or mov.shape != (n,):
            raise InputError(
                f"{self._where}detections: expected {n} positions (N, 3), ranges, terrain and "
                f"moving flags (N,); found shapes {pos.shape}, {rng.shape}, {ground.shape}, "
                f"{mov.shape}"
            )
        distances = rng.tolist()
        # (cheap tests first: a finite sum, the positions of the last scan, checked then)
        if not (math.isfinite(sum(distances)) and self._scan.same_positions(pos)) and not (
            np.isfinite(pos).all() and np.isfinite(rng).all()
        ):
            i = int(np.flatnonzero(~(np.isfinite(pos).all(axis=1) & np.isfinite(rng)))[0])
            raise InputError(
                f"{self._where}detections[{i}]: expected a finite position and range, found "
                f"{pos[i].tolist()} and {rng[i]}"
            )
        spheres, listing = self._scan.arrays(ids, pos, ground, mov, distances)
        self._write_markers(ns, spheres)
        self._emit(T.DETECTION_LIST, ns, listing)

    def write_beams(
        self, t: float, origin: npt.ArrayLike, ends: npt.ArrayLike, hit: npt.ArrayLike
    ) -> None:
        """One rangefinder scan (:mod:`replay.sensors.rangefinder`) as a line list replacing the last:
        a segment from ``origin`` (the aircraft, map metres (3,)) to each beam's end ``ends``
        (B, 3): red where the beam hit (``hit`` (B,)), green where it reached its full range."""
        ns = self._ns(t)
        o = np.asarray(check_vector(origin, 3, f"{self._where}beam origin"), dtype=np.float64)
        e = np.asarray(ends, dtype=np.float64)
        h = np.asarray(hit, dtype=bool)
        if e.ndim != 2 or e.shape[1] != 3 or h.shape != (len(e),) or not np.isfinite(e).all():
            raise InputError(
                f"{self._where}beams: expected finite ends (B, 3) and hit flags (B,); found "
                f"shapes {e.shape} and {h.shape}"
            )
        rel = np.asarray(self.map_origin)
        body = entity_head(ns, T.MAP_FRAME, BEAMS_ENTITY)
        for mask, rgba in ((h, (1.0, 0.15, 0.1, 1.0)), (~h, (0.2, 0.85, 0.3, 0.8))):
            if mask.any():
                pairs = np.empty((2 * int(mask.sum()), 3))
                pairs[0::2], pairs[1::2] = o - rel, e[mask] - rel
                line = line_head(rgba, segments=True) + doubles_messages(LINE_POINTS, pairs)
                body += ld(ENTITY_LINES, line)
        self._emit(T.RANGEFINDER_BEAMS, ns, ld(UPDATE_ENTITIES, body))

    def _write_markers(self, ns: int, spheres: bytes | None) -> None:
        """The scene update of one scan: its spheres (:class:`ScanEncoder`) in the entity
        ``detections``, which replaces the last scan's; nothing when they are the spheres
        shown already (``None``: an entity without a lifetime stays until it is replaced)."""
        if spheres is not None:
            entity = entity_head(ns, T.MAP_FRAME, "detections")
            self._emit(T.DETECTIONS, ns, ld(UPDATE_ENTITIES, entity + spheres))

    # -- events ------------------------------------------------------------------------------

    def write_separations(
        self,
        ts: npt.ArrayLike,
        ids: Sequence[str],
        separations: npt.ArrayLike,
        *,
        margin_m: float = 0.0,
    ) -> int:
        """``/vehicle/separation`` at the samples ``ts`` (s, increasing) that fall on the state
        log's ticks (the first sample of each tick, as :meth:`write_state` keeps): the
        separation from each of ``ids`` (a threat, or a danger zone when it starts with
        ``zone:``), ``separations`` (K, len(ids)) metres, NaN while a threat is inactive.  Each
        message holds the nearest active threat (``nearest_m``, ``nearest``), the nearest danger
        zone (``zone_m``, ``zone``), ``margin_m`` and ``threats``, the (at most) four nearest
        active threats by id.  Of those samples, the ones where something shown changed are
        written (:mod:`replay.record.separation`: a value left its band, crossed the margin or
        reached its least, the threats shown changed; at least one every 10 s).  Separations
        are computed in batches after the states they belong to, so these messages come later
        in the file than the states of their time (MCAP readers order by log time); successive
        calls must not go back in time.  Returns how many messages were written."""
        t = np.asarray(ts, dtype=np.float64).reshape(-1)
        seps = np.asarray(separations, dtype=np.float64).reshape(len(t), len(ids))
        if not len(t):
            return 0
        ns = np.round(t * NS_PER_S).astype(np.int64)
        period = self._state_period
        tick = ns // period
        first = np.ones(len(t), dtype=bool)
        first[1:] = tick[1:] != tick[:-1]
        rows = np.flatnonzero(first & (ns >= self._next_separation))
        if not len(rows):
            return 0
        self._next_separation = int((tick[rows[-1]] + 1) * period)
        is_zone = np.array([i.startswith("zone:") for i in ids], dtype=bool)
        names = list(ids)
        threat_cols = np.flatnonzero(~is_zone)
        zone_cols = np.flatnonzero(is_zone)
        margin = float(margin_m)
        picked = seps[rows]
        cols, shown, zcol, zval = nearest(picked[:, threat_cols], picked[:, zone_cols])
        keep = kept_rows(
            ns[rows], cols, shown, zcol, zval, margin, len(threat_cols), len(zone_cols)
        )
        written = np.flatnonzero(keep)
        sink, channel = self._require(), self._channels[T.SEPARATION]
        for i, c, v, zc, zv in zip(
            written.tolist(),
            cols[written].tolist(),
            shown[written].tolist(),
            zcol[written].tolist(),
            zval[written].tolist(),
            strict=True,
        ):
            doc = separation_doc(margin, names, threat_cols, zone_cols, c, v, zc, zv)
            sink.add_message(channel, int(ns[rows[i]]), dumps(doc))
        self._t_max = max(self._t_max, int(ns[rows[-1]]))
        return len(written)

    def write_decision(self, t: float, decision: Mapping[str, Any]) -> None:
        """An avoidance decision: a JSON object with at least ``algorithm`` (text) and
        ``compute_s`` (seconds spent deciding), and typically ``inputs`` (a summary), ``chosen``
        (waypoint(s)) and ``costs`` (cost terms).  numpy values are converted."""
        ns = self._ns(t)
        if not isinstance(decision, Mapping):
            raise InputError(
                f"{self._where}decision: expected a mapping, found {type(decision).__name__}"
            )
        if not isinstance(decision.get("algorithm"), str):
            raise InputError(f"{self._where}decision: 'algorithm' (text) is required")
        compute = check_finite(decision.get("compute_s"), f"{self._where}decision compute_s")
        if compute < 0:
            raise InputError(f"{self._where}decision compute_s: expected >= 0, found {compute}")
        try:
            doc = jsonable(decision)
        except TypeError as err:
            raise InputError(f"{self._where}decision: {err}") from None
        self._emit(T.DECISION, ns, dumps(doc))
        command = doc.get("command")
        if isinstance(command, dict):
            self._guidance(ns, command, doc)
        cones = doc.get("cones")
        if isinstance(cones, list) and cones:
            self._cones(ns, cones)
        elif doc.get("fga") == "return":
            gone = SceneEntityDeletion(type=SceneEntityDeletion.MATCHING_ID, id=CONES_ENTITY)
            gone.timestamp.seconds, gone.timestamp.nanos = divmod(ns, NS_PER_S)
            self._emit(T.GUIDANCE, ns, SceneUpdate(deletions=[gone]).SerializeToString())
        setpoints = doc.get("setpoints")
        if isinstance(setpoints, list) and len(setpoints) != self._setpoints_drawn:
            # the priority loop's path S (each decision carries it; drawn when it grows)
            self._setpoints_drawn = len(setpoints)
            if len(setpoints) >= 2:
                pts = np.asarray(setpoints, dtype=np.float64) - np.asarray(self.map_origin)
                self._line_update(T.GUIDANCE, ns, SETPOINTS_ENTITY, pts, (1.0, 0.6, 0.0, 1.0))

    def _cones(self, ns: int, cones: list[Any]) -> None:
        """FGA's collision cones (a decision's ``cones``: apex, line of sight, half-angle,
        range, keep radius) as a line list on /avoidance/guidance: each cone's two edges from
        the aircraft to the tangent points, and the protected circle round the obstacle."""
        segs: list[list[float]] = []
        for c in cones:
            apex = np.asarray(c["apex"], dtype=np.float64)
            a_end, b_end, ring = cone_outline(c, apex, 36)
            segs += [apex.tolist(), a_end.tolist(), apex.tolist(), b_end.tolist()]
            pairs = np.empty((2 * (len(ring) - 1), 3))
            pairs[0::2], pairs[1::2] = ring[:-1], ring[1:]
            segs += pairs.tolist()
        pts = np.asarray(segs, dtype=np.float64) - np.asarray(self.map_origin)
        self._line_update(T.GUIDANCE, ns, CONES_ENTITY, pts, (1.0, 0.55, 0.1, 1.0), segments=True)

    def _guidance(self, ns: int, command: dict[str, Any], doc: dict[str, Any]) -> None:
        """An orbit command drawn as its circle (at the commanded altitude, else the arc's or
        the aircraft's; a moving centre where it was at the decision); any other command
        removes it."""
        if command.get("command") != "Orbit":
            gone = SceneEntityDeletion(type=SceneEntityDeletion.MATCHING_ID, id=ORBIT_ENTITY)
            gone.timestamp.seconds, gone.timestamp.nanos = divmod(ns, NS_PER_S)
            self._emit(T.GUIDANCE, ns, SceneUpdate(deletions=[gone]).SerializeToString())
            return
        cx, cy = (float(v) for v in command["center"])
        radius = float(command["radius"])
        z = command.get("altitude")
        if z is None:
            z = (doc.get("arc") or {}).get("altitude")
        if z is None:
            self._encode_states()  # the track so far
            z = float(self._track[self._track_n - 1, 2]) if self._track_n else 0.0
        a = np.linspace(0.0, 2.0 * math.pi, ORBIT_SEGMENTS + 1)
        pts = np.column_stack(
            [cx + radius * np.sin(a), cy + radius * np.cos(a), np.full(len(a), float(z))]
        ) - np.asarray(self.map_origin)
        self._line_update(T.GUIDANCE, ns, ORBIT_ENTITY, pts, (1.0, 0.3, 0.9, 1.0))

    def write_log(self, t: float, level: str, text: str) -> None:
        """A human-readable event (``level``: debug, info, warning, error or fatal)."""
        ns = self._ns(t)
        if level not in LOG_LEVELS:
            raise InputError(
                f"{self._where}log level: expected one of {', '.join(LOG_LEVELS)}, found {level!r}"
            )
        msg = Log(level=Log.Level.Value(level.upper()), message=str(text), name="terrapath")
        msg.timestamp.seconds, msg.timestamp.nanos = divmod(ns, NS_PER_S)
        self._emit(T.LOG, ns, msg.SerializeToString())

    def write_metrics(self, metrics: Mapping[str, Any]) -> None:
        """Run metrics, at the end: a JSON message at the last time written and the metadata
        record ``metrics`` (each value JSON-encoded)."""
        try:
            doc = jsonable(metrics)
        except TypeError as err:
            raise InputError(f"{self._where}metrics: {err}") from None
        if not isinstance(doc, dict):
            raise InputError(f"{self._where}metrics: expected a mapping")
        self._emit(T.METRICS, self._t_max, dumps(doc))
        self._require().add_metadata(T.METRICS_METADATA, {k: json.dumps(v) for k, v in doc.items()})

    def attach(self, name: str, data: bytes, media_type: str = "application/octet-stream") -> None:
        """Store a file inside the run (the mission, threat and vehicle files, so that a recorded
        run can be flown again), e.g. ``attach("mission.yaml", text.encode(), "application/yaml")``."""
        if not isinstance(data, bytes | bytearray | memoryview):
            raise InputError(
                f"{self._where}attachment {name!r}: expected bytes, found {type(data).__name__}"
            )
        if not name or name in self._attachments:
            raise InputError(
                f"{self._where}attachment {name!r}: names must be unique and non-empty"
            )
        self._attachments.add(name)
        self._require().add_attachment(name, media_type, bytes(data), self._t_max)


def _sample(values: Sequence[float] | FloatArray, n: int, what: str) -> list[float]:
    if isinstance(values, np.ndarray):
        if values.shape != (n,):
            raise InputError(f"{what}: expected {n} numbers, found shape {values.shape}")
        out: list[float] = values.astype(np.float64, copy=False).tolist()
        return out
    try:
        out = [float(v) for v in values]
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected {n} numbers") from None
    if len(out) != n:
        raise InputError(f"{what}: expected {n} numbers, found {len(out)}")
    return out


def _package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("terrapath")
    except PackageNotFoundError:
        return "unknown"
