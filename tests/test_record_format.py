"""Recording format 2 (issue 38): the vehicle's samples encoded in batches (replay.record.wire,
replay.record.samples) as protobuf's own encoder would, the batch and the sample-by-sample
paths writing the same file, every message decodable from the schemas in the file, separations
written where they change (replay.record.separation) with the same minima and violations as
every sample, and format 1 files still read."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.LocationFix_pb2 import LocationFix
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import make_reader

from replay.record import topics as T
from replay.record.messages import STATE_EXTRAS, VehicleState
from replay.record.reader import load_run, summary
from replay.record.recorder import RunRecorder
from replay.record.samples import Samples, fix_rows, pose_rows, quaternions_map, state_rows
from replay.record.separation import BAND_ABS_M, BAND_REL
from replay.record.wire import Rows, varints, varints_numpy
from tests.test_record import circle_state, controls, lonlat

DATA = Path(__file__).resolve().parent / "data"
ORIGIN = (500_000.0, 4_000_000.0, 0.0)


def split(data: bytes, lengths: np.ndarray) -> list[bytes]:
    ends = np.cumsum(lengths).tolist()
    return [data[a:b] for a, b in zip([0, *ends[:-1]], ends, strict=True)]


def awkward_values(rng: np.random.Generator, k: int, n: int) -> np.ndarray:
    """Values of every size with zeros, negative zeros, NaN and infinities among them."""
    v = rng.normal(0.0, 1.0, (k, n)) * 10.0 ** rng.integers(-8, 8, (k, n))
    v[rng.random((k, n)) < 0.1] = 0.0
    v[rng.random((k, n)) < 0.05] = -0.0
    v[rng.random((k, n)) < 0.02] = np.nan
    v[rng.random((k, n)) < 0.02] = np.inf
    return v


def awkward_times(rng: np.random.Generator, k: int) -> np.ndarray:
    ns = np.sort(rng.integers(0, 10**15, k))
    ns[:4] = [0, 5, 10**9, 2 * 10**9 + 1]  # zero seconds and nanos are left out
    return ns.astype(np.int64)


# ---------------------------------------------------------------------------------------------
# the batch encoders give protobuf's bytes


def test_varints_are_protobufs() -> None:
    values = np.array([0, 1, 127, 128, 300, 2**31, 2**35 - 1, 2**63 - 1], dtype=np.uint64)
    data, n = varints(values)
    for v, row, size in zip(values.tolist(), data, n, strict=True):
        ref = descriptor_pb2.UninterpretedOption(positive_int_value=v).SerializeToString()
        assert bytes(row[:size]) == ref[1:]  # positive_int_value: field 4, a one-byte tag


def test_the_compiled_varints_and_packing_equal_their_numpy_twins() -> None:
    """The kernels of :mod:`replay.record.wire` against the numpy code they replace: varints of
    every length (the bytes that belong; the rest zero) and rows of fixed, varying, left-out
    and broadcast parts taken in row order."""
    from replay.record.wire import _compact, _pack

    rng = np.random.default_rng(11)
    edges = np.array([0, 1, 127, 128, 2**63 - 1, 2**64 - 1], dtype=np.uint64)
    values = np.concatenate([edges, rng.integers(0, 2**63, 500, dtype=np.uint64)])
    values[6:] >>= rng.integers(0, 63, 500).astype(np.uint64)
    got, n = varints(values)
    want, m = varints_numpy(values)
    assert (n == m).all()
    assert all(bytes(a[:k]) == bytes(b[:k]) for a, b, k in zip(got, want, n, strict=True))
    assert not np.where(np.arange(10) < n[:, None], 0, got).any()
    for k in (1, 7, 300):
        rows = (
            Rows(k)
            .uint(1, rng.integers(0, 2**40, k))
            .text(2, "map")
            .double(3, np.where(rng.random(k) < 0.5, 0.0, rng.normal(size=k)))
            .double(4, rng.normal(size=k), keep=rng.random(k) < 0.3)
            .timestamp(5, rng.integers(0, 10**12, k))
            .uint(6, np.zeros(k, dtype=np.int64), omit_zero=False)
            .float32(7, rng.normal(size=k))
        )
        rows.message(8, Rows(k).uint(1, rng.integers(0, 3, k)))
        assert _pack(rows.parts, k) == _compact(rows.parts, k)
        assert len(_pack(rows.parts, k)) == rows.lengths().sum()


def test_tf_pose_and_fix_are_the_bytes_of_serialize_to_string() -> None:
    rng = np.random.default_rng(1)
    k = 400
    ns = awkward_times(rng, k)
    xyz, q = awkward_values(rng, k, 3), awkward_values(rng, k, 4)
    lon, lat, alt = awkward_values(rng, k, 3).T
    tf, pose = pose_rows(ns, xyz, q)
    tf_msgs, pose_msgs = split(*tf.messages()), split(*pose.messages())
    fix_msgs = split(*fix_rows(ns, lon, lat, alt).messages())
    for i in range(k):
        sec, nsec = divmod(int(ns[i]), 10**9)
        ref = FrameTransform(parent_frame_id="map", child_frame_id="base_link")
        ref.timestamp.seconds, ref.timestamp.nanos = sec, nsec
        ref.translation.x, ref.translation.y, ref.translation.z = xyz[i]
        ref.rotation.x, ref.rotation.y, ref.rotation.z, ref.rotation.w = q[i]
        assert tf_msgs[i] == ref.SerializeToString()
        p = PoseInFrame(frame_id="map")
        p.timestamp.seconds, p.timestamp.nanos = sec, nsec
        pos, ori = p.pose.position, p.pose.orientation
        pos.x, pos.y, pos.z = xyz[i]
        ori.x, ori.y, ori.z, ori.w = q[i]
        assert pose_msgs[i] == p.SerializeToString()
        f = LocationFix(frame_id="base_link")
        f.timestamp.seconds, f.timestamp.nanos = sec, nsec
        f.longitude, f.latitude, f.altitude = lon[i], lat[i], alt[i]
        assert fix_msgs[i] == f.SerializeToString()


def test_state_message_is_the_bytes_of_serialize_to_string() -> None:
    """Every field (also zeros and absent extras), known extras and other names."""
    rng = np.random.default_rng(2)
    k = 300
    ns = awkward_times(rng, k)
    states, ctrl = awkward_values(rng, k, 12), awkward_values(rng, k, 4)
    extras = {
        name: (awkward_values(rng, k, 1)[:, 0], rng.random(k) < 0.8)
        for name in (*STATE_EXTRAS[::2], "leg", "a name with spaces é")
    }
    msgs = split(*state_rows(Samples(ns, states, ctrl, extras)).messages())
    for i in range(k):
        m = VehicleState.FromString(msgs[i])
        assert m.SerializeToString() == msgs[i]  # canonical: protobuf writes these bytes
        assert m.timestamp.seconds * 10**9 + m.timestamp.nanos == ns[i]
        assert np.array_equal([m.pn, m.pe, m.pd], states[i, :3], equal_nan=True)
        np.testing.assert_array_equal(m.alt, -states[i, 2])
        got = [getattr(m, key) for key in T.STATE_FIELDS[3:]]
        np.testing.assert_array_equal(got, states[i, 3:].astype(np.float32))
        got = [getattr(m, key) for key in T.CONTROL_FIELDS]
        np.testing.assert_array_equal(got, ctrl[i].astype(np.float32))
        other = {e.name: e.value for e in m.extras.other}
        for name, (values, present) in extras.items():
            if name in STATE_EXTRAS:
                assert m.extras.HasField(name) == present[i]
                if present[i]:
                    np.testing.assert_array_equal(getattr(m.extras, name), np.float32(values[i]))
            else:
                assert (name in other) == present[i]
                if present[i]:
                    np.testing.assert_array_equal(other[name], values[i])


def test_quaternions_match_the_scalar_ones() -> None:
    from replay.record.scene import quaternion_map

    rng = np.random.default_rng(3)
    angles = rng.uniform(-4, 4, (200, 3))
    q = quaternions_map(angles[:, 0], angles[:, 1], angles[:, 2])
    ref = np.array([quaternion_map(*a) for a in angles])
    assert np.abs(q - ref).max() < 1e-15


# ---------------------------------------------------------------------------------------------
# batches and samples write the same file


def fly(path: Path, batched: bool, wind: bool = True) -> None:
    """A 100 Hz flight of 70 s (log rate 10 Hz) given a second at a time (``batched``) or
    sample by sample; with a wind in the extras from 30 s on."""
    with RunRecorder(path, map_origin=ORIGIN, to_lonlat=lonlat, track_overview_s=20.0) as rec:
        for second in range(70):
            ts = second + np.arange(100) / 100.0
            states = np.array([circle_state(t) for t in ts])
            ctrl = np.array([controls(t) for t in ts])
            extras: dict[str, Any] = {"course_cmd": 0.1 * ts, "xte": np.sin(ts)}
            if wind and second >= 30:
                extras |= {"wind_n": 3.0 + 0 * ts, "wind_e": -4.0 + 0 * ts, "wind_d": 0.5 + 0 * ts}
            if batched:
                rec.write_states(ts, states, ctrl, extras)
            else:
                for i, t in enumerate(ts):
                    rec.write_state(t, states[i], ctrl[i], {k: v[i] for k, v in extras.items()})


def data_messages(path: Path) -> list[tuple[str, int, bytes]]:
    with path.open("rb") as f:
        out = [
            (c.topic, m.log_time, bytes(m.data))
            for _, c, m in make_reader(f, validate_crcs=True).iter_messages(log_time_order=True)
        ]
    return sorted(out)


def test_batches_write_what_samples_write(tmp_path: Path) -> None:
    one, many = tmp_path / "one.mcap", tmp_path / "many.mcap"
    fly(one, batched=False)
    fly(many, batched=True)
    a, b = data_messages(one), data_messages(many)
    assert len(a) == len(b) > 4 * 700
    assert a == b
    rec = load_run(many)
    assert np.array_equal(rec.times_ns, np.arange(700) * 100_000_000)
    # the air data: the body velocity less the wind in body axes (replay.frames' rotation)
    from replay.frames import rotation_body_to_ned

    i = 500  # 50 s, in the wind
    s = circle_state(50.0)
    air = s[3:6] - rotation_body_to_ned(s[6], s[7], s[8]).T @ np.array([3.0, -4.0, 0.5])
    with many.open("rb") as f:
        msgs = [
            VehicleState.FromString(m.data)
            for _, _, m in make_reader(f).iter_messages([T.VEHICLE_STATE], log_time_order=True)
        ]
    va = float(np.linalg.norm(air))
    assert msgs[i].airspeed == pytest.approx(va, rel=2**-23)
    assert msgs[i].alpha == pytest.approx(math.atan2(air[2], air[0]), rel=2**-22)
    assert msgs[i].beta == pytest.approx(math.asin(air[1] / va), rel=2**-22)
    assert msgs[i].extras.wind_n == 3.0 and not msgs[100].extras.HasField("wind_n")


def test_write_states_checks_its_input(tmp_path: Path) -> None:
    from terrain.errors import InputError

    with RunRecorder(tmp_path / "run.mcap") as rec:
        ts = np.arange(10) / 10
        with pytest.raises(InputError, match="expected 10 states"):
            rec.write_states(ts, np.zeros((10, 11)), np.zeros((10, 4)))
        with pytest.raises(InputError, match="increasing"):
            rec.write_states(ts[::-1], np.zeros((10, 12)), np.zeros((10, 4)))
        with pytest.raises(InputError, match="extras 'x': expected 10 numbers"):
            rec.write_states(ts, np.zeros((10, 12)), np.zeros((10, 4)), {"x": np.zeros(3)})
        rec.write_states(ts, np.zeros((10, 12)), np.zeros((10, 4)))
        with pytest.raises(InputError, match="before the previous sample"):
            rec.write_states(ts, np.zeros((10, 12)), np.zeros((10, 4)))
    assert len(load_run(tmp_path / "run.mcap").times_ns) == 10


# ---------------------------------------------------------------------------------------------
# every message decodes from the schemas in the file


def decoders(path: Path) -> dict[int, Any]:
    """A decoder per schema from the schema data alone (what mcap-protobuf-support and Foxglove
    do): protobuf from its FileDescriptorSet, JSON with json."""
    out: dict[int, Any] = {}
    with path.open("rb") as f:
        summ = make_reader(f).get_summary()
    assert summ is not None
    for sid, schema in summ.schemas.items():
        if schema.encoding == "protobuf":
            pool = descriptor_pool.DescriptorPool()
            for fd in descriptor_pb2.FileDescriptorSet.FromString(schema.data).file:
                pool.Add(fd)
            cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
            out[sid] = cls.FromString
        else:
            assert schema.encoding == "jsonschema"
            out[sid] = json.loads
    return out


@pytest.fixture(scope="module")
def replayed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real replay: seed 001's mission among its threats, CTGA avoiding, radar."""
    from terrapath.cli import main

    root = Path(__file__).resolve().parents[1] / "data" / "scenarios"
    out = tmp_path_factory.mktemp("replay") / "run.mcap"
    args = ["replay", str(root / "seed001-mission.yaml"), "--no-picture", "-o", str(out)]
    threats = ["--threats", str(root / "seed001-simple-threats.yaml"), "--avoid", "ctga"]
    assert main([*args, *threats, "--sensor", "cooperative"]) in (0, None, 1)
    return out


def test_every_message_decodes_from_the_file_schemas(replayed: Path) -> None:
    decode = decoders(replayed)
    counts: dict[str, int] = {}
    with replayed.open("rb") as f:
        for schema, channel, message in make_reader(f, validate_crcs=True).iter_messages():
            assert schema is not None
            msg = decode[schema.id](message.data)
            if channel.topic in (T.TF, T.VEHICLE_POSE, T.VEHICLE_STATE, T.VEHICLE_FIX):
                # the batch encoders' messages: canonical, nothing unknown, nothing lost
                assert msg.SerializeToString() == message.data
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    assert counts[T.VEHICLE_STATE] == counts[T.TF] == counts[T.VEHICLE_POSE] > 100


def test_mcap_protobuf_decoder_factory_decodes_every_message(replayed: Path) -> None:
    """mcap-protobuf-support's decoder factory (in the test extra: Foxglove's Python reader of
    protobuf MCAPs) and a JSON one decode every message."""
    from mcap.decoder import DecoderFactory
    from mcap_protobuf import decoder

    class Json(DecoderFactory):
        def decoder_for(self, message_encoding: str, schema: Any) -> Any:
            return json.loads if message_encoding == "json" else None

    seen: dict[str, int] = {}
    with replayed.open("rb") as f:
        reader = make_reader(f, decoder_factories=[decoder.DecoderFactory(), Json()])
        for schema, _channel, _message, msg in reader.iter_decoded_messages():
            assert schema is not None
            if schema.encoding == "protobuf":
                assert msg.DESCRIPTOR.full_name == schema.name
            seen[schema.encoding] = seen.get(schema.encoding, 0) + 1
        assert sum(seen.values()) == reader.get_summary().statistics.message_count
    assert seen["protobuf"] > 300 and seen["jsonschema"] > 10


def test_states_read_back_as_flown(replayed: Path) -> None:
    """The reader's states are the state messages' (doubles exact, the rest float32), with
    the format written in the metadata."""
    rec = load_run(replayed)
    assert rec.metadata["terrapath"] == T.FORMAT_VERSION == "2"
    assert rec.states.shape == (len(rec.times_ns), 12) and len(rec.times_ns) > 100
    assert set(rec.extras) >= {"course_cmd", "next_index", "energy_used", "energy_left"}
    s = rec.states[:, 3:]
    assert np.array_equal(s, s.astype(np.float32).astype(np.float64))


# ---------------------------------------------------------------------------------------------
# format 1 still reads


def test_format_1_reads_as_it_did() -> None:
    """tests/data/run-format1.mcap (written by the JSON-state recorder) reads to what that
    version's reader read from it, and summarises the same."""
    rec = load_run(DATA / "run-format1.mcap")
    expected = np.load(DATA / "run-format1.npz")
    assert rec.metadata["terrapath"] == "1"
    assert np.array_equal(rec.times_ns, expected["times_ns"])
    assert np.array_equal(rec.states, expected["states"])
    assert np.array_equal(rec.controls, expected["controls"])
    names = sorted(k[len("extra_") :] for k in expected.files if k.startswith("extra_"))
    assert sorted(rec.extras) == names
    for name in names:
        assert np.array_equal(rec.extras[name], expected[f"extra_{name}"], equal_nan=True)
    s = summary(rec)
    ref = json.loads((DATA / "run-format1.json").read_text())
    assert {**s, "path": ""} == {**ref, "path": ""}


def test_inspect_reads_format_1(capsys: pytest.CaptureFixture[str]) -> None:
    from terrapath.cli import main

    assert main(["inspect", str(DATA / "run-format1.mcap"), "--json"]) in (0, None)
    out = json.loads(capsys.readouterr().out)
    assert out["samples"] == 200 and out["topics"][T.VEHICLE_STATE] == 200


def test_view_reads_format_1(tmp_path: Path) -> None:
    from terrapath.cli import main

    out = tmp_path / "view.html"
    assert main(["view", str(DATA / "run-format1.mcap"), "-o", str(out)]) in (0, None)
    assert out.stat().st_size > 100_000 and "run-format1" in out.read_text(encoding="utf-8")


def test_unknown_format_is_refused(tmp_path: Path) -> None:
    from terrain.errors import DataFileError

    path = tmp_path / "run.mcap"
    with RunRecorder(path, metadata={"terrapath": "3"}) as rec:
        rec.write_state(0.0, circle_state(0.0), controls(0.0))
    with pytest.raises(DataFileError, match=r"format '3' is not supported .*'1', '2'"):
        load_run(path)


# ---------------------------------------------------------------------------------------------
# separations where they change


def full_docs(
    ts: np.ndarray, ids: list[str], seps: np.ndarray, margin: float
) -> list[dict[str, Any]]:
    """The message format 1 wrote at every sample (its recorder's loop, kept here)."""
    is_zone = np.array([i.startswith("zone:") for i in ids], dtype=bool)
    tcols, zcols = np.flatnonzero(~is_zone), np.flatnonzero(is_zone)
    out = []
    for row in seps:
        doc: dict[str, Any] = {"margin_m": margin, "threats": {}}
        if len(tcols):
            v = row[tcols]
            live = np.flatnonzero(np.isfinite(v))
            if len(live):
                order = live[np.argsort(v[live], kind="stable")[:4]]
                doc["nearest_m"] = round(float(v[order[0]]), 2)
                doc["nearest"] = ids[tcols[order[0]]]
                doc["threats"] = {ids[tcols[j]]: round(float(v[j]), 2) for j in order}
        if len(zcols):
            z = row[zcols]
            if np.isfinite(z).any():
                j = int(np.nanargmin(z))
                doc["zone_m"] = round(float(z[j]), 2)
                doc["zone"] = ids[zcols[j]]
        out.append(doc)
    return out


def separations_flight(n_threats: int) -> tuple[np.ndarray, list[str], np.ndarray]:
    """30 min at 10 Hz past ``n_threats`` spheres (three entered), two zones; a threat appears
    late (NaN before)."""
    rng = np.random.default_rng(7)
    ts = np.arange(18_000) / 10.0
    x = 15.0 * ts
    y = 300.0 * np.sin(ts / 90.0)
    ids = [f"obs{j}" for j in range(n_threats)] + ["zone:a", "zone:b"]
    cx = rng.uniform(0, 27_000, n_threats)
    cy = rng.uniform(2500, 8000, n_threats) * rng.choice([-1.0, 1.0], n_threats)
    cy[:3] = 0.0  # flown through: violations (the others 2.5 to 8 km away, as in the benchmark)
    r = rng.uniform(100, 800, n_threats)
    d = np.hypot(x[:, None] - cx, y[:, None] - cy) - r
    d[ts < 200.0, 5 % n_threats] = np.nan  # appears at 200 s
    za = np.abs(y - 900.0) - 50.0
    zb = np.hypot(x - 20_000.0, y) - 2000.0
    return ts, ids, np.column_stack([d, za, zb])


def runs_below(times: np.ndarray, values: np.ndarray, margin: float) -> list[tuple[int, int]]:
    below = values < margin
    edges = np.flatnonzero(np.diff(np.r_[0, below.astype(int), 0]))
    return [
        (int(times[a]), int(times[b - 1])) for a, b in zip(edges[::2], edges[1::2], strict=True)
    ]


@pytest.mark.parametrize("n_threats", [0, 3, 100])
def test_thinned_separations_keep_minima_violations_and_bands(
    tmp_path: Path, n_threats: int
) -> None:
    ts, ids, seps = separations_flight(max(n_threats, 1))
    if n_threats == 0:
        ids, seps = ids[1:], seps[:, 1:]
    margin = 150.0
    path = tmp_path / "run.mcap"
    with RunRecorder(path) as rec:
        for a in range(0, len(ts), 600):  # the loop's 60-s batches
            rec.write_separations(ts[a : a + 600], ids, seps[a : a + 600], margin_m=margin)
    with path.open("rb") as f:
        got = [
            (m.log_time, json.loads(m.data))
            for _, _, m in make_reader(f).iter_messages([T.SEPARATION], log_time_order=True)
        ]
    full = full_docs(ts, ids, seps, margin)
    ns = np.round(ts * 1e9).astype(np.int64)
    index = {int(t): i for i, t in enumerate(ns)}
    rows = [index[t] for t, _ in got]
    # each written message is the one format 1 wrote at its time
    assert all(doc == full[i] for i, (_, doc) in zip(rows, got, strict=True))
    assert len(got) < len(ts) / 4  # thinned
    # each threat's and zone's least separation, the nearest and zone minima: the same
    keys = {k for d in full for k in d["threats"]}
    for key in keys:
        low = min(d["threats"][key] for d in full if key in d["threats"])
        assert min(d["threats"][key] for _, d in got if key in d["threats"]) == low
    for field in ("nearest_m", "zone_m"):
        values = [d[field] for d in full if field in d]
        if values:
            assert min(d[field] for _, d in got if field in d) == min(values)
    # the violation intervals (of the nearest threat, of the nearest zone): the same samples
    for field in ("nearest_m", "zone_m"):
        every = np.array([d.get(field, np.inf) for d in full])
        kept = np.array([d.get(field, np.inf) for _, d in got])
        assert runs_below(ns[rows], kept, margin) == runs_below(ns, every, margin)
    # between two written samples the nearest threat and zone stay, within their band of the
    # written values
    written = set(rows)
    last = full[0]
    for i, doc in enumerate(full):
        if i in written:
            last = doc
            continue
        assert doc.get("nearest") == last.get("nearest") and doc.get("zone") == last.get("zone")
        pairs = [(doc[k], last[k]) for k in ("nearest_m", "zone_m") if k in doc]
        for a, b in pairs:  # (the values are rounded to 0.01 m)
            assert abs(a - b) <= 1.01 * (BAND_ABS_M + BAND_REL * max(abs(a), abs(b))) + 0.01
    # at least one every 10 s
    assert np.diff(ns[rows]).max() <= 10 * 10**9


def test_the_nearest_threats_of_a_sample_are_its_numpy_twins_by_value_then_column() -> None:
    """The compiled choice of the threats a separation message shows equals its numpy twin (a
    stable sort) on rows with inactive (NaN), infinite and equal separations, for fewer
    columns than shown and many more; an equal separation is listed by its column."""
    from replay.record.separation import _nearest_columns, nearest_columns_numpy

    rng = np.random.default_rng(38)
    for k, n in ((600, 100), (50, 3), (10, 0), (20, 4), (30, 5), (40, 12)):
        v = np.round(rng.uniform(-100.0, 900.0, (k, n)), -2)  # many equal values
        v[rng.random((k, n)) < 0.3] = np.nan
        v[rng.random((k, n)) < 0.1] = np.inf
        v[rng.random((k, n)) < 0.05] = -np.inf
        cols, vals = _nearest_columns(v, 4)
        want_cols, want_vals = nearest_columns_numpy(v, 4)
        np.testing.assert_array_equal(cols, want_cols)
        np.testing.assert_array_equal(vals, want_vals)
    cols, vals = _nearest_columns(np.array([[5.0, 3.0, 3.0, 1.0, 3.0, np.nan]]), 4)
    assert cols.tolist() == [[3, 1, 2, 4]] and vals.tolist() == [[1.0, 3.0, 3.0, 3.0]]


def test_the_row_of_each_threats_least_separation_is_argmin_over_the_table() -> None:
    """Which sample holds each shown threat's least separation of a batch (compiled): the rows
    ``np.argmin`` finds over the (K, N) table of shown separations, infinite where a threat is
    not shown -- the first of equal minima."""
    from replay.record.separation import _least_rows, _nearest_columns

    rng = np.random.default_rng(39)
    for k, n in ((600, 100), (30, 3), (1, 5), (50, 8)):
        v = np.round(rng.uniform(0.0, 500.0, (k, n)), -2)
        v[rng.random((k, n)) < 0.4] = np.nan
        ids, vals = _nearest_columns(v, 4)
        table = np.full((k, n), np.inf)
        for i, j in zip(*np.nonzero(ids >= 0), strict=True):
            table[i, ids[i, j]] = vals[i, j]
        shown = np.isfinite(table).any(axis=0)
        want = np.argmin(table, axis=0)[shown]
        np.testing.assert_array_equal(_least_rows(ids, vals, n), want)


def test_entity_head_is_the_bytes_of_serialize_to_string() -> None:
    from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity

    from replay.record.encoding import entity_head

    for ns in awkward_times(np.random.default_rng(4), 50).tolist():
        e = SceneEntity(frame_id="map", id="track/recent")
        e.timestamp.seconds, e.timestamp.nanos = divmod(ns, 10**9)
        assert entity_head(ns, "map", "track/recent") == e.SerializeToString()


def test_records_frame_each_message_once() -> None:
    """``Rows.records``: MCAP message records (opcode, length, channel, sequence 0, log and
    publish time) of every message, in row order; lengths and times in that order."""
    import struct

    rng = np.random.default_rng(5)
    k = 500
    ns = awkward_times(rng, k)
    tf, _ = pose_rows(ns, awkward_values(rng, k, 3), awkward_values(rng, k, 4))
    want = dict(zip(ns.tolist(), split(*tf.messages()), strict=True))
    data, lengths, times = tf.records(7, ns)
    assert times.tolist() == ns.tolist() and len(data) == lengths.sum()
    for record, t in zip(split(data, lengths), times.tolist(), strict=True):
        op, size, channel, seq, log, pub = struct.unpack_from("<BQHIQQ", record)
        assert (op, size, channel, seq, log, pub) == (5, len(record) - 9, 7, 0, t, t)
        assert record[31:] == want[t]
