"""One monitor: join the mesh, mirror the scenario's world, follow everything into rerun.

:func:`run_monitor` opens a Zenoh session and a read-only world-model client (its replica:
labels, skills' descriptions, beliefs), builds the scenario's model locally (:class:`~mujoco_sim
.recording.Mirror`, on a worker thread), sends the demo's layout framed on it, then follows
until cancelled:

- the world (:class:`~._world.WorldFeed`): devices' states, objects' poses, the clock;
- the mission (:class:`skimesh.recording.MissionFeed`, the path ``skimesh demo`` records
  through): every task's events (a running task from its kept history, seq 1), the plan and
  its graph, each robot's step and progress, every agent's event log;
- the world model: each change in words and the beliefs' ghosts
  (:meth:`~skimesh.recording.MissionRecording.wm_change`, :meth:`~skimesh.recording.
  MissionRecording.follow_beliefs`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial

import anyio
from anyio.abc import TaskStatus

from meshlink import Mesh
from mujoco_sim.recording import Mirror, Recorder
from scenario import Scenario
from wm_store import WmClient, ZenohTransport, display_name
from wm_store.protocol import Value

from ..recording import (
    CallText,
    MissionFeed,
    MissionRecording,
    scene_cameras,
    scene_layout,
    send_layout,
    step_text,
)
from ._clock import MeshClock
from ._world import WorldFeed

__all__ = ["Monitor", "MonitorOptions", "run_monitor"]

_log = logging.getLogger("skimesh.monitor")


@dataclass(frozen=True, kw_only=True)
class MonitorOptions:
    """What :func:`run_monitor` follows, and how often."""

    scenario: Scenario
    images: bool = False
    """Render the scenario's cameras from the mirrored world (needs EGL)."""
    rate: float = 25.0
    """Samples of the world per wall second."""
    truth_period: float = 0.2
    """Seconds between two requests of the objects' poses to the simulator."""
    timeout: float = 5.0
    """Seconds to wait for the world model and the task agent."""
    recent: float = 0.0
    """Also record the tasks that ended within this many seconds (from their history)."""


@dataclass
class Monitor:
    """A running monitor's parts (for checks and the command's lines)."""

    recording: MissionRecording
    mission: MissionFeed
    world: WorldFeed
    wm: WmClient


class _Names:
    """How the recording names elements and skill calls: from the replica once connected."""

    def __init__(self) -> None:
        self.wm: WmClient | None = None
        self.calls: CallText | None = None

    def label_of(self, element_id: str) -> str:
        element = self.wm.find_element(element_id) if self.wm is not None else None
        return display_name(element, element_id)

    def call_text(self, agent: str, skill: str, params: Mapping[str, Value]) -> str:
        if self.calls is None:
            return step_text(skill, params, self.label_of)
        return self.calls(agent, skill, params)


async def run_monitor(
    mesh: Mesh,
    options: MonitorOptions,
    recorder: Recorder,
    *,
    say: Callable[[str], None] = print,
    task_status: TaskStatus[Monitor] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Follow ``mesh`` into ``recorder`` until cancelled (see the module doc); ``started``
    with the :class:`Monitor` once everything is followed."""
    scenario = options.scenario
    clock, names = MeshClock(), _Names()
    robots = {r.name: r.name for r in scenario.robots}
    recording = MissionRecording(
        recorder.rec,
        sim_clock=clock,
        sim_pace=lambda: clock.pace,
        label_of=names.label_of,
        call_text=names.call_text,
        robots=robots,
    )
    mirror = await anyio.to_thread.run_sync(Mirror, scenario)
    cameras = tuple(scene_cameras(scenario)) if options.images else ()
    await anyio.to_thread.run_sync(partial(mirror.start, recorder, cameras=cameras))
    layout = await anyio.to_thread.run_sync(
        partial(
            scene_layout,
            mirror.model,
            mirror.data,
            robots=list(robots),
            objects=list(mirror.plant.facts.objects),
        )
    )
    send_layout(recorder.rec, layout, robots=list(robots.values()), cameras=cameras)
    transport = ZenohTransport(mesh)
    async with WmClient.connect(transport, author="monitor", timeout=options.timeout) as wm:
        names.wm, names.calls = wm, CallText(wm, names.label_of)
        say(f"world model at revision {wm.replica.revision}")
        wm.on_change(recording.wm_change)
        believed = [*robots, *mirror.plant.facts.objects]
        recording.follow_beliefs(believed, lambda: wm.replica.state)
        world = WorldFeed(
            mirror, recorder, clock, wm=wm, rate=options.rate, truth_period=options.truth_period
        )
        mission = MissionFeed(recording, timeout=options.timeout, recent=options.recent)
        async with anyio.create_task_group() as tg:
            await tg.start(world.run, mesh)
            await tg.start(mission.run, mesh)
            task_status.started(Monitor(recording, mission, world, wm))
            await anyio.sleep_forever()
