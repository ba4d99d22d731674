"""The mission of ``skimesh demo``: submit the goal, follow it, verify it, sum it up.

:func:`run_mission` submits the goal to the task agent through a :class:`TaskClient` (over
Zenoh, as any client would), prints every event (the recording follows the mesh on its own:
:class:`skimesh.recording.MissionFeed`, as ``skimesh monitor`` does), and stops early when asked
(``stop``: the first Ctrl-C) or when the simulation fails: the task is then aborted, which
stops every run (each skill's ``on_preempt`` brings its robot to a safe state), and its last
events are still shown. Once the task ended, every goal fact is checked in the world model
and in the physics (:mod:`skimesh.demo`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import anyio

from task_agent import Goal, TaskClient, new_task_id
from task_agent.protocol import TaskFinished, TaskOptions

from .._words import counted
from ._check import FactCheck, goal_holds, verify_goal
from ._output import MissionView
from ._stack import Stack

__all__ = ["MissionResult", "run_mission", "summary_lines"]

Out = Callable[[str], None]


@dataclass
class MissionResult:
    finished: TaskFinished | None
    checks: list[FactCheck]
    interrupted: bool
    world_failure: str = ""

    @property
    def goal_reached(self) -> bool:
        """The task succeeded and every goal fact holds in the world model and the physics."""
        ok = self.finished is not None and self.finished.outcome == "succeeded"
        return ok and not self.world_failure and goal_holds(self.checks)


async def _abort_on(
    stop: anyio.Event, stack: Stack, client: TaskClient, task_id: str, out: Out
) -> None:
    """Abort the task at the first of: ``stop`` set, the world failed."""
    async with anyio.create_task_group() as tg:

        async def world_failed() -> None:
            await stack.world.wait_stopped()
            tg.cancel_scope.cancel()

        tg.start_soon(world_failed)
        await stop.wait()
        tg.cancel_scope.cancel()
    why = "interrupted (Ctrl-C)" if stop.is_set() else f"simulation failed: {stack.world.failure}"
    out(f"aborting the task: {why}; every run is stopped, robots go to a safe state")
    with anyio.CancelScope(shield=True), anyio.move_on_after(client.timeout + 20):
        out(await client.abort(task_id, why))


async def run_mission(
    stack: Stack,
    goal: Goal,
    *,
    options: TaskOptions,
    view: MissionView,
    stop: anyio.Event,
    deadline: float = math.inf,
    out: Out = print,
) -> MissionResult:
    """Run ``goal`` to its end (see the module doc); the world starts stepping now."""
    client = TaskClient(stack.mesh)
    task_id = new_task_id()
    stack.start_world()
    finished: TaskFinished | None = None
    async with client.watch(task_id, deadline=deadline, existing=False) as events:
        await client.submit_goal(goal, options=options, task_id=task_id)
        out(view.header())
        async with anyio.create_task_group() as tg:
            tg.start_soon(_abort_on, stop, stack, client, task_id, out)
            async for event in events:
                view(event)
                if isinstance(event, TaskFinished):
                    finished = event
                    break
            tg.cancel_scope.cancel()
    failure = stack.world.failure
    checks: list[FactCheck] = []
    if not stop.is_set():
        label_of = _labels(stack)
        checks = await verify_goal(goal, stack.wm, stack.world, label_of)
    return MissionResult(
        finished=finished,
        checks=checks,
        interrupted=stop.is_set(),
        world_failure=str(failure) if failure is not None else "",
    )


def _labels(stack: Stack) -> Callable[[str], str]:
    """Element id -> scenario label, for the physics checks (the simulation names its bodies
    by label); what the output shows is :func:`wm_store.display_name`."""

    def label_of(element_id: str) -> str:
        element = stack.wm.find_element(element_id)
        return element.label if element is not None and element.label else element_id

    return label_of


def summary_lines(result: MissionResult, view: MissionView, *, recording: str) -> list[str]:
    """The closing summary: verdict, facts, steps and replans, durations, the recording."""
    f = result.finished
    verdict = "GOAL REACHED" if result.goal_reached else "GOAL NOT REACHED"
    lines = [f"== {verdict}"]
    if result.interrupted:
        lines.append("   interrupted: the task was aborted, nothing was verified")
    if result.world_failure:
        lines.append(f"   the simulation failed: {result.world_failure}")
    wm_ok = sum(c.in_wm for c in result.checks)
    physical = [c for c in result.checks if c.physics is not None]
    lines += [
        f"   facts: {wm_ok}/{len(result.checks)} hold in the world model, "
        f"{sum(bool(c.physics) for c in physical)}/{len(physical)} in the physics"
    ] * bool(result.checks)
    for c in result.checks:
        wm = "yes" if c.in_wm else "NO"
        phys = {True: "yes", False: "NO", None: "-"}[c.physics]
        lines.append(f"     {c.fact:<36} world model {wm:<3}  physics {phys:<3}  {c.detail}")
    if f is not None:
        lines.append(
            f"   task {f.task_id} {f.outcome}: {counted(f.steps_run, 'step')} run, "
            f"{counted(f.replans, 'replan')}"
        )
    plan_time = sum(p.plan_seconds for p in view.plans)
    if view.plans:
        first = view.plans[0]
        lines.append(
            f"   planning: {plan_time:.2f} s in {len(view.plans)} plan(s); first plan "
            f"{counted(len(first.steps), 'step')}, estimated makespan {first.makespan:.1f} s vs "
            f"{first.sequential:.1f} s one step at a time"
        )
    if view.wall_end is not None:
        busy = sum(r.busy for r in view.robots.values())
        overlap = busy / view.sim_makespan if view.sim_makespan > 0 else 0.0
        lines.append(
            f"   makespan: {view.sim_makespan:.1f} s simulated ({view.wall_makespan:.1f} s wall); "
            f"robots busy {busy:.1f} s in total, {overlap:.2f} steps at a time on average"
        )
    for agent, stats in sorted(view.robots.items()):
        failed = f", {stats.failed} failed" if stats.failed else ""
        steps = counted(stats.steps, "step")
        lines.append(f"     {agent:<10} {steps}{failed}, busy {stats.busy:.1f} s")
    lines.append(f"   recording: {recording}")
    return lines
