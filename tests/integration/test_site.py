"""``skimesh up`` of a one-host site on loopback (router, store, both kitting agents with
simulated outcomes in one process, task agent): it comes up in order with health checks, a
task submitted from the CLI succeeds, an agent process killed with SIGKILL is restarted by the
policy and is ready again, ``skimesh status`` shows it, and ``skimesh down`` from another
process stops every child (each PID gone); ``skimesh down`` also stops what a killed
``skimesh up`` left; a process that ends before it is ready fails the bring-up (exit 1,
what was started is stopped); each shipped one-host site (kitting, meal, workshop) comes up with its
simulator and goes down."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from meshlink.testing import free_port

from .procs import ROOT, Child

pytestmark = [pytest.mark.slow, pytest.mark.zenoh, pytest.mark.timeout(300)]

SITE = """
mesh = "{mesh}"
scenario = "kitting"
stop_grace = 5.0

[[routers]]
listen = ["tcp/127.0.0.1:{port}"]

[store]

[[agents]]
robots = ["all"]
simulate = true

[task_agent]

[restart]
policy = "on-failure"
backoff = 0.5
max_restarts = 2
window = 60.0
"""


def _skimesh(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skimesh", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _wait_restarted(state: Path, name: str, old: int, timeout: float) -> int:
    """The new PID of ``name`` once the status file shows it ready after one restart."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        row = _status(state)[name]
        if row["state"] == "ready" and row["pid"] != old:
            assert row["restarts"] == 1
            return int(str(row["pid"]))
        time.sleep(0.1)
    raise AssertionError(f"{name} not ready again in {timeout} s: {_status(state)[name]}")


def _status(state: Path) -> dict[str, dict[str, object]]:
    data = json.loads((state / "status.json").read_text(encoding="utf-8"))
    return {row["name"]: row for row in data["rows"]}


def test_up_runs_a_task_restarts_a_killed_agent_and_down_stops_all(
    tmp_path: Path, mesh_name: str
) -> None:
    port = free_port()
    site = tmp_path / "site.toml"
    site.write_text(SITE.format(mesh=mesh_name, port=port), encoding="utf-8")
    state = tmp_path / "state"
    where = (str(site), "--state-dir", str(state))
    up = Child(["-m", "skimesh", "up", *where], name="skimesh up")
    pids: set[int] = set()
    try:
        up.wait_stderr("site up: 4 processes of host local ready", timeout=180)
        lines = "".join(up.stderr_lines)
        order = list(re.findall(r"skimesh up: (\S+) on local ready", lines))
        assert order == ["router", "store", "agents-r1-r2", "task-agent"]
        rows = _status(state)
        assert all(row["state"] == "ready" for row in rows.values())
        pids = {int(str(row["pid"])) for row in rows.values()}
        assert all((state / "logs" / f"{name}.log").is_file() for name in rows)

        done = _skimesh(
            "task", "submit", "--connect", f"tcp/127.0.0.1:{port}", "--mesh", mesh_name,
            "--goal", "contain(KitBox-1, Gear-1)",
        )  # fmt: skip
        assert done.returncode == 0, done.stdout + done.stderr

        old = int(str(rows["agents-r1-r2"]["pid"]))
        os.kill(old, 9)
        line = up.wait_stderr("restart 1 in 0.5 s", timeout=30)
        assert "killed by SIGKILL" in line
        new = _wait_restarted(state, "agents-r1-r2", old, timeout=60)
        assert _gone(old)
        pids.add(new)

        status = _skimesh("status", *where)
        assert status.returncode == 0, status.stderr
        assert re.search(rf"agents-r1-r2\s+local\s+ready\s+{new}\s+1", status.stdout)

        down = _skimesh("down", *where)
        assert down.returncode == 0, down.stdout + down.stderr
        assert up.proc.wait(timeout=30) == 0, up.log()
        assert all(_gone(pid) for pid in pids), [p for p in pids if not _gone(p)]
        rows = _status(state)
        assert {row["state"] for row in rows.values()} == {"stopped"}
        assert _skimesh("status", *where).returncode == 1
    finally:
        up.stop()
        for pid in pids:  # only the site's children, by PID, should any be left
            if not _gone(pid):
                os.kill(pid, 9)


def _dead(pid: int) -> bool:
    """Gone, or a zombie nobody reaped yet (its parent was killed)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii")
    except OSError:
        return True
    return stat.rsplit(")", 1)[1].split()[0] == "Z"


def test_down_stops_what_a_killed_supervisor_left_running(tmp_path: Path, mesh_name: str) -> None:
    port = free_port()
    site = tmp_path / "site.toml"
    site.write_text(SITE.format(mesh=mesh_name, port=port), encoding="utf-8")
    state = tmp_path / "state"
    where = (str(site), "--state-dir", str(state))
    up = Child(["-m", "skimesh", "up", *where], name="skimesh up")
    pids: set[int] = set()
    try:
        up.wait_stderr("site up", timeout=180)
        pids = {int(str(row["pid"])) for row in _status(state).values()}
        up.kill()  # SIGKILL: its children run on, in their own sessions
        assert not any(_dead(pid) for pid in pids)
        down = _skimesh("down", *where)
        assert down.returncode == 0, down.stdout + down.stderr
        assert "stopped what it left running" in down.stderr
        assert all(_dead(pid) for pid in pids), [p for p in pids if not _dead(p)]
    finally:
        up.stop()
        for pid in pids:
            if not _dead(pid):
                os.kill(pid, 9)


@pytest.mark.sim
@pytest.mark.parametrize("name", ["kitting", "meal", "workshop"])
def test_each_shipped_one_host_site_comes_up_with_its_simulator(tmp_path: Path, name: str) -> None:
    """The shipped site files as written (the router moved to a free port)."""
    site = ROOT / "configs" / "sites" / f"{name}.toml"
    state = tmp_path / "state"
    where = (str(site), "--listen", f"tcp/127.0.0.1:{free_port()}", "--state-dir", str(state))
    up = Child(["-m", "skimesh", "up", *where], name=f"skimesh up {name}")
    pids: set[int] = set()
    try:
        up.wait_stderr("site up", timeout=240)
        rows = _status(state)
        assert "sim" in rows and {str(row["state"]) for row in rows.values()} == {"ready"}
        pids = {int(str(row["pid"])) for row in rows.values()}
        down = _skimesh("down", *where)
        assert down.returncode == 0, down.stdout + down.stderr
        assert up.proc.wait(timeout=30) == 0, up.log()
        assert all(_gone(pid) for pid in pids)
    finally:
        up.stop()
        for pid in pids:
            if not _gone(pid):
                os.kill(pid, 9)


def test_a_process_that_ends_before_it_is_ready_fails_the_bring_up(
    tmp_path: Path, mesh_name: str
) -> None:
    """A store that cannot start (its ontology file is no Turtle): `skimesh up` exits 1 naming
    it and its log, and stops the router it started."""
    (tmp_path / "bad.ttl").write_text("this is not turtle .\n", encoding="utf-8")
    site = tmp_path / "site.toml"
    site.write_text(
        f'mesh = "{mesh_name}"\n[[routers]]\nlisten = ["tcp/127.0.0.1:{free_port()}"]\n'
        '[store]\nontology = ["bad.ttl"]\n[task_agent]\n',
        encoding="utf-8",
    )
    state = tmp_path / "state"
    done = _skimesh("up", str(site), "--state-dir", str(state))
    assert done.returncode == 1, done.stderr
    log = state / "logs" / "store.log"
    assert f"store did not come up: exit code 2 before it was ready (log: {log})" in done.stderr
    rows = _status(state)
    assert (rows["store"]["state"], rows["router"]["state"]) == ("failed", "stopped")
    assert rows["task-agent"]["state"] == "pending"
    assert _gone(int(str(rows["router"]["pid"])))
