"""The site event log without a mesh: its SQLite store, the translation of each source's
messages into records, time parsing and export."""

from __future__ import annotations

import io
import json
import sqlite3
from pathlib import Path

import msgspec
import pytest

from device_drivers import BaseState, GripperState, Pose2D
from device_drivers.protocol import BaseStateReply, GripperStateReply
from skill_agent.protocol import Progress, ProgressEntry, ResultEntry, RunResult, RunStartedEntry
from skimesh.commands.events import parse_time
from skimesh.eventlog import (
    EventFilter,
    EventLogError,
    EventRecord,
    EventRecorder,
    EventStore,
    Translator,
    export_format,
    write_jsonl,
    write_parquet,
)
from task_agent.protocol import StepFinished, StepProgress, StepStarted, TaskFinished
from wm_store.protocol import Change, Element, ElementPut


def record(stamp: float, **fields: str) -> EventRecord:
    return EventRecord(stamp=stamp, kind=fields.pop("kind", "task"), event="e", **fields)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- store
def test_the_store_keeps_records_in_order_and_filters_on_every_field(tmp_path: Path) -> None:
    store = EventStore(tmp_path / "log.sqlite")
    last = store.append(
        [
            record(10.0, robot="r1", task="t1", skill="pick", outcome="succeeded", text="Pick A"),
            record(20.0, robot="r2", task="t1", skill="place", outcome="failed", text="place B"),
            record(30.0, kind="wm", robot="cli", text="rev 3 by cli"),
        ],
        wm_revision=3,
    )
    assert last == 3
    everything = store.query(EventFilter())
    assert [r.seq for r in everything] == [1, 2, 3]
    assert everything[0].text == "Pick A" and everything[0].stamp == 10.0
    assert [r.seq for r in store.query(EventFilter(robot="r2"))] == [2]
    assert [r.seq for r in store.query(EventFilter(task="t1", skill="pick"))] == [1]
    assert [r.seq for r in store.query(EventFilter(outcome="failed"))] == [2]
    assert [r.seq for r in store.query(EventFilter(kinds=["wm"]))] == [3]
    assert [r.seq for r in store.query(EventFilter(since=20.0))] == [2, 3]
    assert [r.seq for r in store.query(EventFilter(until=20.0))] == [1]
    assert [r.seq for r in store.query(EventFilter(text="pick"))] == [1]  # any case
    assert [r.seq for r in store.query(EventFilter(), after=1, limit=1)] == [2]
    info = store.info()
    assert (info.count, info.last_seq, info.wm_revision) == (3, 3, 3)
    assert (info.first_stamp, info.last_stamp) == (10.0, 30.0)
    store.close()


def test_the_store_survives_a_reopen_and_never_lowers_the_revision(tmp_path: Path) -> None:
    path = tmp_path / "log.sqlite"
    store = EventStore(path)
    store.append([record(1.0)], wm_revision=7)
    store.close()
    again = EventStore(path)
    again.append([record(2.0)], wm_revision=5)  # an older revision must not win
    assert again.info().wm_revision == 7
    assert [r.seq for r in again.query(EventFilter())] == [1, 2]
    again.close()


def test_a_file_that_is_no_event_log_is_refused_with_its_name(tmp_path: Path) -> None:
    path = tmp_path / "notes.sqlite"
    path.write_bytes(b"this is not a database" * 100)
    with pytest.raises(EventLogError, match=r"notes\.sqlite"):
        EventStore(path)


def test_a_filter_value_is_never_spliced_into_the_sql(tmp_path: Path) -> None:
    store = EventStore(tmp_path / "log.sqlite")
    store.append([record(1.0, robot="r1")])
    hostile = "r1' OR '1'='1"
    assert store.query(EventFilter(robot=hostile)) == []
    assert store.query(EventFilter(text="%' OR 1=1 --")) == []
    store.close()
    assert sqlite3.connect(tmp_path / "log.sqlite").execute(
        "SELECT COUNT(*) FROM events"
    ).fetchone() == (1,)


# --------------------------------------------------------------------------- translation
def test_runs_are_tied_to_their_task_and_repeated_progress_is_dropped() -> None:
    t = Translator()
    started = t.task_event(
        StepStarted(
            task_id="t1", seq=2, stamp=1.0, step=0, agent="r1", skill="pick", run_id="run-a"
        )
    )
    assert started is not None and (started.task, started.run, started.robot) == (
        "t1",
        "run-a",
        "r1",
    )
    entry = RunStartedEntry(agent="r1", run_id="run-a", skill="pick", stamp=1.1)
    run = t.run_entry(entry)
    assert run is not None and run.task == "t1" and run.kind == "run"
    sub = t.run_entry(RunStartedEntry(agent="r1", run_id="run-a.1", skill="grasp", stamp=1.2))
    assert sub is not None and sub.task == "t1"  # a composite's sub-run belongs to the task too

    def progress(seq: int, message: str) -> ProgressEntry:
        p = Progress(
            run_id="run-a", agent="r1", skill="pick", seq=seq, state="executing", message=message
        )
        return ProgressEntry(progress=p, stamp=1.0 + seq)

    assert t.run_entry(progress(1, "reaching")) is not None
    assert t.run_entry(progress(2, "reaching")) is None  # the same state and message
    assert t.run_entry(progress(3, "closing")) is not None
    step = StepProgress(task_id="t1", seq=3, stamp=2.0, step=0, agent="r1", state="executing")
    assert t.task_event(step) is not None
    assert t.task_event(msgspec.structs.replace(step, seq=4)) is None

    result = RunResult(
        run_id="run-a",
        agent="r1",
        skill="pick",
        seq=9,
        success=False,
        reason="execution",
        message="slipped",
    )
    ended = t.run_entry(ResultEntry(result=result, stamp=3.0))
    assert ended is not None and ended.outcome == "failed" and "slipped" in ended.text
    finished = t.task_event(
        StepFinished(
            task_id="t1",
            seq=5,
            stamp=3.1,
            step=0,
            agent="r1",
            skill="pick",
            success=False,
            reason="failed",
        )
    )
    assert finished is not None and finished.run == "run-a" and finished.outcome == "failed"
    done = t.task_event(
        TaskFinished(task_id="t1", seq=6, stamp=4.0, outcome="failed", duration=3.0)
    )
    assert done is not None and done.outcome == "failed"
    late = t.run_entry(RunStartedEntry(agent="r1", run_id="run-a", skill="pick", stamp=5.0))
    assert late is not None and late.task == "t1"  # an entry arriving after its task ended
    assert json.loads(done.data)["outcome"] == "failed"  # the source message, as JSON


def test_device_states_become_transitions_only() -> None:
    t = Translator()

    def base(moving: bool) -> BaseStateReply:
        return BaseStateReply(state=BaseState(pose=Pose2D(), moving=moving))

    assert t.device_state("r1", "base", base(False), 1.0) is None  # the first sets the state
    assert t.device_state("r1", "base", base(False), 1.1) is None
    moved = t.device_state("r1", "base", base(True), 1.2)
    assert moved is not None and moved.kind == "device" and moved.robot == "r1"
    assert "moving" in moved.text
    assert t.device_state("r2", "base", base(True), 1.3) is None  # another device: its own state
    grip = GripperStateReply(state=GripperState(opening=0.0, holding=""))
    assert t.device_state("r1", "gripper", grip, 2.0) is None
    took = GripperStateReply(state=GripperState(opening=0.02, holding="Gear-1"))
    held = t.device_state("r1", "gripper", took, 2.1)
    assert held is not None and "holding Gear-1" in held.text


def test_a_world_model_change_is_worded_against_the_changes_before_it() -> None:
    t = Translator()
    gear = Element(id="Gear-1", type="Gear", label="gear", properties={"mass": 0.1})
    change = Change(revision=4, deltas=[ElementPut(element=gear)], stamp=9.0, author="r1")
    r = t.change(change)
    assert (r.kind, r.robot, r.stamp) == ("wm", "r1", 9.0)
    assert r.text == "rev 4 by r1: put gear (Gear-1) [Gear]", "not seen before: new or not"
    heavier = Element(id="Gear-1", type="Gear", label="gear", properties={"mass": 0.25})
    change = Change(revision=5, deltas=[ElementPut(element=heavier)], stamp=9.5, author="cli")
    assert t.change(change).text == "rev 5 by cli: gear (Gear-1) mass 0.1 -> 0.25"


# --------------------------------------------------------------------------- time and export
def test_times_are_read_as_ago_iso_or_epoch() -> None:
    assert parse_time("10m", now=1000.0) == 400.0
    assert parse_time("2h", now=10000.0) == 10000.0 - 7200.0
    assert parse_time("1d", now=100000.0) == 100000.0 - 86400.0
    assert parse_time("1795850000.5") == 1795850000.5
    assert parse_time("2026-11-28T08:00:00+00:00") == 1795852800.0
    import argparse

    with pytest.raises(argparse.ArgumentTypeError, match="no time"):
        parse_time("yesterday-ish")


def test_export_writes_json_lines_and_parquet_that_read_back(tmp_path: Path) -> None:
    records = [record(1.0, robot="r1", text="a"), record(2.0, robot="r2", text="b")]
    out = io.BytesIO()
    assert write_jsonl(records, out) == 2
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert [line["robot"] for line in lines] == ["r1", "r2"]
    assert export_format("x.PARQUET") == "parquet" and export_format("x.jsonl") == "jsonl"
    pq = pytest.importorskip("pyarrow.parquet")
    path = tmp_path / "events.parquet"
    assert write_parquet(records, path) == 2
    table = pq.read_table(path)
    assert table.column("text").to_pylist() == ["a", "b"]
    assert table.column("stamp").to_pylist() == [1.0, 2.0]


# --------------------------------------------------------------------------- tying runs to tasks
@pytest.mark.anyio
async def test_a_run_entry_that_arrives_before_its_step_is_held_and_tied() -> None:
    store = EventStore(":memory:")
    recorder = EventRecorder(store, tie_grace=60.0)
    t = recorder.translator
    recorder.add(t.run_entry(RunStartedEntry(agent="r1", run_id="run-b", skill="pick", stamp=1.0)))
    await recorder.flush()
    assert store.query(EventFilter()) == [], "held: its step may still come"
    recorder.add(
        t.task_event(
            StepStarted(
                task_id="t2", seq=2, stamp=1.1, step=0, agent="r1", skill="pick", run_id="run-b"
            )
        )
    )
    await recorder.flush()
    tied = store.query(EventFilter(task="t2", kinds=["run"]))
    assert [r.run for r in tied] == ["run-b"]
    recorder.add(t.run_entry(RunStartedEntry(agent="r2", run_id="run-c", skill="place", stamp=2.0)))
    await recorder.flush(everything=True)  # at a stop nothing stays held
    assert [r.run for r in store.query(EventFilter(robot="r2"))] == ["run-c"]


def test_a_step_that_names_a_stored_run_tags_its_entries_and_sub_runs() -> None:
    store = EventStore(":memory:")
    store.append(
        [
            EventRecord(stamp=1.0, kind="run", event="result", run="run-d"),
            EventRecord(stamp=1.0, kind="run", event="result", run="run-d.1"),
            EventRecord(stamp=1.0, kind="run", event="result", run="run-dd"),
        ]
    )
    store.append([], runs=[("run-d", "t3")])
    assert [r.run for r in store.query(EventFilter(task="t3"))] == ["run-d", "run-d.1"]
