"""One exit-code table for every command (README, "Exit codes"), run as a user runs the commands
(``python -m skimesh ...``), against a loopback mesh (a store with the kitting scene, agent r1
with simulated outcomes, the task agent) and against an empty mesh (a router and nothing else);
the errors are one line that names the closest names; the services start and stop with a clean
stderr (no warning, traceback or leak report), the simulator too."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from skimesh.errors import Exit

from .procs import ROOT, Child, command_imports

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.timeout(300)]

#: (arguments, exit code, a text stderr must hold) on the loopback mesh.
ON_THE_MESH: list[tuple[str, Exit, str]] = [
    ("wm get Gear-1", Exit.OK, ""),
    ("wm get Gear-11", Exit.REFUSED, "did you mean 'Gear-1'"),
    ("wm get r1-arm", Exit.OK, '"id": "Arm-1"'),
    ("wm get r1", Exit.REFUSED, "2 elements are labelled 'r1': give one's id"),
    ("wm get r1-amr", Exit.REFUSED, "did you mean 'r1-arm'"),
    ("wm ls Gaer", Exit.REFUSED, "did you mean 'Gear'"),
    ("wm query Gear --label nothing-like-this", Exit.FAILED, ""),
    ("wm update Gear-1", Exit.REFUSED, "nothing to change"),
    ("wm update r1-amr --set mass=1", Exit.REFUSED, "did you mean 'r1-arm'"),
    ("wm relate r1 contain Gear-2", Exit.REFUSED, "2 elements are labelled 'r1'"),
    ("wm tree r1-arm", Exit.OK, "r1-arm (Arm-1) [Arm]"),
    ("agents", Exit.OK, ""),
    ("run r1 pik", Exit.REFUSED, "did you mean 'pick'"),
    (
        "run r1 pick object=Gear-11 holder=PartBox-1 location=Station-1",
        Exit.REFUSED,
        "did you mean 'Gear-1'",
    ),
    ("run r9 navigate", Exit.REFUSED, "no agent 'r9' on mesh 'exit-codes' (alive: "),
    ("run r11 navigate", Exit.REFUSED, "did you mean 'r1'"),
    ("task status t-nothing", Exit.REFUSED, "no task 't-nothing'"),
    ("task submit --goal contain(KitBox-1,Gear-11)", Exit.REFUSED, "did you mean 'Gear-1'"),
    ("task submit --goal contain(KitBox-1,Shelf-1)", Exit.REFUSED, "unsolvable"),
    ("task", Exit.REFUSED, ""),
]

#: The same commands where nothing answers.
ON_AN_EMPTY_MESH = [
    "agents",
    "skills",
    "wm get Gear-1",
    "run r1 navigate",
    "task status t-1",
    "task submit --goal contain(KitBox-1,Gear-1)",
]

LOG_LINE = re.compile(r"^\d\d:\d\d:\d\d I \S+: ")
"""A service's stderr on a clean start and stop: INFO lines only (ready, stopping, stopped)."""


def skimesh(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skimesh", *args],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )


def assert_clean(child: Child) -> None:
    """The child stopped by SIGTERM with exit code 0 and said only INFO lines."""
    assert child.stop() == 0, child.log()
    lines = [line.rstrip("\n") for line in child.stderr_lines if line != "<eof>"]
    noise = [line for line in lines if not LOG_LINE.match(line)]
    assert not noise, f"{child.name}: {noise}"


@pytest.fixture(scope="module")
def site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[list[str]]:
    """The loopback mesh; yields a command's connection flags. At the end, every service is
    stopped and its stderr checked."""
    flags = ["--connect", module_router, "--mesh", "exit-codes"]
    data = tmp_path_factory.mktemp("wm")
    children: list[Child] = []

    def start(name: str, *args: str, ready: str) -> None:
        child = Child(["-m", "skimesh", *args, *flags], name=name)
        children.append(child)
        child.wait_stderr(ready, timeout=120)

    try:
        start("wm", "wm", "--data", str(data), "--scenario", "kitting", ready="world model ready")
        start("agent", "agent", "--scenario", "kitting", "--robot", "r1", "--simulate",
              ready="agent r1 ready")  # fmt: skip
        start("task agent", "task-agent", ready="task agent ready")
        yield flags
        for child in reversed(children):
            assert_clean(child)
    finally:
        for child in children:
            child.kill()


@pytest.mark.parametrize(("command", "code", "said"), ON_THE_MESH, ids=[c[0] for c in ON_THE_MESH])
def test_exit_codes_on_a_mesh(site: list[str], command: str, code: Exit, said: str) -> None:
    done = skimesh(*command.split(), *site)
    assert done.returncode == code, f"{done.stdout}\n{done.stderr}"
    assert said in done.stderr + done.stdout, done.stderr
    assert "Traceback" not in done.stderr, done.stderr


def test_connection_options_before_the_command(site: list[str]) -> None:
    """The same options before ``task``, between it and its command, or at the end."""
    for words in (
        [*site, "task", "list"],
        ["task", *site, "list"],
        ["task", "list", *site],
        [*site, "agents"],
    ):
        done = skimesh(*words)
        assert done.returncode == Exit.OK, f"{words}: {done.stderr}"


def test_an_agent_that_was_registered_and_died_is_unreachable(
    site: list[str], tmp_path: Path
) -> None:
    """``run`` on an agent the world model knows but whose process is gone: exit 3, at once,
    saying it is not alive (an unknown name is exit 2, above)."""
    r2 = Child(
        ["-m", "skimesh", "agent", "--scenario", "kitting", "--robot", "r2", "--simulate", *site],
        name="r2",
    )
    try:
        r2.wait_stderr("agent r2 ready", timeout=120)
    finally:
        r2.kill()
    deadline = time.monotonic() + 30  # the router drops r2's token when its link closes
    while True:
        listed = skimesh("agents", "--json", *site)
        rows = {row["agent"]: row for row in json.loads(listed.stdout)}
        if not rows["r2"]["alive"] or time.monotonic() > deadline:
            break
    assert not rows["r2"]["alive"], rows
    done = skimesh("run", "r2", "navigate", *site)
    assert done.returncode == Exit.UNREACHABLE, done.stderr
    assert "agent 'r2' is not alive on mesh 'exit-codes'" in done.stderr, done.stderr
    assert done.stderr.startswith("skimesh run: ") and "Traceback" not in done.stderr


@pytest.mark.parametrize("command", ON_AN_EMPTY_MESH)
def test_nothing_answers_on_an_empty_mesh(module_router: str, command: str) -> None:
    flags = ["--connect", module_router, "--mesh", "empty", "--timeout", "1"]
    done = skimesh(*command.split(), *flags)
    assert done.returncode == Exit.UNREACHABLE, f"{done.stdout}\n{done.stderr}"
    assert len(done.stderr.strip().splitlines()) <= 2 and "Traceback" not in done.stderr


LIGHT = ["agents", "skills r1", "wm get Gear-1", "task status t-nothing"]
HEAVY = ("unified_planning", "mujoco", "placo", "rerun", "rdflib")


@pytest.mark.parametrize("command", LIGHT)
def test_light_commands_on_a_mesh_load_no_heavy_package(site: list[str], command: str) -> None:
    """The light commands, answered by the mesh, import neither the planners, the simulator,
    the viewer nor rdflib (``wm get`` and ``agents`` ask the store, they load no replica)."""
    code, loaded = command_imports([*command.split(), *site], HEAVY)
    assert loaded == [], loaded
    assert code == (Exit.REFUSED if "t-nothing" in command else Exit.OK)


def test_the_simulator_starts_and_stops_cleanly(module_router: str, tmp_path: Path) -> None:
    sim = Child(
        ["-m", "skimesh", "sim", "--scenario", "kitting", "--no-rerun", "--fast",
         "--connect", module_router, "--mesh", "sim-clean"],
        name="sim",
    )  # fmt: skip
    try:
        sim.wait_stderr("sim: scenario kitting", timeout=120)
        assert_clean(sim)
    finally:
        sim.kill()


def test_the_router_starts_and_stops_cleanly() -> None:
    from meshlink.testing import free_port

    router = Child(
        ["-m", "skimesh", "router", "--listen", f"tcp/127.0.0.1:{free_port()}"], name="router"
    )
    try:
        router.wait_stderr("router listening", timeout=60)
        assert_clean(router)
    finally:
        router.kill()
