"""Pausing a run pauses its devices: the pausable drivers of the devices it holds (not those
of another run, nor of a queued run), resumed with the run or when it ends; the deadline
stops while paused; a run stopped while paused runs on_preempt unhindered; a device that
fails to pause does not fail the pause."""

from __future__ import annotations

import time
from typing import Any

import anyio
import pytest

from device_drivers import DeviceUnavailableError
from skill_agent import RunStateError, SkillContext
from skill_agent.protocol import Progress, SkillDescription, StartRun
from skill_agent.runtime import AgentCore
from tests.assets.skills import Probe, Wait, entries
from wm_store.protocol import Value

from .conftest import AgentFactory, Kitting, Recorder

pytestmark = pytest.mark.anyio


class Held:
    """A pausable driver recording its calls."""

    def __init__(self, name: str, *, broken: bool = False) -> None:
        self.name, self.broken = name, broken
        self.calls: list[str] = []

    async def stop(self) -> None:
        self.calls.append("stop")

    async def pause(self) -> None:
        self.calls.append("pause")
        if self.broken:
            raise DeviceUnavailableError(f"{self.name}: no answer")

    async def resume(self) -> None:
        self.calls.append("resume")


class Parking(Wait):
    """``wait`` whose on_preempt passes a checkpoint (as a motion helper would), then waits
    for the probe's ``parked`` gate."""

    description = SkillDescription(
        name="parking",
        doc="Waits; its on_preempt checks, then waits too.",
        parameters=Wait.description.parameters,
    )

    async def on_preempt(self, ctx: SkillContext) -> None:
        await ctx.checkpoint()
        self.probe.record(ctx.run_id, "on_preempt")
        await self.probe.gate("parked").wait()


def grippers(kitting: Kitting, **options: bool) -> tuple[Held, Held, dict[str, object]]:
    left, right = Held("left", **options), Held("right")
    return left, right, {kitting["left"]: left, kitting["right"]: right}


async def executing(
    core: AgentCore, probe: Probe, kitting: Kitting, skill: str, **options: Any
) -> str:
    """Start ``skill`` on the left gripper and wait until it executes; its run id."""
    params: dict[str, Value] = {"gripper": kitting["left"]}
    started = await core.start(StartRun(skill=skill, params=params, **options))
    await probe.wait_calls("execute", run_id=started.run_id)
    return started.run_id


async def paused(
    core: AgentCore, probe: Probe, kitting: Kitting, skill: str, **options: Any
) -> str:
    """:func:`executing`, then paused."""
    run_id = await executing(core, probe, kitting, skill, **options)
    await core.pause(run_id)
    return run_id


async def test_pause_and_resume_reach_the_runs_devices_only(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    left, right, devices = grippers(kitting)
    recorder = Recorder()
    async with make_agent(entries(probe, Wait), devices=devices) as core:
        core.subscribe(recorder)
        with anyio.fail_after(5):
            run_id = await paused(core, probe, kitting, "wait")
            assert left.calls == ["pause"] and right.calls == []
            last = recorder.of(run_id)[-1]
            assert isinstance(last, Progress) and last.state == "paused"
            assert last.message == "held at rest: left"
            await core.resume(run_id)
            assert left.calls == ["pause", "resume"]
            probe.open("release")
            result = await core.wait(run_id)
    assert result.success
    assert left.calls == ["pause", "resume"] and right.calls == []


async def test_the_deadline_stops_while_paused_and_counts_on_after(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    _, _, devices = grippers(kitting)
    async with make_agent(entries(probe, Wait), devices=devices) as core:
        with anyio.fail_after(5):
            run_id = await paused(core, probe, kitting, "wait", timeout=0.5)
            await anyio.sleep(1.0)  # twice the run's timeout, paused
            assert core.status(run_id).result is None
            resumed = time.monotonic()
            await core.resume(run_id)
            result = await core.wait(run_id)  # the gate stays shut: it times out
    waited = time.monotonic() - resumed
    assert result.reason == "timeout"
    assert 0.1 < waited < 0.5 + 0.3  # the time left, not a fresh 0.5 s nor none


async def test_a_run_stopped_while_paused_frees_its_devices_for_on_preempt(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    left, _, devices = grippers(kitting)
    probe.open("parked")
    async with make_agent(entries(probe, Parking), devices=devices, preempt_timeout=2.0) as core:
        with anyio.fail_after(5):
            run_id = await paused(core, probe, kitting, "parking")
            result = await core.stop(run_id)
    assert result.reason == "preempted" and "on_preempt" not in result.message
    assert probe.count("on_preempt", run_id) == 1
    assert left.calls == ["pause", "resume"]  # released before on_preempt


async def test_a_run_being_stopped_cannot_be_paused(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    left, _, devices = grippers(kitting)
    async with make_agent(entries(probe, Parking), devices=devices) as core:
        with anyio.fail_after(5):
            run_id = await executing(core, probe, kitting, "parking")
            async with anyio.create_task_group() as tg:
                tg.start_soon(core.stop, run_id)
                await probe.wait_calls("on_preempt", run_id=run_id)
                with pytest.raises(RunStateError, match="being stopped"):
                    await core.pause(run_id)
                probe.open("parked")
    assert left.calls == []


async def test_a_queued_run_paused_leaves_the_devices_of_the_run_ahead_alone(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    left, _, devices = grippers(kitting)
    async with make_agent(entries(probe, Wait), devices=devices) as core:
        params: dict[str, Value] = {"gripper": kitting["left"]}
        first = await core.start(StartRun(skill="wait", params=params))
        queued = await core.start(StartRun(skill="wait", params=params, queue=True))
        with anyio.fail_after(5):
            await probe.wait_calls("execute")
            await core.pause(queued.run_id)
            assert core.status(queued.run_id).state == "paused"
            assert left.calls == []
            await core.stop(queued.run_id)
            await core.stop(first.run_id)


async def test_a_device_that_cannot_pause_does_not_fail_the_pause(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe, caplog: pytest.LogCaptureFixture
) -> None:
    _, _, devices = grippers(kitting, broken=True)
    async with make_agent(entries(probe, Wait), devices=devices) as core:
        with anyio.fail_after(5):
            run_id = await paused(core, probe, kitting, "wait")
            assert core.status(run_id).state == "paused"
            await core.resume(run_id)
            probe.open("release")
            assert (await core.wait(run_id)).success
    assert "cannot pause left" in caplog.text
