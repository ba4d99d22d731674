"""A site started by hand in any order: services that need the world model (a skill agent, the
task agent, the event log) started before ``skimesh wm`` say they wait for it and come up once
it answers, each in its own process, as a site runs them."""

from __future__ import annotations

from pathlib import Path

import pytest

from .procs import Child

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
