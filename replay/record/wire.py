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

import numba as nb
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
    of them each takes (1..width; the bytes after them are zero)."""
    v = np.ascontiguousarray(np.asarray(values).astype(np.uint64).reshape(-1))
    out = np.zeros((len(v), width), dtype=np.uint8)
    n = np.empty(len(v), dtype=np.int64)
    _varints(v, out, n)
    return out, n


@nb.njit(cache=True, nogil=True)
def _varints(v: npt.NDArray[np.uint64], out: U8, n: I64) -> None:  # pragma: no cover - jit
    width = out.shape[1]
    for i in range(v.shape[0]):
        x = v[i]
        j = 0
        while x > 0x7F and j < width - 1:
            out[i, j] = np.uint8((x & 0x7F) | 0x80)
            x >>= 7
            j += 1
        out[i, j] = np.uint8(x & 0xFF)
        n[i] = j + 1


def varints_numpy(values: npt.ArrayLike, width: int = 10) -> tuple[U8, I64]:
    """:func:`varints` with numpy (the twin the tests compare it with)."""
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
        return _pack(self.parts, self.k), self.lengths()

    def records(self, channel: int, log_ns: I64) -> tuple[bytes, I64, I64]:
        """The K messages framed as MCAP message records of ``channel`` at ``log_ns`` (also the
        publish time), one after the other in row order, each record's length and log time."""
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
        return _pack(head + self.parts, self.k), body + 9 + _MESSAGE_HEAD, np.asarray(log_ns)


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


def _pack(parts: list[tuple[U8, I64 | None]], k: int) -> bytes:
    """:func:`_compact` compiled: the parts side by side, then each row's bytes that belong
    (parts written whole next to each other are copied as one)."""
    if not parts or not k:
        return b""
    wide = np.concatenate([data for data, _ in parts], axis=1)
    starts: list[int] = []
    widths: list[int | None] = []  # a whole part's width (runs of them merged), None: varying
    varying: list[I64] = []
    at = 0
    for data, n in parts:
        w = data.shape[1]
        if n is None and widths and widths[-1] is not None:
            widths[-1] += w
        else:
            starts.append(at)
            widths.append(w if n is None else None)
            if n is not None:
                varying.append(n)
        at += w
    sizes = np.empty((k, len(widths)), dtype=np.int64)
    given = iter(varying)
    for j, whole in enumerate(widths):
        sizes[:, j] = next(given) if whole is None else whole
    out = np.empty(int(sizes.sum()), dtype=np.uint8)
    _pack_rows(wide, np.array(starts, dtype=np.int64), sizes, out)
    return out.tobytes()


@nb.njit(cache=True, nogil=True)
def _pack_rows(wide: U8, starts: I64, sizes: I64, out: U8) -> None:  # pragma: no cover - jit
    pos = 0
    for r in range(wide.shape[0]):
        for j in range(starts.shape[0]):
            s = starts[j]
            for b in range(sizes[r, j]):
                out[pos + b] = wide[r, s + b]
            pos += sizes[r, j]


__all__ = ["Rows", "tag", "varint", "varints", "varints_numpy"]
