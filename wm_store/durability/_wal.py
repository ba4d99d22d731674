"""Write-ahead log: an append-only sequence of ``(seq, payload)`` records in segment files.

Blocking file I/O, no async: call it from a worker thread (``anyio.to_thread.run_sync`` with a
limiter of one, as :class:`~wm_store.durability.Durability` does). An instance is not
thread-safe; use it from one thread at a time. Payloads are opaque bytes; ``seq`` is the store
revision and must strictly increase.

Record format (little-endian)::

    [u32 length][u32 crc][u64 seq][payload: length bytes]

``length`` counts the payload only; ``crc`` is ``zlib.crc32(seq bytes + payload)`` (CRC-32,
IEEE polynomial; enough to tell a torn or flipped record from a good one, not a defence against
tampering). Segments are files ``wal-<first seq, 20 digits>.log``; the name is a lower bound of
the seqs in the file. A new segment starts when the next record would push the active one past
``segment_bytes``.

Crash rules the recovery relies on: a segment is fsynced before the next one is created, so
damage in any segment but the last is real corruption (:class:`CorruptLogError`, nothing
dropped), while damage at the end of the last segment is a write the crash interrupted: it is
cut (file truncated at the last good record and fsynced) and reported in :class:`RecoveryReport`.
"""

from __future__ import annotations

import logging
import os
import re
import struct
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import msgspec

from wm_store._errors import CorruptLogError, StorageError

__all__ = [
    "DEFAULT_MAX_RECORD_BYTES",
    "DEFAULT_SEGMENT_BYTES",
    "RecoveryReport",
    "WalStats",
    "WriteAheadLog",
    "fsync_directory",
    "make_directory",
    "write_all",
]

DEFAULT_SEGMENT_BYTES = 64 << 20
DEFAULT_MAX_RECORD_BYTES = 16 << 20
_MAX_SEQ = 2**64 - 1
_HEADER = struct.Struct("<IIQ")  # payload length, crc32(seq + payload), seq
_SEQ = struct.Struct("<Q")
_NAME = re.compile(r"wal-(\d{20})\.log")
_log = logging.getLogger(__name__)


class RecoveryReport(msgspec.Struct, frozen=True):
    """What :meth:`WriteAheadLog.recover` found. ``records`` counts every valid record (also
    those at or below ``after_seq``); ``last_seq`` is the highest seq in the log (0 if empty);
    ``torn_bytes`` were cut from the tail; ``corrupt`` means the cut record was followed by more
    non-zero data (possible after a power loss, but also a sign of damage: look at ``detail``
    and the ``.cut-<offset>`` file kept next to the segment)."""

    records: int
    segments: int
    last_seq: int
    torn_bytes: int
    corrupt: bool
    detail: str


class WalStats(msgspec.Struct, frozen=True):
    segments: int
    bytes: int
    appended: int
    syncs: int


@dataclass
class _Segment:
    first_seq: int
    path: Path
    size: int
    last_seq: int  # 0 while empty


def fsync_directory(directory: Path) -> None:
    """Make creations, renames and deletions in ``directory`` durable. Blocks; raises OSError."""
    fd = os.open(directory, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def make_directory(directory: Path) -> None:
    """Create ``directory`` (and parents) if missing, durably. Blocks; raises OSError."""
    if not directory.is_dir():
        directory.mkdir(parents=True, exist_ok=True)
        fsync_directory(directory.parent)


def write_all(fd: int, data: bytes) -> None:
    """``os.write`` until every byte is written. Blocks; raises OSError."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


class WriteAheadLog:
    """Segmented write-ahead log in ``directory`` (created if missing; the constructor blocks).

    Call :meth:`recover` once, then :meth:`append` / :meth:`sync`. After any write or fsync
    error the log refuses further writes (fail-stop; see :mod:`wm_store.durability`).
    """

    def __init__(
        self,
        directory: Path,
        *,
        segment_bytes: int = DEFAULT_SEGMENT_BYTES,
        max_record_bytes: int = DEFAULT_MAX_RECORD_BYTES,
    ) -> None:
        if segment_bytes < 1 or not 0 <= max_record_bytes < 2**32:
            raise ValueError("segment_bytes must be >= 1 and max_record_bytes in [0, 2**32)")
        self.directory = directory
        self.segment_bytes = segment_bytes
        self.max_record_bytes = max_record_bytes
        make_directory(directory)
        self._segments: list[_Segment] = []
        self._fd: int | None = None  # the active (last) segment, open for appending
        self._last_seq = 0
        self._recovered = False
        self._closed = False
        self._broken: BaseException | None = None
        self._dir_dirty = False
        self._appended = 0
        self._syncs = 0

    @property
    def last_seq(self) -> int:
        """Highest seq recovered or appended (0 for an empty log)."""
        return self._last_seq

    def recover(self, after_seq: int = 0) -> tuple[list[tuple[int, bytes]], RecoveryReport]:
        """Read every segment in order; return the records with ``seq > after_seq`` and a report.

        Blocks. A torn or bad tail of the last segment is truncated on disk and reported.
        Raises :class:`CorruptLogError` (with file and offset) for a bad record in any other
        segment or for seqs that do not increase, and :class:`StorageError` for I/O errors or
        a second call.
        """
        if self._recovered or self._closed:
            raise StorageError("recover() must be called exactly once, before append()")
        try:
            return self._recover(after_seq)
        except OSError as exc:
            raise StorageError(
                f"cannot read the write-ahead log in {self.directory}: {exc}"
            ) from exc

    def _recover(self, after_seq: int) -> tuple[list[tuple[int, bytes]], RecoveryReport]:
        found = sorted(
            (int(m.group(1)), p)
            for p in self.directory.iterdir()
            if (m := _NAME.fullmatch(p.name)) is not None
        )
        records: list[tuple[int, bytes]] = []
        count = torn = 0
        corrupt = False
        detail = f"clean: {len(found)} segment(s)"
        for index, (first, path) in enumerate(found):
            last = index == len(found) - 1
            limit = _MAX_SEQ + 1 if last else found[index + 1][0]
            data = path.read_bytes()
            off = seg_last = 0
            while off < len(data):
                parsed = _parse(data, off)
                if isinstance(parsed, str):
                    break
                seq, start, end = parsed
                if not (self._last_seq < seq and first <= seq < limit):
                    raise CorruptLogError(
                        f"{path.name}:{off}: seq {seq} breaks the order (previous {self._last_seq},"
                        f" segment range [{first}, {limit})); the log is damaged: restore it"
                    )
                if seq > after_seq:
                    records.append((seq, data[start:end]))
                self._last_seq = seg_last = seq
                count += 1
                off = end
            if off < len(data):
                reason = parsed if isinstance(parsed, str) else "bad record"
                if not last:
                    raise CorruptLogError(
                        f"{path.name}:{off}: {reason}, and {len(found) - index - 1} later"
                        " segment(s) follow, so acknowledged records may be behind it; refusing"
                        " to drop them. Restore the log from a backup or inspect it by hand"
                    )
                torn = len(data) - off
                corrupt = self._is_corrupt(data, off)
                kind = "corrupt" if corrupt else "torn"
                detail = f"cut {torn} bytes of a {kind} record ({reason}) at {path.name}:{off}"
                if corrupt:
                    keep = path.with_name(f"{path.name}.cut-{off}")
                    with keep.open("wb") as f:
                        f.write(data[off:])
                        os.fsync(f.fileno())
                    detail += f"; the cut bytes are kept in {keep.name}"
                    _log.error("write-ahead log: %s", detail)
                else:
                    _log.warning("write-ahead log: %s", detail)
                with path.open("r+b") as f:
                    f.truncate(off)
            self._segments.append(_Segment(first, path, off, seg_last))
        if self._segments and self._segments[-1].size == 0:
            # Its name may be above the next seq appended (a cut record was its first): drop it.
            self._segments.pop().path.unlink()
        if self._segments:
            active = self._segments[-1]
            self._fd = os.open(active.path, os.O_WRONLY | os.O_APPEND | os.O_CLOEXEC)
            os.fsync(self._fd)  # the tail may be in the page cache only (crash without fsync)
        if found:
            fsync_directory(self.directory)
        self._recovered = True
        report = RecoveryReport(count, len(found), self._last_seq, torn, corrupt, detail)
        return records, report

    def _is_corrupt(self, data: bytes, off: int) -> bool:
        """A bad record is a torn write if it reaches the end of the file or only zeros follow."""
        tail = data[off:]
        if not tail.strip(b"\0") or len(tail) < _HEADER.size:
            return False
        length = _HEADER.unpack_from(data, off)[0]
        return not (length <= self.max_record_bytes and off + _HEADER.size + length >= len(data))

    def append(self, records: Sequence[tuple[int, bytes]]) -> None:
        """Write records to the OS (one write(2) per segment touched); not durable until
        :meth:`sync`. Blocks. Raises :class:`StorageError` (nothing written) for a seq that does
        not increase or a payload over ``max_record_bytes``, and :class:`StorageError` after an
        I/O error (the log then refuses further writes)."""
        self._check_writable()
        prev = self._last_seq
        for seq, payload in records:
            if not prev < seq <= _MAX_SEQ:
                raise StorageError(f"seq {seq} does not follow {prev}; seqs must strictly increase")
            if len(payload) > self.max_record_bytes:
                raise StorageError(
                    f"record {seq} has {len(payload)} bytes, over the limit of"
                    f" {self.max_record_bytes}; store large data outside the world model"
                )
            prev = seq
        try:
            pieces: list[bytes] = []
            pending = 0
            for seq, payload in records:
                size = _HEADER.size + len(payload)
                used = self._segments[-1].size + pending if self._fd is not None else -1
                if used < 0 or (used > 0 and used + size > self.segment_bytes):
                    self._flush(pieces, pending)
                    pieces, pending = [], 0
                    self._rotate(seq)
                crc = zlib.crc32(payload, zlib.crc32(_SEQ.pack(seq)))
                pieces += (_HEADER.pack(len(payload), crc, seq), payload)
                pending += size
                self._segments[-1].last_seq = seq
            self._flush(pieces, pending)
        except OSError as exc:
            self._broken = exc
            raise StorageError(f"writing the log in {self.directory} failed: {exc}") from exc
        self._last_seq = prev
        self._appended += len(records)

    def _flush(self, pieces: list[bytes], size: int) -> None:
        if pieces:
            assert self._fd is not None
            write_all(self._fd, b"".join(pieces))
            self._segments[-1].size += size

    def _rotate(self, first_seq: int) -> None:
        if self._fd is not None:
            os.fsync(self._fd)  # a closed segment is complete on disk (see the module docstring)
            os.close(self._fd)
            self._fd = None
        path = self.directory / f"wal-{first_seq:020d}.log"
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND | os.O_CLOEXEC
        self._fd = os.open(path, flags, 0o644)
        self._segments.append(_Segment(first_seq, path, 0, 0))
        self._dir_dirty = True

    def sync(self) -> None:
        """fsync the active segment (and the directory after a new segment was created): every
        record appended so far is durable when this returns. Blocks. Raises
        :class:`StorageError` on failure; the log then refuses further writes, because a retried
        fsync may report success for pages the kernel already dropped."""
        self._check_writable()
        try:
            if self._fd is not None:
                os.fsync(self._fd)
            if self._dir_dirty:
                fsync_directory(self.directory)
                self._dir_dirty = False
        except OSError as exc:
            self._broken = exc
            raise StorageError(f"fsync of the log in {self.directory} failed: {exc}") from exc
        self._syncs += 1

    def truncate_through(self, seq: int) -> int:
        """Compaction: delete, oldest first, whole segments whose records all have seq <= ``seq``
        (never the active one); return how many. Blocks; raises :class:`StorageError`."""
        self._check_writable()
        deleted = 0
        try:
            while len(self._segments) > 1 and self._segments[0].last_seq <= seq:
                self._segments[0].path.unlink()
                del self._segments[0]
                deleted += 1
            if deleted:
                fsync_directory(self.directory)
        except OSError as exc:
            raise StorageError(f"compacting the log in {self.directory} failed: {exc}") from exc
        return deleted

    def close(self) -> None:
        """Close the active segment without syncing (call :meth:`sync` first). Idempotent."""
        self._closed = True
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)

    def statistics(self) -> WalStats:
        return WalStats(
            segments=len(self._segments),
            bytes=sum(s.size for s in self._segments),
            appended=self._appended,
            syncs=self._syncs,
        )

    def _check_writable(self) -> None:
        if self._closed:
            raise StorageError("the write-ahead log is closed")
        if not self._recovered:
            raise StorageError("call recover() before writing to the write-ahead log")
        if self._broken is not None:
            raise StorageError(
                f"the write-ahead log failed earlier ({self._broken}) and accepts no more"
                " writes; restart to recover from disk"
            ) from self._broken


def _parse(data: bytes, off: int) -> tuple[int, int, int] | str:
    """Parse the record at ``off``: ``(seq, payload start, end)`` or why it is bad."""
    if len(data) - off < _HEADER.size:
        return f"{len(data) - off}-byte partial header"
    length, crc, seq = _HEADER.unpack_from(data, off)
    end = off + _HEADER.size + length
    if end > len(data):
        return f"{length}-byte record runs past the end of the file"
    if zlib.crc32(memoryview(data)[off + 8 : end]) != crc:
        return "CRC mismatch"
    return seq, off + _HEADER.size, end
