"""AgentCore: refusals before anything moves, parallel runs on disjoint hardware, FIFO queue,
reload during a run, shutdown preempting every run, status and subscriptions, a loop that
never blocks."""

from __future__ import annotations

import itertools

import anyio
import pytest

from skill_agent import (
    ParameterTypeError,
    PreconditionError,
    ResourceBusyError,
    RunStateError,
    SkillContext,
    UnknownParameterError,
    UnknownRunError,
    UnknownSkillError,
    UnspecifiedParameterError,
)
from skill_agent.protocol import Progress, RunResult, SkillDescription, StartRun
from skill_agent.runtime import AgentCore, SkillEntry
from tests.assets.skills import Noop, Probe, ProbedSkill, Wait, entries
from tests.conftest import SlowSteps

from .conftest import AgentFactory, Kitting, Recorder

pytestmark = pytest.mark.anyio


def executing_stamp(recorder: Recorder, run_id: str) -> float:
    return next(
        e.stamp for e in recorder.of(run_id) if isinstance(e, Progress) and e.state == "executing"
    )


def result_of(recorder: Recorder, run_id: str) -> RunResult:
    (result,) = [e for e in recorder.of(run_id) if isinstance(e, RunResult)]
    return result


# --------------------------------------------------------------------------- refusals


async def test_start_refusals_are_precise_and_nothing_moves(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    async with make_agent() as core:
        with pytest.raises(UnknownSkillError, match="did you mean 'pick'"):
            await core.start(StartRun(skill="pik"))
        with pytest.raises(UnknownParameterError, match="objct"):
            await core.start(StartRun(skill="pick", params={"objct": kitting["gear1"]}))
        with pytest.raises(ParameterTypeError):
            await core.start(StartRun(skill="pick", params={"obj": kitting["kit"]}))
        with pytest.raises(ParameterTypeError):
            await core.start(StartRun(skill="slow", params={"steps": "many"}))
        holder = await core.start(StartRun(skill="wait", params={"gripper": kitting["left"]}))
        with pytest.raises(ResourceBusyError) as busy:
            await core.start(StartRun(skill="slow", params={"gripper": kitting["left"]}))
        assert f"device r1-left ({kitting['left']}) is busy: run {holder.run_id} holds it" in str(
            busy.value
        )
        await kitting.move(kitting["gear2"], kitting["right"])  # the right gripper is full
        with pytest.raises(PreconditionError, match=f"{kitting['right']} contains") as pre:
            await core.start(
                StartRun(
                    skill="pick", params={"obj": kitting["gear1"], "gripper": kitting["right"]}
                )
            )
        assert "pick: pre-condition false" in str(pre.value)
        assert core.locks.holder(kitting["right"]) is None
        refused = [r for r in core.runs(active_only=False) if r.skill == "pick"]
        assert [r.result.reason for r in refused if r.result] == ["precondition"]
        await core.stop(holder.run_id)
    # only the holder ever executed; the refused runs moved nothing
    assert [c.run_id for c in probe.calls if c.method == "execute"] == [holder.run_id]
    assert kitting.wm.get_parent(kitting["gear1"]).id == kitting["box"]  # type: ignore[union-attr]


async def test_unspecified_required_value_is_refused(
    make_agent: AgentFactory, probe: Probe
) -> None:
    class Needy(Noop):
        description = SkillDescription(name="needy", parameters=[*Wait.description.parameters])

    from skill_agent.protocol import ParamSpec

    class Speedy(Noop):
        description = SkillDescription(
            name="speedy",
            parameters=[
                ParamSpec(name="speed", type="float"),
                ParamSpec(name="note", type="str", optional=True),
            ],
        )

    async with make_agent(entries(probe, Speedy, Needy)) as core:
        with pytest.raises(UnspecifiedParameterError, match="speed") as refused:
            await core.start(StartRun(skill="speedy"))
        assert refused.value.param_states == {"speed": "initialized", "note": "initialized"}
        started = await core.start(StartRun(skill="speedy", params={"speed": 1.0}))
        assert core.status(started.run_id).param_states == {
            "speed": "specified",
            "note": "initialized",  # optional, without a value: the run may start
        }


async def test_start_needs_a_running_core_and_valid_run_ids(
    kitting: Kitting, make_agent: AgentFactory, probe: Probe
) -> None:
    core = AgentCore(name="idle", wm=kitting.wm, skills=entries(probe))
    with pytest.raises(RunStateError, match="not running"):
        await core.start(StartRun(skill="noop"))
    async with make_agent() as core:
        with pytest.raises(UnknownRunError):
            core.status("nope")
        with pytest.raises(Exception, match="run id"):
            await core.start(StartRun(skill="noop", run_id="a/b"))
        first = await core.start(StartRun(skill="noop", run_id="job-1"))
        assert await core.start(StartRun(skill="noop", run_id="job-1")) == first  # a retry
        with pytest.raises(RunStateError, match="taken"):
            await core.start(StartRun(skill="wait", run_id="job-1"))
        await core.wait("job-1")
    assert probe.count("execute", "job-1") == 1


# --------------------------------------------------------------------------- parallel, queue


async def test_runs_on_disjoint_hardware_overlap_and_a_conflict_is_refused(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    recorder = Recorder()
    async with make_agent() as core:
        core.subscribe(recorder)
        a = await core.start(StartRun(skill="wait", params={"gripper": kitting["left"]}))
        b = await core.start(StartRun(skill="wait", params={"gripper": kitting["right"]}))
        with anyio.fail_after(5):
            await probe.wait_calls("execute", 2)  # both are executing at once
            with pytest.raises(ResourceBusyError, match=a.run_id):
                await core.start(StartRun(skill="slow", params={"gripper": kitting["left"]}))
            assert {r.run_id for r in core.runs()} == {a.run_id, b.run_id}
            probe.open("release")
            ra, rb = await core.wait(a.run_id), await core.wait(b.run_id)
    assert ra.success and rb.success
    # overlap, read from the events: each started executing before the other finished
    assert executing_stamp(recorder, a.run_id) < rb.finished_at
    assert executing_stamp(recorder, b.run_id) < ra.finished_at


async def test_queued_runs_wait_in_fifo_order_never_interleaved(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    recorder = Recorder()
    left = kitting["left"]
    async with make_agent() as core:
        core.subscribe(recorder)
        first = await core.start(StartRun(skill="wait", params={"gripper": left}))
        queued = [
            await core.start(StartRun(skill="slow", params={"gripper": left}, queue=True))
            for _ in range(3)
        ]
        assert [core.status(q.run_id).state for q in queued] == ["pending"] * 3
        assert core.locks.statistics().waiting == [q.run_id for q in queued]
        with anyio.fail_after(5):
            probe.open("release")
            for q in queued:
                await core.wait(q.run_id)
    order = [first.run_id] + [q.run_id for q in queued]
    spans = [(executing_stamp(recorder, r), result_of(recorder, r).finished_at) for r in order]
    for (_, end), (begin, _) in itertools.pairwise(spans):
        assert end <= begin  # one after the other, in the order they were queued
    assert all(result_of(recorder, r).success for r in order)
    pending = [e for e in recorder.of(queued[0].run_id) if isinstance(e, Progress)][:2]
    assert [p.message for p in pending] == [
        f"queued for devices: r1-left ({left})",
        "devices acquired",
    ]


async def test_queued_run_checks_preconditions_when_its_turn_comes(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    left = kitting["left"]
    async with make_agent() as core:
        holder = await core.start(StartRun(skill="wait", params={"gripper": left}))
        picks = [
            await core.start(
                StartRun(skill="pick", params={"gripper": left, "obj": kitting[g]}, queue=True)
            )
            for g in ("gear1", "gear2")
        ]
        probe.open("release")
        with anyio.fail_after(5):
            await core.wait(holder.run_id)
            first, second = [await core.wait(p.run_id) for p in picks]
    assert first.success
    assert second.reason == "precondition" and "contains" in second.message


async def test_stopping_a_queued_run_withdraws_it(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    async with make_agent() as core:
        holder = await core.start(StartRun(skill="wait"))
        queued = await core.start(StartRun(skill="wait", queue=True))
        result = await core.stop(queued.run_id)
        assert result.reason == "preempted"
        assert core.locks.statistics().waiting == []
        await core.stop(holder.run_id)
    assert probe.count("execute", queued.run_id) == 0
    assert probe.count("on_preempt", queued.run_id) == 0  # it never touched the hardware


# --------------------------------------------------------------------------- reload, shutdown


class Versioned(ProbedSkill):
    description = SkillDescription(name="versioned", parameters=Wait.description.parameters)
    version = "old"

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, f"execute {self.version}")
        await self.probe.gate(f"release {self.version}").wait()
        self.probe.record(ctx.run_id, f"done {self.version}")


class VersionedNew(Versioned):
    version = "new"


async def test_reload_keeps_running_runs_on_old_code(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    async with make_agent(entries(probe, Versioned)) as core:
        old = await core.start(StartRun(skill="versioned", params={"gripper": kitting["left"]}))
        await probe.wait_calls("execute old")
        new_entry = SkillEntry(
            description=Versioned.description, factory=lambda: VersionedNew(probe), source="v2"
        )
        core.replace_skills({"versioned": new_entry, **entries(probe, Noop)})
        assert {d.name for d in core.descriptions()} == {"versioned", "noop"}
        new = await core.start(StartRun(skill="versioned", params={"gripper": kitting["right"]}))
        with anyio.fail_after(5):
            await probe.wait_calls("execute new")
            probe.open("release new")
            probe.open("release old")
            r_old, r_new = await core.wait(old.run_id), await core.wait(new.run_id)
    assert r_old.success and r_new.success
    assert probe.methods(old.run_id)[1:3] == ["execute old", "done old"]
    assert probe.methods(new.run_id)[1:3] == ["execute new", "done new"]


async def test_cancelling_run_preempts_every_active_run_before_returning(
    kitting: Kitting, probe: Probe
) -> None:
    recorder = Recorder()
    core = AgentCore(name="r1-agent", wm=kitting.wm, skills=entries(probe), robot=kitting["robot"])
    core.subscribe(recorder)
    with anyio.fail_after(5):
        async with anyio.create_task_group() as tg:
            await tg.start(core.run)
            runs = [
                await core.start(StartRun(skill="wait", params={"gripper": kitting[g]}))
                for g in ("left", "right")
            ]
            queued = await core.start(StartRun(skill="wait", queue=True))
            await probe.wait_calls("execute", 2)
            tg.cancel_scope.cancel()
        # run() has returned: every run ended, on_preempt ran for the two executing ones
    for started in runs:
        result = result_of(recorder, started.run_id)
        assert result.reason == "preempted" and result.message.startswith("the agent stopped")
        assert probe.methods(started.run_id)[-1] == "on_preempt"
    assert result_of(recorder, queued.run_id).reason == "preempted"
    assert core.runs() == []
    assert core.locks.statistics().held == {}
    with pytest.raises(RunStateError):
        await core.start(StartRun(skill="noop"))


# --------------------------------------------------------------------------- status, events


def failing(_event: object) -> None:
    raise ZeroDivisionError


async def test_status_runs_and_subscriptions(make_agent: AgentFactory, probe: Probe) -> None:
    recorder = Recorder()
    async with make_agent() as core:
        unsubscribe = core.subscribe(recorder)
        core.subscribe(failing)  # a failing subscriber never hurts a run
        started = await core.start(StartRun(skill="wait"))
        info = core.status(started.run_id)
        assert info.skill == "wait" and info.resources == [started.params["gripper"]]
        assert info.state == "executing" and info.result is None
        assert info.param_states == {"gripper": "specified"}  # inferred: initialized no more
        assert [r.run_id for r in core.runs()] == [started.run_id]
        result = await core.stop(started.run_id)
        assert core.runs() == []
        assert core.runs(active_only=False)[-1].result == result
        unsubscribe()
        unsubscribe()
        n = len(recorder.events)
        await core.wait((await core.start(StartRun(skill="noop"))).run_id)
        assert len(recorder.events) == n
        assert f"({started.params['gripper']}): " in started.inferred["gripper"]  # label (id)


async def test_event_loop_never_blocks(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe, blocking_detector: SlowSteps
) -> None:
    async with make_agent() as core:
        with anyio.fail_after(20):
            for _ in range(10):
                a = await core.start(StartRun(skill="slow", params={"gripper": kitting["left"]}))
                b = await core.start(StartRun(skill="slow", params={"gripper": kitting["right"]}))
                c = await core.start(StartRun(skill="wait", queue=True))
                await core.wait(a.run_id)
                await core.wait(b.run_id)
                await core.stop(c.run_id)
    assert not blocking_detector.reports
