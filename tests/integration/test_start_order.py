"""A site started by hand in any order, each service in its own process as a site runs them:
services that need the world model (a skill agent, the task agent, the event log) started
before ``skimesh wm`` say they wait for it and come up once it answers; an agent started before
the simulator binds its devices once they are served."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from .procs import ROOT, Child

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.timeout(300)]


def test_services_started_before_the_store_wait_for_it(
    router_endpoint: str, mesh_name: str, tmp_path: Path
) -> None:
    flags = ["--connect", router_endpoint, "--mesh", mesh_name]
    early = {
        "agent r1": Child(
            ["-m", "skimesh", "agent", "--scenario", "kitting", "--robot", "r1", "--simulate",
             *flags],
            name="agent",
        ),
        "task agent": Child(["-m", "skimesh", "task-agent", *flags], name="task agent"),
        "event log": Child(
            ["-m", "skimesh", "eventlog", "--data", str(tmp_path / "events.db"), *flags],
            name="event log",
        ),
    }  # fmt: skip
    children = list(early.values())
    try:
        for who, child in early.items():
            line = child.wait_stderr("waiting for the world-model store", timeout=120)
            assert line.split(" I ", 1)[1].startswith(f"skimesh: {who}: waiting"), line
            assert child.proc.poll() is None, child.log()
        store = Child(
            ["-m", "skimesh", "wm", "--data", str(tmp_path / "wm"), "--scenario", "kitting",
             *flags],
            name="wm",
        )  # fmt: skip
        children.append(store)
        store.wait_stderr("world model ready", timeout=120)
        early["agent r1"].wait_stderr("agent r1 ready", timeout=120)
        early["task agent"].wait_stderr("task agent ready", timeout=120)
        early["event log"].wait_stderr("event log ready", timeout=120)
        for child in reversed(children):
            assert child.stop() == 0, child.log()
            assert not [line for line in child.stderr_lines if " W " in line], child.log()
    finally:
        for child in children:
            child.kill()


def test_an_agent_started_before_the_simulator_binds_its_devices_once_served(
    router_endpoint: str, mesh_name: str, tmp_path: Path
) -> None:
    """The agent warns that its devices do not answer, binds them when ``skimesh sim`` serves
    them, and a skill then runs on them in the physics."""
    flags = ["--connect", router_endpoint, "--mesh", mesh_name]
    children: list[Child] = []

    def start(name: str, *args: str, ready: str) -> Child:
        child = Child(["-m", "skimesh", *args, *flags], name=name)
        children.append(child)
        child.wait_stderr(ready, timeout=120)
        return child

    try:
        start("wm", "wm", "--data", str(tmp_path / "wm"), "--scenario", "kitting",
              ready="world model ready")  # fmt: skip
        agent = start("agent", "agent", "--scenario", "kitting", "--robot", "r1",
                      ready="agent r1 ready")  # fmt: skip
        assert any("no device server answered for r1-arm" in line for line in agent.stderr_lines)
        start("sim", "sim", "--scenario", "kitting", "--fast", "--no-rerun", ready="sim: scenario")
        line = agent.wait_stderr("devices served now", timeout=60)
        assert "r1-base" in line and "r1-arm" in line, line
        run = subprocess.run(
            [sys.executable, "-m", "skimesh", "run", "r1", "navigate", "goal=Station-2", *flags],
            capture_output=True, text=True, timeout=120, cwd=ROOT,
        )  # fmt: skip
        assert run.returncode == 0, run.stdout + run.stderr
        assert "navigate" in run.stdout and "succeeded" in run.stdout, run.stdout
    finally:
        for child in reversed(children):
            child.stop()


def test_services_started_before_the_router_wait_for_it(mesh_name: str, tmp_path: Path) -> None:
    """The store, an agent and the task agent started before the router say they wait for it,
    then come up once it listens."""
    from meshlink.testing import free_port

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    flags = ["--connect", endpoint, "--mesh", mesh_name]
    early = {
        "world model": Child(
            ["-m", "skimesh", "wm", "--data", str(tmp_path / "wm"), "--scenario", "kitting",
             *flags],
            name="wm",
        ),
        "agent r1": Child(
            ["-m", "skimesh", "agent", "--scenario", "kitting", "--robot", "r1", "--simulate",
             *flags],
            name="agent",
        ),
        "task agent": Child(["-m", "skimesh", "task-agent", *flags], name="task agent"),
    }  # fmt: skip
    children = list(early.values())
    try:
        for who, child in early.items():
            line = child.wait_stderr("waiting for the router", timeout=120)
            assert f"skimesh: {who}: waiting for the router" in line, line
        router = Child(["-m", "skimesh", "router", "--listen", endpoint], name="router")
        children.append(router)
        router.wait_stderr("router listening", timeout=60)
        early["world model"].wait_stderr("world model ready", timeout=120)
        early["agent r1"].wait_stderr("agent r1 ready", timeout=120)
        early["task agent"].wait_stderr("task agent ready", timeout=120)
        for child in children:
            assert child.proc.poll() is None, child.log()
        for child in early.values():
            assert child.stop() == 0, child.log()
    finally:
        for child in reversed(children):
            child.kill()
