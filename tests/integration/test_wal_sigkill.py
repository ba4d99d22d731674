"""A store killed with SIGKILL in the middle of a write burst restarts with every acknowledged
transaction and nothing else: a contiguous prefix 1..N with the right payloads, N >= every ack.

The child (``tests/assets/wal_sigkill_child.py``) commits from 16 tasks in group mode with small
segments and periodic snapshots, so kills land during writes, fsyncs, rotations, snapshot
writes and compactions.
"""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path
from types import ModuleType

import anyio
import pytest

from wm_store.durability import Durability, Recovered

ROOT = Path(__file__).absolute().parents[2]
CHILD = ROOT / "tests" / "assets" / "wal_sigkill_child.py"


def load_child() -> ModuleType:
    spec = importlib.util.spec_from_file_location("wal_sigkill_child", CHILD)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_and_kill(data_dir: Path, kill_after: int, stderr_path: Path) -> set[int]:
    """Start the child, read acks until ``kill_after``, SIGKILL it, return every ack it sent."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
    }
    acked: set[int] = set()
    with stderr_path.open("wb") as stderr:
        child = subprocess.Popen(
            [sys.executable, str(CHILD), str(data_dir)],
            stdout=subprocess.PIPE,
            stderr=stderr,
            env=env,
            cwd=ROOT,
        )
        watchdog = threading.Timer(60, child.kill)  # a hung child must not hang the test
        watchdog.start()
        try:
            assert child.stdout is not None
            while len(acked) < kill_after:
                line = child.stdout.readline()
                if not line:
                    pytest.fail(f"the child ended early: {stderr_path.read_text()}")
                acked.add(int(line))
            os.kill(child.pid, signal.SIGKILL)
            rest = child.stdout.read()  # acks already in the pipe count too
            acked.update(int(line) for line in rest.split(b"\n")[:-1])
        finally:
            watchdog.cancel()
            child.kill()
            child.wait()
            if child.stdout is not None:
                child.stdout.close()
    assert child.returncode == -signal.SIGKILL
    return acked


async def restart(data_dir: Path) -> tuple[Recovered, Recovered]:
    """Recover as a restarted store would, commit the next seq, and recover once more."""
    durability, first = await Durability.open(data_dir)
    base = first.snapshot[0] if first.snapshot else 0
    next_seq = (first.records[-1][0] if first.records else base) + 1
    async with anyio.create_task_group() as tg:
        await tg.start(durability.run)
        await durability.commit(next_seq, b"after the crash")
        tg.cancel_scope.cancel()
    await durability.aclose()
    durability, second = await Durability.open(data_dir)
    await durability.aclose()
    return first, second


@pytest.mark.parametrize("kill_after", [300, 1700, 3500])
def test_sigkill_keeps_every_acknowledged_commit_and_nothing_else(
    tmp_path: Path, kill_after: int
) -> None:
    child = load_child()
    data_dir = tmp_path / "data"
    acked = run_and_kill(data_dir, kill_after, tmp_path / "child.stderr")
    files = sorted(p.name for p in (data_dir / "wal").iterdir())

    recovered, again = anyio.run(restart, data_dir)

    assert not recovered.report.corrupt, recovered.report.detail
    base = recovered.snapshot[0] if recovered.snapshot else 0
    if recovered.snapshot is not None:
        assert recovered.snapshot[1] == child.snapshot_payload(base)
    last = recovered.records[-1][0] if recovered.records else base
    seqs = [seq for seq, _ in recovered.records]
    assert seqs == list(range(base + 1, last + 1)), f"not a contiguous prefix; wal: {files}"
    assert all(data == child.payload(seq) for seq, data in recovered.records)
    assert last >= max(acked), f"acknowledged up to {max(acked)}, recovered only {last}"
    assert acked <= set(range(1, last + 1))
    assert again.records[-1] == (last + 1, b"after the crash")
