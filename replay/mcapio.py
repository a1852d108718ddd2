"""The low-level MCAP writing of :mod:`replay.record`: a lean chunked MCAP stream writer
(:class:`_McapSink`) and protobuf wire-format helpers for large arrays.

Messages are framed into chunks here (:class:`_McapSink`, the records themselves are serialised by
``mcap.records``) rather than with ``mcap.writer.Writer``, whose pure-Python ``add_message`` costs
about 10 µs a message on the project machines: 3 messages a state sample, 288,000 samples for an
8-hour mission.  The stream is indexed, chunked (zstd, lz4 or uncompressed) and every CRC is
written (chunks, data section, summary).

Large point arrays (terrain, track) are encoded as protobuf wire format with numpy (``_ld``,
``_doubles_messages``, ``_packed_fixed32``); the field numbers used are checked against the
installed foxglove schemas at import.  :func:`descriptor_set` gives the schema data MCAP expects
for the ``protobuf`` encoding.
"""

from __future__ import annotations

import functools
import struct
import zlib
from collections.abc import Mapping
from typing import IO, Any

import numpy as np
import numpy.typing as npt
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.SpherePrimitive_pb2 import SpherePrimitive
from foxglove_schemas_protobuf.TriangleListPrimitive_pb2 import TriangleListPrimitive
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf import descriptor_pb2
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from replay import topics as T

FloatArray = npt.NDArray[np.float64]

# ---------------------------------------------------------------------------------------------
# protobuf wire format for large arrays (fields checked against the schema descriptors below)

_WIRE_DOUBLE = 1
_WIRE_LEN = 2
_FIXED32 = 7  # FieldDescriptor.TYPE_FIXED32


def _tag(field: int, wire: int) -> bytes:
    return _varint(field << 3 | wire)


def _varint(n: int) -> bytes:
    out = bytearray()
    while n > 0x7F:
        out.append(n & 0x7F | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def _ld(field: int, payload: bytes) -> bytes:
    """A length-delimited field (embedded message, string, packed array)."""
    return _tag(field, _WIRE_LEN) + _varint(len(payload)) + payload


def _doubles_messages(field: int, values: FloatArray) -> bytes:
    """``repeated M field`` where M has only double fields 1..k (Point3, Color): one embedded
    message per row of ``values`` (n, k), every field written (also zeros, which is valid)."""
    n, k = values.shape
    out = np.empty((n, 2 + 9 * k), dtype=np.uint8)
    out[:] = _row_template(field, k)
    raw = np.ascontiguousarray(values, dtype="<f8").view(np.uint8).reshape(n, k, 8)
    for j in range(k):
        out[:, 3 + 9 * j : 11 + 9 * j] = raw[:, j]
    return out.tobytes()


@functools.cache
def _row_template(field: int, k: int) -> npt.NDArray[np.uint8]:
    """The bytes of one embedded message of ``_doubles_messages`` with all doubles zero."""
    tag = _tag(field, _WIRE_LEN)
    if len(tag) != 1 or k > 15:
        raise ValueError("only fields 1..15 with up to 15 doubles are supported")
    row = [tag[0], 9 * k]
    for j in range(k):
        row += [(j + 1) << 3 | _WIRE_DOUBLE] + [0] * 8
    return np.array(row, dtype=np.uint8)


def _packed_fixed32(field: int, values: npt.NDArray[Any]) -> bytes:
    return _ld(field, np.ascontiguousarray(values, dtype="<u4").tobytes())


_DOUBLE = struct.Struct("<d")
_NO_BITS = bytes(8)


def _vector3(x: float, y: float, z: float) -> bytes:
    """A Vector3 / Point3 message as protobuf writes it: the doubles x (1), y (2), z (3), each
    left out when its bits are all zero (proto3 default; -0.0 is written)."""
    out = b""
    for tag, v in ((b"\x09", x), (b"\x11", y), (b"\x19", z)):
        raw = _DOUBLE.pack(v)
        if raw != _NO_BITS:
            out += tag + raw
    return out


def _sphere_field(field: int, x: float, y: float, z: float, tail: bytes) -> bytes:
    """One ``SpherePrimitive field``: ``pose {position: (x, y, z), orientation: identity}``
    followed by ``tail``, the sphere's encoded ``size`` and ``color`` fields (the bytes of
    SerializeToString; the tests compare them)."""
    position = _vector3(x, y, z)
    pose = bytes((_POSE_POSITION_TAG, len(position))) + position + _IDENTITY
    sphere = bytes((_SPHERE_POSE_TAG, len(pose))) + pose + tail
    return _ld(field, sphere)


def _check_wire_layout() -> None:
    """The hand-encoded fields must be what the installed schemas say (fails at import if not)."""

    def number(msg: Any, name: str, ftype: int | None = None) -> int:
        f = msg.DESCRIPTOR.fields_by_name[name]
        if ftype is not None and f.type != ftype:
            raise ImportError(f"unexpected type for {msg.DESCRIPTOR.full_name}.{name}")
        return int(f.number)

    expected: dict[tuple[Any, str], int] = {
        (Point3, "x"): 1,
        (Point3, "y"): 2,
        (Point3, "z"): 3,
        (Color, "r"): 1,
        (Color, "g"): 2,
        (Color, "b"): 3,
        (Color, "a"): 4,
    }
    for (msg, name), num in expected.items():
        if number(msg, name, 1) != num:  # TYPE_DOUBLE
            raise ImportError(f"unexpected field number for {msg.DESCRIPTOR.full_name}.{name}")
    number(TriangleListPrimitive, "indices", _FIXED32)
    for msg in (Vector3, Point3):
        for j, name in enumerate("xyz"):
            if number(msg, name, 1) != j + 1:
                raise ImportError(f"unexpected field number for {msg.DESCRIPTOR.full_name}.{name}")
    if (number(Pose, "position"), number(Pose, "orientation")) != (1, 2) or number(
        SpherePrimitive, "pose"
    ) >= min(number(SpherePrimitive, "size"), number(SpherePrimitive, "color")):
        raise ImportError("unexpected field numbers for foxglove.Pose or SpherePrimitive")


_check_wire_layout()
_TRI_POINTS = TriangleListPrimitive.DESCRIPTOR.fields_by_name["points"].number
_TRI_COLORS = TriangleListPrimitive.DESCRIPTOR.fields_by_name["colors"].number
_TRI_INDICES = TriangleListPrimitive.DESCRIPTOR.fields_by_name["indices"].number
_LINE_POINTS = LinePrimitive.DESCRIPTOR.fields_by_name["points"].number
_ENTITY_LINES = SceneEntity.DESCRIPTOR.fields_by_name["lines"].number
_ENTITY_TRIANGLES = SceneEntity.DESCRIPTOR.fields_by_name["triangles"].number
_UPDATE_ENTITIES = SceneUpdate.DESCRIPTOR.fields_by_name["entities"].number
_ENTITY_SPHERES = SceneEntity.DESCRIPTOR.fields_by_name["spheres"].number
_SPHERE_POSE = SpherePrimitive.DESCRIPTOR.fields_by_name["pose"].number
_POSE_POSITION = Pose.DESCRIPTOR.fields_by_name["position"].number
_SPHERE_POSE_TAG = _tag(_SPHERE_POSE, _WIRE_LEN)[0]  # one byte each (fields 1..15), and so are
_POSE_POSITION_TAG = _tag(_POSE_POSITION, _WIRE_LEN)[0]  # the lengths: a pose is < 128 bytes
_IDENTITY = Pose(orientation=Quaternion(w=1.0)).SerializeToString()  # the orientation field


def descriptor_set(message_class: Any) -> bytes:
    """Serialized ``FileDescriptorSet`` of a protobuf class and all its dependencies (the schema
    data MCAP expects for the ``protobuf`` encoding)."""
    fds = descriptor_pb2.FileDescriptorSet()
    seen: set[str] = set()

    def add(fd: Any) -> None:
        if fd.name in seen:
            return
        seen.add(fd.name)
        for dep in fd.dependencies:
            add(dep)
        fd.CopyToProto(fds.file.add())

    add(message_class.DESCRIPTOR.file)
    return bytes(fds.SerializeToString())


# ---------------------------------------------------------------------------------------------
# a lean MCAP writer: mcap.records serialise every record; messages are framed with one pack


_MAGIC = b"\x89MCAP0\r\n"
_MESSAGE = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log, publish time
_MESSAGE_INDEX = struct.Struct("<BQHI")  # opcode, record length, channel, records length


def _record_bytes(record: McapRecord) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return bytes(builder.end())


class _OpenChunk:
    """Messages of one chunk being built: the records, and per channel (log time, offset) pairs."""

    __slots__ = ("data", "index", "t0", "t1")

    def __init__(self) -> None:
        self.data = bytearray()
        self.index: dict[int, list[int]] = {}  # channel -> [log_time, offset, log_time, ...]
        self.t0 = -1
        self.t1 = 0


class _McapSink:
    """Writes an indexed, chunked MCAP stream with CRCs (data section, chunks, summary).

    Schemas and channels are written in the data section before the first chunk and repeated in
    the summary, with statistics, chunk, attachment and metadata indexes and summary offsets.
    Each channel belongs to a chunk *group*; a chunk holds one group's messages, so a reader that
    asks for the topics of one group skips the chunks of the others (their time ranges overlap,
    which MCAP allows: the message indexes order them).
    """

    def __init__(self, out: IO[bytes], *, compression: str, chunk_size: int, library: str) -> None:
        self._out = out
        self._offset = 0
        self._crc = 0
        self._compression = compression
        self._chunk_size = chunk_size
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._group_of: list[int] = [0]  # by channel id
        self._open: dict[int, _OpenChunk] = {}
        self._chunk_indexes: list[ChunkIndex] = []
        self._attachment_indexes: list[AttachmentIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = {}
        self._first = -1
        self._last = 0
        self._write(_MAGIC)
        self._write_record(Header(profile=T.PROFILE, library=library))

    def _write(self, data: bytes) -> None:
        self._crc = zlib.crc32(data, self._crc)
        self._out.write(data)
        self._offset += len(data)

    def _write_record(self, record: McapRecord) -> tuple[int, int]:
        data = _record_bytes(record)
        start = self._offset
        self._write(data)
        return start, len(data)

    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._write_record(schema)
        return schema.id

    def add_channel(self, topic: str, message_encoding: str, schema_id: int, group: int = 0) -> int:
        channel = Channel(
            id=len(self._channels) + 1,
            topic=topic,
            message_encoding=message_encoding,
            schema_id=schema_id,
            metadata={},
        )
        self._channels.append(channel)
        self._write_record(channel)
        self._group_of.append(group)
        self._open.setdefault(group, _OpenChunk())
        return channel.id

    def add_message(self, channel: int, log_time: int, data: bytes) -> None:
        chunk = self._open[self._group_of[channel]]
        buf = chunk.data
        index = chunk.index.get(channel)
        if index is None:
            index = chunk.index[channel] = []
        index.append(log_time)
        index.append(len(buf))
        buf += _MESSAGE.pack(Opcode.MESSAGE, 22 + len(data), channel, 0, log_time, log_time)
        buf += data
        if log_time < chunk.t0 or chunk.t0 < 0:
            chunk.t0 = log_time
        if log_time > chunk.t1:
            chunk.t1 = log_time
        if len(buf) >= self._chunk_size:
            self._flush(self._group_of[channel])

    def _flush(self, group: int) -> None:
        chunk = self._open[group]
        if not chunk.index:
            return
        self._open[group] = _OpenChunk()
        raw = bytes(chunk.data)
        if self._compression == "zstd":
            import zstandard

            data = zstandard.ZstdCompressor().compress(raw)
        elif self._compression == "lz4":
            import lz4.frame

            data = lz4.frame.compress(raw)
        else:
            data = raw
        record = Chunk(
            compression="" if self._compression == "none" else self._compression,
            data=data,
            message_start_time=chunk.t0,
            message_end_time=chunk.t1,
            uncompressed_crc=zlib.crc32(raw),
            uncompressed_size=len(raw),
        )
        start, length = self._write_record(record)
        index_start = self._offset
        offsets: dict[int, int] = {}
        for channel in sorted(chunk.index):
            pairs = np.asarray(chunk.index[channel], dtype=np.uint64).reshape(-1, 2)
            if np.any(np.diff(pairs[:, 0].astype(np.int64)) < 0):
                pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
            body = pairs.astype("<u8").tobytes()
            offsets[channel] = self._offset
            self._write(
                _MESSAGE_INDEX.pack(Opcode.MESSAGE_INDEX, 6 + len(body), channel, len(body)) + body
            )
            self._counts[channel] = self._counts.get(channel, 0) + len(pairs)
        self._chunk_indexes.append(
            ChunkIndex(
                message_start_time=chunk.t0,
                message_end_time=chunk.t1,
                chunk_start_offset=start,
                chunk_length=length,
                message_index_offsets=offsets,
                message_index_length=self._offset - index_start,
                compression=record.compression,
                compressed_size=len(data),
                uncompressed_size=len(raw),
            )
        )
        self._first = chunk.t0 if self._first < 0 else min(self._first, chunk.t0)
        self._last = max(self._last, chunk.t1)

    def add_attachment(self, name: str, media_type: str, data: bytes, log_time: int) -> None:
        record = Attachment(
            create_time=0, log_time=log_time, name=name, media_type=media_type, data=data
        )
        start, length = self._write_record(record)
        self._attachment_indexes.append(
            AttachmentIndex(
                offset=start,
                length=length,
                log_time=log_time,
                create_time=0,
                data_size=len(data),
                name=name,
                media_type=media_type,
            )
        )

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        start, length = self._write_record(Metadata(name=name, metadata=dict(data)))
        self._metadata_indexes.append(MetadataIndex(offset=start, length=length, name=name))

    def finish(self) -> None:
        for group in sorted(self._open):
            self._flush(group)
        self._write_record(DataEnd(data_section_crc=self._crc))
        summary_start = self._offset
        summary = bytearray()
        groups: list[SummaryOffset] = []
        stats = Statistics(
            message_count=sum(self._counts.values()),
            schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=len(self._attachment_indexes),
            metadata_count=len(self._metadata_indexes),
            chunk_count=len(self._chunk_indexes),
            message_start_time=max(self._first, 0),
            message_end_time=self._last,
            channel_message_counts=dict(self._counts),
        )
        for opcode, records in (
            (Opcode.SCHEMA, self._schemas),
            (Opcode.CHANNEL, self._channels),
            (Opcode.STATISTICS, [stats]),
            (Opcode.CHUNK_INDEX, self._chunk_indexes),
            (Opcode.ATTACHMENT_INDEX, self._attachment_indexes),
            (Opcode.METADATA_INDEX, self._metadata_indexes),
        ):
            if not records:
                continue
            group_start = summary_start + len(summary)
            for record in records:
                summary += _record_bytes(record)
            groups.append(
                SummaryOffset(opcode, group_start, summary_start + len(summary) - group_start)
            )
        offsets_start = summary_start + len(summary)
        for offset in groups:
            summary += _record_bytes(offset)
        footer_head = struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start, offsets_start)
        crc = zlib.crc32(footer_head, zlib.crc32(summary))
        self._write(bytes(summary))
        self._write_record(Footer(summary_start, offsets_start, crc))
        self._write(_MAGIC)
