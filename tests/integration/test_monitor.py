"""``skimesh monitor`` started mid-task on a split deployment, each component its own process
on loopback::

    skimesh router --listen tcp/127.0.0.1:<port>
    skimesh wm --scenario kitting          skimesh sim --scenario kitting --fast --no-rerun
    skimesh agent --scenario kitting --robot all                  skimesh task-agent
    (the scenario's goal submitted; once its first step ended:)
    skimesh monitor --scenario kitting --rrd monitor.rrd

The recording, read back, holds the kinds of entities the demo's holds (see
``test_demo_recording.py``): the world's bodies moving (the objects from the simulator's
ground truth), labels, the world model's ghosts, each robot's joints, step and progress, the
task's events from ``TaskStarted`` (seq 1, fetched from the task agent's history) to its end,
each once, the plan and its graph, the world-model changes and the agents' logs, with the
demo's layout.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from scenario import load_scenario
from task_agent import TaskClient
from task_agent.protocol import StepFinished, TaskFinished

from .procs import ROOT
from .rrd import chunks, column
from .test_deploy_cli import Deployment, start_router

pytestmark = [pytest.mark.slow, pytest.mark.sim, pytest.mark.zenoh, pytest.mark.timeout(420)]

SCENARIO = load_scenario(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml")
DEADLINE = 200.0


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Deployment]:
    s = Deployment("", tmp_path_factory.mktemp("monitor"))
    try:
        start_router(s)
        connect = s.connect
        s.start("wm", "wm", *connect, "--data", str(s.folder / "wm"), "--scenario", "kitting",
                ready="world model ready")  # fmt: skip
        s.start("sim", "sim", *connect, "--scenario", "kitting", "--fast", "--no-rerun",
                ready="sim: scenario kitting", timeout=120)  # fmt: skip
        s.start("agents", "agent", *connect, "--scenario", "kitting", "--robot", "all",
                ready="agent r2 ready", timeout=120)  # fmt: skip
        s.start("task agent", "task-agent", *connect, ready="task agent ready")
        yield s
    finally:
        codes = s.stop()
        bad = {name: code for name, code in codes.items() if code != 0}
        assert not bad, f"components did not stop cleanly: {bad}"


async def _mission(site: Deployment, rrd: Path) -> tuple[str, TaskFinished]:
    """Submit the goal; once a step has ended, start the monitor; follow the task to its end
    and stop the monitor a little later."""
    goal = " and ".join(SCENARIO.goals)
    async with open_mesh(MeshConfig(connect=(site.endpoint,))) as mesh:
        client = TaskClient(mesh)
        task_id = await client.submit_goal(goal)
        async with client.watch(task_id, deadline=DEADLINE) as events:
            async for event in events:
                if isinstance(event, StepFinished):
                    break
        site.start("monitor", "-v", "monitor", *site.connect, "--scenario", "kitting",
                   "--rrd", str(rrd), ready="monitor ready", timeout=120)  # fmt: skip
        async with client.watch(task_id, deadline=DEADLINE) as events:
            async for event in events:
                if isinstance(event, TaskFinished):
                    finished = event
        monitor = site.children["monitor"]  # it says when it has recorded the task's end
        await anyio.to_thread.run_sync(monitor.wait_stderr, f"task {task_id} ended")
    return task_id, finished


def test_a_monitor_started_mid_task_records_what_the_demo_records(
    site: Deployment, tmp_path: Path
) -> None:
    rrd = tmp_path / "monitor.rrd"
    task_id, finished = anyio.run(_mission, site, rrd)
    assert finished.outcome == "succeeded", finished
    assert site.children.pop("monitor").stop() == 0
    rows: Counter[str] = Counter()
    texts: dict[str, list[str]] = {}
    labels: set[str] = set()
    moves: Counter[str] = Counter()
    for chunk in chunks(rrd):
        name = str(chunk.entity_path)
        rows[name] += chunk.num_rows
        texts.setdefault(name, []).extend(map(str, column(chunk, "TextLog:text")))
        if name.endswith("/label") and chunk.is_static:
            labels.update(map(str, column(chunk, "Points3D:labels")))
        if not chunk.is_static:
            moves[name] += len(column(chunk, "Transform3D:translation"))
    entities = set(rows)
    # the mission's entities, as the demo records them
    mission = {"/task/events", "/task/plan", "/task/plan/graph", "/world_model/changes"}
    for robot in ("r1", "r2"):
        mission |= {f"/robots/{robot}/{k}" for k in ("joints", "skill", "progress")}
    assert mission <= entities, sorted(mission - entities)
    assert any(e.startswith("/agents/") and e.endswith("/events") for e in entities), entities
    assert any(e.startswith("/belief/") for e in entities), "the world model's ghosts"
    assert {"r1", "r2", "Gear-1", "KitBox-1"} <= labels, labels
    # the world moves: both robots' bases, and a part carried (poses from the ground truth)
    assert moves["/world/r1.base"] > 1 and moves["/world/r2.base"] > 1, moves.most_common(8)
    assert moves["/world/Gear-1"] > 1, moves.most_common(8)
    # the task from seq 1 (its history, fetched at the start) to its end, each event once
    events = texts["/task/events"]
    assert sum(line.startswith(f"task {task_id} started") for line in events) == 1, events
    assert any(re.match(r"plan \d+: \d+ steps", line) for line in events), "\n".join(events)
    assert events[-1].startswith(f"task {task_id} succeeded"), events[-1]
    step_lines = [line for line in events if " started" in line and ": step " in line]
    assert len(step_lines) == finished.steps_run, "\n".join(events)  # each step once
    # the demo's layout, with its camera framed on the scene
    helper = subprocess.run(
        [sys.executable, "-m", "skimesh.recording", str(rrd), "--rbl", str(tmp_path / "l.rbl")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert helper.returncode == 0, helper.stderr
    facts = dict(line.split("=", 1) for line in helper.stdout.splitlines())
    assert facts["eye"] == "recorded"
    views = set(facts["views"].split("; "))
    assert {"Plan (arrows: must finish first)", "World-model changes", "Agents' logs"} <= views
