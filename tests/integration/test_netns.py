"""The system split across Linux network namespaces on one machine, as on several hosts:

    core 10.77.42.1   router (configs/zenoh/router.json5) + world-model store (durable)
    r1   10.77.42.2   skill agent r1 (kitting, simulated outcomes)
    r2   10.77.42.3   skill agent r2
    ops  10.77.42.4   task agent, the CLI (``skimesh task submit``), and a probe client

Every process is a Zenoh client of the router over the lab's bridge (tests/integration/netns.py;
no packet leaves the namespaces). The configs are the shipped ones with the lease cut to
``LEASE_MS`` (both sides: each expires a link after the lease its peer announced).

Covers: the split deployment comes up and a kitting task for both robots completes; cutting
r2's cable mid-task (``ip link set eth0 down`` inside its namespace): r2 becomes unavailable in
the world model within the lease, the task agent replans and r1 finishes the task, every
transaction acknowledged during the cut is in the store and a fresh client sees the same
content; restoring the cable brings r2 back (liveliness, ``available`` true again).
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from .netns import Lab, unavailable
from .netns_site import Site
from .procs import ROOT, Child

pytestmark = [pytest.mark.netns, pytest.mark.slow, pytest.mark.zenoh, pytest.mark.timeout(240)]

CONFIGS = ROOT / "configs" / "zenoh"
LEASE_MS = 2000
PORT = 7447
SERVE = '"skill_agent.skills:Place",\n    "skill_agent.skills:Serve",'
SIMULATION = """
[simulation]
probabilities = { navigate = 1.0, locate = 1.0, pick = 1.0, place = 1.0, serve = 1.0 }
time_scale = 0.3
seed = 1
"""
"""The kitting agents with ``serve`` (onto a tray at a station: either robot can do it) and
deterministic outcomes; navigate 1.5 s, pick / place 1.2 s: long enough to cut mid-step."""

PROBE = '''
"""In-namespace probe: a world-model client driven by JSON lines on stdin."""
import hashlib, json, sys, time
import anyio, msgspec
from scenario import load_scenario
from meshlink import MeshConfig, open_mesh
from skill_agent.client import list_agents
from scenario.wm import scenario_ops
from wm_store import WmClient, ZenohTransport
from wm_store.protocol import AddElement, Relation


def emit(obj):
    print(json.dumps(obj), flush=True)


def digest(wm):
    snap = wm.replica.state.to_snapshot()
    snap.elements.sort(key=lambda e: e.id)
    snap.relations.sort(key=lambda r: (r.subject, r.predicate, r.object))
    return hashlib.sha256(msgspec.msgpack.encode(snap)).hexdigest()


def available(wm, name):
    found = wm.resolve_element(type="Agent", label=name)
    return bool(found and found[0].properties.get("available", False))


async def state(mesh):
    async with WmClient.connect(ZenohTransport(mesh), author="probe-fresh") as fresh:
        return {"revision": fresh.revision, "digest": digest(fresh)}


async def main(endpoint, mesh_name, config, scenario):
    cfg = MeshConfig(connect=(endpoint,), mesh=mesh_name, config_file=config)
    async with open_mesh(cfg) as mesh, WmClient.connect(ZenohTransport(mesh), author="probe") as wm:
        emit({"ready": wm.revision})
        while line := await anyio.to_thread.run_sync(sys.stdin.readline):
            cmd = json.loads(line)
            if cmd["cmd"] == "scene":  # the kitting scenario, plus a tray at each station
                await wm.transact(scenario_ops(load_scenario(scenario), ontology=wm.ontology))
                trays = []
                for s in (1, 2):
                    station = wm.resolve_element(type="Station", label=f"Station-{s}")[0].id
                    where = [Relation(station, "contain", "$"), Relation("$", "at", station)]
                    trays.append(AddElement(type="Tray", label=f"Tray-{s}", relations=where,
                                            properties={"capacity": 50}))
                emit({"revision": (await wm.transact(trays)).revision})
            elif cmd["cmd"] == "write":
                acked = []
                for i in range(cmd["count"]):
                    label = f"{cmd['label']}-{i}"
                    await wm.transact([AddElement(type="Gear", label=label)], txn_id=label)
                    acked.append(label)
                emit({"acked": acked, "revision": wm.revision})
            elif cmd["cmd"] == "check":
                fresh = await state(mesh)
                await wm.wait_for_revision(fresh["revision"])
                labels = {e.label for e in wm.replica.state.elements.values()}
                missing = sorted(set(cmd["labels"]) - labels)
                emit({**fresh, "replica": digest(wm), "missing": missing})
            elif cmd["cmd"] == "available":
                t0, deadline = time.monotonic(), time.monotonic() + cmd["within"]
                while time.monotonic() < deadline:
                    alive = cmd["agent"] in await list_agents(mesh)
                    if available(wm, cmd["agent"]) == cmd["value"] == alive:
                        break
                    await anyio.sleep(0.1)
                emit({"available": available(wm, cmd["agent"]), "alive": alive,
                      "seconds": round(time.monotonic() - t0, 2)})


anyio.run(main, *sys.argv[1:])
'''


def lease_tuned(name: str, out: Path) -> Path:
    text = (CONFIGS / name).read_text()
    assert "lease: 4000" in text, f"{name} no longer sets lease: 4000"
    out.write_text(text.replace("lease: 4000", f"lease: {LEASE_MS}"))
    return out


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    reason = unavailable()
    if reason:
        pytest.skip(reason)
    folder = tmp_path_factory.mktemp("netns")
    router_cfg = lease_tuned("router.json5", folder / "router.json5")
    client_cfg = str(lease_tuned("client.json5", folder / "client.json5"))
    (folder / "probe.py").write_text(PROBE)
    for robot in ("r1", "r2"):
        text = (ROOT / "configs" / "agents" / "kitting" / f"{robot}.toml").read_text()
        place = '"skill_agent.skills:Place",'
        assert place in text, f"the kitting agent {robot} no longer has {place}"
        text = text.split("[simulation]")[0].replace(place, SERVE)
        (folder / f"{robot}.toml").write_text(text + SIMULATION)
    with Lab(["core", "r1", "r2", "ops"]) as lab:
        s = Site(lab, f"ns-{uuid.uuid4().hex[:8]}", folder)
        try:
            listen = ["--listen", s.endpoint, "--config", str(router_cfg)]
            s.skimesh("router", "core", "router", *listen, ready="listening")
            lab.wait_for_port("ops", lab.address("core"), PORT)
            store = ["-m", "skimesh", "wm", "--data", str(folder / "wm"), "--config", client_cfg]
            s.start("store", "core", *store, *s.flags(), ready="world model ready")
            scenario = str(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml")
            probe_args = [str(folder / "probe.py"), s.endpoint, s.mesh, client_cfg, scenario]
            probe = s.start("probe", "ops", *probe_args)
            probe.expect(lambda m: "ready" in m, timeout=60)
            assert "revision" in s.ask(probe, cmd="scene")
            for robot in ("r1", "r2"):
                agent = ["-m", "skimesh", "agent", "--agent-config", str(folder / f"{robot}.toml")]
                s.start(robot, robot, *agent, "--simulate", "--config", client_cfg, *s.flags())
            for robot in ("r1", "r2"):
                s.children[robot].wait_stderr(f"agent {robot} ready", timeout=60)
            task_agent = ["-m", "skimesh", "task-agent", "--config", client_cfg, *s.flags()]
            s.start("task agent", "ops", *task_agent, ready="task agent ready")
            yield s
        finally:
            for child in reversed(list(s.children.values())):
                child.stop()


def submit(site: Site, goal: str) -> Child:
    args = ["-m", "skimesh", "task", "submit", "--goal", goal, "--json", "--deadline", "120"]
    config = str(site.folder / "client.json5")
    return site.start(f"submit {goal}", "ops", *args, "--config", config, *site.flags())


def events_until_end(task: Child, on_event: Any = None) -> list[dict[str, Any]]:
    events: list[dict[str, Any]] = []
    while True:
        event = task.next_json(timeout=120)
        assert event is not None, f"task submit ended early:\n{task.log()}"
        events.append(event)
        if on_event is not None:
            on_event(event)
        if event["event"] == "TaskFinished":
            return events


def test_the_split_deployment_completes_a_task(site: Site) -> None:
    t0 = time.monotonic()
    task = submit(site, "contain(KitBox-1, Gear-1) and contain(KitBox-2, Bracket-1)")
    events = events_until_end(task)
    assert task.stop() == 0, task.log()
    done = events[-1]
    assert done["outcome"] == "succeeded", done
    agents = {e["agent"] for e in events if e["event"] == "StepFinished" and e["success"]}
    assert agents == {"r1", "r2"}, events
    assert time.monotonic() - t0 < 60


def test_a_cut_link_loses_nothing_and_the_robot_comes_back(site: Site) -> None:
    probe = site.children["probe"]
    before = site.ask(probe, cmd="check", labels=[])
    cut: list[float] = []

    lost_after: list[float] = []

    def on_event(event: dict[str, Any]) -> None:
        if not cut and event["event"] == "StepStarted" and event["agent"] == "r2":
            site.lab.link_down("r2")  # r2's cable, mid-step
            cut.append(time.monotonic())
        if event["event"] == "StepFinished" and event.get("reason") == "agent_lost":
            lost_after.append(time.monotonic() - cut[0])

    # KitBox-2 rides on r2: only r2 can fill it, so r2 works, and once its link is cut that
    # fact is lost while r1 still achieves its own: the task ends partial, saying which and why
    task = submit(site, "contain(Tray-1, Gear-3) and contain(KitBox-2, Bracket-2)")
    events = events_until_end(task, on_event)
    assert cut, f"r2 never started a step: {events}"
    done = events[-1]
    assert done["outcome"] == "partial", events
    assert done["partial"]["achieved"] == ["contain(Tray-1, Gear-3)"], done
    assert [f["fact"] for f in done["partial"]["lost"]] == ["contain(KitBox-2, Bracket-2)"], done
    assert [a["agent"] for a in done["partial"]["lost_agents"]] == ["r2"], done
    task.stop()
    lost = [e for e in events if e["event"] == "StepFinished" and e["agent"] == "r2"]
    assert [e["reason"] for e in lost if not e["success"]] == ["agent_lost"], lost
    replan = next(e for e in events if e["event"] == "Replanning")
    later = [e for e in events if e["event"] == "StepStarted" and e["seq"] > replan["seq"]]
    assert all(e["agent"] == "r1" for e in later), later
    # Noticed within the lease (plus the keep-alive period and some scheduling slack).
    assert lost_after and lost_after[0] < LEASE_MS / 1000 + 2.0, lost_after

    gone = site.ask(probe, cmd="available", agent="r2", value=False, within=10)
    assert gone["available"] is False and gone["alive"] is False, gone
    # The store kept every acknowledged transaction: the task's, and a burst during the cut.
    burst = site.ask(probe, cmd="write", label="cut", count=20)
    after = site.ask(probe, cmd="check", labels=burst["acked"])
    assert after["missing"] == [] and after["replica"] == after["digest"], after
    assert after["revision"] >= burst["revision"] > before["revision"]

    site.lab.link_up("r2")
    back = site.ask(probe, cmd="available", agent="r2", value=True, within=30)
    assert back["available"] is True and back["alive"] is True, (back, site.children["r2"].log())
    assert back["seconds"] < 15, back  # the client retries its router every <= 4 s
    print(f"r2 lost {lost_after[0]:.2f} s after the cut, back {back['seconds']:.2f} s after")
    final = site.ask(probe, cmd="check", labels=burst["acked"])
    assert final["missing"] == [] and final["revision"] >= after["revision"], final
