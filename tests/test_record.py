"""Recording a replay run as MCAP (replay.record.recorder) and reading it back (replay.record.reader)."""

from __future__ import annotations

import json
import math
import struct
import time
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zstandard
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.LocationFix_pb2 import LocationFix
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Chunk, MessageIndex
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import Writer

from replay.frames import quaternion_map_from_euler
from replay.record import topics as T
from replay.record.messages import VehicleState
from replay.record.reader import load_run, summary
from replay.record.recorder import RunRecorder
from replay.record.scene import decimate_mesh, quaternion_map, superellipsoid_mesh
from terrain.errors import DataFileError, InputError

ORIGIN = (500_000.0, 4_000_000.0, 0.0)
RADIUS, OMEGA = 2000.0, 2 * math.pi / 60.0  # one circle a minute
FOXGLOVE: dict[str, Any] = {
    T.FRAME_TRANSFORM: FrameTransform,
    T.POSE_IN_FRAME: PoseInFrame,
    T.LOCATION_FIX: LocationFix,
    T.SCENE_UPDATE: SceneUpdate,
    T.LOG_SCHEMA: Log,
    T.STATE_SCHEMA: VehicleState,  # terrapath's own protobuf schema (format 2)
}


def circle_state(t: float) -> np.ndarray:
    """A level circle round the map origin at 200 m AMSL, 12-state NED (replay.frames)."""
    s = np.zeros(12)
    s[0] = ORIGIN[1] + RADIUS * math.cos(OMEGA * t)  # pn
    s[1] = ORIGIN[0] + RADIUS * math.sin(OMEGA * t)  # pe
    s[2] = -200.0 - 5.0 * math.sin(0.3 * t)
    s[3], s[4], s[5] = 25.0 + 0.1 * math.sin(t), 0.2 * math.cos(t), 1.1
    s[6], s[7], s[8] = (
        0.35,
        0.03 * math.sin(t),
        math.atan2(math.cos(OMEGA * t), -math.sin(OMEGA * t)),
    )
    s[9], s[10], s[11] = 0.001 * t, -0.002, OMEGA
    return s


def controls(t: float) -> np.ndarray:
    return np.array([-0.05 + 0.001 * t, 0.01, -0.002, 0.6])


def lonlat(x: float, y: float) -> tuple[float, float]:
    return (-117.0 + (x - ORIGIN[0]) / 1e5, 36.0 + (y - ORIGIN[1]) / 1e5)


def grid_mesh(n: int, size: float = 8000.0) -> tuple[np.ndarray, np.ndarray]:
    """A height-field mesh n x n vertices centred on the origin."""
    u = np.linspace(-size / 2, size / 2, n)
    x, y = np.meshgrid(u + ORIGIN[0], u + ORIGIN[1])
    z = 100.0 + 80.0 * np.sin(x / 900.0) * np.cos(y / 700.0)
    verts = np.c_[x.ravel(), y.ravel(), z.ravel()]
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    faces = np.concatenate([np.c_[a, a + 1, a + n + 1], np.c_[a, a + n + 1, a + n]])
    return verts, faces


WAYPOINTS_0 = [[ORIGIN[0], ORIGIN[1] + 2000, 200.0], [ORIGIN[0] + 2000, ORIGIN[1], 200.0]]
WAYPOINTS_1 = [WAYPOINTS_0[0], [ORIGIN[0] + 1500, ORIGIN[1] + 1500, 250.0], WAYPOINTS_0[1]]
SPHERE = {
    "id": "obs2",
    "kind": "sphere",
    "center": [ORIGIN[0] + 900, ORIGIN[1], 200],
    "radius": 300,
}
CYLINDER: dict[str, Any] = {
    "id": "sam",
    "kind": "cylinder",
    "center": [ORIGIN[0] - 1500, ORIGIN[1] + 500],
    "radius": 400,
    "top": 3000,
    "bottom": None,
}
BODY: dict[str, Any] = {
    "id": "tower",
    "kind": "ellipsoid",
    "center": [ORIGIN[0], ORIGIN[1] - 1800, 0.0],
    "axes": [80, 80, 400],
    "exponents": [1, 1, 4],
}
HILL: dict[str, Any] = {
    "id": "ridge",
    "kind": "sphere",
    "center": [[ORIGIN[0] + 100, ORIGIN[1] + 100, 150], [ORIGIN[0] + 300, ORIGIN[1] + 50, 160]],
    "radius": [200, 250],
}


def intruder(t: float) -> dict[str, Any]:
    return {
        "id": "uav2",
        "kind": "sphere",
        "center": [ORIGIN[0] + 20.0 * t, ORIGIN[1] - 500 + 10.0 * t, 200.0],
        "radius": 100,
    }


def threats_at(t: float) -> list[dict[str, Any]]:
    out = [SPHERE] if t < 30 else []
    if t >= 10:
        out += [CYLINDER, BODY, HILL]
    if 10 <= t < 40:
        out.append(intruder(t))
    return out


ATTACHMENTS = {
    "mission.yaml": (b"terrapath: 1\nname: demo\n", "application/yaml"),
    "threats.yaml": (b"terrapath: 1\nthreats: []\n", "application/yaml"),
    "vehicle.yaml": (bytes(range(256)), "application/octet-stream"),
}
DECISION = {
    "algorithm": "pso-ca",
    "compute_s": 0.0123,
    "inputs": {"threats": ["obs2"], "state": np.arange(3.0)},
    "chosen": [WAYPOINTS_1[1]],
    "costs": {"f1": 1.5, "f2": np.float64(0.25), "nan": float("nan")},
}
METRICS = {"success": True, "plr": 1.07, "min_separation_m": {"obs2": 120.5}, "flight_time_s": 60}


def record(path: Path, *, rate_hz: float = 100.0, duration: float = 60.0) -> dict[str, Any]:
    """The synthetic run: a circle at 10 Hz from a ``rate_hz`` caller, waypoint changes, threats
    appearing/moving/disappearing, radar scans, a decision, logs, metrics and attachments."""
    written: list[int] = []
    verts, faces = grid_mesh(41)
    with RunRecorder(
        path,
        map_origin=ORIGIN,
        crs="EPSG:32611",
        seed=42,
        command="terrapath replay mission.yaml --avoid pso-ca",
        avoid="pso-ca",
        to_lonlat=lonlat,
        track_overview_s=20.0,
        metadata={"mission": "demo"},
    ) as rec:
        n_tri = rec.write_terrain(verts, faces)
        rec.write_waypoints(0.0, WAYPOINTS_0, "initial", 0)
        steps = round(duration * rate_hz)
        for k in range(steps):
            t = k / rate_hz
            if k % round(rate_hz) == 0:  # once a second: threats and a radar scan
                rec.write_detections(
                    t,
                    [
                        {
                            "id": "obs2",
                            "position": SPHERE["center"],
                            "range": 900.0,
                            "kind": "threat",
                        },
                        {"id": "t1", "position": [ORIGIN[0], ORIGIN[1], 90.0], "kind": "terrain"},
                    ],
                )
            rec.write_threats(t, threats_at(t))
            if k == round(20 * rate_hz):
                rec.write_decision(t, DECISION)
                rec.write_waypoints(t, WAYPOINTS_1, "avoidance: pso-ca inserted 1", 1)
                rec.write_log(t, "warning", "obs2 inside the look-ahead: avoiding")
            if k == round(40 * rate_hz):
                rec.write_waypoints(t, WAYPOINTS_1, "leg 2", 2)
                rec.write_log(t, "info", "leg 2")
            extras = {"course_cmd": 0.1 * t, "xte": math.sin(t), "leg": float(k // 2000)}
            if rec.write_state(t, circle_state(t), controls(t), extras):
                written.append(k)
        rec.write_log(duration, "error", "a made-up violation")
        rec.write_metrics(METRICS)
        for name, (data, media) in ATTACHMENTS.items():
            rec.attach(name, data, media)
    return {"written": written, "rate_hz": rate_hz, "triangles": n_tri, "mesh": (verts, faces)}


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    path = tmp_path_factory.mktemp("run") / "run.mcap"
    return path, record(path)


def f32(a: Any) -> np.ndarray:
    """What /vehicle/state keeps of a float32 field: the value rounded to float32."""
    return np.asarray(a, dtype=np.float64).astype(np.float32).astype(np.float64)


def kept_states(states: np.ndarray) -> np.ndarray:
    """What /vehicle/state keeps of states (K, 12): pn, pe, pd as they are (doubles), the rest
    rounded to float32."""
    return np.column_stack([states[:, :3], f32(states[:, 3:])])


def messages(path: Path) -> list[tuple[Any, Any, Any]]:
    with open(path, "rb") as f:
        return list(make_reader(f, validate_crcs=True).iter_messages())


# ---------------------------------------------------------------------------------------------
# round trip


def test_round_trip(run: tuple[Path, dict[str, Any]]) -> None:
    path, info = run
    rec = load_run(path)
    ks = np.array(info["written"])
    t = ks / info["rate_hz"]
    assert np.array_equal(ks, np.arange(0, 6000, 10))  # 10 Hz from a 100 Hz caller
    assert rec.times_ns.dtype == np.int64
    assert np.array_equal(rec.times_ns, np.arange(600, dtype=np.int64) * 100_000_000)
    expected = np.array([circle_state(x) for x in t])
    assert np.array_equal(rec.states, kept_states(expected))
    assert np.allclose(rec.states, expected, rtol=2**-24, atol=0)  # float32's half ulp
    assert np.array_equal(rec.controls, f32(np.array([controls(x) for x in t])))
    assert sorted(rec.extras) == ["course_cmd", "leg", "xte"]
    # xte and leg are not fields of VehicleState.extras: extras.other, doubles
    assert np.array_equal(rec.extras["xte"], np.sin(t))
    assert np.array_equal(rec.extras["course_cmd"], f32(0.1 * t))
    assert np.array_equal(rec.extras["leg"], (ks // 2000).astype(float))

    assert [(w.t_ns, w.reason, w.active_index) for w in rec.waypoints] == [
        (0, "initial", 0),
        (20_000_000_000, "avoidance: pso-ca inserted 1", 1),
        (40_000_000_000, "leg 2", 2),
    ]
    assert np.array_equal(rec.waypoints[1].waypoints, np.array(WAYPOINTS_1))

    events = {(u.t_ns, a) for u in rec.threats for a in u.appeared}
    assert events == {
        (0, "obs2"),
        (10 * 10**9, "sam"),
        (10 * 10**9, "tower"),
        (10 * 10**9, "ridge"),
        (10 * 10**9, "uav2"),
    }
    removed = {(u.t_ns, r) for u in rec.threats for r in u.removed}
    assert removed == {(30 * 10**9, "obs2"), (40 * 10**9, "uav2")}
    moves = [u.t_ns for u in rec.threats if u.changed]
    assert moves == list(range(10 * 10**9 + 10**8, 40 * 10**9, 10**8))  # at most at the log rate
    last = rec.threats[-1]
    assert sorted(th["id"] for th in last.threats) == ["ridge", "sam", "tower"]
    sam = next(th for th in last.threats if th["id"] == "sam")
    assert sam == {**CYLINDER, "center": [ORIGIN[0] - 1500, ORIGIN[1] + 500], "top": 3000.0}
    uav = next(
        th for u in rec.threats for th in u.threats if u.t_ns == 25 * 10**9 and th["id"] == "uav2"
    )
    assert uav["center"] == intruder(25.0)["center"]

    assert len(rec.detections) == 60
    assert rec.detections[5].t_ns == 5 * 10**9
    assert rec.detections[5].detections[0] == {
        "id": "obs2",
        "position": SPHERE["center"],
        "kind": "threat",
        "moving": False,
        "range": 900.0,
    }
    assert rec.detections[5].detections[1]["kind"] == "terrain"

    (decision,) = rec.decisions
    assert decision.t_ns == 20 * 10**9 and decision.compute_s == 0.0123
    assert decision.decision["inputs"]["state"] == [0.0, 1.0, 2.0]
    assert decision.decision["costs"] == {"f1": 1.5, "f2": 0.25, "nan": None}

    assert [(e.t_ns, e.level, e.text) for e in rec.logs] == [
        (20 * 10**9, "warning", "obs2 inside the look-ahead: avoiding"),
        (40 * 10**9, "info", "leg 2"),
        (60 * 10**9, "error", "a made-up violation"),
    ]
    assert rec.metrics == METRICS
    assert {k: v for k, v in rec.attachments.items()} == {k: v[0] for k, v in ATTACHMENTS.items()}
    assert rec.attachment_types["mission.yaml"] == "application/yaml"
    md = rec.metadata
    assert md["seed"] == "42" and md["avoid"] == "pso-ca" and md["crs"] == "EPSG:32611"
    assert md["command"].startswith("terrapath replay") and md["mission"] == "demo"
    assert json.loads(md["map_origin"]) == list(ORIGIN)
    assert md["software_version"] and md["terrapath"] == T.FORMAT_VERSION
    started = datetime.fromisoformat(md["started_utc"])
    assert started.tzinfo is not None and abs(started.timestamp() - time.time()) < 3600
    assert rec.duration_s == 60.0


def test_summary(run: tuple[Path, dict[str, Any]]) -> None:
    path, _ = run
    s = summary(load_run(path))
    json.dumps(s)  # JSON-ready for `terrapath inspect --json`
    assert s["samples"] == 600 and s["duration_s"] == 60.0 and s["seed"] == 42
    assert s["topics"][T.VEHICLE_STATE] == 600 and s["topics"][T.TF] == 600
    assert s["topics"][T.VEHICLE_FIX] == 600 and s["topics"][T.TERRAIN] == 1
    assert s["topics"][T.VEHICLE_TRACK] == 57  # 1 Hz from the 2nd point, not at overviews
    assert s["topics"][T.VEHICLE_TRACK_OVERVIEW] == 2
    assert s["decisions"] == 1 and s["decision_compute_s"]["max"] == 0.0123
    assert s["warnings"] == 2 and s["metrics"]["plr"] == 1.07
    assert [a["name"] for a in s["attachments"]] == list(ATTACHMENTS)
    assert s["attachments"][2]["bytes"] == 256


def test_metrics_also_in_metadata(run: tuple[Path, dict[str, Any]]) -> None:
    path, _ = run
    with open(path, "rb") as f:
        md = {m.name: m.metadata for m in make_reader(f, validate_crcs=True).iter_metadata()}
    assert {k: json.loads(v) for k, v in md[T.METRICS_METADATA].items()} == METRICS
    assert set(md[T.RUN_METADATA]) >= {
        "seed",
        "software_version",
        "command",
        "avoid",
        "started_utc",
        "crs",
        "map_origin",
    }


# ---------------------------------------------------------------------------------------------
# Foxglove schemas and messages


def test_schemas_are_the_foxglove_ones(run: tuple[Path, dict[str, Any]]) -> None:
    path, _ = run
    with open(path, "rb") as f:
        summ = make_reader(f, validate_crcs=True).get_summary()
    assert summ is not None
    by_topic = {c.topic: (c, summ.schemas[c.schema_id]) for c in summ.channels.values()}
    assert set(by_topic) == set(T.SCHEMAS)
    for topic, (channel, schema) in by_topic.items():
        assert schema.name == T.SCHEMAS[topic]
        if schema.name in FOXGLOVE:
            assert (schema.encoding, channel.message_encoding) == ("protobuf", "protobuf")
            fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
            pool = descriptor_pool.DescriptorPool()
            for fd in fds.file:
                pool.Add(fd)
            cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
            assert cls.DESCRIPTOR.full_name == FOXGLOVE[schema.name].DESCRIPTOR.full_name
        else:
            assert (schema.encoding, channel.message_encoding) == ("jsonschema", "json")
            doc = json.loads(schema.data)
            assert doc["type"] == "object" and doc["title"] == schema.name


def test_messages_decode_with_foxglove_classes(run: tuple[Path, dict[str, Any]]) -> None:
    path, info = run
    seen: dict[str, list[Any]] = {}
    for schema, channel, message in messages(path):
        if schema.encoding == "protobuf":
            msg = FOXGLOVE[schema.name].FromString(message.data)
            stamp = getattr(msg, "timestamp", None)
            if stamp is not None and channel.topic != T.TF_STATIC:
                assert stamp.seconds * 10**9 + stamp.nanos == message.log_time
            seen.setdefault(channel.topic, []).append((message.log_time, msg))
        else:
            seen.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
        assert message.publish_time == message.log_time

    ox, oy, oz = ORIGIN
    ((_, static),) = seen[T.TF_STATIC]
    assert (static.parent_frame_id, static.child_frame_id) == ("map", "world")  # map: the root
    assert (static.translation.x, static.translation.y, static.translation.z) == (-ox, -oy, -oz)
    for (ns, pose), (ns2, tf), (ns3, fix) in zip(
        seen[T.VEHICLE_POSE], seen[T.TF], seen[T.VEHICLE_FIX], strict=True
    ):
        assert ns == ns2 == ns3
        s = circle_state(ns / 1e9)
        assert pose.frame_id == "map"
        p = pose.pose.position
        assert (p.x, p.y, p.z) == (s[1] - ox, s[0] - oy, -s[2] - oz)
        q = np.array(
            [
                pose.pose.orientation.x,
                pose.pose.orientation.y,
                pose.pose.orientation.z,
                pose.pose.orientation.w,
            ]
        )
        ref = np.array(quaternion_map_from_euler(s[6], s[7], s[8]))
        assert min(np.abs(q - ref).max(), np.abs(q + ref).max()) < 1e-12
        assert (tf.parent_frame_id, tf.child_frame_id) == ("map", "base_link")
        assert tf.translation == pose.pose.position and tf.rotation == pose.pose.orientation
        assert (fix.longitude, fix.latitude) == lonlat(s[1], s[0]) and fix.altitude == -s[2]

    ((_, terrain),) = seen[T.TERRAIN]
    (entity,) = terrain.entities
    (tri,) = entity.triangles
    verts, faces = info["mesh"]
    assert entity.frame_id == "map" and len(tri.indices) == 3 * len(faces) == 3 * info["triangles"]
    pts = np.array([(p.x, p.y, p.z) for p in tri.points])
    assert np.array_equal(pts, verts - np.array(ORIGIN))
    assert np.array_equal(np.array(tri.indices).reshape(-1, 3), faces)
    assert len(tri.colors) == len(tri.points) and tri.pose.orientation.w == 1.0
    assert np.abs(pts).max() < 10_000  # small numbers in Foxglove

    # the track (1 Hz): an overview every 20 s, and the line since the last overview
    track = np.array([circle_state(k) for k in range(60)])
    track = np.c_[track[:, 1] - ox, track[:, 0] - oy, -track[:, 2] - oz]
    overview = seen[T.VEHICLE_TRACK_OVERVIEW]
    assert [ns for ns, _ in overview] == [20 * 10**9, 40 * 10**9]
    (line,) = overview[1][1].entities[0].lines
    assert np.array_equal(np.array([(p.x, p.y, p.z) for p in line.points]), track[:41])
    ns, upd = seen[T.VEHICLE_TRACK][-1]
    (line,) = upd.entities[0].lines
    assert ns == 59 * 10**9 and upd.entities[0].id == "track/recent"
    assert np.array_equal(np.array([(p.x, p.y, p.z) for p in line.points]), track[40:60])

    # threats: shapes, then a deletion when one goes
    for ns, upd in seen[T.THREATS]:
        ids = {e.id for e in upd.entities}
        if ns == 10 * 10**9:
            assert ids == {"threat/sam", "threat/tower", "threat/ridge", "threat/uav2"}
            ents = {e.id: e for e in upd.entities}
            (cyl,) = ents["threat/sam"].cylinders
            floor = float(verts[:, 2].min())  # an unbounded bottom is drawn from the terrain
            assert cyl.size.z == 3000.0 - floor and cyl.pose.position.z == (floor + 3000.0) / 2
            assert cyl.size.x == cyl.size.y == 800.0 and cyl.pose.orientation.w == 1.0
            assert len(ents["threat/ridge"].spheres) == 2
            assert len(ents["threat/tower"].triangles[0].points) > 100  # exponents != 1: a mesh
        if ns == 30 * 10**9:
            assert [d.id for d in upd.deletions] == ["threat/obs2"]
    (_, wp), *_ = seen[T.WAYPOINTS]
    assert len(wp.entities[0].spheres) == 2 and len(wp.entities[0].lines[0].points) == 2
    levels = [Log.Level.Name(m.level) for _, m in seen[T.LOG]]
    assert levels == ["WARNING", "INFO", "ERROR"]
    # every state field is the sample's: map coordinates exactly, the rest to float32
    assert len(seen[T.VEHICLE_STATE]) == 600
    for ns, msg in seen[T.VEHICLE_STATE]:
        t = ns / 1e9
        s, c = circle_state(t), controls(t)
        assert all(msg.HasField(k) for k in (*T.STATE_FIELDS, *T.CONTROL_FIELDS, "alt"))
        assert (msg.pn, msg.pe, msg.pd, msg.alt) == (s[0], s[1], s[2], -s[2])
        assert [getattr(msg, k) for k in T.STATE_FIELDS[3:]] == f32(s[3:]).tolist()
        assert [getattr(msg, k) for k in T.CONTROL_FIELDS] == f32(c).tolist()
        va = math.sqrt(s[3] ** 2 + s[4] ** 2 + s[5] ** 2)
        air = [va, math.atan2(s[5], s[3]), math.asin(s[4] / va)]
        assert np.allclose([msg.airspeed, msg.alpha, msg.beta], air, rtol=2**-23, atol=0)
        assert msg.extras.course_cmd == f32(0.1 * t)
        assert [f.name for f, _ in msg.extras.ListFields()] == ["course_cmd", "other"]
        other = {e.name: e.value for e in msg.extras.other}
        assert other == {"xte": math.sin(t), "leg": float(round(t * 100) // 2000)}


def test_indexes_point_at_their_messages(run: tuple[Path, dict[str, Any]]) -> None:
    """Foxglove seeks with the message indexes: each (log time, offset) must be that message."""
    path, _ = run
    with open(path, "rb") as f:
        records = list(StreamReader(f, emit_chunks=True, validate_crcs=True).records)
    chunk: Chunk | None = None
    checked = 0
    for rec in records:
        if isinstance(rec, Chunk):
            chunk = rec
            raw = breakup_chunk(chunk, validate_crc=True)
            assert raw  # the chunk CRC holds
        elif isinstance(rec, MessageIndex):
            assert chunk is not None
            data = zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size
            )
            times = [ts for ts, _ in rec.records]
            assert times == sorted(times)
            for ts, offset in rec.records:
                opcode, _, channel, _, log_time = struct.unpack_from("<BQHIQ", data, offset)
                assert (opcode, channel, log_time) == (0x05, rec.channel_id, ts)
                checked += 1
    assert checked == sum(1 for _ in messages(path))
    with open(path, "rb") as f:  # mcap's own linear reader, data-section CRC included
        assert sum(1 for _ in NonSeekingReader(f, validate_crcs=True).iter_messages()) == checked


def test_summary_offsets_point_at_their_groups(run: tuple[Path, dict[str, Any]]) -> None:
    path, _ = run
    data = path.read_bytes()
    opcode, _, summary_start, offsets_start, _ = struct.unpack_from("<BQQQI", data, len(data) - 37)
    assert opcode == 0x02 and summary_start < offsets_start < len(data) - 37
    groups, pos = {}, offsets_start
    while pos < len(data) - 37:
        op, length, group_op, start, size = struct.unpack_from("<BQBQQ", data, pos)
        assert op == 0x0E
        groups[group_op] = (start, size)
        pos += 9 + length
    assert set(groups) == {0x03, 0x04, 0x0B, 0x08, 0x0A, 0x0D}  # schema ... metadata index
    for group_op, (start, size) in groups.items():
        end, n = start + size, 0
        while start < end:
            assert data[start] == group_op
            start += 9 + struct.unpack_from("<Q", data, start + 1)[0]
            n += 1
        assert start == end and n >= 1


def test_data_and_display_topics_in_separate_chunks(run: tuple[Path, dict[str, Any]]) -> None:
    path, _ = run
    with open(path, "rb") as f:
        summ = make_reader(f, validate_crcs=True).get_summary()
    assert summ is not None
    data_ids = {c.id for c in summ.channels.values() if c.topic in T.DATA_TOPICS}
    for index in summ.chunk_indexes:
        ids = set(index.message_index_offsets)
        assert ids <= data_ids or not ids & data_ids


# ---------------------------------------------------------------------------------------------
# damaged files, interrupted runs


@pytest.mark.parametrize("fraction", [0.0, 0.001, 0.01, 0.2, 0.5, 0.9, 0.99, 0.999])
def test_truncated_file_is_refused(
    run: tuple[Path, dict[str, Any]], tmp_path: Path, fraction: float
) -> None:
    path, _ = run
    data = path.read_bytes()
    cut = tmp_path / "run.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(
        DataFileError, match=r"^'.*run\.mcap': not a complete terrapath run \("
    ) as err:
        load_run(cut)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("tail", [1, 8, 20, 37, 38])
def test_file_cut_near_the_end_is_refused(
    run: tuple[Path, dict[str, Any]], tmp_path: Path, tail: int
) -> None:
    path, _ = run
    cut = tmp_path / "run.mcap"
    cut.write_bytes(path.read_bytes()[:-tail])
    with pytest.raises(DataFileError, match="not a complete terrapath run"):
        load_run(cut)


def test_flipped_byte_in_a_chunk_is_refused(
    run: tuple[Path, dict[str, Any]], tmp_path: Path
) -> None:
    path, _ = run
    with open(path, "rb") as f:
        summ = make_reader(f, validate_crcs=True).get_summary()
    assert summ is not None
    data = path.read_bytes()
    for index in summ.chunk_indexes[:: max(1, len(summ.chunk_indexes) // 6)]:
        for where in (
            index.chunk_start_offset + index.chunk_length // 2,
            index.chunk_start_offset + 1,
        ):
            bad = bytearray(data)
            bad[where] ^= 0x40
            damaged = tmp_path / "run.mcap"
            damaged.write_bytes(bytes(bad))
            with pytest.raises(DataFileError, match="not a complete terrapath run"):
                load_run(damaged)


def test_any_flipped_byte_is_refused(run: tuple[Path, dict[str, Any]], tmp_path: Path) -> None:
    """Every byte is under a CRC: data section (attachments and metadata too), chunks, summary."""
    path, _ = run
    data = path.read_bytes()
    rng = np.random.default_rng(0)
    positions = list(rng.integers(0, len(data), 60)) + list(range(len(data) - 45, len(data)))
    for where in positions:
        bad = bytearray(data)
        bad[where] ^= 0x01
        damaged = tmp_path / "run.mcap"
        damaged.write_bytes(bytes(bad))
        with pytest.raises(DataFileError, match="not a complete terrapath run"):
            load_run(damaged)


def test_other_files_are_refused(tmp_path: Path) -> None:
    text = tmp_path / "notes.mcap"
    text.write_text("hello, this is not MCAP\n" * 10)
    with pytest.raises(DataFileError, match=r"not a complete terrapath run \(not an MCAP file\)"):
        load_run(text)
    with pytest.raises(DataFileError, match="cannot open"):
        load_run(tmp_path / "missing.mcap")
    with pytest.raises(DataFileError, match="cannot open"):
        load_run(tmp_path)
    other = tmp_path / "other.mcap"
    with open(other, "wb") as f:
        w = Writer(f)
        w.start()
        w.add_metadata("something", {"a": "b"})
        schema = w.register_schema("x", "jsonschema", b"{}")
        ch = w.register_channel("/x", "json", schema)
        w.add_message(ch, 1, b"{}", 1)
        w.finish()
    with pytest.raises(DataFileError, match=r"other\.mcap': not a terrapath run \(no 'terrapath'"):
        load_run(other)


def test_exception_in_the_block_leaves_no_file(tmp_path: Path) -> None:
    target = tmp_path / "run.mcap"
    with pytest.raises(RuntimeError, match="boom"), RunRecorder(target) as rec:
        rec.write_state(0.0, np.zeros(12), np.zeros(4))
        rec.attach("mission.yaml", b"x")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []

    target.write_bytes(b"previous run")
    with pytest.raises(KeyboardInterrupt), RunRecorder(target) as rec:
        rec.write_state(0.0, np.zeros(12), np.zeros(4))
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == [target] and target.read_bytes() == b"previous run"

    with pytest.raises(InputError), RunRecorder(target) as rec:
        rec.write_state(0.0, np.zeros(11), np.zeros(4))
    assert list(tmp_path.iterdir()) == [target]


def test_file_appears_only_when_complete(tmp_path: Path) -> None:
    target = tmp_path / "run.mcap"
    with RunRecorder(target) as rec:
        rec.write_state(0.0, np.zeros(12), np.zeros(4))
        assert not target.exists()
        (tmp,) = tmp_path.iterdir()
        assert tmp.name.startswith(".run.mcap.") and tmp.name.endswith(".part")
    assert list(tmp_path.iterdir()) == [target]
    assert load_run(target).states.shape == (1, 12)
    # a missing folder is created (as every command's outputs are); a file in its way is refused
    with RunRecorder(tmp_path / "new" / "run.mcap") as rec:
        rec.write_state(0.0, np.zeros(12), np.zeros(4))
    assert load_run(tmp_path / "new" / "run.mcap").states.shape == (1, 12)
    (tmp_path / "file").write_bytes(b"")
    with (
        pytest.raises(DataFileError, match="is a file, not a folder"),
        RunRecorder(tmp_path / "file" / "run.mcap"),
    ):
        pass
    assert not (tmp_path / "file" / "run.mcap").exists()


# ---------------------------------------------------------------------------------------------
# rates and inputs


def test_log_rate_is_honoured(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    written = []
    with RunRecorder(path, log_rate_hz=10.0) as rec:
        t = 0.0
        rng = np.random.default_rng(1)
        while t < 10.0:  # irregular steps of 7..23 ms
            if rec.write_state(t, circle_state(t), controls(t)):
                written.append(t)
            t += float(rng.uniform(0.007, 0.023))
        assert rec.write_state(t, circle_state(t), controls(t), force=True)
        with pytest.raises(InputError, match="before the previous sample"):
            rec.write_state(t - 0.5, circle_state(t), controls(t))
    ticks = np.floor(np.array(written) * 10 + 1e-9)
    assert np.array_equal(ticks, np.arange(100))  # one sample per 0.1 s tick, the first after it
    assert len(load_run(path).times_ns) == 101


def test_bad_inputs(tmp_path: Path) -> None:
    with RunRecorder(tmp_path / "run.mcap") as rec:
        with pytest.raises(InputError, match=r"unknown key\(s\) \['colour'\]; allowed: id, kind"):
            rec.write_threats(0, [{**SPHERE, "colour": "red"}])
        with pytest.raises(InputError, match="kind: expected one of sphere, cylinder, ellipsoid"):
            rec.write_threats(0, [{**SPHERE, "kind": "cube"}])
        with pytest.raises(InputError, match="radius: expected a number > 0"):
            rec.write_threats(0, [{**SPHERE, "radius": -1}])
        with pytest.raises(InputError, match="duplicate id"):
            rec.write_threats(0, [SPHERE, SPHERE])
        with pytest.raises(InputError, match="detections\\[0\\] kind"):
            rec.write_detections(0, [{"id": 1, "position": [0, 0, 0], "kind": "bird"}])
        with pytest.raises(InputError, match="state: expected 12 numbers"):
            rec.write_state(0, [0.0] * 11, [0.0] * 4)
        with pytest.raises(InputError, match="expected finite seconds"):
            rec.write_state(float("nan"), np.zeros(12), np.zeros(4))
        with pytest.raises(InputError, match="expected seconds >= 0"):
            rec.write_log(-1.0, "info", "x")
        with pytest.raises(InputError, match="log level"):
            rec.write_log(0.0, "loud", "x")
        with pytest.raises(InputError, match="'algorithm'"):
            rec.write_decision(0.0, {"compute_s": 1.0})
        with pytest.raises(InputError, match="compute_s"):
            rec.write_decision(0.0, {"algorithm": "ctga"})
        with pytest.raises(InputError, match="waypoints: expected finite"):
            rec.write_waypoints(0.0, [[0, 0]], "initial")
        rec.attach("a.yaml", b"1")
        with pytest.raises(InputError, match="unique"):
            rec.attach("a.yaml", b"2")
    with pytest.raises(InputError, match="not open"):
        rec.write_log(0.0, "info", "late")
    with pytest.raises(InputError, match="log_rate_hz"):
        RunRecorder(tmp_path / "x.mcap", log_rate_hz=0)
    with pytest.raises(InputError, match="compression"):
        RunRecorder(tmp_path / "x.mcap", compression="gzip")


def test_non_finite_values_are_kept(tmp_path: Path) -> None:
    """Format 2 writes an infinity or NaN as it is (format 1 wrote null, read as NaN)."""
    path = tmp_path / "run.mcap"
    state = circle_state(0.0)
    state[4] = float("inf")
    with RunRecorder(path) as rec:
        rec.write_state(0.0, state, controls(0.0), {"xte": float("nan"), "leg": 1})
        rec.write_state(0.1, circle_state(0.1), controls(0.1), {"leg": 1})
    r = load_run(path)
    assert np.isinf(r.states[0, 4]) and r.states[0, 0] == state[0]
    assert np.isnan(r.extras["xte"]).all() and np.array_equal(r.extras["leg"], [1.0, 1.0])


@pytest.mark.parametrize("compression", ["lz4", "none"])
def test_other_compressions(tmp_path: Path, compression: str) -> None:
    path = tmp_path / "run.mcap"
    with RunRecorder(path, compression=compression) as rec:
        for k in range(50):
            rec.write_state(k / 10, circle_state(k / 10), controls(k / 10))
    assert len(load_run(path).times_ns) == 50


# ---------------------------------------------------------------------------------------------
# geometry helpers


def test_quaternion_matches_frames() -> None:
    rng = np.random.default_rng(3)
    for phi, theta, psi in rng.uniform(-math.pi, math.pi, (200, 3)) * [1, 0.5, 1]:
        q = np.array(quaternion_map(phi, theta, psi))
        ref = np.array(quaternion_map_from_euler(phi, theta, psi))
        assert min(np.abs(q - ref).max(), np.abs(q + ref).max()) < 1e-12


def test_terrain_is_decimated_to_the_cap() -> None:
    verts, faces = grid_mesh(201)  # 80,000 triangles
    v, f = decimate_mesh(verts, faces, 10_000)
    assert 5_000 <= len(f) <= 10_000
    assert f.min() == 0 and f.max() == len(v) - 1
    assert np.all(v.min(axis=0) >= verts.min(axis=0) - 1e-6)
    assert np.all(v.max(axis=0) <= verts.max(axis=0) + 1e-6)
    assert decimate_mesh(verts, faces, len(faces))[1] is faces


def test_superellipsoid_mesh_lies_on_the_surface() -> None:
    axes, exps = [80.0, 50.0, 400.0], [1.0, 0.5, 4.0]
    pts, faces = superellipsoid_mesh(axes, exps)
    gamma = np.sum(np.abs(pts / axes) ** (2 * np.array(exps)), axis=1)
    assert np.allclose(gamma, 1.0, atol=1e-9)
    assert faces.max() == len(pts) - 1
    # outward orientation: each face normal points away from the centre
    a, b, c = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
    normals = np.cross(b - a, c - a)
    assert np.all(np.einsum("ij,ij->i", normals, (a + b + c) / 3) > 0)


# ---------------------------------------------------------------------------------------------
# size and speed


def test_size_and_throughput(tmp_path: Path) -> None:
    """Bytes and time per state sample with noisy states (which compress like real ones)."""
    path = tmp_path / "run.mcap"
    n = 6000
    rng = np.random.default_rng(5)
    states = np.array([circle_state(k / 10) for k in range(n)]) + rng.normal(0, 1e-3, (n, 12))
    ctrl = rng.uniform(-0.3, 0.3, (n, 4))
    start = time.perf_counter()
    with RunRecorder(path, to_lonlat=lonlat) as rec:
        for k in range(n):
            extras = {
                "course_cmd": float(ctrl[k, 0]),
                "alt_cmd": 200.0,
                "xte": float(ctrl[k, 1]),
                "leg": 3.0,
            }
            rec.write_state(k / 10, states[k], ctrl[k], extras)
    elapsed = time.perf_counter() - start
    per_sample = path.stat().st_size / n
    eight_hours = per_sample * 288_000
    print(
        f"\n{per_sample:.0f} bytes/sample, {n / elapsed:.0f} samples/s, 8 h at 10 Hz: {eight_hours / 1e6:.0f} MB"
    )
    assert eight_hours < 200e6
    assert n / elapsed > 2_000  # loose: CI machines are shared; the measured rate is reported


def _radar_both_ways(
    tmp_path: Path, scans: list[tuple[Any, ...]]
) -> tuple[list[tuple[str, int, bytes]], list[tuple[str, int, bytes]]]:
    """The radar messages of ``scans`` (ids, positions, ranges, terrain, moving) recorded with
    ``write_detections`` (as dicts) and with ``write_detection_arrays``: (dicts', arrays')."""
    paths = tmp_path / "dicts.mcap", tmp_path / "arrays.mcap"
    for path in paths:
        with RunRecorder(path, map_origin=ORIGIN) as rec:
            for k, (ids, pos, rng_m, terrain, moving) in enumerate(scans):
                if path.name == "arrays.mcap":
                    rec.write_detection_arrays(float(k), ids, pos, rng_m, terrain, moving)
                    continue
                rec.write_detections(
                    float(k),
                    [
                        {
                            "id": ids[i],
                            "position": pos[i].tolist(),
                            "range": float(rng_m[i]),
                            "kind": "terrain" if terrain[i] else "threat",
                            "moving": bool(moving[i]),
                        }
                        for i in range(len(ids))
                    ],
                )
    dicts, arrays = (
        [(ch.topic, m.log_time, m.data) for _, ch, m in messages(p) if "radar" in ch.topic]
        for p in paths
    )
    return dicts, arrays


def test_detection_arrays_write_the_messages_of_detection_dicts(tmp_path: Path) -> None:
    """``write_detection_arrays`` (what the simulation uses) writes byte for byte the messages of
    ``write_detections`` with the same scan as dicts: every colour, zero and negative offsets
    from the map origin, ids JSON must escape, numbers of every size, empty scans."""
    rng = np.random.default_rng(3)
    scans = []
    for k in range(60):
        n = int(rng.integers(0, 6))
        pos = ORIGIN + rng.normal(0.0, 3000.0, (n, 3)) * 10.0 ** rng.integers(-9, 9, (n, 1))
        if n:
            pos[0] = ORIGIN  # exactly at the origin: zero offsets
        ids = [f"d{k}/{i}" if i % 2 else f'o"b\\s/\u00fc\n{k}' for i in range(n)]
        if k >= 30:  # seen again (a static threat, no noise): new ranges and flags
            ids, pos = scans[k - 30][0], scans[k - 30][1]
            n = len(ids)
        flags = rng.random(n) < 0.3, rng.random(n) < 0.5
        if k >= 30 and k % 3:  # the last scan again (the usual case): new ranges only
            ids, pos, _, *last = scans[-1]
            n, flags = len(ids), (last[0], last[1])
        ranges = rng.uniform(0.0, 10_000.0, n) * 10.0 ** rng.integers(-20, 20, n)
        scans.append((ids, pos, ranges, *flags))
    a, b = _radar_both_ways(tmp_path, scans)
    assert a == b
    # a detection list per scan; the markers are the message the foxglove classes build, written
    # when they differ from the last written (Foxglove shows those until they are replaced)
    assert [t for topic, t, _ in a if topic == T.DETECTION_LIST] == [k * NS for k in range(60)]
    expected, shown = [], None
    for k, (_, pos, _, terrain, moving) in enumerate(scans):
        if reference_markers(0, pos - ORIGIN, terrain, moving) != shown:
            shown = reference_markers(0, pos - ORIGIN, terrain, moving)
            expected.append(reference_markers(k * NS, pos - ORIGIN, terrain, moving))
    assert 20 < len(expected) < 50
    assert [data for topic, _, data in a if topic == T.DETECTIONS] == expected


NS = 1_000_000_000


def test_scans_of_moving_terrain_returns_are_the_dict_scans(tmp_path: Path) -> None:
    """Scans given as arrays (every return written at once) against the same scans given as
    detection dicts, byte for byte, with terrain returns that move every scan, ids holding ``%``,
    every kind of return and zero offsets."""
    rng = np.random.default_rng(11)
    scans = []
    own = np.array([ORIGIN[0] - 9000.0, ORIGIN[1] - 10_000.0, 3000.0])
    for k in range(80):
        own = own + np.array([20.0, 22.0, 0.5])
        n_threat, n_ground = int(rng.integers(0, 4)), int(rng.integers(0, 60))
        n = n_threat + n_ground
        pos = own + rng.uniform(-10_000.0, 10_000.0, (n, 3)) * [1.0, 1.0, 0.1]
        if n and k % 7 == 0:  # offsets of +0.0 and -0.0 from the origin in some rows
            pos[rng.integers(0, n), rng.integers(0, 3)] = ORIGIN[0]
            pos[rng.integers(0, n)] = [ORIGIN[0], ORIGIN[1], -0.0]
        ids = [f"{'%' * (i % 3)}th%d{k}/{i}%r%%" for i in range(n_threat)]
        ids += [f"terrain/{int(x // 100)}/{int(y // 100)}" for x, y in pos[n_threat:, :2]]
        terrain = np.arange(n) >= n_threat
        moving = rng.random(n) < 0.4  # also "moving" terrain, which the dicts can say
        ranges = np.linalg.norm(pos - own, axis=1)
        scans.append((ids, pos, ranges, terrain, moving))
        if k % 5 == 0:  # the same returns again: new ranges only
            scans.append((ids, pos.copy(), ranges * 1.0001, terrain, moving))
    dicts, arrays = _radar_both_ways(tmp_path, scans)
    assert len(dicts) > len(scans) + 50  # most scans write their markers
    assert arrays == dicts


def reference_markers(
    ns: int, rel: np.ndarray, terrain: np.ndarray, moving: np.ndarray, size: float = 50.0
) -> bytes:
    """The detection markers of one scan built with the foxglove protobuf classes."""
    from foxglove_schemas_protobuf.Color_pb2 import Color
    from foxglove_schemas_protobuf.Pose_pb2 import Pose
    from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
    from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
    from foxglove_schemas_protobuf.SpherePrimitive_pb2 import SpherePrimitive
    from foxglove_schemas_protobuf.Vector3_pb2 import Vector3

    e = SceneEntity(frame_id=T.MAP_FRAME, id="detections")
    e.timestamp.seconds, e.timestamp.nanos = divmod(ns, NS)
    for (x, y, z), g, m in zip(rel.tolist(), terrain, moving, strict=True):
        rgb = (0.6, 0.4, 0.2) if g else (1.0, 0.55, 0.0) if m else (1.0, 0.1, 0.1)
        e.spheres.append(
            SpherePrimitive(
                pose=Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(w=1.0)),
                size=Vector3(x=size, y=size, z=size),
                color=Color(r=rgb[0], g=rgb[1], b=rgb[2], a=1.0),
            )
        )
    return bytes(SceneUpdate(entities=[e]).SerializeToString())


def test_detection_markers_with_zero_and_negative_zero_offsets(tmp_path: Path) -> None:
    """Protobuf leaves out a double that is +0.0 and writes -0.0: the hand-written markers too."""
    pos = np.array([[0.0, 0.0, 0.0], [-0.0, 1.0, -0.0], [0.0, -0.0, 5.0], [-0.0, -0.0, -0.0]])
    flags = np.array([False, True, False, False]), np.array([False, False, True, False])
    path = tmp_path / "run.mcap"
    with RunRecorder(path) as rec:
        rec.write_detection_arrays(2.5, ["a", "b", "c", "d"], pos, np.ones(4), *flags)
        rec.write_detections(3.5, [{"id": "e", "position": [-0.0, 0.0, 0.0]}])
    scenes = [m.data for _, ch, m in messages(path) if ch.topic == T.DETECTIONS]
    assert scenes[0] == reference_markers(int(2.5 * NS), pos, *flags)
    assert scenes[1] == reference_markers(
        int(3.5 * NS), np.array([[-0.0, 0.0, 0.0]]), [False], [False]
    )


def test_detection_arrays_are_checked(tmp_path: Path) -> None:
    with RunRecorder(tmp_path / "run.mcap") as rec:
        ok = (["a", "b"], np.zeros((2, 3)), np.ones(2), [False, True], [False, False])
        rec.write_detection_arrays(0.0, *ok)
        with pytest.raises(InputError, match=r"expected 2 positions \(N, 3\)"):
            rec.write_detection_arrays(1.0, ok[0], np.zeros((2, 2)), *ok[2:])
        with pytest.raises(InputError, match=r"detections\[1\]: expected a finite position"):
            rec.write_detection_arrays(1.0, ok[0], [[0, 0, 0], [0, math.nan, 0]], *ok[2:])
        with pytest.raises(InputError, match=r"detections\[0\]: expected a finite position"):
            rec.write_detection_arrays(1.0, *ok[:2], [math.inf, 1.0], *ok[3:])
