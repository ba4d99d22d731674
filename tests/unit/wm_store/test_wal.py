"""The write-ahead log on its own: format, rotation, torn/corrupt tails, compaction."""

from __future__ import annotations

import hashlib
import os
import struct
import tempfile
import zlib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wm_store import CorruptLogError, StorageError
from wm_store.durability import RecoveryReport, WriteAheadLog


def payload(seq: int) -> bytes:
    """Deterministic, variable length (0..128 bytes)."""
    return hashlib.sha256(str(seq).encode()).digest() * (seq % 5)


def encode(seq: int, data: bytes) -> bytes:
    """The documented record format, written independently of the implementation."""
    crc = zlib.crc32(struct.pack("<Q", seq) + data)
    return struct.pack("<IIQ", len(data), crc, seq) + data


def opened(
    path: Path, after_seq: int = 0, **kw: int
) -> tuple[WriteAheadLog, list[tuple[int, bytes]], RecoveryReport]:
    wal = WriteAheadLog(path, **kw)
    records, report = wal.recover(after_seq)
    return wal, records, report


def write(path: Path, seqs: range, **kw: int) -> None:
    wal, _, _ = opened(path, **kw)
    wal.append([(s, payload(s)) for s in seqs])
    wal.sync()
    wal.close()


def recover(path: Path, after_seq: int = 0, **kw: int) -> tuple[list[int], RecoveryReport]:
    wal, records, report = opened(path, after_seq, **kw)
    wal.close()
    assert all(data == payload(seq) for seq, data in records)
    return [seq for seq, _ in records], report


def segments(path: Path) -> list[Path]:
    return sorted(path.glob("wal-*.log"))


def test_round_trip_and_reopen_continues(tmp_path: Path) -> None:
    write(tmp_path, range(1, 51))
    write(tmp_path, range(51, 61))
    seqs, report = recover(tmp_path)
    assert seqs == list(range(1, 61))
    assert report == RecoveryReport(60, 1, 60, 0, False, "clean: 1 segment(s)")


def test_bytes_on_disk_follow_the_documented_format(tmp_path: Path) -> None:
    write(tmp_path, range(1, 4))
    (segment,) = segments(tmp_path)
    assert segment.name == f"wal-{1:020d}.log"
    assert segment.read_bytes() == b"".join(encode(s, payload(s)) for s in range(1, 4))


def test_rotation_names_each_segment_after_its_first_seq(tmp_path: Path) -> None:
    wal, _, _ = opened(tmp_path, segment_bytes=300)
    for start in range(1, 101, 7):  # batches that straddle segment boundaries
        wal.append([(s, payload(s)) for s in range(start, min(start + 7, 101))])
    wal.sync()
    assert wal.statistics().segments == len(segments(tmp_path)) > 5
    wal.close()
    for segment in segments(tmp_path):
        data = segment.read_bytes()
        assert len(data) <= 300
        assert int(segment.name[4:24]) == struct.unpack_from("<IIQ", data)[2]
    assert recover(tmp_path, segment_bytes=300)[0] == list(range(1, 101))


def test_torn_tail_is_cut_at_every_byte_offset_of_the_last_record(tmp_path: Path) -> None:
    source = tmp_path / "source"
    write(source, range(1, 5))
    good = segments(source)[0].read_bytes()
    full = good + encode(5, b"x" * 100)
    for cut in range(len(good), len(full)):
        d = tmp_path / f"cut{cut}"
        d.mkdir()
        (d / f"wal-{1:020d}.log").write_bytes(full[:cut])
        seqs, report = recover(d)
        assert seqs == [1, 2, 3, 4]
        assert (report.torn_bytes, report.corrupt, report.last_seq) == (cut - len(good), False, 4)
        assert segments(d)[0].stat().st_size == len(good)
        write(d, range(5, 7))  # the log is usable again
        assert recover(d)[0] == [1, 2, 3, 4, 5, 6]


def test_torn_first_record_of_a_new_segment(tmp_path: Path) -> None:
    write(tmp_path, range(1, 3))
    torn = tmp_path / f"wal-{9:020d}.log"
    torn.write_bytes(encode(9, b"abc")[:7])
    seqs, report = recover(tmp_path)
    assert (seqs, report.torn_bytes, report.segments) == ([1, 2], 7, 2)
    assert not torn.exists()  # an empty segment named above the next seq is dropped
    write(tmp_path, range(3, 5))
    assert recover(tmp_path)[0] == [1, 2, 3, 4]


def test_bad_crc_in_the_last_record_is_cut(tmp_path: Path) -> None:
    write(tmp_path, range(1, 6))
    segment = segments(tmp_path)[0]
    data = bytearray(segment.read_bytes())
    data[-1] ^= 0xFF
    segment.write_bytes(bytes(data))
    seqs, report = recover(tmp_path)
    assert seqs == [1, 2, 3, 4]
    assert report.torn_bytes == len(encode(5, payload(5)))
    assert not report.corrupt
    assert "CRC mismatch" in report.detail
    assert f"{segment.name}:" in report.detail


def test_zero_filled_tail_is_a_torn_write(tmp_path: Path) -> None:
    write(tmp_path, range(1, 4))
    with segments(tmp_path)[0].open("ab") as f:
        f.write(bytes(4096))
    seqs, report = recover(tmp_path)
    assert (seqs, report.torn_bytes, report.corrupt) == ([1, 2, 3], 4096, False)


def test_bad_record_followed_by_data_in_last_segment_is_cut_loudly(tmp_path: Path) -> None:
    write(tmp_path, range(1, 11))
    segment = segments(tmp_path)[0]
    data = bytearray(segment.read_bytes())
    offset = sum(len(encode(s, payload(s))) for s in range(1, 4))
    data[offset + 8] ^= 0x01  # seq field of record 4
    segment.write_bytes(bytes(data))
    seqs, report = recover(tmp_path)
    assert seqs == [1, 2, 3]
    assert report.corrupt
    assert report.torn_bytes == len(data) - offset
    assert f"{segment.name}:{offset}" in report.detail
    kept = tmp_path / f"{segment.name}.cut-{offset}"
    assert kept.read_bytes() == bytes(data[offset:])


def test_bad_record_followed_by_a_later_segment_raises(tmp_path: Path) -> None:
    write(tmp_path, range(1, 41), segment_bytes=400)
    first = segments(tmp_path)[0]
    data = bytearray(first.read_bytes())
    data[40] ^= 0x01
    first.write_bytes(bytes(data))
    with pytest.raises(CorruptLogError, match=rf"{first.name}:\d+: CRC mismatch"):
        opened(tmp_path, segment_bytes=400)
    assert first.read_bytes() == bytes(data)  # nothing cut


def test_appending_a_non_increasing_seq_is_rejected_before_writing(tmp_path: Path) -> None:
    wal, _, _ = opened(tmp_path)
    with pytest.raises(StorageError, match="strictly increase"):
        wal.append([(1, b"a"), (1, b"b")])
    wal.append([(5, b"e")])
    for bad in (5, 3, 0):
        with pytest.raises(StorageError, match="strictly increase"):
            wal.append([(6, b"f"), (bad, b"x")])
    wal.sync()
    wal.close()
    assert opened(tmp_path)[1] == [(5, b"e")]


def test_non_monotonic_seqs_on_disk_are_corruption(tmp_path: Path) -> None:
    (tmp_path / f"wal-{1:020d}.log").write_bytes(encode(2, b"b") + encode(1, b"a"))
    with pytest.raises(CorruptLogError, match="breaks the order"):
        opened(tmp_path)


def test_oversized_record_is_rejected(tmp_path: Path) -> None:
    wal, _, _ = opened(tmp_path, max_record_bytes=10)
    with pytest.raises(StorageError, match="over the limit of 10"):
        wal.append([(1, b"0123456789"), (2, b"0123456789A")])
    wal.append([(1, b"0123456789")])
    wal.sync()
    wal.close()
    assert opened(tmp_path)[1] == [(1, b"0123456789")]


def test_truncate_through_deletes_only_whole_old_segments(tmp_path: Path) -> None:
    wal, _, _ = opened(tmp_path, segment_bytes=400)
    wal.append([(s, payload(s)) for s in range(1, 101)])
    wal.sync()
    before = len(segments(tmp_path))
    deleted = wal.truncate_through(50)
    assert deleted > 0
    assert len(segments(tmp_path)) == before - deleted
    assert wal.truncate_through(50) == 0
    wal.close()
    seqs, _ = recover(tmp_path, segment_bytes=400)
    assert seqs == list(range(seqs[0], 101))
    assert 40 < seqs[0] <= 51
    wal, _, _ = opened(tmp_path, segment_bytes=400)
    left = len(segments(tmp_path))
    assert wal.truncate_through(10**9) == left - 1  # never the active segment
    assert wal.statistics().segments == len(segments(tmp_path)) == 1
    wal.close()


def test_recover_after_seq_skips_older_records(tmp_path: Path) -> None:
    write(tmp_path, range(1, 51), segment_bytes=500)
    seqs, report = recover(tmp_path, after_seq=30)
    assert seqs == list(range(31, 51))
    assert (report.records, report.last_seq) == (50, 50)


def test_misuse_is_a_storage_error(tmp_path: Path) -> None:
    wal = WriteAheadLog(tmp_path)
    with pytest.raises(StorageError, match="recover"):
        wal.append([(1, b"")])
    wal.recover()
    with pytest.raises(StorageError, match="exactly once"):
        wal.recover()
    wal.close()
    with pytest.raises(StorageError, match="closed"):
        wal.sync()


def test_fsync_failure_makes_the_log_refuse_writes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    wal, _, _ = opened(tmp_path)
    wal.append([(1, b"a")])

    def failing_fsync(fd: int) -> None:
        raise OSError(5, "Input/output error")

    with monkeypatch.context() as m:
        m.setattr(os, "fsync", failing_fsync)
        with pytest.raises(StorageError, match="fsync"):
            wal.sync()
    with pytest.raises(StorageError, match="failed earlier"):
        wal.sync()  # no retry: the kernel may have dropped the pages
    with pytest.raises(StorageError, match="failed earlier"):
        wal.append([(2, b"b")])
    wal.close()


batches = st.lists(
    st.tuples(st.lists(st.binary(max_size=300), min_size=1, max_size=20), st.booleans()),
    max_size=12,
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(batches=batches, segment_bytes=st.sampled_from([64, 700, 1 << 20]), gap=st.integers(1, 3))
def test_random_batches_survive_close_and_recover(
    batches: list[tuple[list[bytes], bool]], segment_bytes: int, gap: int
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp)
        expected: list[tuple[int, bytes]] = []
        wal, _, _ = opened(path, segment_bytes=segment_bytes)
        for payloads, reopen in batches:
            start = expected[-1][0] if expected else 0
            batch = [(start + gap * (i + 1), p) for i, p in enumerate(payloads)]
            wal.append(batch)
            wal.sync()
            expected += batch
            if reopen:
                wal.close()
                wal, records, report = opened(path, segment_bytes=segment_bytes)
                assert records == expected
                assert report.torn_bytes == 0
        wal.close()
        wal, records, report = opened(path, segment_bytes=segment_bytes)
        wal.close()
        assert records == expected
        assert report.last_seq == (expected[-1][0] if expected else 0)
