"""A two-host site across network namespaces, one ``skimesh up`` per host: ``server`` runs
the router, the store and the task agent; ``robots`` both kitting agents (simulated outcomes).
The router listens beyond loopback, so the site is secure by default: the first ``skimesh up``
makes the site's CA and a certificate per component (the other host reuses them: the folder
is shared here, copied on a real site), and every process runs on mutual TLS under the
least-privilege ACL. The robots' host is started first and waits for the server's components
over the mesh; a task submitted from the robots' host with the operator's credential
succeeds, while a client without one cannot even open a session; ``skimesh down`` on each
host stops its part (every PID gone). Needs root (skipped otherwise)."""

from __future__ import annotations

import json
import os
import uuid
from pathlib import Path

import pytest

from .netns import Lab, unavailable
from .procs import Child

pytestmark = [pytest.mark.netns, pytest.mark.slow, pytest.mark.zenoh, pytest.mark.timeout(300)]

SITE = """
mesh = "{mesh}"
scenario = "kitting"
stop_grace = 5.0
remote_timeout = 120.0

[hosts.server]
address = "{server}"

[hosts.robots]
address = "{robots}"

[[routers]]
host = "server"
listen = ["tcp/0.0.0.0:7447"]

[store]
host = "server"

[[agents]]
host = "robots"
robots = ["all"]
simulate = true

[task_agent]
host = "server"
"""


def _pids(state: Path) -> set[int]:
    rows = json.loads((state / "status.json").read_text(encoding="utf-8"))["rows"]
    return {int(r["pid"]) for r in rows if r["pid"]}


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def test_a_two_host_site_comes_up_with_one_command_per_host_and_runs_a_task(
    tmp_path: Path,
) -> None:
    reason = unavailable()
    if reason:
        pytest.skip(reason)
    mesh = f"nss-{uuid.uuid4().hex[:8]}"
    with Lab(["server", "robots"]) as lab:
        site = tmp_path / "site.toml"
        text = SITE.format(mesh=mesh, server=lab.address("server"), robots=lab.address("robots"))
        site.write_text(text, encoding="utf-8")
        ups: dict[str, Child] = {}
        pids: set[int] = set()

        def where(host: str) -> list[str]:
            return [str(site), "--host", host, "--state-dir", str(tmp_path / host)]

        try:
            for host in ("robots", "server"):  # the robots wait for the server over the mesh
                args = lab.python(host, "-m", "skimesh", "up", *where(host))
                ups[host] = Child(args, name=f"up {host}")
            ups["robots"].wait_stderr("store on server waiting", timeout=60)
            ups["server"].wait_stderr("site up: 3 processes of host server ready", timeout=180)
            ups["robots"].wait_stderr("site up: 1 processes of host robots ready", timeout=180)
            pids = _pids(tmp_path / "server") | _pids(tmp_path / "robots")
            assert len(pids) == 4

            endpoint = f"tls/{lab.address('server')}:7447"
            operator = str(tmp_path / "site-credentials" / "operator.json5")
            goal = "contain(KitBox-1, Gear-1)"
            done = lab.run(
                "robots", "-m", "skimesh", "task", "submit", "--connect", endpoint,
                "--mesh", mesh, "--config", operator, "--goal", goal, timeout=120,
            )  # fmt: skip
            assert done.returncode == 0, done.stdout + done.stderr
            anonymous = lab.run(
                "robots", "-m", "skimesh", "agents", "--connect", endpoint, "--mesh", mesh,
                timeout=60,
            )  # fmt: skip
            assert anonymous.returncode == 3, anonymous.stdout + anonymous.stderr

            status = lab.run("robots", "-m", "skimesh", "status", *where("robots"), "--probe")
            assert status.returncode == 0, status.stdout + status.stderr
            assert "task-agent: ready" in status.stdout

            for host in ("robots", "server"):
                down = lab.run(host, "-m", "skimesh", "down", *where(host), timeout=60)
                assert down.returncode == 0, down.stdout + down.stderr
                assert ups[host].proc.wait(timeout=30) == 0, ups[host].log()
            assert all(_gone(pid) for pid in pids)
        finally:
            for up in ups.values():
                up.stop()
            for pid in pids:  # the site's children, by PID, should any be left
                if not _gone(pid):
                    os.kill(pid, 9)
