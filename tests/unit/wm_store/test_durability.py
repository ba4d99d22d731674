"""Durability: group commit, per-record fsync, fail-stop, snapshots with compaction."""

from __future__ import annotations

import errno
import hashlib
import io
import itertools
import os
import shutil
import threading
from collections.abc import AsyncIterator, Callable, Sequence
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import anyio
import pytest

from wm_store import StorageError
from wm_store.durability import Durability, DurabilityMode, Recovered, WriteAheadLog

pytestmark = pytest.mark.anyio


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


def payload(seq: int) -> bytes:
    return hashlib.sha256(str(seq).encode()).digest() * (1 + seq % 4)


@asynccontextmanager
async def running(path: Path, **kw: Any) -> AsyncIterator[tuple[Durability, Recovered]]:
    """An open Durability with its writer running; cancelled and closed on exit."""
    durability, recovered = await Durability.open(path, **kw)
    try:
        async with anyio.create_task_group() as tg:
            await tg.start(durability.run)
            yield durability, recovered
            tg.cancel_scope.cancel()
    finally:
        await durability.aclose()


async def reopen(path: Path) -> Recovered:
    durability, recovered = await Durability.open(path)
    await durability.aclose()
    return recovered


def recover_copy(data_dir: Path, into: Path) -> list[int]:
    """Recover a copy of the log with a fresh instance (leaves the live files alone)."""
    shutil.copytree(data_dir / "wal", into)
    wal = WriteAheadLog(into)
    records, _ = wal.recover()
    wal.close()
    return [seq for seq, _ in records]


async def commit_concurrently(durability: Durability, count: int, start: int = 1) -> None:
    seqs = itertools.count(start)

    async def one() -> None:
        seq = next(seqs)  # taken and queued without a checkpoint in between: seq order
        await durability.commit(seq, payload(seq))

    async with anyio.create_task_group() as tg:
        for _ in range(count):
            tg.start_soon(one)


async def test_group_commit_releases_callers_only_after_their_fsync(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    watermark = {"written": 0, "durable": 0}
    real_append, real_fsync = WriteAheadLog.append, os.fsync

    def append(self: WriteAheadLog, records: Sequence[tuple[int, bytes]]) -> None:
        real_append(self, records)
        watermark["written"] = records[-1][0]

    def fsync(fd: int) -> None:
        written = watermark["written"]
        real_fsync(fd)
        watermark["durable"] = max(watermark["durable"], written)

    monkeypatch.setattr(WriteAheadLog, "append", append)
    monkeypatch.setattr(os, "fsync", fsync)
    seqs = itertools.count(1)
    checked: list[int] = []

    async with running(tmp_path, mode="group") as (durability, recovered):
        assert recovered.snapshot is None
        assert recovered.records == []

        async def committer() -> None:
            seq = next(seqs)
            await durability.commit(seq, payload(seq))
            assert watermark["durable"] >= seq
            if seq % 40 == 0:  # a fresh instance on a copy of the files sees the record
                assert seq in recover_copy(tmp_path, tmp_path / f"copy{seq}")
                checked.append(seq)

        async with anyio.create_task_group() as tg:
            for _ in range(200):
                tg.start_soon(committer)
        stats = durability.statistics()
    assert checked == [40, 80, 120, 160, 200]
    assert stats.commits == 200
    assert stats.mode == "group"
    assert stats.batches < stats.commits
    assert stats.max_batch_seen > 1
    assert stats.fsyncs == stats.batches
    recovered = await reopen(tmp_path)
    assert recovered.records == [(s, payload(s)) for s in range(1, 201)]


async def test_max_batch_bounds_a_group(tmp_path: Path) -> None:
    async with running(tmp_path, mode="group", max_batch=8) as (durability, _):
        await commit_concurrently(durability, 100)
        stats = durability.statistics()
    assert stats.commits == 100
    assert stats.max_batch_seen <= 8
    assert stats.batches >= 13


async def test_a_group_holds_at_most_8_mib_of_payload(tmp_path: Path) -> None:
    big = bytes(3 << 20)
    async with running(tmp_path) as (durability, _):
        async with anyio.create_task_group() as tg:
            for seq in range(1, 5):
                tg.start_soon(durability.commit, seq, big)
        stats = durability.statistics()
    assert stats.commits == 4
    assert stats.max_batch_seen == 2
    assert [s for s, _ in (await reopen(tmp_path)).records] == [1, 2, 3, 4]


async def test_fsync_mode_syncs_every_record_on_its_own(tmp_path: Path) -> None:
    async with running(tmp_path, mode="fsync") as (durability, _):
        await commit_concurrently(durability, 50)
        stats = durability.statistics()
    assert (stats.commits, stats.batches, stats.fsyncs, stats.max_batch_seen) == (50, 50, 50, 1)
    assert [s for s, _ in (await reopen(tmp_path)).records] == list(range(1, 51))


async def test_none_mode_writes_without_fsync(tmp_path: Path) -> None:
    async with running(tmp_path, mode="none") as (durability, _):
        await commit_concurrently(durability, 30)
        stats = durability.statistics()
    assert (stats.commits, stats.fsyncs) == (30, 0)
    assert [s for s, _ in (await reopen(tmp_path)).records] == list(range(1, 31))


@pytest.mark.parametrize("mode", ["group", "fsync"])
@pytest.mark.parametrize("failing", ["fsync", "write"])
async def test_io_failure_fails_waiting_and_later_commits(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, mode: DurabilityMode, failing: str
) -> None:
    def fail(*args: object) -> None:
        raise OSError(errno.EIO, "Input/output error")

    async with running(tmp_path, mode=mode) as (durability, _):
        await durability.commit(1, b"fine")
        errors: list[StorageError] = []

        async def committer(seq: int) -> None:
            try:
                await durability.commit(seq, b"doomed")
            except StorageError as exc:
                errors.append(exc)

        with monkeypatch.context() as m:
            m.setattr(os, failing, fail)
            async with anyio.create_task_group() as tg:
                for seq in range(2, 22):
                    tg.start_soon(committer, seq)
        assert len(errors) == 20
        assert all("fail-stop" in str(e) and "Input/output" in str(e) for e in errors)
        with pytest.raises(StorageError, match="fail-stop"):  # the disk is fine again: no retry
            await durability.commit(100, b"later")
        with pytest.raises(StorageError):
            await durability.write_snapshot(1, b"state")
    assert (await reopen(tmp_path)).records[0] == (1, b"fine")


async def test_commit_rejects_bad_input_without_poisoning_the_log(tmp_path: Path) -> None:
    async with running(tmp_path, max_record_bytes=100) as (durability, _):
        await durability.commit(5, b"five")
        for seq in (5, 3):
            with pytest.raises(StorageError, match="seqs must increase"):
                await durability.commit(seq, b"x")
        with pytest.raises(StorageError, match="over the limit"):
            await durability.commit(6, bytes(101))
        await durability.commit(6, bytes(100))
    assert [s for s, _ in (await reopen(tmp_path)).records] == [5, 6]


async def test_snapshot_compaction_and_recovery(tmp_path: Path) -> None:
    wal_dir = tmp_path / "wal"
    async with running(tmp_path, segment_bytes=1024) as (durability, _):
        await commit_concurrently(durability, 200)
        before = len(list(wal_dir.iterdir()))
        await durability.write_snapshot(150, b"state@150")
        assert len(list(wal_dir.iterdir())) < before
        await commit_concurrently(durability, 50, start=201)
    recovered = await reopen(tmp_path)
    assert recovered.snapshot == (150, b"state@150")
    assert recovered.records == [(s, payload(s)) for s in range(151, 251)]

    async with running(tmp_path, segment_bytes=1024) as (durability, recovered):
        await durability.commit(251, payload(251))  # continues after the recovered tail
        with pytest.raises(StorageError, match="seqs must increase"):
            await durability.commit(251, b"again")
    assert (await reopen(tmp_path)).records[-1] == (251, payload(251))


async def test_corrupt_newest_snapshot_falls_back_without_losing_records(tmp_path: Path) -> None:
    async with running(tmp_path, segment_bytes=512) as (durability, _):
        await commit_concurrently(durability, 100)
        await durability.write_snapshot(100, b"state@100")
        await commit_concurrently(durability, 100, start=101)
        await durability.write_snapshot(200, b"state@200")
        await commit_concurrently(durability, 20, start=201)
    newest = tmp_path / "snapshots" / f"snap-{200:020d}.snap"
    newest.write_bytes(newest.read_bytes()[:-1])
    recovered = await reopen(tmp_path)
    assert recovered.snapshot == (100, b"state@100")
    assert recovered.records == [(s, payload(s)) for s in range(101, 221)]
    assert recovered.snapshot_error is not None
    assert newest.name in recovered.snapshot_error


async def test_open_refuses_when_no_snapshot_verifies(tmp_path: Path) -> None:
    async with running(tmp_path) as (durability, _):
        await durability.commit(1, b"one")
        await durability.write_snapshot(1, b"state@1")
    snapshot = tmp_path / "snapshots" / f"snap-{1:020d}.snap"
    snapshot.write_bytes(b"garbage")
    with pytest.raises(StorageError, match="no snapshot verifies"):
        await Durability.open(tmp_path)


async def test_snapshot_waits_until_its_seq_is_durable(tmp_path: Path) -> None:
    async with running(tmp_path) as (durability, _):
        with pytest.raises(StorageError, match="only 0 is durable"):
            await durability.write_snapshot(1, b"never committed")
        async with anyio.create_task_group() as tg:
            tg.start_soon(durability.commit, 1, b"one")
            tg.start_soon(durability.write_snapshot, 1, b"state@1")  # queued before 1 is durable
    assert (await reopen(tmp_path)).snapshot == (1, b"state@1")


async def test_stopped_writer_refuses_commits_but_allows_a_final_snapshot(tmp_path: Path) -> None:
    durability, _ = await Durability.open(tmp_path)
    async with anyio.create_task_group() as tg:
        await tg.start(durability.run)
        await durability.commit(1, b"one")
        tg.cancel_scope.cancel()
    with pytest.raises(StorageError, match="writer stopped"):
        await durability.commit(2, b"two")
    await durability.write_snapshot(1, b"state@1")
    await durability.aclose()
    await durability.aclose()  # idempotent
    with pytest.raises(StorageError, match="closed"):
        await durability.commit(2, b"two")


async def test_event_loop_never_touches_the_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    loop_thread = threading.get_ident()
    on_loop: list[str] = []

    def spy(module: Any, name: str) -> None:
        real: Callable[..., Any] = getattr(module, name)

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            if threading.get_ident() == loop_thread:
                on_loop.append(name)
            return real(*args, **kwargs)

        monkeypatch.setattr(module, name, wrapper)

    for name in ("open", "write", "fsync", "replace", "unlink", "listdir", "mkdir", "truncate"):
        spy(os, name)
    spy(io, "open")
    async with running(tmp_path, segment_bytes=512) as (durability, _):
        await commit_concurrently(durability, 50)
        await durability.write_snapshot(50, b"state@50")
        await commit_concurrently(durability, 50, start=51)
    await reopen(tmp_path)
    assert on_loop == []
    os.listdir(tmp_path)  # the detector itself works
    assert on_loop == ["listdir"]
