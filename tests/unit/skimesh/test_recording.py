"""The mission in rerun: one line per world-model change, skill calls as people read them, and
every task event on the task log, the plan document and graph, and each robot's timeline."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import rerun as rr
import rerun.chunk

from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.runtime import load_config
from skill_agent.server import agent_registration
from skill_agent.skills import Navigate, Pick, Place
from skimesh.recording import CallText, MissionRecording, step_text
from task_agent.protocol import (
    Planned,
    PlannedStep,
    Replanning,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskEvent,
    TaskFinished,
    TaskStarted,
)
from tests.unit.wm_store.stores import memory_client
from wm_store import WmClient, describe_change
from wm_store.protocol import (
    Change,
    Element,
    ElementPut,
    ElementRemoved,
    Pose,
    Position,
    Relation,
    RelationAdded,
)

ROOT = Path(__file__).resolve().parents[3]
LABELS = {"KitBox-1": "kit", "Gear-1": "gear"}


def label_of(element_id: str) -> str:
    return LABELS.get(element_id, element_id)


def test_a_change_is_one_line_with_its_revision_and_author() -> None:
    change = Change(
        revision=42,
        author="r1",
        stamp=0.0,
        deltas=[
            ElementPut(element=Element(id="Gear-1", type="Gear", label="gear")),
            RelationAdded(relation=Relation("KitBox-1", "contain", "Gear-1")),
            ElementRemoved(id="Bolt-9"),
        ],
    )
    assert describe_change(change, label_of) == (
        "rev 42 by r1: put gear (Gear-1) [Gear]; +contain(kit, gear (Gear-1)); removed Bolt-9"
    )
    many = Change(
        revision=1,
        author="demo",
        stamp=0.0,
        deltas=[ElementPut(element=Element(id=f"Gear-{i}", type="Gear")) for i in range(9)],
    )
    assert describe_change(many, label_of) == "rev 1 by demo: 9 deltas (9 new)", "from empty"


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    async with memory_client() as client:
        yield client


@pytest.mark.anyio
async def test_calls_leave_out_hardware_and_defaults(wm: WmClient) -> None:
    reply = await wm.transact(
        scenario_ops(load_scenario(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml"))
    )
    ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
    config = load_config(ROOT / "configs" / "agents" / "kitting" / "r1.toml")
    skills = [Navigate.description, Pick.description, Place.description]
    await wm.register_robot(agent_registration(config, skills))

    def labels(element_id: str) -> str:
        element = wm.find_element(element_id)
        return element.label if element is not None else element_id

    text = CallText(wm, labels)
    params = {
        "object": ids["Gear-1"],
        "holder": ids["PartBox-1"],
        "robot": ids["r1"],
        "arm": ids["r1-arm"],
        "sensor": ids["Camera-1"],
        "platform": None,
        "force": 20.0,
        "approach": 0.2,
    }
    assert text("r1", "pick", params) == "pick(object=Gear-1, holder=PartBox-1, approach=0.2)"
    assert text("r9", "pick", {"object": ids["Gear-1"]}) == "pick(object=Gear-1)"  # unknown
    assert step_text("heat", {"duration": 45.0}, labels) == "heat(duration=45.0)"


@pytest.mark.anyio
async def test_the_changes_panel_says_what_an_update_changed(wm: WmClient, tmp_path: Path) -> None:
    """Seeded from the replica by ``follow_beliefs``, a change is worded against the state
    before it: the pose from -> to, not the element put again."""
    start = Pose(Position(1.0, 0.5, 0.7))
    gear = await wm.add_element("Gear", label="gear-z", properties={"pose": start})
    path = tmp_path / "changes.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    recording = MissionRecording(rec, sim_clock=lambda: 0.0, label_of=str)
    wm.on_change(recording.wm_change)
    recording.follow_beliefs([], lambda: wm.replica.state)
    await wm.update_element(gear, {"pose": Pose(Position(0.445, -0.9981, 0.37))})
    box = await wm.add_element("Box", label="bin")
    rec.flush()
    rec.disconnect()
    lines = _texts(path)["/world_model/changes"]
    assert [line.split(": ", 1)[1] for line in lines] == [
        f"gear-z ({gear}) pose (1.000, 0.500, 0.700) -> (0.445, -0.998, 0.370)",
        f"+bin ({box}) [Box]",
    ]
    assert lines[0].startswith("rev 2 by ")


def _events() -> list[TaskEvent]:
    steps = [
        PlannedStep(index=0, agent="r1", skill="navigate", params={"goal": "Station-1"}),
        PlannedStep(index=1, agent="r1", skill="pick", params={"object": "Gear-1"}, after=[0]),
    ]
    t, at = "t-1", 0.0
    return [
        TaskStarted(task_id=t, seq=1, stamp=at, goal="contain(KitBox-1, Gear-1)"),
        Planned(task_id=t, seq=2, stamp=at, steps=steps, planner="kairos", makespan=9.0),
        StepStarted(
            task_id=t,
            seq=3,
            stamp=at,
            step=0,
            agent="r1",
            skill="navigate",
            run_id="a",
            params={"goal": "Station-1"},
        ),
        StepProgress(
            task_id=t,
            seq=4,
            stamp=at,
            step=0,
            agent="r1",
            state="executing",
            message="driving",
            fraction=0.5,
        ),
        StepFinished(
            task_id=t,
            seq=5,
            stamp=at,
            step=0,
            agent="r1",
            skill="navigate",
            success=False,
            reason="execution",
            message="blocked",
        ),
        Replanning(task_id=t, seq=6, stamp=at, attempt=1, reason="step 0 failed"),
        TaskFinished(task_id=t, seq=7, stamp=at, outcome="failed", message="gave up"),
    ]


def _texts(path: Path) -> dict[str, list[str]]:
    found: dict[str, list[str]] = {}
    for chunk in rerun.chunk.RrdReader(path).stream():
        batch = chunk.to_record_batch()
        name = str(chunk.entity_path)
        if name.startswith(("/task", "/robots", "/world_model", "/demo")) and not chunk.is_static:
            assert {"sim_time", "wall_time"} <= set(chunk.timeline_names), name
        found.setdefault(name, [])
        for column in ("TextLog:text", "TextDocument:text"):
            if column in batch.schema.names:
                for row in batch.column(column).to_pylist():
                    found[name] += [str(t) for t in row or []]
    return found


def test_task_events_go_to_the_task_log_the_plan_and_the_robots(tmp_path: Path) -> None:
    path = tmp_path / "mission.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    clock = iter(float(t) for t in range(100))
    recording = MissionRecording(
        rec, sim_clock=lambda: next(clock), label_of=label_of, robots={"r1": "robot-1"}
    )
    recording.note("hello")
    for event in _events():
        recording.task_event(event)
    recording.wm_change(Change(revision=3, author="r1", stamp=0.0, deltas=[]))
    rec.flush()
    rec.disconnect()
    texts = _texts(path)
    assert {"/" + e for e in recording.entities()} | {"/task/plan/graph"} <= set(texts)
    events = texts["/task/events"]
    assert events[0] == "task t-1 started: contain(KitBox-1, Gear-1)"
    assert "replanning (attempt 1): step 0 failed" in events
    assert events[-1].startswith("task t-1 failed: 0 steps run, 0 replans")
    assert "| 1 | r1 | `pick(object=gear)` | 0 |" in texts["/task/plan"][0]
    skill = texts["/robots/robot-1/skill"]
    assert skill[:2] == [
        "step 0 navigate(goal=Station-1) started",
        "step 0 navigate [executing] driving",
    ]
    assert skill[2] == "step 0 navigate FAILED (execution): blocked"
    assert texts["/world_model/changes"] == ["rev 3 by r1: no change"]
    assert texts["/demo/log"] == ["hello"]


def test_the_plan_graph_has_a_row_per_agent_in_planned_order(tmp_path: Path) -> None:
    def step(index: int, agent: str, start: float, after: list[int]) -> PlannedStep:
        return PlannedStep(
            index=index, agent=agent, skill="pick", params={}, after=after, start=start
        )

    steps = [step(0, "r1", 0.0, []), step(1, "r2", 0.0, []), step(2, "r1", 5.0, [0, 1])]
    steps.append(step(3, "r2", 2.0, [1]))
    path = tmp_path / "plan.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    recording = MissionRecording(rec, sim_clock=lambda: 0.0, label_of=label_of)
    recording.task_event(Planned(task_id="t", seq=1, stamp=0.0, steps=steps, planner="p"))
    rec.flush()
    rec.disconnect()
    nodes: dict[str, tuple[float, float]] = {}
    edges: list[tuple[str, str]] = []
    for chunk in rerun.chunk.RrdReader(path).stream():
        if str(chunk.entity_path) != "/task/plan/graph":
            continue
        batch = chunk.to_record_batch()
        if "GraphNodes:positions" in batch.schema.names:
            ids = batch.column("GraphNodes:node_ids").to_pylist()[0]
            where = batch.column("GraphNodes:positions").to_pylist()[0]
            nodes.update({n: (p[0], p[1]) for n, p in zip(ids, where, strict=True)})
        if "GraphEdges:edges" in batch.schema.names:
            edges += [
                (e["first"], e["second"]) for e in batch.column("GraphEdges:edges").to_pylist()[0]
            ]
    # r1's row first (its first step starts first), each row left to right by planned start
    assert nodes["0"][1] == nodes["2"][1] < nodes["1"][1] == nodes["3"][1]
    assert nodes["0"][0] == nodes["1"][0] == 0.0 < nodes["3"][0] == nodes["2"][0]
    assert sorted(edges) == [("0", "2"), ("1", "2"), ("1", "3")]


def test_task_events_are_recorded_at_their_own_times(tmp_path: Path) -> None:
    """A task joined midway: its history (fetched at once) lands where it happened on both
    timelines, ``ago`` seconds back (simulated: at the clock's pace), not at the moment it
    was fetched; a stamp ahead of this host's clock counts as now."""
    path = tmp_path / "history.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    recording = MissionRecording(
        rec,
        sim_clock=lambda: 100.0,
        sim_pace=lambda: 2.0,  # a world running twice real time
        clock=lambda: 1000.0,  # this host's clock now
        label_of=label_of,
    )
    t = "t-1"
    recording.task_event(TaskStarted(task_id=t, seq=1, stamp=970.0, goal="g"))
    recording.task_event(Replanning(task_id=t, seq=2, stamp=990.0, attempt=1, reason="r"))
    recording.task_event(TaskFinished(task_id=t, seq=3, stamp=1000.5, outcome="succeeded"))
    rec.flush()
    rec.disconnect()
    rows: list[tuple[str, float, float]] = []  # (text, sim_time, wall_time) of each event
    for chunk in rerun.chunk.RrdReader(path).stream():
        if str(chunk.entity_path) != "/task/events":
            continue
        batch = chunk.to_record_batch()
        texts = [str(t[0]) for t in batch.column("TextLog:text").to_pylist()]
        sims = batch.column("sim_time").cast("int64").to_pylist()
        walls = batch.column("wall_time").cast("int64").to_pylist()
        rows += [(t, s / 1e9, w / 1e9) for t, s, w in zip(texts, sims, walls, strict=True)]

    def at(start: str) -> tuple[float, float]:
        (found,) = [(sim, wall) for text, sim, wall in rows if text.startswith(start)]
        return found

    (started_sim, started), (replanned_sim, replanned) = at("task t-1 started"), at("replan")
    assert started_sim == pytest.approx(40.0)  # 30 s ago at 2x: 60 simulated s back
    assert replanned_sim == pytest.approx(80.0)
    assert at("task t-1 succeeded")[0] == pytest.approx(100.0)  # ahead of this host: now
    assert -31.0 < started < -29.0 and -11.0 < replanned < -9.0  # before the recording began
    assert replanned - started == pytest.approx(20.0, abs=0.1)
    assert 0.0 <= at("task t-1 succeeded")[1] < 1.0
