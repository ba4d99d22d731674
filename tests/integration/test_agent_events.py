"""A skill agent's event log as a mesh stream, over real Zenoh on loopback: a world-model store
and an agent, each in its own process (``skimesh agent --agent-config ...`` with the
``event_log`` key set), read from the test with :class:`EventFeed`.

Covers: a run's entries (run started, progress, the skill's world-model write made through
``ctx.wm`` as library skills write, the result) and
a refused start reach one agent's and every agent's subscribers in order, exactly as the agent
appended them to its JSON-lines file; payloads that are no log entry are skipped and logged;
the demo's follower records the entries into an ``.rrd``; the task agent lists each step's
world-model writes in ``StepFinished``.
"""

from __future__ import annotations

import logging
import textwrap
import uuid
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path

import anyio
import pytest
import rerun as rr
import rerun.chunk

from meshlink import Mesh, MeshConfig, open_mesh
from meshlink.rpc import encode
from skill_agent import UnknownSkillError
from skill_agent.client import AgentClient, EventFeed
from skill_agent.protocol import (
    LogEntry,
    ProgressEntry,
    RefusedEntry,
    ResultEntry,
    RunResult,
    RunStartedEntry,
    WmWriteEntry,
)
from skill_agent.runtime import EventLog
from skimesh.recording import AgentEventLines, record_agent_events, step_text
from task_agent import TaskClient
from task_agent.protocol import StepFinished, StepStarted, TaskEvent
from task_agent.service import serve_tasks
from wm_store import WmClient, ZenohTransport
from wm_store.protocol import AddElement

from .procs import Child, start_store

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.anyio]

MARK = """
from skill_agent.protocol import ParamSpec, SkillDescription
from skill_agent import Skill
from wm_store.protocol import AddElement


class Mark(Skill):
    description = SkillDescription(
        name="mark",
        doc="Adds one gear to the world model.",
        parameters=[ParamSpec(name="label", type="str", kind="offline", default="gear")],
    )

    async def execute(self, ctx):
        await ctx.progress("adding", fraction=0.0)
        await ctx.wm.transact([AddElement(type="Gear", label=ctx.params["label"])])
        await ctx.progress("added", fraction=1.0)
"""

CONFIG = """
name = "marker"
event_log = "events.jsonl"

[robot]
type = "Robot"
label = "marker-robot"

[skills]
paths = ["{skill}"]
"""

TASK = """
name = "mark once"

[root]
block = "sequence"

[[root.children]]
block = "call"
agent = "marker"
skill = "mark"
params = {{ label = "{label}" }}
"""


@dataclass
class Site:
    endpoint: str
    mesh: str
    folder: Path

    @asynccontextmanager
    async def session(self) -> AsyncIterator[Mesh]:
        async with open_mesh(MeshConfig(connect=(self.endpoint,), mesh=self.mesh)) as mesh:
            yield mesh


@pytest.fixture(scope="module")
def site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    folder = tmp_path_factory.mktemp("events")
    (folder / "mark.py").write_text(MARK)
    config = folder / "marker.toml"
    config.write_text(textwrap.dedent(CONFIG.format(skill=folder / "mark.py")))
    s = Site(module_router, f"it-{uuid.uuid4().hex[:10]}", folder)
    flags = ["--connect", s.endpoint, "--mesh", s.mesh]
    store = start_store(s.endpoint, s.mesh, folder / "wm")
    agent: Child | None = None
    try:
        agent = Child(
            ["-m", "skimesh", "agent", "--agent-config", str(config), *flags], name="agent"
        )
        agent.wait_stderr("agent marker ready")
        yield s
    finally:
        if agent is not None:
            agent.stop()
        store.stop()


async def until_refused(feed: EventFeed) -> list[LogEntry]:
    """The feed's entries up to and including the first refused start."""
    entries: list[LogEntry] = []
    with anyio.fail_after(10):
        async for entry in feed:
            entries.append(entry)
            if isinstance(entry, RefusedEntry):
                return entries
    raise AssertionError("the feed ended")


async def mark_and_refuse(mesh: Mesh, label: str) -> RunResult:
    """Run ``mark`` on the agent, then ask for a skill it does not have."""
    client = AgentClient(mesh, "marker")
    result = await client.run("mark", {"label": label}, deadline=20)
    assert result.success, result.message
    with pytest.raises(UnknownSkillError):
        await client.start("mrak")
    return result


async def test_a_run_reaches_subscribers_in_order_as_in_the_agents_file(site: Site) -> None:
    async with (
        site.session() as mesh,
        EventFeed.open(mesh, "marker") as mine,
        EventFeed.open(mesh) as every,
    ):
        result = await mark_and_refuse(mesh, "gear-feed")
        received, everyone = await until_refused(mine), await until_refused(every)
    assert everyone == received
    started, *middle, last, refused = received
    assert isinstance(started, RunStartedEntry) and started.run_id == result.run_id
    assert started.skill == "mark" and started.params == {"label": "gear-feed"}
    assert last == ResultEntry(result=result, stamp=last.stamp)
    assert isinstance(refused, RefusedEntry) and refused.code == "unknown_skill"
    progress = [e.progress for e in middle if isinstance(e, ProgressEntry)]
    assert [p.seq for p in progress] == sorted(p.seq for p in progress)
    (write,) = [e for e in middle if isinstance(e, WmWriteEntry)]
    assert write.run_id == result.run_id and write.revision > 0 and write.step == "execute"
    assert write.ops == [AddElement(type="Gear", label="gear-feed")]
    messages = [e.progress.message if isinstance(e, ProgressEntry) else "WRITE" for e in middle]
    assert messages.index("adding") < messages.index("WRITE") < messages.index("added")
    assert [e.stamp for e in received] == sorted(e.stamp for e in received)
    logged = list(EventLog.read(site.folder / "events.jsonl"))  # the `event_log` TOML key
    first = logged.index(started)
    assert logged[first : first + len(received)] == received, "the stream is the file"


async def test_payloads_that_are_no_entry_are_skipped_and_logged(
    site: Site, caplog: pytest.LogCaptureFixture
) -> None:
    good = RefusedEntry(agent="ghost", skill="s", code="unknown_skill", message="m", stamp=1.0)
    other = RefusedEntry(agent="other", skill="s", code="unknown_skill", message="m", stamp=2.0)
    caplog.set_level(logging.WARNING, logger="skill_agent.client")
    async with site.session() as listener, site.session() as talker:
        key = talker.keys.agent_events("ghost")
        async with EventFeed.open(listener, "ghost") as ghost, EventFeed.open(listener) as every:
            talker.put(talker.keys.agent_events("other"), encode(other))
            talker.put(key, b"\xc1 not msgpack")
            talker.put(key, encode(RunResult(run_id="r", agent="ghost", skill="s", seq=1,
                                             success=True, reason="ok")))  # fmt: skip
            talker.delete(key)
            talker.put(key, encode(good))
            with anyio.fail_after(10):
                assert await ghost.receive() == good, "one agent's feed: its own entries"
                assert [await every.receive(), await every.receive()] == [other, good]
    assert ghost.skipped == every.skipped == 3
    warned = [r.getMessage() for r in caplog.records if r.name.startswith("skill_agent.client")]
    assert len(warned) == 6 and all(key in line for line in warned)
    assert sum("undecodable" in line for line in warned) == 4


class Lines(AgentEventLines):
    """Lines that say when the refused start arrived."""

    def __init__(self, rec: rr.RecordingStream) -> None:
        super().__init__(
            rec,
            sim_clock=lambda: 0.0,
            wall_clock=anyio.current_time,
            label_of=str,
            call_text=lambda _agent, skill, params: step_text(skill, params, str),
            flush_every=600.0,  # one send, when the follower stops
        )
        self.refused = anyio.Event()

    def add(self, entry: LogEntry) -> None:
        super().add(entry)
        if isinstance(entry, RefusedEntry):
            self.refused.set()


async def test_the_recording_follows_the_agents_events(site: Site, tmp_path: Path) -> None:
    path = tmp_path / "agents.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    lines = Lines(rec)
    async with site.session() as mesh, anyio.create_task_group() as tg:
        await tg.start(record_agent_events, mesh, lines)
        result = await mark_and_refuse(mesh, "gear-rrd")
        with anyio.fail_after(10):
            await lines.refused.wait()
        tg.cancel_scope.cancel()
    rec.flush()
    rec.disconnect()
    texts, chunks = [], 0
    for chunk in rerun.chunk.RrdReader(path).stream():
        if str(chunk.entity_path) == "/agents/marker/events":
            assert {"sim_time", "wall_time"} <= set(chunk.timeline_names)
            chunks += 1
            column = chunk.to_record_batch().column("TextLog:text").to_pylist()
            texts += [str(t) for row in column for t in row or []]
    run = result.run_id
    assert chunks == 1, "batched: sent once"
    assert texts[0] == f"run {run}: mark(label=gear-rrd) started"
    assert texts[1].startswith(f"run {run} wrote rev ") and texts[1].endswith(": add gear-rrd")
    assert texts[2].startswith(f"run {run}: mark succeeded in ")
    assert texts[3].startswith("refused mrak (run ") and ": unknown_skill: no skill" in texts[3]
    assert len(texts) == 4, "progress is on the robots' timelines already"


async def test_the_task_agent_lists_each_steps_world_model_writes(site: Site) -> None:
    events: list[TaskEvent] = []
    async with (
        site.session() as mesh,
        WmClient.connect(ZenohTransport(mesh), author="test") as wm,
        EventFeed.open(mesh, "marker") as feed,
        anyio.create_task_group() as tg,
    ):
        await tg.start(lambda task_status: serve_tasks(mesh, wm, operator=None,
                                                       task_status=task_status))  # fmt: skip
        client = TaskClient(mesh, timeout=10.0)
        done = await client.run_file(TASK.format(label="gear-task"), on_event=events.append)
        assert done.outcome == "succeeded", done.message
        (step,) = [e for e in events if isinstance(e, StepStarted)]
        revisions: list[int] = []
        with anyio.fail_after(10):
            async for entry in feed:
                if isinstance(entry, WmWriteEntry) and entry.run_id == step.run_id:
                    revisions.append(entry.revision)
                if isinstance(entry, ResultEntry) and entry.result.run_id == step.run_id:
                    break
        tg.cancel_scope.cancel()
    (finished,) = [e for e in events if isinstance(e, StepFinished)]
    assert finished.success and finished.wm_writes == revisions and len(revisions) == 1
