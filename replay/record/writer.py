"""How a run is written to disk: an MCAP file under a temporary name, renamed into place when
complete (:class:`McapFile`), and the lean chunked MCAP stream writer behind it (:class:`McapSink`).

The file is written under a temporary name beside its path (``terrain.atomic.atomic_output``) and
renamed into place only when it ends cleanly; an exception (or Ctrl-C) removes the temporary file,
so a file at the path is always complete.

Messages are framed into chunks here (:class:`McapSink`, the records themselves are serialised by
``mcap.records``) rather than with ``mcap.writer.Writer``, whose pure-Python ``add_message`` costs
about 10 µs a message on the project machines: 3 messages a state sample, 288,000 samples for an
8-hour mission.  The stream is indexed, chunked (``COMPRESSIONS``: zstd, lz4 or uncompressed) and
every CRC is written (chunks, data section, summary).  :func:`descriptor_set` gives the schema data
MCAP expects for the ``protobuf`` encoding.  What goes into the file is :mod:`replay.record.recorder`'s
business; how a message's bytes are made, :mod:`replay.record.encoding`'s.
"""

from __future__ import annotations

import contextlib
import struct
import zlib
from collections.abc import Mapping
from os import PathLike
from types import TracebackType
from typing import IO, Any

import numpy as np
import numpy.typing as npt
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

from replay.record import topics as T
from terrain.atomic import atomic_output

COMPRESSIONS = ("zstd", "lz4", "none")
# zstd's level: 1 compresses a run's chunks 40 % faster than the default 3, into a file 23 %
# larger (measured on a 1-h seed 000 run: 0.080 s vs 0.134 s, 6.1 vs 5.0 MiB)
ZSTD_LEVEL = 1


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

    __slots__ = ("batches", "data", "index", "t0", "t1")

    def __init__(self) -> None:
        self.data = bytearray()
        self.index: dict[int, list[int]] = {}  # channel -> [log_time, offset, log_time, ...]
        # channel -> (log_time, offset) pairs (n, 2) of the batches (McapSink.add_records)
        self.batches: dict[int, list[npt.NDArray[np.uint64]]] = {}
        self.t0 = -1
        self.t1 = 0


class McapSink:
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

    def add_records(
        self, channel: int, log_times: npt.NDArray[np.int64], data: bytes, lengths: npt.ArrayLike
    ) -> None:
        """Many messages of ``channel`` at once: ``data``, their MCAP message records one after
        the other (:meth:`replay.record.wire.Rows.records`), ``lengths`` the length of each,
        ``log_times`` their log times.  The chunk is closed after them when full."""
        n = len(log_times)
        if not n:
            return
        group = self._group_of[channel]
        chunk = self._open[group]
        buf = chunk.data
        pairs = np.empty((n, 2), dtype=np.uint64)
        pairs[:, 0] = log_times
        pairs[0, 1] = len(buf)
        np.cumsum(np.asarray(lengths, dtype=np.uint64)[:-1], out=pairs[1:, 1])
        pairs[1:, 1] += np.uint64(len(buf))
        chunk.batches.setdefault(channel, []).append(pairs)
        buf += data
        lo, hi = int(log_times.min()), int(log_times.max())
        if lo < chunk.t0 or chunk.t0 < 0:
            chunk.t0 = lo
        if hi > chunk.t1:
            chunk.t1 = hi
        if len(buf) >= self._chunk_size:
            self._flush(group)

    def _flush(self, group: int) -> None:
        chunk = self._open[group]
        if not chunk.index and not chunk.batches:
            return
        self._open[group] = _OpenChunk()
        raw = bytes(chunk.data)
        if self._compression == "zstd":
            import zstandard

            data = zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(raw)
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
        for channel in sorted({*chunk.index, *chunk.batches}):
            pieces = chunk.batches.get(channel, [])
            if channel in chunk.index:
                pieces = [np.asarray(chunk.index[channel], dtype=np.uint64).reshape(-1, 2), *pieces]
            pairs = pieces[0] if len(pieces) == 1 else np.concatenate(pieces)
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


class McapFile:
    """One MCAP file being written to ``path``: a :class:`McapSink` (``sink``) on a temporary file
    beside it (buffered 1 MiB), renamed into place by :meth:`close` after a clean end."""

    def __init__(
        self, path: str | PathLike[str], *, compression: str, chunk_size: int, library: str
    ) -> None:
        stack = contextlib.ExitStack()
        try:
            tmp = stack.enter_context(atomic_output(path))
            out = stack.enter_context(open(tmp, "wb", buffering=1 << 20))
            self.sink = McapSink(
                out, compression=compression, chunk_size=chunk_size, library=library
            )
        except BaseException as err:  # the temporary file goes, nothing is renamed
            stack.__exit__(type(err), err, err.__traceback__)
            raise
        self._stack = stack

    def close(
        self,
        exc_type: type[BaseException] | None = None,
        exc: BaseException | None = None,
        tb: TracebackType | None = None,
    ) -> bool:
        """Without an exception: finish the stream and rename the file into place.  With one (the
        arguments of ``__exit__``): remove the temporary file.  Returns whether the exception is
        suppressed (as ``__exit__``)."""
        if exc_type is None:
            try:
                self.sink.finish()
            except BaseException as err:
                if not self._stack.__exit__(type(err), err, err.__traceback__):
                    raise
                return False
        return bool(self._stack.__exit__(exc_type, exc, tb))
