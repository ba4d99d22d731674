"""EventLog: history, subscribers, JSON lines read back; an agent logs runs and WM writes
(effects, and a skill's own writes through ``ctx.wm`` in ``execute`` and ``on_preempt``)."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import anyio
import pytest

from skill_agent import SkillContext, UnknownSkillError
from skill_agent.protocol import (
    LogEntry,
    ParamSpec,
    Progress,
    ProgressEntry,
    RefusedEntry,
    ResultEntry,
    RunResult,
    RunStartedEntry,
    SkillDescription,
    StartRun,
    WmWriteEntry,
)
from skill_agent.runtime import EventLog
from tests.assets.skills import Probe, entries
from tests.assets.skills.basic import ProbedSkill
from wm_store import WmClient
from wm_store.protocol import AddElement, SetRelation, UpdateElement

from .conftest import AgentFactory, Kitting

pytestmark = pytest.mark.anyio


def progress(seq: int) -> ProgressEntry:
    return ProgressEntry(
        progress=Progress(run_id="r", agent="a", skill="s", seq=seq, state="executing")
    )


def failing(_entry: LogEntry) -> None:
    raise ZeroDivisionError


def test_history_is_bounded_and_subscribers_see_every_entry() -> None:
    log = EventLog(history=3)
    seen: list[LogEntry] = []
    unsubscribe = log.subscribe(seen.append)
    log.subscribe(failing)  # a failing subscriber is logged, never raised
    for seq in range(5):
        log.record(progress(seq))
    unsubscribe()
    unsubscribe()
    log.record(progress(9))
    assert [e.progress.seq for e in log.history() if isinstance(e, ProgressEntry)] == [3, 4, 9]
    assert len(seen) == 5
    assert all(e.stamp > 0 for e in seen)


def test_json_lines_file_reads_back(tmp_path: Path) -> None:
    path = tmp_path / "logs" / "events.jsonl"
    entries: list[LogEntry] = [
        RunStartedEntry(agent="a", run_id="r", skill="s", params={"x": 1.5}, resources=["G-1"]),
        progress(1),
        WmWriteEntry(
            agent="a",
            run_id="r",
            revision=7,
            ops=[SetRelation(subject="G-1", predicate="contain", object="P-1")],
        ),
        ResultEntry(
            result=RunResult(run_id="r", agent="a", skill="s", seq=2, success=True, reason="ok")
        ),
        RefusedEntry(agent="a", skill="x", code="unknown_skill", message="no skill"),
    ]
    with EventLog(path) as log:
        for entry in entries:
            log.record(entry)
    with path.open("ab") as file:
        file.write(b'{"kind": "progress", "progr')  # a torn last line
    assert list(EventLog.read(path)) == entries
    assert path.read_text().count("\n") == len(entries)


async def test_agent_logs_runs_results_writes_and_refusals(
    tmp_path: Path, make_agent: AgentFactory, kitting: Kitting
) -> None:
    path = tmp_path / "events.jsonl"
    with EventLog(path) as log:
        async with make_agent(events=log) as core:
            started = await core.start(StartRun(skill="pick", params={"obj": kitting["gear1"]}))
            with anyio.fail_after(5):
                result = await core.wait(started.run_id)
            with pytest.raises(UnknownSkillError):
                await core.start(StartRun(skill="pik"))
    read = list(EventLog.read(path))
    kinds = [type(e).__name__ for e in read]
    assert kinds[0] == "RunStartedEntry"
    assert kinds[-2:] == ["ResultEntry", "RefusedEntry"]
    assert kinds[-3] == "WmWriteEntry"
    assert set(kinds[1:-3]) == {"ProgressEntry"}
    (write,) = [e for e in read if isinstance(e, WmWriteEntry)]
    assert write.revision == result.effects_revision > 0 and write.step == "commit"
    assert write.ops[-1] == SetRelation(
        subject=kitting["left"], predicate="contain", object=kitting["gear1"]
    )
    (start,) = [e for e in read if isinstance(e, RunStartedEntry)]
    assert start.params == started.params and "gripper" in start.inferred
    (refused,) = [e for e in read if isinstance(e, RefusedEntry)]
    assert refused.code == "unknown_skill" and "pick" in refused.message
    seqs = [e.progress.seq for e in read if isinstance(e, ProgressEntry)]
    assert seqs == sorted(seqs) and read[-2] == ResultEntry(result=result, stamp=read[-2].stamp)


class Writer(ProbedSkill):
    """Writes through ``ctx.wm`` as the library skills do: twice in ``execute`` (then waits to
    be stopped), once in ``on_preempt``."""

    description = SkillDescription(name="writer", parameters=[ParamSpec(name="obj", type="Gear")])

    async def execute(self, ctx: SkillContext) -> None:
        wm, obj = cast(WmClient, ctx.wm), str(ctx.params["obj"])
        await wm.update_element(obj, {"mass": 0.3})
        self.probe.record(ctx.run_id, f"reads mass {wm.get_element(obj).properties['mass']}")
        await wm.add_element("Gear", "spare")
        self.probe.record(ctx.run_id, "wrote")
        await anyio.sleep_forever()

    async def on_preempt(self, ctx: SkillContext) -> None:
        await cast(WmClient, ctx.wm).update_element(str(ctx.params["obj"]), {"mass": 0.1})


async def test_a_skills_own_writes_through_ctx_wm_are_logged_with_their_step(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    gear = kitting["gear1"]
    async with make_agent(entries(probe, Writer)) as core:
        run = (await core.start(StartRun(skill="writer", params={"obj": gear}))).run_id
        with anyio.fail_after(5):
            await probe.wait_calls("wrote", run_id=run)
            result = await core.stop(run)
    assert result.reason == "preempted"
    assert probe.methods(run) == ["pre_sense", "reads mass 0.3", "wrote"]
    log = core.events.history()
    writes = [e for e in log if isinstance(e, WmWriteEntry)]
    assert [(w.agent, w.run_id, w.step) for w in writes] == [
        ("r1-agent", run, "execute"),
        ("r1-agent", run, "execute"),
        ("r1-agent", run, "preempt"),
    ]
    assert [w.ops for w in writes] == [
        [UpdateElement(id=gear, properties={"mass": 0.3})],
        [AddElement(type="Gear", label="spare", ref="$new")],
        [UpdateElement(id=gear, properties={"mass": 0.1})],
    ]
    revisions = [w.revision for w in writes]
    assert revisions == sorted(set(revisions)) and revisions[-1] == kitting.wm.revision
    assert kitting.wm.get_element(gear).properties["mass"] == 0.1
    assert [e.label for e in kitting.wm.resolve_element(type="Gear", label="spare")] == ["spare"]
    safe = next(
        i
        for i, e in enumerate(log)
        if isinstance(e, ProgressEntry) and e.progress.step == "preempt"
    )
    last_write = log.index(writes[-1])
    assert safe < last_write < log.index(ResultEntry(result=result, stamp=log[-1].stamp))
