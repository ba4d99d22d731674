"""The agents' event logs in the mission recording: one line per run started, result, refused
start and world-model write (progress left out), batched per agent, on both timelines."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import rerun as rr
import rerun.chunk

from skill_agent.protocol import (
    LogEntry,
    Progress,
    ProgressEntry,
    RefusedEntry,
    ResultEntry,
    RunResult,
    RunStartedEntry,
    WmWriteEntry,
)
from skimesh.recording import MissionRecording, describe_ops, entry_line
from wm_store.protocol import (
    AddElement,
    Observe,
    Op,
    RemoveElement,
    SetRelation,
    UnsetRelation,
    UpdateElement,
    Value,
)

LABELS = {"KitBox-1": "kit", "Gear-1": "gear", "Gripper-1": "gripper"}


def label_of(element_id: str) -> str:
    return LABELS.get(element_id, element_id)


def call(_agent: str, skill: str, params: Mapping[str, Value]) -> str:
    return f"{skill}({', '.join(f'{k}={label_of(str(v))}' for k, v in params.items())})"


def entries(agent: str = "r1") -> list[LogEntry]:
    result = RunResult(
        run_id="a",
        agent=agent,
        skill="pick",
        seq=4,
        success=True,
        reason="ok",
        started_at=10.0,
        finished_at=12.5,
        effects_revision=8,
    )
    return [
        RunStartedEntry(
            agent=agent,
            run_id="a",
            skill="pick",
            params={"object": "Gear-1"},
            resources=["Gripper-1"],
        ),
        ProgressEntry(
            progress=Progress(run_id="a", agent=agent, skill="pick", seq=1, state="executing")
        ),
        WmWriteEntry(
            agent=agent,
            run_id="a",
            revision=8,
            ops=[SetRelation(subject="Gripper-1", predicate="contain", object="Gear-1")],
        ),
        ResultEntry(result=result),
        RefusedEntry(agent=agent, skill="place", code="resource_busy", message="Gripper-1 busy"),
    ]


def test_lines_say_what_the_task_events_do_not() -> None:
    lines = [entry_line(e, label_of, call) for e in entries()]
    assert lines == [
        ("run a: pick(object=gear) started; locks gripper", "INFO"),
        None,  # progress: on the robot's skill timeline already
        ("run a wrote rev 8: +contain(gripper, gear)", "INFO"),
        ("run a: pick succeeded in 2.50 s, effects rev 8", "INFO"),
        ("refused place: resource_busy: Gripper-1 busy", "WARN"),
    ]
    sub = RunStartedEntry(agent="r1", run_id="a.1", skill="grasp", parent="a", queued=True)
    assert entry_line(sub, label_of, call) == (
        "run a.1: grasp() started (queued) as a sub-run of a",
        "INFO",
    )
    failed = RunResult(
        run_id="b", agent="r1", skill="pick", seq=3, success=False, reason="error", message="boom"
    )
    assert entry_line(ResultEntry(result=failed), label_of, call) == (
        "run b: pick error: boom",
        "ERROR",
    )


def test_writes_are_described_op_by_op_then_counted() -> None:
    ops: list[Op] = [
        AddElement(type="Gear", label="gear-9"),
        UpdateElement(id="Gear-1", properties={"pose": None}, remove=["color"]),
        Observe(id="Gear-1", property="mass", value=0.2, source="scale"),
        UnsetRelation(subject="KitBox-1", predicate="contain", object="Gear-1"),
        RemoveElement(id="Gear-1"),
    ]
    assert describe_ops(ops, label_of) == (
        "add gear-9, update gear (pose, color), observe gear.mass, -contain(kit, gear), remove gear"
    )
    many = [AddElement(type="Gear") for _ in range(9)]
    assert describe_ops(many, label_of).endswith("add Gear, 3 more ops")
    assert describe_ops([], label_of) == "no op"


def read(path: Path) -> tuple[dict[str, list[str]], dict[str, int]]:
    texts: dict[str, list[str]] = {}
    chunks: dict[str, int] = {}
    for chunk in rerun.chunk.RrdReader(path).stream():
        name = str(chunk.entity_path)
        if not name.startswith("/agents/"):
            continue
        assert {"sim_time", "wall_time"} <= set(chunk.timeline_names), name
        chunks[name] = chunks.get(name, 0) + 1
        batch = chunk.to_record_batch()
        texts[name] = texts.get(name, []) + [
            str(t) for row in batch.column("TextLog:text").to_pylist() for t in row or []
        ]
    return texts, chunks


def test_entries_are_recorded_per_agent_in_one_send_each(tmp_path: Path) -> None:
    path = tmp_path / "agents.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    clock = iter(float(t) for t in range(100))
    recording = MissionRecording(
        rec, sim_clock=lambda: next(clock), label_of=label_of, call_text=call
    )
    for entry in [*entries("r1"), *entries("r2")]:
        recording.agent_entry(entry)
    assert recording.agents.due_in() <= recording.agents.flush_every
    recording.agents.flush()
    assert recording.agents.due_in() == float("inf")
    recording.agents.max_lines = 2  # a long burst is sent before it is due
    for entry in entries("r3")[:3]:
        recording.agent_entry(entry)
    rec.flush()
    rec.disconnect()
    texts, chunks = read(path)
    assert {"agents/r1/events", "agents/r2/events"} <= set(recording.entities())
    assert texts["/agents/r1/events"] == texts["/agents/r2/events"]
    assert len(texts["/agents/r1/events"]) == 4 and chunks["/agents/r1/events"] == 1
    assert texts["/agents/r1/events"][2] == "run a: pick succeeded in 2.50 s, effects rev 8"
    assert len(texts["/agents/r3/events"]) == 2, "sent once max_lines were waiting"
