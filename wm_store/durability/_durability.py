"""Durable commits for the store: a write-ahead log with group commit, plus snapshots.

Layout under ``data_dir``: ``wal/`` (:class:`~wm_store.durability.WriteAheadLog`) and ``snapshots/``
(:class:`~wm_store.durability.SnapshotFiles`). Every file operation runs in a worker thread
(``anyio.to_thread.run_sync``); the event loop never blocks on the disk. WAL work goes through
one ``CapacityLimiter(1)`` so it stays in order; snapshot writing has its own limiter so a large
snapshot does not stall commits.

Group commit: :meth:`Durability.commit` queues the record and waits. The writer task
(:meth:`Durability.run`) takes everything queued (up to ``max_batch`` records and 8 MiB),
writes it with one write(2) and makes it durable with ONE fsync, then releases all those
callers. While that fsync runs, new commits queue up and form the next batch, so the batch size
grows with the load without any timer. Modes: ``"group"`` as above; ``"fsync"`` writes and
fsyncs each record on its own; ``"none"`` writes to the OS only (tests and benchmarks: survives
a process crash, not a power loss).

Snapshots: :meth:`Durability.write_snapshot` compacts the log only through the oldest snapshot
still kept, so falling back to the previous snapshot (newest one corrupt) loses nothing.

Fail-stop: if a write or an fsync fails, the waiting commits and every later one raise
:class:`StorageError`; the log is never written again by this process. Retrying is unsafe:
after a failed fsync Linux may already have dropped the dirty pages and marked them clean, so
a second fsync "succeeds" although the data never reached the disk (PostgreSQL "fsyncgate",
2018; PostgreSQL now panics instead). Restart the store; it recovers from what is on disk.
"""

from __future__ import annotations

import logging
from collections import deque
from pathlib import Path
from typing import Literal, get_args

import anyio
import anyio.abc
import anyio.lowlevel
import msgspec

from wm_store._errors import StorageError
from wm_store.durability._snapshots import SnapshotFiles
from wm_store.durability._wal import (
    DEFAULT_MAX_RECORD_BYTES,
    DEFAULT_SEGMENT_BYTES,
    RecoveryReport,
    WriteAheadLog,
)

__all__ = ["Durability", "DurabilityMode", "DurabilityStats", "Recovered"]

DurabilityMode = Literal["fsync", "group", "none"]
_BATCH_BYTES = 8 << 20
_log = logging.getLogger(__name__)


class Recovered(msgspec.Struct, frozen=True):
    """State found by :meth:`Durability.open`: the newest good snapshot, the log records after
    it (in seq order), the log's recovery report, and why a snapshot was skipped (if one was)."""

    snapshot: tuple[int, bytes] | None
    records: list[tuple[int, bytes]]
    report: RecoveryReport
    snapshot_error: str | None = None


class DurabilityStats(msgspec.Struct, frozen=True):
    """``commits`` acknowledged records; ``batches`` writes; ``fsyncs`` commit fsyncs (not the
    extra fsync when a segment is closed); ``max_batch_seen`` the largest group."""

    commits: int
    batches: int
    fsyncs: int
    max_batch_seen: int
    mode: DurabilityMode


def _check_options(mode: str, max_batch: int) -> None:
    if mode not in get_args(DurabilityMode) or max_batch < 1:
        raise ValueError(f"mode must be one of {get_args(DurabilityMode)} and max_batch >= 1")


class _Pending:
    __slots__ = ("done", "failed", "payload", "seq")

    def __init__(self, seq: int, payload: bytes) -> None:
        self.seq = seq
        self.payload = payload
        self.done = anyio.Event()
        self.failed = False


class Durability:
    """Owns the log and the snapshots of one data directory. Create with :meth:`open`, run
    :meth:`run` in the store's task group, then :meth:`commit` / :meth:`write_snapshot`."""

    def __init__(
        self,
        wal: WriteAheadLog,
        snapshots: SnapshotFiles,
        *,
        mode: DurabilityMode,
        max_batch: int,
        last_seq: int,
    ) -> None:
        """Use :meth:`open`. ``wal`` must be recovered; ``last_seq`` is the highest seq stored."""
        _check_options(mode, max_batch)
        self._wal = wal
        self._snapshots = snapshots
        self._mode: DurabilityMode = mode
        self._max_batch = 1 if mode == "fsync" else max_batch
        self._wal_io = anyio.CapacityLimiter(1)
        self._snapshot_io = anyio.CapacityLimiter(1)
        self._queue: deque[_Pending] = deque()
        self._wakeup = anyio.Event()
        self._progress = anyio.Event()
        self._last_queued = self._durable = last_seq
        self._stopped: str | None = None  # why commits are no longer accepted
        self._cause: BaseException | None = None  # the write/fsync error, if that was why
        self._running = self._closed = False
        self._commits = self._batches = self._fsyncs = self._max_batch_seen = 0

    @classmethod
    async def open(
        cls,
        data_dir: Path,
        *,
        mode: DurabilityMode = "group",
        segment_bytes: int = DEFAULT_SEGMENT_BYTES,
        max_batch: int = 512,
        max_record_bytes: int = DEFAULT_MAX_RECORD_BYTES,
        keep_snapshots: int = 2,
    ) -> tuple[Durability, Recovered]:
        """Recover ``data_dir`` (in a worker thread) and return the instance and what it holds.

        Raises :class:`~wm_store.CorruptLogError` for damage inside the log and
        :class:`StorageError` for I/O errors or when snapshot files exist but none verifies
        (the log may have been compacted past what it alone can rebuild).
        """

        _check_options(mode, max_batch)

        def recover() -> tuple[WriteAheadLog, SnapshotFiles, Recovered]:
            wal = WriteAheadLog(
                data_dir / "wal", segment_bytes=segment_bytes, max_record_bytes=max_record_bytes
            )
            snapshots = SnapshotFiles(data_dir / "snapshots", keep=keep_snapshots)
            snapshot = snapshots.latest()
            if snapshot is None and snapshots.last_error is not None:
                raise StorageError(
                    f"{snapshots.last_error}. The log may have been compacted, so the state cannot"
                    " be rebuilt safely: restore the data directory from a backup (or move the bad"
                    " snapshots away if the log is known to be complete)"
                )
            try:
                records, report = wal.recover(after_seq=snapshot[0] if snapshot else 0)
            except BaseException:
                wal.close()
                raise
            return wal, snapshots, Recovered(snapshot, records, report, snapshots.last_error)

        with anyio.CancelScope(shield=True):  # the thread runs to the end anyway; keep its files
            wal, snapshots, recovered = await anyio.to_thread.run_sync(recover)
        last_seq = max(wal.last_seq, recovered.snapshot[0] if recovered.snapshot else 0)
        self = cls(wal, snapshots, mode=mode, max_batch=max_batch, last_seq=last_seq)
        return self, recovered

    async def run(
        self, *, task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """The writer task. Returns when cancelled (a batch already handed to the worker thread
        is finished and acknowledged first; commits still queued get :class:`StorageError`),
        after :meth:`aclose`, or after a write/fsync failure (see the module docstring).
        Raises :class:`StorageError` if it runs already or ran before."""
        if self._running or self._stopped is not None:
            raise StorageError("Durability.run() is already running or has stopped")
        self._running = True
        task_status.started()
        try:
            while self._stopped is None:
                await anyio.lowlevel.checkpoint()  # a cancellation point even under full load
                if not self._queue:
                    await self._wakeup.wait()
                    self._wakeup = anyio.Event()
                    continue
                batch = self._take_batch()
                with anyio.CancelScope(shield=True):  # the outcome must reach the waiters
                    try:
                        await anyio.to_thread.run_sync(self._write, batch, limiter=self._wal_io)
                    except Exception as exc:
                        _log.error("durability: the log failed (%s); writes stop here", exc)
                        self._cause = exc
                        self._stop(f"the write-ahead log failed: {exc}", batch)
                        break
                self._durable = batch[-1].seq
                self._commits += len(batch)
                self._batches += 1
                self._max_batch_seen = max(self._max_batch_seen, len(batch))
                for item in batch:
                    item.done.set()
                self._progress.set()
                self._progress = anyio.Event()
        finally:
            self._running = False
            self._stop("the durability writer stopped", [])

    def _take_batch(self) -> list[_Pending]:
        """The oldest queued records: at most ``max_batch``, and at most ``_BATCH_BYTES`` of
        payload unless a single record is larger (bounds the memory of one write)."""
        batch = [self._queue.popleft()]
        size = len(batch[0].payload)
        while self._queue and len(batch) < self._max_batch:
            size += len(self._queue[0].payload)
            if size > _BATCH_BYTES:
                break
            batch.append(self._queue.popleft())
        return batch

    def _write(self, batch: list[_Pending]) -> None:
        """Worker thread: one append (one write(2)) and, unless mode is "none", one fsync."""
        self._wal.append([(item.seq, item.payload) for item in batch])
        if self._mode != "none":
            self._wal.sync()
            self._fsyncs += 1

    def _stop(self, reason: str, batch: list[_Pending]) -> None:
        """Accept no more commits; fail ``batch`` and everything queued; wake every waiter."""
        if self._stopped is None:
            self._stopped = reason
        for item in (*batch, *self._queue):
            item.failed = True
            item.done.set()
        self._queue.clear()
        self._progress.set()
        self._wakeup.set()

    def _error(self) -> StorageError:
        if self._cause is not None:
            return StorageError(
                f"{self._stopped}; no further commits are acknowledged (fail-stop):"
                " restart the store to recover from the log"
            )
        if self._closed:
            return StorageError("the durability layer is closed; no commits are accepted")
        return StorageError(f"{self._stopped}; no commits are accepted")

    async def commit(self, seq: int, payload: bytes) -> None:
        """Queue ``(seq, payload)`` and wait until it is durable under the mode.

        ``seq`` must exceed every seq committed before (commit order is seq order). Raises
        :class:`StorageError` if it does not, if the payload is too large (both before anything
        is queued), or if the writer failed, stopped or was closed (then the record is not
        durable). Returns only while :meth:`run` is running (it may start later). Cancelling a
        waiting commit does not withdraw the record: it may still become durable.
        """
        if self._stopped is not None:
            raise self._error() from self._cause
        if seq <= self._last_queued:
            raise StorageError(f"commit of seq {seq} after {self._last_queued}: seqs must increase")
        if len(payload) > self._wal.max_record_bytes:
            raise StorageError(
                f"record {seq} has {len(payload)} bytes, over the limit of"
                f" {self._wal.max_record_bytes}"
            )
        item = _Pending(seq, payload)
        self._queue.append(item)
        self._last_queued = seq
        self._wakeup.set()
        await item.done.wait()
        if item.failed:
            raise self._error() from self._cause

    async def write_snapshot(self, seq: int, payload: bytes) -> None:
        """Store the state at ``seq`` (waits until ``seq`` is durable), then compact the log.

        Works after :meth:`run` stopped (not after :meth:`aclose` or a failure) for any durable
        ``seq``. The log is compacted through the OLDEST snapshot kept, not through ``seq``: if
        the newest snapshot is found corrupt on restart, the previous one plus the log still
        rebuild everything. Records <= the snapshot left in the active segment are skipped by
        recovery. Raises :class:`StorageError` if ``seq`` is not (and can no longer become)
        durable, if the snapshot is older than the newest one, or on failure.
        """
        while self._durable < seq:
            if seq > self._last_queued or self._stopped is not None:
                raise StorageError(
                    f"snapshot at {seq}, but only {self._durable} is durable"
                    + (f" ({self._stopped})" if self._stopped else "")
                ) from self._cause
            await self._progress.wait()
        if self._closed or self._cause is not None:
            raise StorageError(f"cannot write a snapshot: {self._stopped}") from self._cause

        def write() -> int:
            self._snapshots.write(seq, payload)
            return self._snapshots.seqs()[0]

        oldest = await anyio.to_thread.run_sync(write, limiter=self._snapshot_io)
        await anyio.to_thread.run_sync(self._wal.truncate_through, oldest, limiter=self._wal_io)

    async def aclose(self) -> None:
        """Stop accepting commits (queued ones get :class:`StorageError`), fsync unless the log
        failed, and close the files. Waits for a batch in progress. Idempotent."""
        if self._closed:
            return
        self._stop("the durability layer is closed", [])
        self._closed = True

        def close() -> None:
            try:
                if self._cause is None:
                    self._wal.sync()
            finally:
                self._wal.close()

        with anyio.CancelScope(shield=True):
            await anyio.to_thread.run_sync(close, limiter=self._wal_io)

    def statistics(self) -> DurabilityStats:
        return DurabilityStats(
            commits=self._commits,
            batches=self._batches,
            fsyncs=self._fsyncs,
            max_batch_seen=self._max_batch_seen,
            mode=self._mode,
        )
