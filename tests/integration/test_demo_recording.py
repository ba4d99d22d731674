"""What ``skimesh demo --images`` records for the viewer, read back from the ``.rrd``: the default
layout (the 3-D view with the physics and the world model's beliefs, the plan graph, the
world-model changes, the agents' logs, each robot's progress, the cameras) with its camera
framed on the scene, labels over the robots and objects, a ghost per object at its believed
pose, the plan graph laid out in one row per agent, and the cameras' images (where EGL can
render: else the run goes on without them, and that part is skipped).

One demo run (the meal scenario: a robot and the microwave's agent, two cameras) in its own
process, as a user runs it; ``python -m skimesh.recording`` reads the recording back as
``scripts/screenshot`` does.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from .procs import ROOT
from .rrd import chunks, column

pytestmark = [pytest.mark.slow, pytest.mark.sim, pytest.mark.zenoh]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    tmp = tmp_path_factory.mktemp("demo-recording")
    rrd = tmp / "run.rrd"
    argv = [sys.executable, "-m", "skimesh", "demo", "--scenario", "meal", "--images"]
    done = subprocess.run(
        [*argv, "--rrd", str(rrd)],
        cwd=tmp,
        capture_output=True,
        text=True,
        timeout=400,
        env={**os.environ, "PYTHONUNBUFFERED": "1", "PYTHONPATH": str(ROOT)},
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return rrd, done


@pytest.mark.timeout(480)
def test_the_recording_holds_labels_ghosts_plan_changes_logs(
    run: tuple[Path, subprocess.CompletedProcess[str]],
) -> None:
    rrd, _ = run
    labels: dict[str, str] = {}
    ghosts: Counter[str] = Counter()
    rows: Counter[str] = Counter()
    positions: list[object] = []
    for chunk in chunks(rrd):
        name = str(chunk.entity_path)
        rows[name] += chunk.num_rows
        if name.endswith("/label") and chunk.is_static:
            (text,) = column(chunk, "Points3D:labels")
            labels[str(text)] = name
        if name.startswith("/belief/"):
            ghosts[name] += len(column(chunk, "Boxes3D:centers"))
        if name == "/task/plan/graph":
            positions += column(chunk, "GraphNodes:positions")
    # a label over the robot (on its base) and over each object, riding on its body
    assert labels["friend"] == "/world/friend.base/label"
    for thing in ("MealBox-1", "Tray-1", "Microwave-1"):
        assert labels[thing] == f"/world/{thing}/label", sorted(labels)
    # the world model's beliefs: a ghost per placed object; the meal box's moved with the task
    assert {"/belief/MealBox-1", "/belief/Tray-1"} <= set(ghosts), sorted(ghosts)
    assert ghosts["/belief/MealBox-1"] >= 2
    # the plan graph, its steps in rows (one per agent): two agents, two rows
    assert len({round(float(np.asarray(p)[1]), 3) for p in positions}) == 2, positions
    assert rows["/world_model/changes"] > 5
    assert rows["/agents/friend/events"] > 0 and rows["/agents/microwave/events"] > 0


@pytest.mark.timeout(480)
def test_the_layout_is_framed_on_the_scene_and_shows_the_mission(
    run: tuple[Path, subprocess.CompletedProcess[str]], tmp_path: Path
) -> None:
    rrd, done = run
    rbl = tmp_path / "layout.rbl"
    helper = subprocess.run(
        [sys.executable, "-m", "skimesh.recording", str(rrd), "--rbl", str(rbl)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert helper.returncode == 0, helper.stderr
    facts = dict(line.split("=", 1) for line in helper.stdout.splitlines())
    assert facts["eye"] == "recorded", "the demo sent a layout with its camera framed"
    views = set(facts["views"].split("; "))
    mission = {
        "World: physics, labels, world-model beliefs",
        "Plan (arrows: must finish first)",
        "Progress of each robot's step",
        "Task events",
        "World-model changes",
        "Agents' logs",
    }
    assert mission <= views, views
    if "camera images disabled" in done.stderr:
        pytest.skip("no EGL renderer on this machine: no camera images to look for")
    cameras = facts["cameras"].split(",")
    assert cameras == ["Camera-1", "friend.wrist_camera"]
    assert {"Camera-1", "friend/wrist_camera"} <= views
    frames = Counter(
        str(c.entity_path) for c in chunks(rrd) for _ in column(c, "EncodedImage:blob")
    )
    assert frames["/cameras/Camera-1"] >= 2 and frames["/cameras/friend.wrist_camera"] >= 2
