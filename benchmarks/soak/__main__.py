"""The router's memory over many tasks: does it level off?

    python -m benchmarks.soak                 # 10,000 tasks
    python -m benchmarks.soak --tasks 2000    # fewer

A Zenoh router (``skimesh router``), the store (``skimesh wm``, in memory), one skill agent with
the ``noop`` skill and simulated outcomes, and the task agent run as processes of their own on
127.0.0.1 (a free port, a fresh mesh). This process submits one-step tasks one after the other
(``TaskClient.run_file``: it follows each task's events to its end) and samples the router's
resident memory (VmRSS) every ``--every`` tasks. The figure is the router's growth per task over
the second half of the run, beside its growth per task over the first half (same run): a router
that levels off grows much less in the second half; one that leaks per task grows the same.
Results: docs/benchmarks.md, section "A router that levels off".
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import anyio

from benchmarks.common import ROOT, Row, format_table, machine_info
from meshlink import MeshConfig, open_mesh
from meshlink.testing import free_port
from task_agent import TaskClient

SKIMESH = (sys.executable, "-m", "skimesh")
TASK = """
name = "noop"

[root]
block = "call"
agent = "soak"
skill = "noop"
"""
AGENT = f"""
name = "soak"
[robot]
type = "Robot"
label = "soak"
[skills]
paths = ["{ROOT / "docs" / "examples" / "noop.py"}"]
[simulation]
enabled = true
default = 1.0
time_scale = 0.001
"""


def rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError(f"no VmRSS for {pid}")


def start(args: list[str], ready: str, log: Path) -> subprocess.Popen[str]:
    """A ``skimesh`` process, returned once its stderr says ``ready``."""
    proc = subprocess.Popen(
        [*SKIMESH, *args], cwd=ROOT, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True
    )
    assert proc.stderr is not None
    with log.open("w") as out:
        for line in proc.stderr:
            out.write(line)
            if ready in line:
                return proc
    raise RuntimeError(f"{args[0]} ended before it was ready (log: {log})")


async def soak(config: MeshConfig, router: int, tasks: int, every: int) -> list[tuple[int, int]]:
    samples = [(0, rss_kb(router))]
    async with open_mesh(config) as mesh:
        client = TaskClient(mesh, timeout=10.0)
        for i in range(1, tasks + 1):
            done = await client.run_file(TASK)
            if done.outcome != "succeeded":
                raise RuntimeError(f"task {i}: {done.outcome}: {done.message}")
            if i % every == 0:
                samples.append((i, rss_kb(router)))
                print(f"  {i} tasks: router {samples[-1][1] / 1024:.1f} MB", file=sys.stderr)
    return samples


def run(tasks: int, every: int) -> list[Row]:
    port, mesh = free_port(), f"soak-{uuid.uuid4().hex[:8]}"
    endpoint = f"tcp/127.0.0.1:{port}"
    client = ["--connect", endpoint, "--mesh", mesh]
    procs: list[subprocess.Popen[str]] = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "agent.toml").write_text(AGENT)
        try:
            router = ["router", "--listen", endpoint]
            procs.append(start(router, "router listening", folder / "router.log"))
            store = ["wm", *client, "--durability", "none"]
            procs.append(start(store, "world model ready", folder / "wm.log"))
            agent = ["agent", *client, "--agent-config", str(folder / "agent.toml")]
            procs.append(start(agent, "agent soak ready", folder / "agent.log"))
            procs.append(start(["task-agent", *client], "task agent ready", folder / "ta.log"))
            t0 = time.monotonic()
            config = MeshConfig(connect=(endpoint,), mesh=mesh)
            samples = anyio.run(soak, config, procs[0].pid, tasks, every)
            took = time.monotonic() - t0
        finally:
            for proc in reversed(procs):
                proc.terminate()
                try:
                    proc.wait(10)
                except subprocess.TimeoutExpired:
                    proc.kill()
    half = len(samples) // 2
    (n0, m0), (nh, mh), (n1, m1) = samples[0], samples[half], samples[-1]
    first = (mh - m0) * 1024 / max(1, nh - n0)
    second = (m1 - mh) * 1024 / max(1, n1 - nh)
    return [
        Row(figure="router memory at the start", value=m0 / 1024, unit="MB"),
        Row(figure=f"router memory after {n1} tasks", value=m1 / 1024, unit="MB"),
        Row(
            figure="router growth per task, second half",
            value=second,
            unit="B",
            baseline="first half",
            baseline_value=first,
            note=f"{n1} tasks in {took:.0f} s",
        ),
    ]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", type=int, default=10_000, help="how many tasks (default 10000)")
    parser.add_argument("--every", type=int, default=500, help="sample the router every N tasks")
    args = parser.parse_args()
    rows = run(args.tasks, args.every)
    print(machine_info())
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
