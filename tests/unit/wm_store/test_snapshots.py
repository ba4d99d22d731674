"""Snapshot files: atomic write, verification and fallback, pruning, leftovers."""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import pytest

from wm_store import StorageError
from wm_store.durability import SnapshotFiles


def corrupt(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0x01
    path.write_bytes(bytes(data))


def test_write_then_latest_round_trip_in_the_documented_format(tmp_path: Path) -> None:
    snaps = SnapshotFiles(tmp_path)
    path = snaps.write(7, b"state at 7")
    assert path.name == f"snap-{7:020d}.snap"
    crc = zlib.crc32(struct.pack("<QQ", 7, 10) + b"state at 7")
    assert path.read_bytes() == b"SKMSNAP1" + struct.pack("<QIQ", 7, crc, 10) + b"state at 7"
    assert snaps.latest() == (7, b"state at 7")
    assert snaps.last_error is None
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary file left


def test_empty_directory_has_no_snapshot(tmp_path: Path) -> None:
    snaps = SnapshotFiles(tmp_path / "new")
    assert snaps.latest() is None
    assert snaps.last_error is None


def test_a_failed_write_leaves_the_previous_snapshot(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    snaps = SnapshotFiles(tmp_path)
    snaps.write(1, b"one")

    def failing_fsync(fd: int) -> None:
        raise OSError(28, "No space left on device")

    with monkeypatch.context() as m:
        m.setattr(os, "fsync", failing_fsync)
        with pytest.raises(StorageError, match="No space left"):
            snaps.write(2, b"two")
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"snap-{1:020d}.snap"]
    assert snaps.latest() == (1, b"one")


def test_leftover_temporary_file_is_ignored_and_removed(tmp_path: Path) -> None:
    snaps = SnapshotFiles(tmp_path)
    snaps.write(1, b"one")
    tmp = tmp_path / f"snap-{2:020d}.snap.tmp"
    tmp.write_bytes(b"SKMSNAP1 half written")  # a crash before os.replace
    assert snaps.latest() == (1, b"one")
    assert not tmp.exists()
    assert snaps.last_error is None


@pytest.mark.parametrize(
    "damage",
    ["payload", "crc", "magic", "seq", "truncated", "empty"],
)
def test_corrupt_newest_snapshot_falls_back_to_the_previous(tmp_path: Path, damage: str) -> None:
    snaps = SnapshotFiles(tmp_path)
    snaps.write(1, b"one")
    newest = snaps.write(2, b"two" * 100)
    match damage:
        case "payload":
            corrupt(newest, 100)
        case "crc":
            corrupt(newest, 16)
        case "magic":
            corrupt(newest, 0)
        case "seq":
            corrupt(newest, 8)
        case "truncated":
            newest.write_bytes(newest.read_bytes()[:-1])
        case "empty":
            newest.write_bytes(b"")
    assert snaps.latest() == (1, b"one")
    assert snaps.last_error is not None
    assert newest.name in snaps.last_error
    assert newest.exists()  # kept for inspection


def test_no_snapshot_verifies(tmp_path: Path) -> None:
    snaps = SnapshotFiles(tmp_path)
    corrupt(snaps.write(3, b"three"), 30)
    assert snaps.latest() is None
    assert snaps.last_error is not None
    assert "no snapshot verifies" in snaps.last_error


@pytest.mark.parametrize("keep", [1, 2, 3])
def test_only_the_newest_keep_snapshots_remain(tmp_path: Path, keep: int) -> None:
    snaps = SnapshotFiles(tmp_path, keep=keep)
    for seq in range(1, 7):
        snaps.write(seq * 10, f"state {seq}".encode())
    assert snaps.seqs() == [seq * 10 for seq in range(7 - keep, 7)]
    assert snaps.latest() == (60, b"state 6")


def test_older_snapshot_than_the_newest_is_refused(tmp_path: Path) -> None:
    snaps = SnapshotFiles(tmp_path)
    snaps.write(5, b"five")
    with pytest.raises(StorageError, match="older than the newest"):
        snaps.write(4, b"four")
    snaps.write(5, b"five again")  # same seq: replaced atomically
    assert snaps.latest() == (5, b"five again")


def test_keep_must_be_positive(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="keep"):
        SnapshotFiles(tmp_path, keep=0)
