"""Snapshot files: the whole store state at one seq, written atomically, newest ``keep`` kept.

Blocking file I/O, no async: call it from a worker thread. Not thread-safe.

File ``snap-<seq, 20 digits>.snap``, little-endian::

    [magic b"SKMSNAP1"][u64 seq][u32 crc][u64 length][payload: length bytes]

``crc`` is ``zlib.crc32(u64 seq + u64 length + payload)``, so a damaged header is caught as
well as a damaged payload. A snapshot is written to ``<name>.tmp``, fsynced, renamed over the
final name with ``os.replace`` and the directory fsynced: a crash leaves either the old set of
snapshots or the new one, plus at most a ``.tmp`` file that :meth:`SnapshotFiles.latest`
removes.
"""

from __future__ import annotations

import logging
import os
import re
import struct
import zlib
from pathlib import Path

from wm_store._errors import StorageError
from wm_store.durability._wal import fsync_directory, make_directory, write_all

__all__ = ["SNAPSHOT_MAGIC", "SnapshotFiles"]

SNAPSHOT_MAGIC = b"SKMSNAP1"
_HEADER = struct.Struct("<8sQIQ")  # magic, seq, crc, payload length
_SEQ_LEN = struct.Struct("<QQ")
_NAME = re.compile(r"snap-(\d{20})\.snap")
_log = logging.getLogger(__name__)


class SnapshotFiles:
    """The snapshots in ``directory`` (created if missing: the constructor blocks); the newest
    ``keep`` >= 1 are kept.

    ``last_error`` says which snapshots :meth:`latest` had to skip (``None`` if none).
    """

    def __init__(self, directory: Path, *, keep: int = 2) -> None:
        if keep < 1:
            raise ValueError("keep must be >= 1")
        self.directory = directory
        self.keep = keep
        self.last_error: str | None = None
        make_directory(directory)

    def seqs(self) -> list[int]:
        """Seqs of the snapshot files present, ascending (not verified). Blocks."""
        return sorted(
            int(m.group(1))
            for p in self.directory.iterdir()
            if (m := _NAME.fullmatch(p.name)) is not None
        )

    def path_for(self, seq: int) -> Path:
        return self.directory / f"snap-{seq:020d}.snap"

    def write(self, seq: int, payload: bytes) -> Path:
        """Write the snapshot at ``seq`` atomically and durably, then delete all but the newest
        ``keep``; return its path. Blocks. Raises :class:`StorageError` if ``seq`` is older than
        the newest snapshot or on an I/O error (the previous snapshots are then untouched)."""
        if not 0 <= seq < 2**64:
            raise StorageError(f"snapshot seq {seq} is out of range")
        existing = self.seqs()
        if existing and seq < existing[-1]:
            raise StorageError(f"snapshot at {seq} is older than the newest one ({existing[-1]})")
        final = self.path_for(seq)
        tmp = final.with_name(final.name + ".tmp")
        crc = zlib.crc32(payload, zlib.crc32(_SEQ_LEN.pack(seq, len(payload))))
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o644)
            try:
                write_all(fd, _HEADER.pack(SNAPSHOT_MAGIC, seq, crc, len(payload)))
                write_all(fd, payload)
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, final)
            fsync_directory(self.directory)
            self._prune()
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise StorageError(f"writing snapshot {final} failed: {exc}") from exc
        return final

    def _prune(self) -> None:
        old = self.seqs()[: -self.keep]
        for seq in old:
            self.path_for(seq).unlink(missing_ok=True)
        if old:
            fsync_directory(self.directory)

    def latest(self) -> tuple[int, bytes] | None:
        """The newest snapshot that verifies, as ``(seq, payload)``, or ``None``.

        Blocks. Removes leftover ``.tmp`` files. Snapshots that fail to verify are skipped (and
        left in place for inspection); ``last_error`` names them. Raises :class:`StorageError`
        only if the directory cannot be listed.
        """
        self.last_error = None
        problems: list[str] = []
        try:
            for p in self.directory.iterdir():
                if p.name.endswith(".snap.tmp") and _NAME.fullmatch(p.name[:-4]):
                    p.unlink(missing_ok=True)
            seqs = self.seqs()
        except OSError as exc:
            raise StorageError(f"cannot list snapshots in {self.directory}: {exc}") from exc
        found: tuple[int, bytes] | None = None
        for seq in reversed(seqs):
            path = self.path_for(seq)
            try:
                data = path.read_bytes()
            except OSError as exc:
                problems.append(f"{path.name}: unreadable ({exc})")
                continue
            problem = _verify(seq, data)
            if problem is None:
                found = seq, data[_HEADER.size :]
                break
            problems.append(f"{path.name}: {problem}")
        if problems:
            fallback = f"using snapshot {found[0]}" if found else "no snapshot verifies"
            self.last_error = f"skipped corrupt snapshot(s): {'; '.join(problems)}; {fallback}"
            _log.error("%s", self.last_error)
        return found


def _verify(seq: int, data: bytes) -> str | None:
    if len(data) < _HEADER.size:
        return f"{len(data)} bytes, shorter than the header"
    magic, stored_seq, crc, length = _HEADER.unpack_from(data)
    if magic != SNAPSHOT_MAGIC:
        return f"bad magic {magic!r}"
    if stored_seq != seq:
        return f"header says seq {stored_seq}"
    if length != len(data) - _HEADER.size:
        return f"header says {length} payload bytes, file has {len(data) - _HEADER.size}"
    if zlib.crc32(memoryview(data)[_HEADER.size :], zlib.crc32(_SEQ_LEN.pack(seq, length))) != crc:
        return "CRC mismatch"
    return None
