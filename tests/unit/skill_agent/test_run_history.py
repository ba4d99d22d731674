"""The agent's run history (``RunHistory``, bounded) and the ``RunEvents`` request: a run's
state and every event it kept, also after the core forgot the run."""

from __future__ import annotations

import pytest

from skill_agent import UnknownRunError
from skill_agent.protocol import Progress, RunEvents, RunEventsReply, RunResult, StartRun
from skill_agent.server import AgentService, RunHistory
from tests.assets.skills import Probe, Slow, Wait, entries

from .conftest import AgentFactory


def progress(run: str, seq: int) -> Progress:
    return Progress(run_id=run, agent="a", skill="s", seq=seq, state="executing")


def result(run: str, seq: int) -> RunResult:
    return RunResult(run_id=run, agent="a", skill="s", seq=seq, success=True, reason="ok")


def test_a_run_keeps_its_last_events_and_its_result_and_old_runs_are_forgotten() -> None:
    history = RunHistory(max_events=3, max_runs=2)
    for seq in range(1, 6):
        history.add(progress("a", seq))
    history.add(result("a", 6))
    kept = history.events("a")
    assert kept is not None
    events, dropped = kept
    assert [e.seq for e in events] == [4, 5, 6] and isinstance(events[-1], RunResult)
    assert dropped == 3
    assert history.events("a", after_seq=5) == ([result("a", 6)], 3)
    history.add(progress("running", 1))  # never forgotten while it runs
    for run in ("b", "c"):
        history.add(result(run, 1))
    assert "a" not in history and "b" in history and "c" in history and "running" in history
    assert history.events("nope") is None
    with pytest.raises(ValueError, match="at least one"):
        RunHistory(max_runs=0)


@pytest.mark.anyio
async def test_run_events_answers_a_runs_state_and_its_history(
    make_agent: AgentFactory, probe: Probe
) -> None:
    async with make_agent(entries(probe, Slow, Wait), keep_finished=1) as core:
        service = AgentService(core)
        started = await core.start(StartRun(skill="slow", params={"steps": 3}))
        await core.wait(started.run_id)
        reply = await service.handle(RunEvents(run_id=started.run_id))
        assert isinstance(reply, RunEventsReply) and reply.run.state == "succeeded"
        moves = [e.message for e in reply.events if isinstance(e, Progress) and e.step == "move"]
        assert moves == ["step 1/3", "step 2/3", "step 3/3"]
        assert isinstance(reply.events[-1], RunResult) and reply.events[-1].success
        seqs = [e.seq for e in reply.events]
        assert seqs == sorted(seqs) and seqs[0] == 1
        later = await service.handle(RunEvents(run_id=started.run_id, after_seq=seqs[-2]))
        assert isinstance(later, RunEventsReply) and later.events == reply.events[-1:]
        # the core forgets the run (keep_finished=1); its kept result still answers
        other = await core.start(StartRun(skill="slow", params={"steps": 1}))
        await core.wait(other.run_id)
        with pytest.raises(UnknownRunError):
            core.status(started.run_id)
        again = await service.handle(RunEvents(run_id=started.run_id))
        assert isinstance(again, RunEventsReply) and again.run.state == "succeeded"
        assert again.events == reply.events
        with pytest.raises(UnknownRunError):
            await service.handle(RunEvents(run_id="nope"))
