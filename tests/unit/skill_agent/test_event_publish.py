"""The event log on the wire: entries round-trip as MessagePack, name their agent and run, and
the agent's publisher sends them on ``agents/<a>/events`` in the bursts of the run events,
before the run's result."""

from __future__ import annotations

import anyio
import anyio.lowlevel
import pytest

from meshlink import KeySpace
from meshlink.rpc import encode
from skill_agent import UnknownSkillError
from skill_agent.protocol import (
    LogEntry,
    Progress,
    ProgressEntry,
    RefusedEntry,
    ResultEntry,
    RunResult,
    RunStartedEntry,
    StartRun,
    WmWriteEntry,
    decode_event,
    decode_log_entry,
)
from skill_agent.runtime import AgentCore, EventLog, entry_agent, entry_run
from skill_agent.server import RunEventPublisher
from wm_store.protocol import AddElement, SetRelation

from .conftest import AgentFactory, Kitting

pytestmark = pytest.mark.anyio

PROGRESS = Progress(run_id="r.1", agent="a1", skill="s", seq=1, state="executing")
RESULT = RunResult(run_id="r", agent="a1", skill="s", seq=9, success=True, reason="ok")
ENTRIES: list[LogEntry] = [
    RunStartedEntry(agent="a1", run_id="r", skill="s", params={"x": 1.5}, resources=["G-1"]),
    ProgressEntry(progress=PROGRESS, stamp=2.0),
    WmWriteEntry(
        agent="a1",
        run_id="r.1",
        revision=7,
        ops=[
            AddElement(type="Gear", label="g"),
            SetRelation(subject="A", predicate="p", object="B"),
        ],
    ),
    ResultEntry(result=RESULT),
    RefusedEntry(agent="a1", skill="t", code="unknown_skill", message="no skill t"),
]


def test_entries_round_trip_and_name_their_agent_and_run() -> None:
    for entry in ENTRIES:
        assert decode_log_entry(encode(entry)) == entry
    assert {entry_agent(e) for e in ENTRIES} == {"a1"}
    assert [entry_run(e) for e in ENTRIES] == ["r", "r.1", "r.1", "r", ""]
    assert KeySpace("m").agent_events("a1") == "skimesh/m/agents/a1/events"
    assert KeySpace("m").agents_events() == "skimesh/m/agents/*/events"


class RecordingMesh:
    """What RunEventPublisher uses of a Mesh: its keys and ``put``."""

    def __init__(self) -> None:
        self.keys = KeySpace("m")
        self.puts: list[tuple[str, bytes]] = []
        self.first = anyio.Event()

    def put(self, key: str, payload: bytes) -> None:
        self.puts.append((key, payload))
        self.first.set()

    def entries(self) -> list[LogEntry]:
        return [decode_log_entry(p) for k, p in self.puts if k.endswith("/events")]


async def test_entries_go_out_in_the_bursts_of_the_run_events_before_the_result() -> None:
    mesh = RecordingMesh()
    publisher = RunEventPublisher(mesh, "a1", max_delay=0.05)  # type: ignore[arg-type]
    async with anyio.create_task_group() as tg:
        tg.start_soon(publisher.run)
        publisher.record(ENTRIES[0])
        publisher.record(ENTRIES[1])
        assert mesh.puts == [], "entries wait for company, like progress"
        with anyio.fail_after(2):
            await mesh.first.wait()
        assert mesh.entries() == ENTRIES[:2]
        publisher.record(ENTRIES[3])  # the core logs a result before it publishes it
        publisher.publish(RESULT)
        with anyio.fail_after(2):
            while len(mesh.puts) < 4:  # the next loop turns, not max_delay
                await anyio.lowlevel.checkpoint()
        keys = [k for k, _ in mesh.puts[2:]]
        assert keys == ["skimesh/m/agents/a1/events", "skimesh/m/agents/a1/runs/r/progress"]
        assert decode_event(mesh.puts[-1][1]) == RESULT, "the result flushed both at once"
        tg.cancel_scope.cancel()


async def test_a_result_waits_for_no_company_only_for_the_reply_to_go_first() -> None:
    """A result goes out with what is pending in the loop's next turns, long before
    ``max_delay``; a task that was waiting for it (a ``call``'s reply) runs before the puts."""
    mesh = RecordingMesh()
    publisher = RunEventPublisher(mesh, "a1", max_delay=30.0)  # type: ignore[arg-type]
    order: list[str] = []
    done = anyio.Event()

    async def replier() -> None:
        await done.wait()
        order.append(f"reply after {len(mesh.puts)} puts")

    async with anyio.create_task_group() as tg:
        tg.start_soon(publisher.run)
        tg.start_soon(replier)
        await anyio.lowlevel.checkpoint()
        publisher.record(ENTRIES[0])
        publisher.publish(RESULT)
        done.set()  # the core wakes the run's waiters once the result is published
        with anyio.fail_after(2):
            while len(mesh.puts) < 2:
                await anyio.lowlevel.checkpoint()
        assert order == ["reply after 0 puts"]
        assert decode_event(mesh.puts[-1][1]) == RESULT
        tg.cancel_scope.cancel()


async def test_an_attached_core_publishes_its_whole_log_in_order(
    make_agent: AgentFactory, kitting: Kitting
) -> None:
    mesh = RecordingMesh()
    log = EventLog()
    async with make_agent(events=log) as core:
        assert isinstance(core, AgentCore)
        publisher = RunEventPublisher(mesh, core.name)  # type: ignore[arg-type]
        detach = publisher.attach(core)
        started = await core.start(StartRun(skill="pick", params={"obj": kitting["gear1"]}))
        with anyio.fail_after(5):
            await core.wait(started.run_id)
        detach()
        publisher.flush()
        with pytest.raises(UnknownSkillError):
            await core.start(StartRun(skill="pik"))
        publisher.flush()
    published = mesh.entries()
    assert published == log.history()[: len(published)]
    assert [type(e) for e in published[-2:]] == [WmWriteEntry, ResultEntry]
    assert len(log.history()) > len(published), "nothing is published once detached"
