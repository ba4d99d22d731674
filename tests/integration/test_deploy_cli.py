"""The split deployment as README.md and docs/guides/deploy-on-several-hosts.md (section 1)
write it, each component its own ``skimesh`` process on loopback, with physics; the guide's
forms (shipped Zenoh files, an agent TOML) and the README's (``--scenario S --robot R``)::

    skimesh router --config configs/zenoh/router.json5 --listen tcp/127.0.0.1:<port>
    skimesh wm --config configs/zenoh/client.json5 --connect ... \
        --data <tmp> --durability group --scenario kitting         (loads the scene once)
    skimesh sim --connect ... --scenario kitting --fast --no-rerun
    skimesh agent --agent-config configs/agents/kitting/r1.toml \
        --config configs/zenoh/client.json5 --connect ...
    skimesh agent --connect ... --scenario kitting --robot r2
    skimesh task-agent --config configs/zenoh/client.json5 --connect ...
    skimesh agents --connect ...
    skimesh task verify --connect ... configs/tasks/kitting.toml
    skimesh task submit --connect ... --file configs/tasks/kitting.toml
    skimesh task submit --connect ... --goal "<the scenario's goals>"

Covers: the world model loads the scenario's scene at start (and a second load, from the CLI,
writes nothing); the agents wire to it and to the simulated devices; the shipped example task
file (the one docs/guides/program-a-task-by-hand.md runs) verifies and runs in the physics
with both robots at once; then the scenario's goals, submitted from the CLI, are planned and
run for what the file left (Bolt-2) and hold in the world model.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from meshlink.testing import free_port
from scenario import load_scenario
from wm_store import WmClient, ZenohTransport

from .procs import ROOT, Child

pytestmark = [pytest.mark.slow, pytest.mark.sim, pytest.mark.zenoh, pytest.mark.timeout(300)]

SCENARIO = load_scenario(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml")
TASK_FILE = ROOT / "configs" / "tasks" / "kitting.toml"
ZENOH = ROOT / "configs" / "zenoh"
CLIENT = ("--config", str(ZENOH / "client.json5"))
DEADLINE = 150.0
"""Seconds a task may take (a busy 2-core machine runs the physics below real time)."""


@dataclass
class Deployment:
    endpoint: str
    folder: Path
    children: dict[str, Child] = field(default_factory=dict)

    def start(self, name: str, *args: str, ready: str, timeout: float = 60.0) -> Child:
        child = Child(["-m", "skimesh", *args], name=name)
        self.children[name] = child
        child.wait_stderr(ready, timeout=timeout)
        return child

    @property
    def connect(self) -> tuple[str, str]:
        return ("--connect", self.endpoint)

    def skimesh(
        self, *args: str, timeout: float = DEADLINE + 30
    ) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "skimesh", *args],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=timeout,
        )

    def stop(self) -> dict[str, int]:
        """Stop every child by its PID, the last started first."""
        return {name: child.stop() for name, child in reversed(self.children.items())}


def start_router(site: Deployment, attempts: int = 3) -> None:
    """``skimesh router --listen`` on a free port (another process may take it first: retry)."""
    router = ("--config", str(ZENOH / "router.json5"))
    for attempt in range(attempts):
        site.endpoint = f"tcp/127.0.0.1:{free_port()}"
        try:
            site.start("router", "router", *router, "--listen", site.endpoint,
                       ready="router listening")  # fmt: skip
            return
        except AssertionError:
            site.children.pop("router").stop()
            if attempt == attempts - 1:
                raise


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Deployment]:
    s = Deployment("", tmp_path_factory.mktemp("deploy"))
    try:
        start_router(s)
        connect = s.connect
        data = str(s.folder / "wm")
        s.start("wm", "wm", *CLIENT, *connect, "--data", data, "--durability", "group",
                "--scenario", "kitting", ready="world model ready")  # fmt: skip
        s.start("sim", "sim", *connect, "--scenario", "kitting", "--fast", "--no-rerun",
                ready="sim: scenario kitting", timeout=120)  # fmt: skip
        r1 = str(ROOT / "configs" / "agents" / "kitting" / "r1.toml")
        s.start("agent r1", "agent", "--agent-config", r1, *CLIENT, *connect,
                ready="agent r1 ready", timeout=120)  # fmt: skip
        s.start("agent r2", "agent", *connect, "--scenario", "kitting", "--robot", "r2",
                ready="agent r2 ready", timeout=120)  # fmt: skip
        s.start("task agent", "task-agent", *CLIENT, *connect, ready="task agent ready")
        yield s
    finally:
        codes = s.stop()
        bad = {name: code for name, code in codes.items() if code != 0}
        assert not bad, f"components did not stop cleanly: {bad}"


async def kit_contents(endpoint: str) -> dict[str, set[str]]:
    """Kit box label -> labels of what it contains, read from a fresh world-model client."""
    async with (
        open_mesh(MeshConfig(connect=(endpoint,))) as mesh,
        WmClient.connect(ZenohTransport(mesh), author="test") as wm,
    ):
        state = wm.replica.state
        kits: dict[str, set[str]] = {}
        for kit in ("KitBox-1", "KitBox-2"):
            (box,) = wm.resolve_element(type="KitBox", label=kit)
            held = wm.query_relation(box.id, "contain")
            kits[kit] = {state.elements[r.object].label for r in held}
        return kits


def test_the_documented_deployment_runs_the_example_file_then_the_goal(site: Deployment) -> None:
    again = site.skimesh("wm", *site.connect, "import-scenario", "kitting", timeout=60)
    assert again.returncode == 0 and "nothing imported" in again.stdout, again
    agents = site.skimesh("agents", *site.connect, timeout=60)
    assert agents.returncode == 0 and "r1" in agents.stdout and "r2" in agents.stdout, agents

    checked = site.skimesh("task", "verify", *site.connect, str(TASK_FILE), timeout=60)
    assert checked.returncode == 0, f"{checked.stdout}\n{checked.stderr}"

    t0 = time.monotonic()
    done = site.skimesh(
        "task", "submit", *site.connect, "--file", str(TASK_FILE), "--deadline", str(DEADLINE)
    )
    file_seconds = time.monotonic() - t0
    assert done.returncode == 0, f"{done.stdout}\n{done.stderr}\n{site_logs(site)}"
    kits = anyio.run(kit_contents, site.endpoint)
    assert kits == {"KitBox-1": {"Gear-1"}, "KitBox-2": {"Bracket-1", "Bolt-1"}}, kits

    goal = " and ".join(SCENARIO.goals)
    t0 = time.monotonic()
    done = site.skimesh(
        "task", "submit", *site.connect, "--goal", goal, "--deadline", str(DEADLINE)
    )
    goal_seconds = time.monotonic() - t0
    assert done.returncode == 0, f"{done.stdout}\n{done.stderr}\n{site_logs(site)}"
    # the task agent asked skimesh sim (another process) for each goal fact
    assert "goal check (world model and physics at simulated time" in done.stdout, done.stdout
    assert done.stdout.count("physics yes") == len(SCENARIO.goals), done.stdout
    kits = anyio.run(kit_contents, site.endpoint)
    assert kits == {"KitBox-1": {"Gear-1"}, "KitBox-2": {"Bracket-1", "Bolt-1", "Bolt-2"}}, kits
    print(f"task file {file_seconds:.1f} s, goal {goal_seconds:.1f} s")


def site_logs(site: Deployment) -> str:
    return "\n".join(f"--- {name}\n{child.log()}" for name, child in site.children.items())
