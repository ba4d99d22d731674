"""The run lifecycle: progress and one result, failure reasons, sensing skips, post-conditions
and effects, stop / timeout / hold violation with on_preempt, pause and resume."""

from __future__ import annotations

import statistics
import time

import anyio
import msgspec
import pytest

from skill_agent import RunStateError, SkillContext
from skill_agent.protocol import Progress, RunResult, SkillDescription, StartRun, WmWriteEntry
from skill_agent.runtime import RunContext
from tests.assets.skills import Carry, Pick, Probe, ProbedSkill, Slow, Wait, entries
from wm_store.protocol import Change, UpdateElement

from .conftest import AgentFactory, Kitting, Recorder

pytestmark = pytest.mark.anyio


def progress_of(events: list[Progress | RunResult]) -> list[Progress]:
    return [e for e in events if isinstance(e, Progress)]


async def test_lifecycle_emits_ordered_progress_then_one_result(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    recorder = Recorder()
    async with make_agent() as core:
        core.subscribe(recorder)
        started = await core.start(StartRun(skill="slow", params={"steps": 3}))
        with anyio.fail_after(5):
            result = await core.wait(started.run_id)
    events = recorder.of(started.run_id)
    assert isinstance(events[-1], RunResult) and events[-1] == result
    assert sum(isinstance(e, RunResult) for e in events) == 1
    seqs = [e.seq for e in events]
    assert seqs == list(range(1, len(events) + 1))
    steps = progress_of(events)
    assert [p.stamp for p in steps] == sorted(p.stamp for p in steps)
    states = [p.state for p in steps]
    assert states[:4] == ["pending", "pre_sense", "checking_pre", "executing"]
    assert states[-2:] == ["post_sense", "checking_post"]
    moves = [p for p in steps if p.step == "move"]
    assert [p.fraction for p in moves] == pytest.approx([1 / 3, 2 / 3, 1.0])
    assert [p.message for p in moves] == ["step 1/3", "step 2/3", "step 3/3"]
    assert all(p.state == "executing" and p.agent == "r1-agent" for p in moves)
    assert result.success and result.reason == "ok"
    assert result.started_at <= steps[0].stamp <= result.finished_at
    assert probe.methods(started.run_id) == ["pre_sense", "execute", "post_sense"]
    assert core.status(started.run_id).state == "succeeded"


async def test_skill_failure_is_execution_without_preempt(
    make_agent: AgentFactory, probe: Probe
) -> None:
    async with make_agent() as core:
        result = await core.wait((await core.start(StartRun(skill="fail"))).run_id)
    assert (result.success, result.reason) == (False, "execution")
    assert result.message == "the part slipped out of the gripper"
    assert probe.count("on_preempt") == 0
    assert core.status(result.run_id).state == "failed"


async def test_unexpected_exception_is_error_and_agent_lives_on(
    make_agent: AgentFactory, probe: Probe
) -> None:
    async with make_agent() as core:
        result = await core.wait((await core.start(StartRun(skill="buggy"))).run_id)
        assert result.reason == "error"
        assert "KeyError" in result.message and "missing calibration" in result.message
        assert result.message.startswith("execute:")
        # the hardware is brought to a safe state, and the agent still serves runs
        assert probe.count("on_preempt", result.run_id) == 1
        again = await core.wait((await core.start(StartRun(skill="noop"))).run_id)
        assert again.success


async def test_postcondition_false_without_effect_fails(
    make_agent: AgentFactory, kitting: Kitting
) -> None:
    async with make_agent() as core:
        before = kitting.wm.revision
        started = await core.start(StartRun(skill="weigh", params={"obj": kitting["gear1"]}))
        result = await core.wait(started.run_id)
    assert result.reason == "postcondition"
    assert "temperature" in result.message
    assert result.effects_revision == 0 and kitting.wm.revision == before


async def test_effects_are_committed_in_one_transaction(
    make_agent: AgentFactory, kitting: Kitting
) -> None:
    changes: list[Change] = []
    unsubscribe = kitting.wm.on_change(changes.append)
    async with make_agent() as core:
        started = await core.start(StartRun(skill="pick", params={"obj": kitting["gear2"]}))
        result = await core.wait(started.run_id)
    unsubscribe()
    assert result.success
    assert [c.revision for c in changes] == [result.effects_revision]
    assert kitting.wm.get_parent(kitting["gear2"]).id == kitting["left"]  # type: ignore[union-attr]


async def test_sensing_runs_when_stale_and_is_skipped_when_fresh(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    async with make_agent() as core:
        sensed = await core.start(StartRun(skill="pick", params={"obj": kitting["gear1"]}))
        trusting = await core.start(
            StartRun(
                skill="trusting_pick", params={"obj": kitting["gear2"], "gripper": kitting["right"]}
            )
        )
        r1, r2 = await core.wait(sensed.run_id), await core.wait(trusting.run_id)
    assert r1.success and r1.trusted_wm == []
    assert probe.methods(sensed.run_id) == ["pre_sense", "execute", "post_sense"]
    assert r2.success and r2.trusted_wm == ["pre_sense", "post_sense"]
    assert probe.methods(trusting.run_id) == ["execute"]


async def test_sensing_not_skipped_when_data_is_older_than_max_age(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    class Picky(Pick):
        description = msgspec.structs.replace(Pick.description, name="picky", sensing_max_age=0.0)

    async with make_agent(entries(probe, Picky)) as core:
        started = await core.start(StartRun(skill="picky", params={"obj": kitting["gear1"]}))
        result = await core.wait(started.run_id)
    assert result.trusted_wm == []
    assert probe.methods(started.run_id) == ["pre_sense", "execute", "post_sense"]


# --------------------------------------------------------------------------- stop, timeout


async def test_stop_cancels_at_next_await_then_on_preempt_and_is_fast(
    make_agent: AgentFactory, probe: Probe
) -> None:
    """Stop-to-result latency with a skill blocked on an Event: measured over 20 runs."""
    latencies: list[float] = []
    recorder = Recorder()
    async with make_agent() as core:
        core.subscribe(recorder)
        for i in range(20):
            started = await core.start(StartRun(skill="wait"))
            with anyio.fail_after(5):
                await probe.wait_calls("execute", i + 1)
            t0 = time.perf_counter()
            result = await core.stop(started.run_id)
            latencies.append(time.perf_counter() - t0)
            assert result.reason == "preempted" and not result.success
            assert "stopped on request" in result.message
            assert probe.methods(started.run_id) == ["pre_sense", "execute", "on_preempt"]
            last = recorder.of(started.run_id)
            assert last[-1] == result
            assert isinstance(last[-2], Progress) and last[-2].step == "preempt"
            assert core.status(started.run_id).state == "preempted"
            assert core.locks.holder(started.params["gripper"]) is None  # type: ignore[arg-type]
    print(
        f"\nstop-to-result latency over {len(latencies)} runs: "
        f"median {statistics.median(latencies) * 1e3:.2f} ms, max {max(latencies) * 1e3:.2f} ms"
    )
    assert max(latencies) < 0.5
    assert len(probe.safe_states) == 20


async def test_stop_of_an_ended_run_returns_its_result(make_agent: AgentFactory) -> None:
    async with make_agent() as core:
        started = await core.start(StartRun(skill="noop"))
        result = await core.wait(started.run_id)
        assert await core.stop(started.run_id) == result


async def test_timeout_ends_with_timeout_and_on_preempt(
    make_agent: AgentFactory, probe: Probe
) -> None:
    async with make_agent() as core:
        started = await core.start(StartRun(skill="wait", timeout=0.05))
        with anyio.fail_after(5):
            result = await core.wait(started.run_id)
    assert result.reason == "timeout"
    assert "timed out after 0.05 s in execute" in result.message
    assert probe.methods(started.run_id)[-1] == "on_preempt"
    assert 0.05 <= result.finished_at - result.started_at < 1.0


async def test_description_timeout_applies(make_agent: AgentFactory, probe: Probe) -> None:
    class Impatient(Wait):
        description = SkillDescription(
            name="impatient", parameters=Wait.description.parameters, timeout=0.02
        )

    async with make_agent(entries(probe, Impatient)) as core:
        result = await core.wait((await core.start(StartRun(skill="impatient"))).run_id)
    assert result.reason == "timeout"


class StuckPreempt(ProbedSkill):
    description = SkillDescription(name="stuck_preempt")

    async def execute(self, ctx: SkillContext) -> None:
        await anyio.sleep_forever()

    async def on_preempt(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "on_preempt")
        await anyio.sleep_forever()


async def test_on_preempt_is_time_limited(make_agent: AgentFactory, probe: Probe) -> None:
    async with make_agent(entries(probe, StuckPreempt), preempt_timeout=0.05) as core:
        started = await core.start(StartRun(skill="stuck_preempt"))
        with anyio.fail_after(5):
            result = await core.stop(started.run_id)
    assert result.reason == "preempted"
    assert "on_preempt did not finish within 0.05 s" in result.message
    assert probe.count("on_preempt") == 1


async def test_hold_violation_is_seen_through_wm_changes(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    gripper, gear = kitting["left"], kitting["gear1"]
    await kitting.move(gear, gripper)
    async with make_agent(entries(probe, Carry)) as core:
        started = await core.start(
            StartRun(skill="carry", params={"obj": gear, "gripper": gripper})
        )
        with anyio.fail_after(5):
            await probe.wait_calls("execute")
            assert core.status(started.run_id).state == "executing"
            await kitting.move(gear, kitting["kit"])  # the part slipped out
            result = await core.wait(started.run_id)
    assert result.reason == "hold_violated"
    assert gear in result.message
    assert probe.methods(started.run_id)[-1] == "on_preempt"


async def test_hold_false_at_execute_start_aborts(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    class LooseCarry(Carry):
        description = SkillDescription(
            name="loose_carry", parameters=Carry.description.parameters, hold=Carry.description.hold
        )

    async with make_agent(entries(probe, LooseCarry)) as core:
        started = await core.start(StartRun(skill="loose_carry", params={"obj": kitting["gear1"]}))
        with anyio.fail_after(5):
            result = await core.wait(started.run_id)
    assert result.reason == "hold_violated"


# --------------------------------------------------------------------------- pause


async def test_pause_holds_at_checkpoint_and_resume_releases(
    make_agent: AgentFactory, probe: Probe
) -> None:
    recorder = Recorder()
    async with make_agent() as core:
        core.subscribe(recorder)
        started = await core.start(StartRun(skill="wait"))
        run_id = started.run_id
        with anyio.fail_after(5):
            await probe.wait_calls("execute")
            await core.pause(run_id)
            assert core.status(run_id).state == "paused"
            with pytest.raises(RunStateError, match="cannot be paused"):
                await core.pause(run_id)
            probe.open("release")
            await anyio.wait_all_tasks_blocked()  # the skill is now held at its checkpoint
            assert probe.methods(run_id)[-1] == "released"
            assert core.status(run_id).state == "paused"
            await core.resume(run_id)
            result = await core.wait(run_id)
        with pytest.raises(RunStateError, match="not paused"):
            await core.resume(run_id)
    assert result.success
    assert probe.methods(run_id)[-3:] == ["released", "after_checkpoint", "post_sense"]
    states = [(p.state, p.message) for p in progress_of(recorder.of(run_id))]
    assert ("paused", "paused; holds at its next checkpoint") in states
    assert ("executing", "resumed") in states


async def test_pause_between_steps_and_stop_while_paused(
    make_agent: AgentFactory, probe: Probe
) -> None:
    async with make_agent(entries(probe, Slow)) as core:
        started = await core.start(StartRun(skill="slow", params={"steps": 1000}))
        with anyio.fail_after(5):
            await probe.wait_calls("execute")
            await core.pause(started.run_id)
            await anyio.wait_all_tasks_blocked()
            held = core.status(started.run_id)
            result = await core.stop(started.run_id)
    assert held.state == "paused"
    assert result.reason == "preempted"
    assert probe.methods(started.run_id)[-1] == "on_preempt"


# --------------------------------------------------------------------------- the context


class FakeGripper:
    def __init__(self) -> None:
        self.closed = False


class Grasp(ProbedSkill):
    """Uses the context API: its gripper's driver, elements, progress, logged WM writes."""

    description = SkillDescription(name="grasp", parameters=[*Pick.description.parameters])

    async def execute(self, ctx: SkillContext) -> None:
        driver = ctx.device("gripper", FakeGripper)
        driver.closed = True
        obj = ctx.element("obj")
        self.probe.record(ctx.run_id, f"grasped {obj.label}")
        assert isinstance(ctx, RunContext)
        await ctx.transact([UpdateElement(id=obj.id, properties={"seenAt": 1.0})])

    async def on_preempt(self, ctx: SkillContext) -> None:
        raise RuntimeError("the arm is stuck")


async def test_context_gives_drivers_elements_and_logged_writes(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    left, right = FakeGripper(), FakeGripper()
    devices = {kitting["left"]: left, kitting["right"]: right}
    gear = kitting["gear1"]
    async with make_agent(entries(probe, Grasp), devices=devices) as core:
        result = await core.wait(
            (await core.start(StartRun(skill="grasp", params={"obj": gear}))).run_id
        )
        simulated = await core.wait(
            (await core.start(StartRun(skill="grasp", params={"obj": gear}, simulate=True))).run_id
        )
    assert result.success and left.closed and not right.closed
    assert probe.methods(result.run_id) == ["pre_sense", "grasped gear-1", "post_sense"]
    assert kitting.wm.get_element(gear).properties["seenAt"] == 1.0
    writes = [e for e in core.events.history() if isinstance(e, WmWriteEntry)]
    assert [(w.run_id, w.step) for w in writes] == [(result.run_id, "execute")]  # ctx.transact
    assert simulated.success  # simulated: execute (and the device) are never touched


async def test_wrong_driver_kind_is_an_error_and_a_failing_preempt_is_reported(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    devices = {kitting["left"]: object(), kitting["right"]: object()}
    async with make_agent(entries(probe, Grasp), devices=devices) as core:
        result = await core.wait(
            (await core.start(StartRun(skill="grasp", params={"obj": kitting["gear1"]}))).run_id
        )
    assert result.reason == "error"
    assert "ParameterTypeError" in result.message and "not a FakeGripper" in result.message
    assert "on_preempt failed: RuntimeError: the arm is stuck" in result.message
