"""The workshop scenario (``configs/scenarios/workshop``): three mobile manipulators at three
stations facing three ways, two of whose part types (Bearing, Pulley) exist only in the
scenario's own Turtle file (``ontology = ["parts.ttl"]``), not in the core ontology.

- ``skimesh demo --scenario <file>`` runs its goal, which needs all three robots, to success
  in the world model and in the physics.
- The split deployment (docs/guides/deploy-on-several-hosts.md), each component its own
  process on loopback with its own mesh name::

      skimesh router --listen tcp/127.0.0.1:<port>
      skimesh wm --connect ... --mesh M --data <tmp> --scenario <file>     (teaches parts.ttl)
      skimesh sim --connect ... --mesh M --scenario <file> --fast --no-rerun
      skimesh agent --connect ... --mesh M --scenario <file> --robot r1    (r2, r3 alike)
      skimesh task-agent --connect ... --mesh M
      skimesh wm ls Bearing / task plan / task verify / task submit / wm sparql   (clients)

  No client is given ``--ontology``: every process takes the terms from the store, so the CLI
  lists bearings, plans and verifies with them, and the goal runs to success.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from uuid import uuid4

import pytest

from meshlink.testing import free_port
from scenario import load_scenario
from wm_store.ontology import Ontology

from .procs import ROOT, Child

pytestmark = [pytest.mark.slow, pytest.mark.sim, pytest.mark.zenoh, pytest.mark.timeout(400)]

SCENARIO_FILE = ROOT / "configs" / "scenarios" / "workshop" / "scenario.toml"
SCENARIO = load_scenario(SCENARIO_FILE)
GOAL = " and ".join(SCENARIO.goals)
ROBOTS = ("r1", "r2", "r3")
KITS = {"KitBox-1": {"Bearing-1"}, "KitBox-2": {"Pulley-1"}, "KitBox-3": {"Gear-1"}}
"""What the scenario's goal puts in each robot's kit box."""
DEADLINE = 150.0
"""Seconds a task may take (a busy 2-core machine runs the physics below real time)."""


def test_the_scenario_needs_its_own_ontology_and_all_three_robots() -> None:
    core = Ontology.default().classes
    assert "Bearing" not in core and "Pulley" not in core, "the part types must be taught"
    assert [Path(p).name for p in SCENARIO.ontology] == ["parts.ttl"]
    kits = {k.label: k.parent for k in SCENARIO.containers if k.type == "KitBox"}
    assert sorted(kits.values()) == list(ROBOTS)
    wanted = {fact.split("(")[1].split(",")[0] for fact in SCENARIO.goals}
    assert {kits[kit] for kit in wanted} == set(ROBOTS), "each robot fills its own kit box"


def test_the_demo_runs_the_workshop_goal_in_the_world_model_and_the_physics(
    tmp_path: Path,
) -> None:
    t0 = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-m", "skimesh", "demo", "--scenario", str(SCENARIO_FILE),
         "--rrd", str(tmp_path / "run.rrd")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )  # fmt: skip
    seconds = time.monotonic() - t0
    out = done.stdout + done.stderr
    assert done.returncode == 0, out[-4000:]
    n = len(SCENARIO.goals)
    assert f"facts: {n}/{n} hold in the world model, {n}/{n} in the physics" in out, out[-3000:]
    for kit, parts in KITS.items():
        for part in parts:
            assert f"{part} lies in {kit}" in out, out[-3000:]
    assert "Traceback" not in done.stderr, done.stderr[-3000:]
    print(f"workshop demo: {seconds:.1f} s")


# ------------------------------------------------------------------ the split deployment


@dataclass
class Site:
    endpoint: str
    mesh: str
    folder: Path
    children: dict[str, Child] = field(default_factory=dict)

    def start(self, name: str, *args: str, ready: str, timeout: float = 60.0) -> Child:
        child = Child(["-m", "skimesh", *args], name=name)
        self.children[name] = child
        child.wait_stderr(ready, timeout=timeout)
        return child

    @property
    def mesh_args(self) -> tuple[str, ...]:
        return ("--connect", self.endpoint, "--mesh", self.mesh)

    def cli(self, *args: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
        """``skimesh <args>`` as a separate client process (no ``--ontology``)."""
        return subprocess.run(
            [sys.executable, "-m", "skimesh", *args],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=timeout,
        )

    def stop(self) -> dict[str, int]:
        """Stop every child by its PID: the task agent and the robots' agents together (each
        unregisters while the store still answers), then the others, the last started first."""
        agents = [n for n in self.children if n == "task agent" or n.startswith("agent ")]
        with ThreadPoolExecutor(max_workers=len(agents) or 1) as pool:
            stopped = list(pool.map(lambda n: self.children[n].stop(), agents))
        codes = dict(zip(agents, stopped, strict=True))
        rest = [n for n in self.children if n not in codes]
        return codes | {name: self.children[name].stop() for name in reversed(rest)}

    def logs(self) -> str:
        return "\n".join(f"--- {name}\n{child.log()}" for name, child in self.children.items())


def _start_router(site: Site, attempts: int = 3) -> None:
    """``skimesh router --listen`` on a free port (another process may take it first: retry)."""
    for attempt in range(attempts):
        site.endpoint = f"tcp/127.0.0.1:{free_port()}"
        try:
            site.start("router", "router", "--listen", site.endpoint, ready="router listening")
            return
        except AssertionError:
            site.children.pop("router").stop()
            if attempt == attempts - 1:
                raise


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    s = Site("", f"workshop-{uuid4().hex[:8]}", tmp_path_factory.mktemp("workshop"))
    scenario = str(SCENARIO_FILE)
    try:
        _start_router(s)
        m = s.mesh_args
        s.start("wm", "wm", *m, "--data", str(s.folder / "wm"), "--scenario", scenario,
                ready="world model ready")  # fmt: skip
        s.start("sim", "sim", *m, "--scenario", scenario, "--fast", "--no-rerun",
                ready="sim: scenario workshop", timeout=120)  # fmt: skip
        for robot in ROBOTS:
            s.start(f"agent {robot}", "agent", *m, "--scenario", scenario, "--robot", robot,
                    ready=f"agent {robot} ready", timeout=120)  # fmt: skip
        s.start("task agent", "task-agent", *m, ready="task agent ready")
        yield s
    finally:
        codes = s.stop()
        bad = {name: code for name, code in codes.items() if code != 0}
        assert not bad, f"components did not stop cleanly: {bad}"


TASK = """\
name = "a bearing and a pulley"

[root]
block = "parallel"

[[root.children]]
block = "sequence"
id = "r1"

[[root.children.children]]
block = "call"
agent = "r1"
skill = "navigate"
params = { goal = "label:Station-1" }

[[root.children.children]]
block = "call"
id = "r1-pick"
agent = "r1"
skill = "pick"
params = { object = "Bearing-2" }

[[root.children.children]]
block = "call"
agent = "r1"
skill = "place"
params = { object = "@r1-pick.object", container = "KitBox-1" }

[[root.children]]
block = "sequence"
id = "r2"

[[root.children.children]]
block = "call"
agent = "r2"
skill = "navigate"
params = { goal = "label:Station-2" }

[[root.children.children]]
block = "call"
id = "r2-pick"
agent = "r2"
skill = "pick"
params = { object = "Pulley-2" }

[[root.children.children]]
block = "call"
agent = "r2"
skill = "place"
params = { object = "@r2-pick.object", container = "KitBox-2" }
"""
"""A task file on the taught part types, only verified (not run)."""


def test_clients_without_the_ontology_list_plan_and_verify_the_taught_part_types(
    site: Site,
) -> None:
    m = site.mesh_args
    listed = site.cli("wm", *m, "ls", "--json", "Bearing")
    assert listed.returncode == 0, f"{listed.stdout}\n{listed.stderr}"
    found = {e["label"]: e["type"] for e in json.loads(listed.stdout)}
    assert found == {f"Bearing-{i}": "Bearing" for i in (1, 2, 3)}, found
    parts = site.cli("wm", *m, "ls", "--json", "Part")  # taught classes are Parts as the core's
    assert parts.returncode == 0, f"{parts.stdout}\n{parts.stderr}"
    types = {e["label"]: e["type"] for e in json.loads(parts.stdout)}
    assert {types[f"Pulley-{i}"] for i in (1, 2, 3)} == {"Pulley"}, types
    assert types["Bearing-1"] == "Bearing" and types["Gear-1"] == "Gear", types

    goal = "contain(KitBox-1, Bearing-2) and contain(KitBox-2, Pulley-2)"
    planned = site.cli("task", "plan", *m, "--goal", goal, "--json")
    assert planned.returncode == 0, f"{planned.stdout}\n{planned.stderr}"
    steps = [s["step"] for s in json.loads(planned.stdout)["steps"]]
    moves = {(s["agent"], s["skill"], s["params"].get("object")) for s in steps}
    for robot, part in (("r1", "Bearing-2"), ("r2", "Pulley-2")):
        assert {(robot, "pick", part), (robot, "place", part)} <= moves, steps

    task = site.folder / "bearing-and-pulley.toml"
    task.write_text(TASK, encoding="utf-8")
    checked = site.cli("task", "verify", *m, str(task))
    assert checked.returncode == 0, f"{checked.stdout}\n{checked.stderr}"

    # The verifier knows where a taught class sits: a pulley is a Part, not a Container.
    wrong = site.folder / "into-a-pulley.toml"
    wrong.write_text(TASK.replace('"KitBox-1"', '"Pulley-3"'), encoding="utf-8")
    refused = site.cli("task", "verify", *m, str(wrong))
    said = refused.stdout + refused.stderr
    assert refused.returncode == 1 and "Pulley-3 is a Pulley (Pulley < Part" in said, said


KIT_QUERY = textwrap.dedent(
    """\
    SELECT ?kit ?part WHERE {
        ?kit a skm:KitBox . ?kit skm:contain ?part . ?part a/rdfs:subClassOf* skm:Part
    }"""
)


def test_the_split_deployment_runs_the_workshop_goal(site: Site) -> None:
    m = site.mesh_args
    agents = site.cli("agents", *m)
    assert agents.returncode == 0 and all(r in agents.stdout for r in ROBOTS), agents

    t0 = time.monotonic()
    done = site.cli(
        "task", "submit", *m, "--goal", GOAL, "--deadline", str(DEADLINE), timeout=DEADLINE + 30
    )
    seconds = time.monotonic() - t0
    assert done.returncode == 0, f"{done.stdout}\n{done.stderr}\n{site.logs()}"
    assert "succeeded" in done.stdout, done.stdout
    # The task agent checked every goal fact in the simulator process too.
    assert done.stdout.count("physics yes") == len(SCENARIO.goals), done.stdout
    assert "goal check (world model and physics at simulated time" in done.stdout, done.stdout

    rows = site.cli("wm", *m, "sparql", "--json", KIT_QUERY)
    assert rows.returncode == 0, f"{rows.stdout}\n{rows.stderr}"
    kits: dict[str, set[str]] = {}
    for row in json.loads(rows.stdout)["rows"]:
        kits.setdefault(row["kit"], set()).add(row["part"])
    # Another test of this module may have verified a task, never run one: only the goal's.
    assert kits == KITS, kits
    print(f"workshop split: goal {seconds:.1f} s")
