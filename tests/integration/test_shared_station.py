"""Two robots take turns at one station, in MuJoCo (``configs/scenarios/workshop-shared``):
three mobile manipulators, a goal wanting a bearing from Station-1's shelf in r1's kit and
another in r2's (and a gear from Station-3 in r3's). The whole demo stack runs in this process
(router, store, world, the three agents, the task agent on loopback Zenoh: ``demo_stack``);
the goal is submitted through a ``TaskClient``.

Checked: the task succeeds with every goal fact in the world model and in the physics; r1 and
r2 both work at Station-1, one after the other (the second drives there only after the first
has left); and the world recorded no contact between two robots' bodies during the whole run.
"""

from __future__ import annotations

import time
from pathlib import Path

import anyio
import pytest

from scenario import load_scenario
from skimesh.demo import StackOptions, agent_configs, demo_stack
from task_agent import TaskClient, new_task_id, parse_goal
from task_agent.protocol import StepFinished, StepStarted, TaskEvent, TaskFinished

from .procs import ROOT

pytestmark = [
    pytest.mark.slow,
    pytest.mark.sim,
    pytest.mark.zenoh,
    pytest.mark.anyio,
    pytest.mark.timeout(400),
]

SCENARIO_FILE = ROOT / "configs" / "scenarios" / "workshop-shared" / "scenario.toml"
DEADLINE = 300.0
"""Wall seconds the task may take (a busy 2-core machine runs the physics slowly)."""


def stays(events: list[TaskEvent], station: str) -> dict[str, tuple[float, float]]:
    """Per agent: when its drive to ``station`` started and when its drive away finished
    (the end of the task if it never left), on the task's clock."""
    started = {e.step: e for e in events if isinstance(e, StepStarted)}
    finished = {e.step: e for e in events if isinstance(e, StepFinished)}
    end = max(e.stamp for e in events)
    out: dict[str, tuple[float, float]] = {}
    for step, e in sorted(started.items()):
        if e.skill != "navigate":
            continue
        if e.params.get("goal") == station:
            out[e.agent] = (e.stamp, end)
        elif e.params.get("start") == station and e.agent in out and step in finished:
            out[e.agent] = (out[e.agent][0], finished[step].stamp)
    return out


async def test_two_robots_take_turns_at_one_station_and_never_touch(tmp_path: Path) -> None:
    scenario = load_scenario(SCENARIO_FILE)
    options = StackOptions(
        scenario=scenario, agents=agent_configs(scenario), data_dir=tmp_path / "wm", mesh="shared"
    )
    said: list[str] = []
    events: list[TaskEvent] = []
    t0 = time.monotonic()
    async with demo_stack(options, None, say=said.append) as stack:
        station = stack.ids["Station-1"]
        client = TaskClient(stack.mesh)
        task_id = new_task_id()
        stack.start_world()
        with anyio.fail_after(DEADLINE):
            async with client.watch(task_id, existing=False) as stream:
                goal = parse_goal(" and ".join(scenario.goals), stack.wm)
                await client.submit_goal(goal, task_id=task_id)
                async for event in stream:
                    events.append(event)
                    if isinstance(event, TaskFinished):
                        break
        stats = stack.world.statistics()
    done = events[-1]
    assert isinstance(done, TaskFinished)
    assert done.outcome == "succeeded", done.message
    assert done.check is not None and done.check.simulator and done.check.holds, done.check
    assert stats.robot_contact_ticks == 0, stats.first_robot_contact
    at_station = stays(events, station)
    assert {"r1", "r2"} <= set(at_station), at_station
    (first, (_, left)), (second, (came, _)) = sorted(
        ((a, at_station[a]) for a in ("r1", "r2")), key=lambda x: x[1][0]
    )
    assert came >= left, (
        f"{second} drove to Station-1 at {came:.1f} s, {first} left at {left:.1f} s"
    )
    print(
        f"shared station: {done.duration:.1f} s on the task's clock, {time.monotonic() - t0:.1f} s "
        f"wall, {stats.sim_time:.1f} s simulated; {first} then {second} at Station-1"
    )
