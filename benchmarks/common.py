"""Shared helpers of the benchmarks: statistics, a results table, machine facts, child processes.

Statistics are nearest-rank percentiles over raw samples (no interpolation, no outlier
removal). A :class:`Row` holds one figure beside the baseline measured in the same run; the
ratio, not the absolute value, is what survives from one noisy shared machine to the next.

Child processes (:class:`Child`) are ``sys.executable`` subprocesses (fork + exec: never a bare
fork of a process with an open Zenoh session) that speak one JSON object per stdout line;
they are stopped by closing their stdin, then SIGTERM, then SIGKILL, always by their own PID.
Inside a child, :func:`emit` writes a line and :func:`stdin_lines` reads commands.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import queue
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import AsyncIterator, Iterable, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import anyio
import anyio.from_thread
import anyio.lowlevel
import msgspec

__all__ = [
    "ROOT",
    "Child",
    "Row",
    "Stats",
    "calibrate",
    "cpu_seconds",
    "emit",
    "fmt_num",
    "format_grid",
    "format_table",
    "load_average",
    "machine_info",
    "percentile",
    "stdin_lines",
    "summarize",
]

ROOT = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- statistics


def percentile(ordered: Sequence[float], q: float) -> float:
    """Nearest-rank ``q``-th percentile (0 < q <= 100) of already sorted samples."""
    if not ordered:
        return math.nan
    rank = max(1, math.ceil(q / 100.0 * len(ordered)))
    return ordered[min(rank, len(ordered)) - 1]


class Stats(msgspec.Struct, frozen=True):
    """Summary of samples, in the unit they were given in."""

    count: int
    p50: float
    p90: float
    p99: float
    mean: float
    min: float
    max: float


def summarize(samples: Iterable[float], scale: float = 1.0) -> Stats:
    """Stats of ``samples`` multiplied by ``scale`` (e.g. ``1e-3`` for ns -> µs)."""
    ordered = sorted(s * scale for s in samples)
    if not ordered:
        nan = math.nan
        return Stats(0, nan, nan, nan, nan, nan, nan)
    return Stats(
        count=len(ordered),
        p50=percentile(ordered, 50),
        p90=percentile(ordered, 90),
        p99=percentile(ordered, 99),
        mean=sum(ordered) / len(ordered),
        min=ordered[0],
        max=ordered[-1],
    )


# --------------------------------------------------------------------------- results table


class Row(msgspec.Struct, kw_only=True):
    """One figure beside its same-run baseline. ``met`` is None when no target applies."""

    figure: str
    value: float
    unit: str
    baseline: str = ""
    baseline_value: float = math.nan
    target: str = ""
    met: bool | None = None
    note: str = ""
    paired_ratio: float | None = None
    """The ratio judged, when it is not value / baseline_value: e.g. the median of ratios of
    pairs measured back to back (the ratio of two medians can fall the other side of a target)."""

    @property
    def ratio(self) -> float:
        if self.paired_ratio is not None:
            return self.paired_ratio
        if not self.baseline_value or math.isnan(self.baseline_value):
            return math.nan
        return self.value / self.baseline_value


def fmt_num(value: float) -> str:
    if math.isnan(value):
        return "-"
    if abs(value) >= 100:
        return f"{value:,.0f}"
    if abs(value) >= 10:
        return f"{value:.1f}"
    return f"{value:.2f}"


def format_grid(head: Sequence[str], body: Sequence[Sequence[str]]) -> str:
    """A plain-text table with a header rule; columns as wide as their widest cell."""
    widths = [max(len(line[i]) for line in (head, *body)) for i in range(len(head))]

    def fmt(cells: Sequence[str]) -> str:
        return " | ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)).rstrip()

    rule = "-+-".join("-" * w for w in widths)
    return "\n".join([fmt(head), rule, *(fmt(line) for line in body)])


def format_table(rows: Sequence[Row]) -> str:
    """The results: figure | value | baseline | ratio | target | met?"""
    head = ("figure", "value", "baseline (same run)", "ratio", "target", "met?")
    body = [
        (
            f"{r.figure} ({r.note})" if r.note else r.figure,
            f"{fmt_num(r.value)} {r.unit}",
            f"{r.baseline} {fmt_num(r.baseline_value)}" if r.baseline else "-",
            "-" if math.isnan(r.ratio) else f"{r.ratio:.2f}x",
            r.target or "-",
            {None: "-", True: "yes", False: "NO"}[r.met],
        )
        for r in rows
    ]
    return format_grid(head, body)


# --------------------------------------------------------------------------- machine


def machine_info(packages: Sequence[str] = ()) -> dict[str, str]:
    """CPU count and model, Python, kernel and the versions of ``packages``."""
    model = platform.processor() or "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info = {
        "cpus": str(os.cpu_count()),
        "cpus_usable": str(len(os.sched_getaffinity(0))),
        "cpu_model": model,
        "python": platform.python_version(),
        "kernel": platform.release(),
    }
    for name in packages:
        try:
            info[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            info[name] = "not installed"
    return info


def calibrate(repeat: int = 5) -> float:
    """ms for a fixed pure-Python workload, best of ``repeat``: how fast this machine runs
    Python right now (other load on a shared machine makes it slower). Print it with results."""
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        total = 0
        for i in range(300_000):
            total += i % 7
        best = min(best, time.perf_counter() - start)
    return best * 1e3


def load_average() -> str:
    """The 1-minute load average and the number of usable CPUs, e.g. ``"2.5 on 2 CPUs"``."""
    return f"{os.getloadavg()[0]:.1f} on {len(os.sched_getaffinity(0))} CPUs"


def cpu_seconds(pid: int | None = None) -> float:
    """CPU time (user + system, every thread) used so far by process ``pid`` (Linux
    ``/proc/<pid>/stat``), or by this process when ``pid`` is None."""
    if pid is None:
        return time.process_time()
    stat = Path(f"/proc/{pid}/stat").read_text()
    fields = stat[stat.rindex(")") + 2 :].split()  # after "pid (comm) "
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


# --------------------------------------------------------------------------- child processes


class Child:
    """A ``sys.executable`` child speaking JSON lines on stdout; stderr kept for diagnostics."""

    def __init__(self, args: Sequence[str], *, name: str, env: Mapping[str, str] | None = None):
        self.name = name
        self.proc = subprocess.Popen(
            [sys.executable, *args],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
        )
        self._lines: queue.Queue[str | None] = queue.Queue()
        self._stderr: deque[str] = deque(maxlen=60)
        self._threads = [
            threading.Thread(target=self._pump, args=(True,), daemon=True),
            threading.Thread(target=self._pump, args=(False,), daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    @property
    def pid(self) -> int:
        return self.proc.pid

    def _pump(self, stdout: bool) -> None:
        stream = self.proc.stdout if stdout else self.proc.stderr
        assert stream is not None
        for line in stream:
            if stdout:
                self._lines.put(line)
            else:
                self._stderr.append(line)
        if stdout:
            self._lines.put(None)

    def log(self) -> str:
        """The last lines the child wrote on stderr."""
        return "".join(self._stderr)

    def expect(self, key: str, timeout: float = 30.0) -> dict[str, Any]:
        """The next JSON line holding ``key`` (others are skipped). Blocking; raises
        RuntimeError with the child's stderr if it ends or stays silent for ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self._lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise RuntimeError(
                    f"{self.name}: no {key!r} in {timeout} s\n{self.log()}"
                ) from None
            if line is None:
                self.proc.wait(timeout=10)
                raise RuntimeError(
                    f"{self.name} exited ({self.proc.returncode}) before {key!r}\n{self.log()}"
                )
            message: dict[str, Any] = json.loads(line)
            if key in message:
                return message

    async def expect_async(self, key: str, timeout: float = 30.0) -> dict[str, Any]:
        """:meth:`expect` in a worker thread (the loop keeps running)."""
        return await anyio.to_thread.run_sync(self.expect, key, timeout)

    def send(self, message: object) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(message) + "\n")
        self.proc.stdin.flush()

    def stop(self, grace: float = 10.0) -> int:
        """Close stdin (the child's signal to finish), then SIGTERM, then SIGKILL; by PID."""
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            with contextlib.suppress(BrokenPipeError):
                self.proc.stdin.close()
        for sig in (None, signal.SIGTERM, signal.SIGKILL):
            if sig is not None and self.proc.poll() is None:
                os.kill(self.proc.pid, sig)
            try:
                code = self.proc.wait(timeout=grace)
                break
            except subprocess.TimeoutExpired:
                continue
        else:  # pragma: no cover - SIGKILL always ends a process
            code = self.proc.wait()
        for thread in self._threads:
            thread.join(timeout=5)
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None:
                stream.close()
        return code

    def __enter__(self) -> Child:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def emit(message: object) -> None:
    """Inside a child: write one JSON line on stdout."""
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()


async def stdin_lines() -> AsyncIterator[str]:
    """Inside a child: the lines of stdin, ending at end of file. Read by a daemon thread, so
    a blocked read never holds up the interpreter's exit."""
    send, receive = anyio.create_memory_object_stream[str | None](16)
    token = anyio.lowlevel.current_token()

    def reader() -> None:
        try:
            for line in sys.stdin:
                anyio.from_thread.run(send.send, line.rstrip("\n"), token=token)
            anyio.from_thread.run(send.send, None, token=token)
        except RuntimeError:  # the loop is gone
            pass

    threading.Thread(target=reader, daemon=True, name="stdin").start()
    async with receive:
        async for line in receive:
            if line is None:
                return
            yield line


def start_router_child(module: str, stack: contextlib.ExitStack, attempts: int = 5) -> str:
    """Start ``python -m module --role router`` on a free loopback port (stopped, by its PID,
    when ``stack`` closes) and return its endpoint; a port taken meanwhile is tried again."""
    from meshlink.testing import free_port

    for attempt in range(attempts):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        child = Child(["-m", module, "--role", "router", "--listen", endpoint], name="router")
        stack.callback(child.stop)
        try:
            child.expect("ready", timeout=30)
        except RuntimeError:
            if attempt == attempts - 1:
                raise
            continue
        return endpoint
    raise AssertionError("unreachable")


def child_router(args: argparse.Namespace) -> int:
    """A benchmark's router child (``--role router --listen ENDPOINT``): a Zenoh router until
    its stdin closes; prints ``{"ready": endpoint}`` once it listens."""
    from meshlink import run_router
    from skimesh.runtime import run_service

    async def main() -> int:
        async with anyio.create_task_group() as tg:
            await tg.start(run_router, [args.listen])
            emit({"ready": args.listen})
            async for _ in stdin_lines():
                pass
            tg.cancel_scope.cancel()
        return 0

    return run_service(main)
