"""A loopback site for the connected commands of the start-up benchmark: a router, a store with
the kitting scene (in memory), agent r1 with simulated outcomes and the task agent, each a
``python -m skimesh`` process of its own, stopped by PID at the end."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

from benchmarks.common import ROOT

__all__ = ["loopback_site"]

#: Each service: its arguments after ``-m skimesh`` and the stderr text that says it is ready.
_SERVICES: Sequence[tuple[str, Sequence[str], str]] = (
    ("wm", ["wm", "--scenario", "kitting"], "world model ready"),
    ("agent", ["agent", "--scenario", "kitting", "--robot", "r1", "--simulate"], "r1 ready"),
    ("task agent", ["task-agent"], "task agent ready"),
)


def _start(args: Sequence[str], log: Path) -> subprocess.Popen[bytes]:
    with log.open("wb") as out:
        return subprocess.Popen(
            [sys.executable, "-m", "skimesh", *args], cwd=ROOT, stdout=out, stderr=out
        )


def _wait_for(proc: subprocess.Popen[bytes], log: Path, needle: str, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while needle not in log.read_text(errors="replace"):
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"no {needle!r} from {proc.args!r}:\n{log.read_text()[-2000:]}")
        time.sleep(0.1)  # a child's log file gives no event to wait on


@contextlib.contextmanager
def loopback_site(port: int, mesh: str) -> Iterator[list[str]]:
    """Start the site on ``tcp/127.0.0.1:port``; yields the connection flags of a command."""
    endpoint = f"tcp/127.0.0.1:{port}"
    flags = ["--connect", endpoint, "--mesh", mesh]
    procs: list[subprocess.Popen[bytes]] = []
    with tempfile.TemporaryDirectory(prefix="skimesh-cli-bench-") as tmp:
        try:
            log = Path(tmp, "router.log")
            procs.append(_start(["router", "--listen", endpoint], log))
            _wait_for(procs[-1], log, "router listening", 60)
            for name, args, ready in _SERVICES:
                log = Path(tmp, f"{name}.log")
                procs.append(_start([*args, *flags], log))
                _wait_for(procs[-1], log, ready, 120)
            yield flags
        finally:
            for proc in reversed(procs):
                if proc.poll() is None:
                    os.kill(proc.pid, signal.SIGTERM)
                try:
                    proc.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    os.kill(proc.pid, signal.SIGKILL)
                    proc.wait()
