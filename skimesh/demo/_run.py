"""One run of ``skimesh demo``: the services up, the mission run, the summary printed and
recorded (the command, :mod:`skimesh.commands.demo`, parses the arguments, owns the recorder
and handles the signals).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import anyio

from device_drivers import DeviceError
from meshlink import MeshlinkError
from mujoco_sim import SimWorld
from mujoco_sim.recording import Recorder
from scenario import Scenario
from skill_agent import SkillError
from skill_agent.runtime import AgentConfig
from task_agent import GoalParseError, TaskError, parse_goal
from task_agent.protocol import TaskOptions
from wm_store import WmClient, WmError, display_name
from wm_store.protocol import Value

from ..errors import DemoError
from ..recording import (
    CallText,
    MissionFeed,
    MissionRecording,
    record_scene,
    step_text,
)
from ._mission import run_mission, summary_lines
from ._output import MissionView
from ._stack import StackOptions, background, demo_stack

__all__ = ["EXIT_NOT_REACHED", "EXIT_SETUP", "DemoSetup", "run_demo"]

EXIT_NOT_REACHED, EXIT_SETUP = 1, 2


@dataclass(frozen=True, kw_only=True)
class DemoSetup:
    """Everything read before the event loop starts."""

    scenario: Scenario
    agents: dict[str, AgentConfig]
    goal: str
    rrd: Path
    data: Path
    fast: bool = True
    seed: int = 0
    port: int = 0
    max_replans: int = 5
    planner_timeout: float = 60.0
    deadline: float = 1800.0
    images: bool = False
    """Camera images recorded (the recorder renders them): their views in the layout."""


SETUP_ERRORS: tuple[type[Exception], ...] = (
    DemoError,
    SkillError,
    WmError,
    MeshlinkError,
    TaskError,
    DeviceError,
)
"""What stops the demo before or outside the mission: said in one line, exit code 2."""


def _leaves(error: BaseException) -> list[BaseException]:
    if isinstance(error, BaseExceptionGroup):
        return [leaf for e in error.exceptions for leaf in _leaves(e)]
    return [error]


def _print(line: str) -> None:
    print(line, flush=True)  # live also when piped (`| tee`)


def _error(text: str) -> None:
    print(f"skimesh demo: {text}", file=sys.stderr, flush=True)


async def run_demo(setup: DemoSetup, recorder: Recorder, stop: anyio.Event) -> int:
    """Start the services, run the mission, print and record the summary, stop the services;
    returns the exit code (0: the goal holds in the world model and in the physics)."""
    started = time.monotonic()
    scenario = setup.scenario
    options = StackOptions(
        scenario=scenario,
        agents=setup.agents,
        data_dir=setup.data,
        fast=setup.fast,
        seed=setup.seed,
        port=setup.port,
    )
    live = _Live()
    robots = {name: c.robot_label for name, c in setup.agents.items()}
    recording = MissionRecording(
        recorder.rec,
        sim_clock=live.sim_time,
        label_of=live.label_of,
        call_text=live.call_text,
        robots=robots,
    )

    def say(text: str) -> None:
        _print(f"[demo] {text}")
        recording.note(text)

    say(f"scenario {scenario.name}: {scenario.description}")
    try:
        async with demo_stack(options, recorder, say=say, on_wm=live.watch(recording)) as stack:
            live.world = world = stack.world
            # the default layout framed on this world, labels, and the world model's beliefs
            await record_scene(
                recorder.rec, world, robots=list(robots.values()), images=setup.images
            )
            believed = [*(r.name for r in scenario.robots), *world.facts.objects]
            recording.follow_beliefs(believed, lambda: stack.wm.replica.state)
            goal = parse_goal(setup.goal, stack.wm)
            say(f"ready after {time.monotonic() - started:.1f} s; goal: {goal}")
            view = MissionView(sim_clock=live.sim_time, call_text=live.call_text, out=_print)
            task_options = TaskOptions(
                max_replans=setup.max_replans, planner_timeout=setup.planner_timeout
            )
            # the task's events and the agents' logs into the recording, from the mesh, by
            # the path `skimesh monitor` takes
            feed = MissionFeed(recording)
            async with background(feed.run, stack.mesh):
                result = await run_mission(
                    stack,
                    goal,
                    options=task_options,
                    view=view,
                    stop=stop,
                    deadline=setup.deadline,
                    out=_print,
                )
                if result.finished is not None:  # its last events recorded too
                    with anyio.move_on_after(10):
                        await feed.wait_ended(result.finished.task_id)
            for line in summary_lines(result, view, recording=str(setup.rrd)):
                _print(line)
                recording.note(line, level="INFO" if result.goal_reached else "WARN")
            say("stopping: task agent, skill agents, world, world model, router")
    except TimeoutError:
        _error(f"the task did not end within {setup.deadline:g} s")
        return EXIT_NOT_REACHED
    except (*SETUP_ERRORS, BaseExceptionGroup) as error:  # type: ignore[misc]  # mypy misreads *
        leaves = _leaves(error)  # a service that failed to start raises inside a task group
        if not all(isinstance(leaf, SETUP_ERRORS) for leaf in leaves):
            raise
        for leaf in leaves:
            what = "bad goal" if isinstance(leaf, GoalParseError) else type(leaf).__name__
            _error(f"{what}: {leaf}")
        return EXIT_SETUP
    _print(f"[demo] stopped cleanly after {time.monotonic() - started:.1f} s")
    return 0 if result.goal_reached else EXIT_NOT_REACHED


class _Live:
    """What the printer and the recording read from the running system, bound as it starts:
    the demo's world-model client (labels, skill descriptions) and the world (its clock)."""

    def __init__(self) -> None:
        self.wm: WmClient | None = None
        self.world: SimWorld | None = None
        self._calls: CallText | None = None

    def watch(self, recording: MissionRecording) -> Callable[[WmClient], None]:
        def connected(wm: WmClient) -> None:
            self.wm = wm
            self._calls = CallText(wm, self.label_of)
            wm.on_change(recording.wm_change)  # every change, the scene's first

        return connected

    def sim_time(self) -> float:
        return self.world.snapshot.time if self.world is not None else 0.0

    def label_of(self, element_id: str) -> str:
        """How the output and the recording name an element (:func:`wm_store.display_name`)."""
        element = self.wm.find_element(element_id) if self.wm is not None else None
        return display_name(element, element_id)

    def call_text(self, agent: str, skill: str, params: Mapping[str, Value]) -> str:
        if self._calls is None:
            return step_text(skill, params, self.label_of)
        return self._calls(agent, skill, params)
