"""Many protobuf messages at once: the wire bytes of K messages of one layout built column by
column with numpy (:class:`Rows`), for the high-rate topics of :mod:`replay.record.recorder`
(``/tf``, ``/vehicle/pose``, ``/vehicle/state``, ``/vehicle/fix``).

A message is a sequence of *parts*, each a (K, w) byte matrix with, per row, how many of its w
bytes belong to the message (a varint is 1..10 bytes, a field left out is 0): the parts are
placed side by side and the bytes that belong are taken in row order (one boolean index), which
gives the K messages one after the other.  Fields are written as protobuf's ``SerializeToString``
writes them (field-number order is the caller's, as the schemas' numbering; proto3 scalars left out
when their bits are zero, submessages always present): the tests compare the bytes.  Nested
messages are :class:`Rows` themselves (:meth:`Rows.message`); their length prefix is a varint of
their per-row length.

:meth:`Rows.records` frames the K messages as MCAP message records (opcode, length, channel,
sequence 0, log and publish time) so that a writer appends a whole batch with one copy
(:meth:`replay.record.writer.McapSink.add_records`).
"""

from __future__ import annotations

import functools
import struct

import numpy as np
import numpy.typing as npt

U8 = npt.NDArray[np.uint8]
I64 = npt.NDArray[np.int64]

_WIRE_VARINT, _WIRE_I64, _WIRE_LEN, _WIRE_I32 = 0, 1, 2, 5
_MCAP_MESSAGE = 0x05
_MESSAGE_HEAD = 22  # channel (2), sequence (4), log time (8), publish time (8)


@functools.cache
def tag(field: int, wire: int) -> bytes:
    """The key of a field (its number and wire type) as a varint."""
    return varint(field << 3 | wire)


def varint(n: int) -> bytes:
    out = bytearray()
    while n > 0x7F:
        out.append(n & 0x7F | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def varints(values: npt.ArrayLike, width: int = 10) -> tuple[U8, I64]:
    """Each value (K,) (unsigned, or int64 >= 0) as a varint: the bytes (K, width) and how many
    of them each takes (1..width)."""
    v = np.asarray(values).astype(np.uint64).reshape(-1)
    shifts = np.arange(width, dtype=np.uint64) * np.uint64(7)
    groups = v[:, None] >> shifts
    n = np.maximum(1, np.count_nonzero(groups, axis=1)).astype(np.int64)
    out = (groups & np.uint64(0x7F)).astype(np.uint8)
    out[np.arange(width) < (n - 1)[:, None]] |= 0x80
    return out, n


class Rows:
    """K messages of one layout being built (module docstring).  Each method appends a field to
    every row; :meth:`messages` gives the messages' bytes and lengths."""

    def __init__(self, k: int) -> None:
        self.k = k
        self.parts: list[tuple[U8, I64 | None]] = []  # (bytes (K, w), length per row or None: all)

    def raw(self, data: bytes | U8, lengths: I64 | None = None) -> Rows:
        """Bytes as they are: the same for every row (``bytes``) or a (K, w) matrix, of which
        the first ``lengths`` bytes of each row (default all)."""
        if isinstance(data, bytes):
            if data:
                row = np.frombuffer(data, dtype=np.uint8)
                self.parts.append((np.broadcast_to(row, (self.k, len(row))), None))
        else:
            self.parts.append((data, lengths))
        return self

    def lengths(self) -> I64:
        """The length of each row's message so far."""
        total = np.zeros(self.k, dtype=np.int64)
        for data, n in self.parts:
            total += data.shape[1] if n is None else n
        return total

    def _fixed(self, field: int, wire: int, raw: U8, keep: npt.NDArray[np.bool_] | None) -> Rows:
        """A tag and fixed-size value (K, w) per row, left out where ``keep`` is false."""
        key = tag(field, wire)
        if keep is None:
            self.raw(key)
            return self.raw(raw)
        w = len(key) + raw.shape[1]
        both = np.empty((self.k, w), dtype=np.uint8)
        both[:, : len(key)] = np.frombuffer(key, dtype=np.uint8)
        both[:, len(key) :] = raw
        return self.raw(both, np.where(keep, w, 0).astype(np.int64))

    def double(
        self, field: int, values: npt.ArrayLike, keep: npt.NDArray[np.bool_] | str | None = "bits"
    ) -> Rows:
        """A double field: ``keep="bits"`` leaves it out where its bits are zero (proto3: +0.0
        only), a boolean array where false (proto2 optional: absent), None writes it always."""
        v = np.ascontiguousarray(values, dtype="<f8").reshape(self.k)
        raw = v.view(np.uint8).reshape(self.k, 8)
        mask = v.view(np.uint64) != 0 if isinstance(keep, str) else keep
        return self._fixed(field, _WIRE_I64, raw, mask)

    def float32(
        self, field: int, values: npt.ArrayLike, keep: npt.NDArray[np.bool_] | None = None
    ) -> Rows:
        """A float field (the values rounded to float32), written where ``keep`` (default: always)."""
        v = np.ascontiguousarray(np.asarray(values, dtype=np.float64).reshape(self.k), dtype="<f4")
        return self._fixed(field, _WIRE_I32, v.view(np.uint8).reshape(self.k, 4), keep)

    def doubles(self, first: int, values: npt.ArrayLike, keep: str | None = "bits") -> Rows:
        """Double fields ``first``, ``first + 1``... from the columns of ``values`` (K, n)."""
        v = np.asarray(values, dtype=np.float64).reshape(self.k, -1)
        for j in range(v.shape[1]):
            self.double(first + j, v[:, j], keep)
        return self

    def uint(self, field: int, values: npt.ArrayLike, *, omit_zero: bool = True) -> Rows:
        """A varint field of values >= 0 (left out where zero, as proto3 does, by default)."""
        data, n = varints(values)
        key = tag(field, _WIRE_VARINT)
        both = np.empty((self.k, len(key) + data.shape[1]), dtype=np.uint8)
        both[:, : len(key)] = np.frombuffer(key, dtype=np.uint8)
        both[:, len(key) :] = data
        size = n + len(key)
        if omit_zero:
            size = np.where(np.asarray(values).reshape(-1) == 0, 0, size)
        return self.raw(both, size.astype(np.int64))

    def text(self, field: int, value: str) -> Rows:
        """A string field, the same in every row (left out when empty, as proto3 does)."""
        data = value.encode()
        if data:
            self.raw(tag(field, _WIRE_LEN) + varint(len(data)) + data)
        return self

    def message(self, field: int, inner: Rows) -> Rows:
        """An embedded message (always written, as a set submessage is), ``inner`` its fields."""
        self.raw(tag(field, _WIRE_LEN))
        size, n = varints(inner.lengths(), 3)
        self.raw(size, n)
        self.parts.extend(inner.parts)
        return self

    def timestamp(self, field: int, ns: I64) -> Rows:
        """A ``google.protobuf.Timestamp`` field from integer nanoseconds (>= 0)."""
        sec, nsec = np.divmod(np.asarray(ns, dtype=np.int64), 1_000_000_000)
        return self.message(field, Rows(self.k).uint(1, sec).uint(2, nsec))

    def messages(self) -> tuple[bytes, I64]:
        """The K messages one after the other, and the length of each."""
        return _compact(self.parts, self.k), self.lengths()

    def records(self, channel: int, log_ns: I64) -> tuple[bytes, I64, I64]:
        """The K messages framed as MCAP message records of ``channel`` at ``log_ns`` (also the
        publish time), one after the other -- grouped by layout (rows whose varints are as long
        are copied together), not in row order -- each record's length and log time in the
        order written."""
        body = self.lengths()
        t = np.ascontiguousarray(log_ns, dtype="<u8").view(np.uint8).reshape(self.k, 8)
        length = np.ascontiguousarray(body + _MESSAGE_HEAD, dtype="<u8")
        head: list[tuple[U8, I64 | None]] = [
            (np.broadcast_to(np.uint8(_MCAP_MESSAGE), (self.k, 1)), None),
            (length.view(np.uint8).reshape(self.k, 8), None),
            (np.broadcast_to(_channel_bytes(channel), (self.k, 6)), None),
            (t, None),
            (t, None),
        ]
        data, order = _compact_grouped(head + self.parts, self.k)
        return data, (body + 9 + _MESSAGE_HEAD)[order], np.asarray(log_ns)[order]


@functools.cache
def _channel_bytes(channel: int) -> U8:
    return np.frombuffer(struct.pack("<HI", channel, 0), dtype=np.uint8)


def _compact(parts: list[tuple[U8, I64 | None]], k: int) -> bytes:
    if not parts or not k:
        return b""
    wide = np.concatenate([data for data, _ in parts], axis=1)
    if all(n is None for _, n in parts):
        return wide.tobytes()
    masks = [
        np.broadcast_to(True, data.shape) if n is None else np.arange(data.shape[1]) < n[:, None]
        for data, n in parts
    ]
    return bytes(wide[np.concatenate(masks, axis=1)].tobytes())


def _compact_grouped(parts: list[tuple[U8, I64 | None]], k: int) -> tuple[bytes, I64]:
    """The rows' bytes (as :func:`_compact`) written group by group of rows with the same
    lengths in every part (a column selection each, cheaper than one boolean mask over all),
    and the order of the rows written."""
    wide = np.concatenate([data for data, _ in parts], axis=1)
    varying = [(j, n) for j, (_, n) in enumerate(parts) if n is not None]
    if not varying:
        return wide.tobytes(), np.arange(k)
    sizes = np.stack([n for _, n in varying], axis=1)  # (K, V), each 0..10 (< 16)
    key = sizes @ (16 ** np.arange(sizes.shape[1], dtype=np.int64))
    _, first, group = np.unique(key, return_index=True, return_inverse=True)
    patterns = sizes[first]
    group = group.reshape(-1)
    starts = np.cumsum([0] + [data.shape[1] for data, _ in parts])
    pieces, orders = [], []
    for g, pattern in enumerate(patterns):
        cols: list[npt.NDArray[np.int64]] = []
        v = 0
        for j, (_, n) in enumerate(parts):
            if n is None:
                cols.append(np.arange(starts[j], starts[j + 1]))
            else:
                cols.append(np.arange(starts[j], starts[j] + int(pattern[v])))
                v += 1
        rows = np.flatnonzero(group == g) if len(patterns) > 1 else np.arange(k)
        pieces.append(wide[rows][:, np.concatenate(cols)].tobytes())
        orders.append(rows)
    return b"".join(pieces), np.concatenate(orders).astype(np.int64)


__all__ = ["Rows", "tag", "varint", "varints"]
