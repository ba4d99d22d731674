"""Several agents in one process (``skimesh agent --robot r1 --robot r2``, ``--robot all``):
they share one Zenoh session, load their skills side by side, register each, answer each, and
stop together; an agent named twice is refused before anything starts."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from .procs import ROOT, Child

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]


def skimesh(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skimesh", *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )


@pytest.mark.parametrize("robots", [["--robot", "r1", "--robot", "r2"], ["--robot", "all"]])
def test_agents_share_one_process(
    router_endpoint: str, mesh_name: str, tmp_path: Path, robots: list[str]
) -> None:
    common = ["--connect", router_endpoint, "--mesh", mesh_name]
    store = Child(
        ["-m", "skimesh", "wm", *common, "--data", str(tmp_path / "wm"), "--scenario", "kitting"],
        name="store",
    )
    agents: Child | None = None
    try:
        store.wait_stderr("world model ready")
        agents = Child(
            ["-m", "skimesh", "agent", *common, "--scenario", "kitting", *robots, "--simulate"],
            name="agents",
        )
        agents.wait_stderr("agent r1 ready", timeout=60)
        agents.wait_stderr("agent r2 ready", timeout=60)
        listed = skimesh("agents", *common, "--json")
        assert listed.returncode == 0, listed.stderr
        alive = {a["agent"] for a in json.loads(listed.stdout) if a["alive"] and a["available"]}
        assert {"r1", "r2"} <= alive, listed.stdout
        assert agents.stop() == 0, agents.log()
        agents = None
    finally:
        if agents is not None:
            agents.stop()
        store.stop()


def test_an_agent_named_twice_is_refused(router_endpoint: str, mesh_name: str) -> None:
    twice = skimesh(
        "agent", "--connect", router_endpoint, "--mesh", mesh_name,
        "--scenario", "kitting", "--robot", "r1", "--robot", "r1", "--simulate",
    )  # fmt: skip
    assert twice.returncode != 0 and "given twice" in twice.stderr, twice.stderr


def test_agents_on_an_empty_mesh_say_so(
    router_endpoint: str, mesh_name: str, tmp_path: Path
) -> None:
    common = ["--connect", router_endpoint, "--mesh", mesh_name, "--timeout", "1"]
    nothing = skimesh("agents", *common)
    assert nothing.returncode == 3 and "no world model" in nothing.stderr, nothing.stderr
    store = Child(
        ["-m", "skimesh", "wm", *common[:4], "--data", str(tmp_path / "wm")], name="store"
    )
    try:
        store.wait_stderr("world model ready")
        empty = skimesh("agents", *common)
        assert empty.returncode == 1 and "no agent on mesh" in empty.stderr, empty.stderr
    finally:
        store.stop()
