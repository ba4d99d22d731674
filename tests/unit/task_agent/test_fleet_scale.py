"""A cheap scale test of planning that follows the goal: twenty simulated-outcome robots in
this process with an in-memory world model (tests.assets.task_fleet), one part into each
robot's kit. The task agent's executor must take the decomposed path (one goal part per
robot, each a small problem), run a valid plan to success, and keep every robot's steps on
that robot. The figures at 50 and 100 robots are in docs/benchmarks.md (``python -m
benchmarks.fleet``)."""

from __future__ import annotations

import pytest

from task_agent import parse_goal
from task_agent.discovery import agents_from_view
from task_agent.execution import unmet_goal
from task_agent.protocol import Planned, StepStarted
from tests.assets.task_fleet import PLANNER, fleet

pytestmark = pytest.mark.anyio

ROBOTS = 20


async def test_twenty_robots_one_kit_each_take_the_decomposed_path() -> None:
    async with fleet(robots=ROBOTS, parts=ROBOTS, time_scale=0.001) as f:
        text = f.kit_goal(*range(ROBOTS))
        done = await f.executor(planner_timeout=60.0).run_goal(parse_goal(text, f.wm))
        assert done.outcome == "succeeded", done.message
        plan = f.of(Planned)[0]
        assert isinstance(plan, Planned)
        assert plan.parts == ROBOTS, "the goal was not planned by parts"
        kits = {f.kits[i]: f"r{i + 1}" for i in range(ROBOTS)}
        placing = [s for s in plan.steps if s.skill == "place"]
        assert {kits[str(s.params["container"])] == s.agent for s in placing} == {True}
        ran = {e.agent for e in f.events if isinstance(e, StepStarted)}
        assert ran == {f"r{i}" for i in range(1, ROBOTS + 1)}
        assert unmet_goal(parse_goal(text, f.wm), f.wm) == []
        assert done.replans == 0


async def test_two_trays_go_to_two_robots() -> None:
    # Either robot can fill either tray, on a site small enough to plan whole: the goal's
    # two parts are allocated before planning, one to each robot, and both are planned apart.
    async with fleet(start={"r1": 1, "r2": 2}, time_scale=0.001) as f:
        goal = parse_goal(f.tray_goal(0, 3), f.wm)
        plan = await PLANNER.plan(agents_from_view(f.wm), f.wm, goal)
        assert plan.stats.parts == 2
        assert {s.agent for s in plan.steps} == {"r1", "r2"}
        done = await f.executor().run_goal(goal)
        assert done.outcome == "succeeded", done.message
