"""A simulated-outcome agent (``skimesh agent --scenario kitting --robot r1 --simulate``) run as a
user runs it, on a loopback mesh with a store: it imports none of the planners, the simulator,
the viewer or rdflib (its world-model replica follows the store's compiled ontology, also when
a relation is taught while it runs, before it commits a skill's effects), and it stays under
100 MB."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from .procs import ROOT, Child, command_imports

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.timeout(300)]

HEAVY = ("unified_planning", "mujoco", "placo", "pinocchio", "rerun", "numpy", "rdflib")
"""What a simulated-outcome agent has no use for."""

RSS_LIMIT_KB = 100_000
"""The target of a simulated-outcome agent process (docs/benchmarks.md, "Light agents"): its
resident memory and its proportional set size."""


@pytest.fixture(scope="module")
def store(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[list[str]]:
    """A store with the kitting scene; yields the connection flags."""
    flags = ["--connect", module_router, "--mesh", "light-agent"]
    data = tmp_path_factory.mktemp("wm")
    wm = Child(["-m", "skimesh", "wm", "--data", str(data), "--scenario", "kitting", *flags],
               name="wm")  # fmt: skip
    try:
        wm.wait_stderr("world model ready", timeout=120)
        yield flags
        assert wm.stop() == 0, wm.log()
    finally:
        wm.kill()


def _memory_kb(pid: int) -> dict[str, int]:
    """``rss``, ``pss`` and ``zenoh_shm`` (the resident part of Zenoh's shared-memory
    segments, ``/dev/shm/*.zenoh``: 16 MB each, two or three per process) of a process."""
    out = {"rss": 0, "pss": 0, "zenoh_shm": 0}
    shm = False
    for line in Path(f"/proc/{pid}/smaps").read_text().splitlines():
        fields = line.split()
        if not fields[0].endswith(":"):  # a mapping's header: address range ... [path]
            shm = fields[-1].startswith("/dev/shm/") and fields[-1].endswith(".zenoh")
        elif fields[0] in ("Rss:", "Pss:"):
            out[fields[0][:-1].lower()] += int(fields[1])
            if shm and fields[0] == "Rss:":
                out["zenoh_shm"] += int(fields[1])
    return out


@pytest.mark.skipif(not Path("/proc/self/smaps").exists(), reason="reads /proc")
def test_a_simulated_outcome_agent_is_light(store: list[str]) -> None:
    args = ["agent", "--scenario", "kitting", "--robot", "r1", "--simulate", *store]
    probe = (  # what the process imported by the time it ends, on its last stderr line
        "import atexit, sys\n"
        f"atexit.register(lambda: print('loaded', [m for m in {HEAVY!r} if m in sys.modules],"
        " file=sys.stderr, flush=True))\n"
        "from skimesh.cli import main\n"
        f"sys.exit(main({args!r}))\n"
    )
    agent = Child(["-c", probe], name="agent")
    try:
        agent.wait_stderr("agent r1 ready", timeout=120)
        memory = _memory_kb(agent.pid)
        for command in (  # a relation taught while the agent runs, then a run that commits
            ["wm", "define-relation", "inspectedBy", "--domain", "Part", "--range", "Agent"],
            ["run", "r1", "navigate"],  # after the teaching: its replica passed it
        ):
            done = subprocess.run(
                [sys.executable, "-m", "skimesh", *command, *store],
                capture_output=True, text=True, timeout=120, cwd=ROOT,
            )  # fmt: skip
            assert done.returncode == 0, done.stdout + done.stderr
        assert agent.stop() == 0, agent.log()
    finally:
        agent.kill()
    last = [line for line in agent.stderr_lines if line.startswith("loaded ")]
    assert last == ["loaded []\n"], agent.log()
    assert memory["zenoh_shm"] == 0, "meshlink turns Zenoh's shared-memory transport off"
    assert memory["rss"] < RSS_LIMIT_KB and memory["pss"] < RSS_LIMIT_KB, memory


@pytest.mark.parametrize("command", ["wm ls Gear", "wm tree", "wm query Gear"])
def test_commands_with_a_replica_load_no_rdflib(store: list[str], command: str) -> None:
    """The commands that keep a world-model replica check against the store's compiled
    ontology: no rdflib in the process."""
    assert command_imports([*command.split(), *store], HEAVY) == (0, [])
