"""Goal facts checked after a task, without MuJoCo: the task service's default check (world
model only, and it says so), a ground truth that contradicts the world model, one that cannot
answer, how ``skimesh task`` prints the verdicts and its exit code when the physics
contradicts."""

from __future__ import annotations

import argparse
from collections.abc import AsyncIterator

import anyio
import pytest

from device_drivers import DeviceUnavailableError, WorldPose
from device_drivers import truth as t
from skimesh.commands._task_output import check_lines
from skimesh.commands._tasks import EXIT_CONTRADICTED, follow
from task_agent import NO_SIMULATOR, check_goal_facts, parse_goal
from task_agent.protocol import GoalCheck, SubmitGoal, TaskEvent, TaskFinished
from task_agent.service import TaskService
from tests.assets.task_fleet import PLANNER, Fleet, fleet

pytestmark = pytest.mark.anyio


class FakeTruth:
    """A simulator that knows ``objects`` and says whether each lies in its holder
    (``inside``); ``broken``: every request raises it."""

    def __init__(
        self, objects: list[str], *, inside: bool, broken: Exception | None = None
    ) -> None:
        self.objects, self.inside, self.broken = objects, inside, broken
        self.asked: list[str] = []
        self.settled: list[str] = []

    async def answer(self, request: t.TruthRequest) -> t.TruthReply:
        self.asked.append(type(request).__name__)
        if self.broken is not None and not isinstance(request, t.Scene):
            raise self.broken
        match request:
            case t.Scene():
                return t.SceneReply(time=1.0, objects=self.objects)
            case t.Settle(objects=objects):
                self.settled += objects
                return t.SettleReply(time=1.5)
            case t.ObjectIn(thing=thing, holder=holder):
                pose = WorldPose(0.5, 0.25, 0.75)
                return t.ObjectInReply(
                    time=2.0, thing=thing, holder=holder, inside=self.inside, pose=pose
                )
        raise AssertionError(f"not asked for: {request}")


async def _kit_one_gear(f: Fleet) -> tuple[str, TaskFinished]:
    """Run ``contain(kit-1, gear-1)`` on the fleet's task service (default check)."""
    goal = f"contain({f.kits[0]}, {f.parts[0]})"
    tasks = TaskService(
        wm=f.wm,
        discovery=f.discovery,
        runner=f.runner,
        publish=f.publish,
        planners=lambda _options: PLANNER,
    )
    async with anyio.create_task_group() as tg:
        await tg.start(tasks.run)
        await tasks.handle(SubmitGoal(goal=goal, task_id="kit-1"))
        await f.wait_for(TaskFinished)
        info = tasks.tasks()[0]
        tg.cancel_scope.cancel()
    (finished,) = [e for e in f.events if isinstance(e, TaskFinished)]
    assert info.check == finished.check, "task status carries the same check"
    return goal, finished


async def test_without_a_simulator_the_check_says_world_model_only() -> None:
    async with fleet(start={"r1": 1}) as f:
        _, finished = await _kit_one_gear(f)
    assert finished.outcome == "succeeded"
    check = finished.check
    assert check is not None and check.note == NO_SIMULATOR and not check.simulator
    assert [(c.fact, c.in_wm, c.physics) for c in check.facts] == [
        ("contain(kit-1, gear-1)", True, None)
    ]
    assert check.holds and not check.contradicted and check.sim_time is None
    lines = check_lines(check)
    assert lines[0] == "  goal check (world model):"
    assert "world model yes  physics cannot tell  (no simulator)" in lines[1]
    assert lines[-1] == f"  {NO_SIMULATOR}"


async def test_a_contradicting_physics_is_reported_and_exits_5() -> None:
    async with fleet(start={"r1": 1}) as f:
        goal, _ = await _kit_one_gear(f)
        parsed = parse_goal(goal, f.wm)
        truth = FakeTruth(["kit-1", "gear-1"], inside=False)
        check = await check_goal_facts(parsed, f.wm, truth)
        agrees = await check_goal_facts(parsed, f.wm, FakeTruth(["kit-1", "gear-1"], inside=True))
    assert truth.asked == ["Scene", "Settle", "ObjectIn"] and truth.settled == ["gear-1"]
    assert check.simulator and check.sim_time == 2.0
    assert [(c.in_wm, c.physics) for c in check.facts] == [(True, False)]
    assert check.contradicted == check.facts and not check.holds
    assert check.facts[0].detail == "gear-1 does not lie in kit-1 (at 0.500, 0.250, 0.750)"
    assert agrees.holds and not agrees.contradicted
    text = "\n".join(check_lines(check))
    assert "goal check (world model and physics at simulated time 2.00 s):" in text
    assert "world model yes  physics NO" in text
    assert "THE PHYSICS CONTRADICTS THE WORLD MODEL: contain(kit-1, gear-1)" in text

    async def events(check: GoalCheck | None) -> AsyncIterator[TaskEvent]:
        yield TaskFinished(task_id="t", seq=1, stamp=0.0, outcome="succeeded", check=check)

    args = argparse.Namespace(json=True, no_progress=True)
    assert await follow(args, events(check)) == EXIT_CONTRADICTED == 5
    assert await follow(args, events(agrees)) == 0
    assert await follow(args, events(None)) == 0


async def test_a_simulator_that_cannot_answer_leaves_the_facts_undecided() -> None:
    async with fleet(start={"r1": 1}) as f:
        goal, _ = await _kit_one_gear(f)
        parsed = parse_goal(goal, f.wm)
        gone = DeviceUnavailableError("the simulator stopped")
        check = await check_goal_facts(
            parsed, f.wm, FakeTruth(["kit-1", "gear-1"], inside=True, broken=gone)
        )
        unknown = await check_goal_facts(parsed, f.wm, FakeTruth(["other"], inside=True))
    assert [(c.in_wm, c.physics) for c in check.facts] == [(True, None)]
    assert check.facts[0].detail == "cannot tell: DeviceUnavailableError: the simulator stopped"
    assert "the world did not settle" in check.note and check.holds
    assert [(c.in_wm, c.physics) for c in unknown.facts] == [(True, None)]
    assert unknown.facts[0].detail.startswith("cannot tell: the simulation has no such fact")
