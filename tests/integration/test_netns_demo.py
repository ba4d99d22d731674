"""The kitting demo split across Linux network namespaces, each host its own, as on a site
(docs/guides/deploy-on-several-hosts.md, section 1), with the physics::

    core 10.77.42.1   skimesh router + skimesh wm --scenario kitting (durable)
    sim  10.77.42.2   skimesh sim --scenario kitting --fast (the MuJoCo world, its devices)
    r1   10.77.42.3   skimesh agent --scenario kitting --robot r1 (devices over Zenoh)
    r2   10.77.42.4   skimesh agent --scenario kitting --robot r2
    ops  10.77.42.5   skimesh task-agent, skimesh monitor, the CLI (task submit, wm sparql)

Every process is a Zenoh client of the router over the lab's bridge (tests/integration/netns.py;
no packet leaves the namespaces), with the shipped Zenoh files unchanged.

Covers: the scenario's goal, submitted from the CLI, is planned and run by both robots through
the simulated devices served from another host, and succeeds; the goal holds in the world
model (read back by ``skimesh wm sparql`` from the operations host) and in the physics: the
grippers hold nothing (read over Zenoh) and, in the last poses of the simulator's own
recording, every part lies at rest in its kit box (``object_in``, the ground truth the demo's
check uses); ``skimesh monitor`` on the operations host records the demo's kinds of entities
(the world, labels, ghosts, joints, steps, task events, the plan, changes, agents' logs). The
network itself (a link cut mid-task) is tests/integration/test_netns.py's.
"""

from __future__ import annotations

import json
import re
import subprocess
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pyarrow as pa  # type: ignore[import-untyped]  # rerun's own dependency
import pytest
import rerun.chunk

from mujoco_sim import SceneFacts, Snapshot, object_in
from mujoco_sim.models import build_scene
from scenario import load_scenario

from .netns import Lab, unavailable
from .netns_site import Site
from .procs import ROOT

pytestmark = [
    pytest.mark.netns,
    pytest.mark.slow,
    pytest.mark.sim,
    pytest.mark.zenoh,
    pytest.mark.timeout(300),
]

SCENARIO = load_scenario(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml")
ZENOH = ROOT / "configs" / "zenoh"
CLIENT = ("--config", str(ZENOH / "client.json5"))
PORT = 7447
DEADLINE = 150.0
"""Seconds the task may take (a busy 2-core machine runs the physics below real time)."""
GOAL = [
    (m.group(1), m.group(2))
    for g in SCENARIO.goals
    if (m := re.fullmatch(r"contain\(([\w-]+), ([\w-]+)\)", g))
]
"""(kit box, part) of each of the scenario's goals."""
assert len(GOAL) == len(SCENARIO.goals), f"goals other than contain(box, part): {SCENARIO.goals}"
Floats = npt.NDArray[np.float64]
Poses = tuple[Floats, Floats, Floats]
"""An entity's recorded poses: times (s), positions (n x 3), quaternions x y z w (n x 4)."""

GRIPPERS = '''
"""In-namespace: what each robot's gripper holds, from the simulated devices over Zenoh."""
import json, sys
import anyio
from device_drivers.remote import connect_devices
from meshlink import MeshConfig, open_mesh


async def main(endpoint, mesh_name, config):
    cfg = MeshConfig(connect=(endpoint,), mesh=mesh_name, config_file=config)
    async with open_mesh(cfg) as mesh:
        devices = await connect_devices(mesh, timeout=10.0)
        held = {owner: (await dev.state()).holding
                for (owner, name), dev in devices.items() if name == "gripper"}
    print(json.dumps(held), flush=True)


anyio.run(main, *sys.argv[1:])
'''


MONITORED = {
    "/world/r1.base", "/world/Gear-1", "/world/Gear-1/label", "/belief/Gear-1",
    "/robots/r1/joints", "/robots/r1/skill", "/robots/r2/progress", "/task/events",
    "/task/plan", "/task/plan/graph", "/world_model/changes", "/agents/r1/events",
}  # fmt: skip
"""What ``skimesh monitor`` on the operations host records: the demo's kinds of entities."""


def monitored(rrd: Path) -> set[str]:
    """The entities of ``rrd`` with data (poses over time, lines, the plan)."""
    return {str(chunk.entity_path) for chunk in rerun.chunk.RrdReader(rrd).stream()}


def cli(site: Site, *args: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    """``skimesh ARGS`` on the operations host, to its end."""
    return site.lab.run("ops", "-m", "skimesh", *args, timeout=timeout)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    reason = unavailable()
    if reason:
        pytest.skip(reason)
    folder = tmp_path_factory.mktemp("netns-demo")
    (folder / "grippers.py").write_text(GRIPPERS)
    with Lab(["core", "sim", "r1", "r2", "ops"]) as lab:
        s = Site(lab, f"nsd-{uuid.uuid4().hex[:8]}", folder, PORT, CLIENT)
        try:
            router = ["router", "--config", str(ZENOH / "router.json5"), "--listen", s.endpoint]
            s.skimesh("router", "core", *router).wait_stderr("listening", timeout=60)
            lab.wait_for_port("ops", lab.address("core"), PORT)
            wm = ["wm", *s.flags(), "--data", str(folder / "wm"), "--scenario", "kitting"]
            sim = ["sim", *s.flags(), "--scenario", "kitting", "--fast"]
            s.skimesh("wm", "core", *wm)
            s.skimesh("sim", "sim", *sim, "--rerun", str(folder / "sim.rrd"))
            s.children["wm"].wait_stderr("world model ready", timeout=90)
            s.children["sim"].wait_stderr("sim: scenario kitting", timeout=120)
            for robot in ("r1", "r2"):  # both at once: one registration may lose the race
                agent = ["agent", *s.flags(), "--scenario", "kitting", "--robot", robot]
                s.skimesh(robot, robot, *agent)
            s.skimesh("task agent", "ops", "task-agent", *s.flags())
            for robot in ("r1", "r2"):
                s.children[robot].wait_stderr(f"agent {robot} ready", timeout=120)
            s.children["task agent"].wait_stderr("task agent ready", timeout=90)
            monitor = ["monitor", *s.flags(), "--scenario", "kitting"]
            s.skimesh("monitor", "ops", *monitor, "--rrd", str(folder / "monitor.rrd"))
            s.children["monitor"].wait_stderr("monitor ready", timeout=120)
            yield s
        finally:
            codes = {name: child.stop() for name, child in reversed(s.children.items())}
    bad = {name: code for name, code in codes.items() if code != 0}
    assert not bad, f"components did not stop cleanly: {bad}\n{s.logs()}"


def last_poses(rrd: Path) -> dict[str, Poses]:
    """Entity -> its recorded poses in time order (a static pose at time -1)."""
    found: dict[str, list[tuple[Floats, Floats, Floats]]] = {}
    for chunk in rerun.chunk.RrdReader(rrd).stream():
        batch = chunk.to_record_batch()
        if "Transform3D:translation" not in batch.schema.names or batch.num_rows == 0:
            continue
        pos = np.asarray(batch.column("Transform3D:translation").flatten().flatten())
        quat = np.asarray(batch.column("Transform3D:quaternion").flatten().flatten())
        if chunk.is_static:
            times = np.full(batch.num_rows, -1.0)
        else:
            times = np.asarray(batch.column("sim_time").cast(pa.int64())) / 1e9
        rows = found.setdefault(str(chunk.entity_path), [])
        rows.append((times, pos.reshape(-1, 3), quat.reshape(-1, 4)))
    poses: dict[str, Poses] = {}
    for entity, rows in found.items():
        times, pos, quat = (np.concatenate(parts) for parts in zip(*rows, strict=True))
        order = np.argsort(times, kind="stable")
        poses[entity] = (times[order], pos[order], quat[order])
    return poses


def physics_kits(rrd: Path, held: set[str]) -> dict[str, set[str]]:
    """Kit box -> the goal's parts that lie in it at rest, not held, judged by ``object_in``
    on the last poses the simulator recorded (its bodies' world poses, sampled as the world
    stepped; a part's speed from its last two samples)."""
    poses = last_poses(rrd)
    model = build_scene(SCENARIO).compile()
    facts = SceneFacts.build(SCENARIO, model)
    body_pos, body_quat = np.zeros((model.nbody, 3)), np.zeros((model.nbody, 4))
    speeds: dict[str, float] = {}
    for label, info in facts.objects.items():
        assert f"/world/{label}" in poses, f"{label}: no pose in the recording"
        times, pos, quat = poses[f"/world/{label}"]
        body_pos[info.body] = pos[-1]
        body_quat[info.body] = quat[-1][[3, 0, 1, 2]]  # rerun's x y z w -> MuJoCo's w x y z
        if len(times) > 1 and times[-1] > times[-2]:
            step = float(np.linalg.norm(pos[-1] - pos[-2]))
            speeds[label] = step / float(times[-1] - times[-2])
    end = max(float(times[-1]) for times, _, _ in poses.values())
    snap = Snapshot(end, {}, body_pos, body_quat, np.zeros(0), speeds, frozenset(held))
    kits: dict[str, set[str]] = {box: set() for box, _ in GOAL}
    for box, part in GOAL:
        if object_in(snap, facts, part, box):
            kits[box].add(part)
    return kits


def wm_kits(site: Site) -> dict[str, set[str]]:
    """Kit box -> labels of what it contains, from ``skimesh wm sparql`` on the ops host."""
    query = (
        "SELECT ?box ?part WHERE { ?b a skm:KitBox ; rdfs:label ?box ; skm:contain ?p . "
        "?p rdfs:label ?part }"
    )
    done = cli(site, "wm", *site.flags(), "sparql", query)
    assert done.returncode == 0, done.stderr
    header, *rows = done.stdout.splitlines()
    assert header.split("\t") == ["box", "part"], done.stdout
    kits: dict[str, set[str]] = {}
    for row in rows:
        box, part = row.split("\t")
        kits.setdefault(box, set()).add(part)
    return kits


def test_the_demo_split_across_namespaces_reaches_its_goal_in_wm_and_physics(
    site: Site,
) -> None:
    goal = " and ".join(SCENARIO.goals)
    t0 = time.monotonic()
    submit = ["task", "submit", *site.flags(), "--goal", goal, "--json"]
    done = cli(site, *submit, "--deadline", str(DEADLINE), timeout=DEADLINE + 30)
    took = time.monotonic() - t0
    events = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    assert done.returncode == 0, f"{done.stdout[-3000:]}\n{done.stderr}\n{site.logs()}"
    assert events[-1]["event"] == "TaskFinished" and events[-1]["outcome"] == "succeeded", events
    ran = {e["agent"] for e in events if e["event"] == "StepFinished" and e["success"]}
    assert ran == {"r1", "r2"}, "both robots worked, each from its own namespace"

    expected: dict[str, set[str]] = {}
    for box, part in GOAL:
        expected.setdefault(box, set()).add(part)
    assert wm_kits(site) == expected, "the goal holds in the world model"

    grippers = site.lab.run(
        "ops", str(site.folder / "grippers.py"), site.endpoint, site.mesh, CLIENT[1]
    )
    assert grippers.returncode == 0, grippers.stderr
    held = json.loads(grippers.stdout)
    assert held == {"r1": "", "r2": ""}, f"a gripper still holds something: {held}"

    monitor = site.children.pop("monitor")
    assert monitor.stop() == 0, monitor.log()  # its recording finished
    missing = MONITORED - monitored(site.folder / "monitor.rrd")
    assert not missing, f"the monitor's recording lacks {sorted(missing)}"

    sim = site.children["sim"]
    assert sim.stop() == 0, sim.log()  # SIGTERM: the recording is flushed and closed
    assert physics_kits(site.folder / "sim.rrd", set(held.values()) - {""}) == expected, (
        "the goal holds in the physics"
    )
    print(f"goal reached in {took:.1f} s ({len(events)} task events)")
