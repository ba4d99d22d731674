"""Child process of ``tests/integration/test_wal_sigkill.py``.

Runs :class:`~wm_store.durability.Durability` in group mode, commits records as fast as it can
from several concurrent tasks, snapshots every ``SNAPSHOT_EVERY`` records, and prints each
acknowledged seq on its own line (flushed) right after ``commit`` returns. The parent kills it
with SIGKILL at some point. Usage: ``python wal_sigkill_child.py DATA_DIR``.
"""

from __future__ import annotations

import hashlib
import itertools
import sys
from pathlib import Path

import anyio

from wm_store.durability import Durability

WORKERS = 16
SEGMENT_BYTES = 32 << 10
SNAPSHOT_EVERY = 1000


def payload(seq: int) -> bytes:
    """The record for ``seq``: deterministic, 32..320 bytes."""
    return hashlib.sha256(seq.to_bytes(8, "little")).digest() * (1 + seq % 10)


def snapshot_payload(seq: int) -> bytes:
    """The "state" after ``seq``: a digest of every record up to it, in order."""
    digest = hashlib.sha256()
    for s in range(1, seq + 1):
        digest.update(payload(s))
    return digest.digest()


async def main(data_dir: Path) -> None:
    durability, recovered = await Durability.open(
        data_dir, mode="group", segment_bytes=SEGMENT_BYTES
    )
    if recovered.records or recovered.snapshot:
        raise SystemExit("the child expects an empty data directory")
    seqs = itertools.count(1)
    send, receive = anyio.create_memory_object_stream[int](100)

    async def committer() -> None:
        while True:
            seq = next(seqs)
            await durability.commit(seq, payload(seq))
            sys.stdout.write(f"{seq}\n")
            sys.stdout.flush()
            if seq % SNAPSHOT_EVERY == 0:
                send.send_nowait(seq)

    async def snapshotter() -> None:
        async for seq in receive:
            data = await anyio.to_thread.run_sync(snapshot_payload, seq)
            await durability.write_snapshot(seq, data)

    async with anyio.create_task_group() as tg:
        await tg.start(durability.run)
        tg.start_soon(snapshotter)
        for _ in range(WORKERS):
            tg.start_soon(committer)


if __name__ == "__main__":
    anyio.run(main, Path(sys.argv[1]))
