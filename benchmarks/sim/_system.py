"""The simulation benchmark's system under test, in three layouts (:data:`LAYOUTS`).

Each runs in this process the world (``SimWorld``) with a :class:`Tap` recorder (rerun to a
file, plus every control tick's set-points for the replay) and its devices served on one
session (``serve_devices``); the workload (:mod:`benchmarks.sim._workload`) drives them
through the remote proxies (``connect_devices``), via a Zenoh router on 127.0.0.1 (free port,
multicast scouting off):

- *deployed*: the router in this process too; the workload in a client process of its own
  (:mod:`benchmarks.sim._client`), as skill agents are;
- *router-apart*: the same with the router in a process of its own as well, as ``skimesh
  router`` runs it;
- *in-process*: router and workload (from a second session) in this process, sharing its loop
  and its GIL.

Child processes start while the world is built; the client is stopped by PID before the world
and its server stop, the router after them. The :class:`Window` is marked in this process
whatever the layout, so the figures are this process's.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import anyio
import numpy as np

from benchmarks.common import Child, cpu_seconds, start_router_child
from benchmarks.sim._client import serve_truth
from benchmarks.sim._workload import drive
from device_drivers import WorldPose
from device_drivers.remote import connect_devices, serve_devices
from meshlink import MeshConfig, open_mesh
from meshlink.testing import running_router
from mujoco_sim import SimWorld, WorldOptions, sim_devices
from mujoco_sim.recording import Recorder
from scenario import Scenario
from skimesh.runtime import settle_heap

__all__ = ["LAYOUTS", "Tap", "Window", "WorldTruth", "full_system"]

LAYOUTS = ("deployed", "router-apart", "in-process")
"""Where the workload's client and the router run (see the module doc)."""


class Tap(Recorder):
    """A recorder that also keeps, every control tick, what run 2 replays (so the plant calls
    it every tick; it records at its own rate as usual). The rows go into preallocated arrays
    (four row copies per tick, so that the figure is the system's, not the tap's; the tap's
    cost: docs/benchmarks.md, section "Simulation")."""

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self._rows: list[np.ndarray[Any, Any]] = []  # a row a tick: see ticks()
        self._count = 0
        self._sources: tuple[np.ndarray[Any, Any], ...] = ()  # set by start(): no row before

    def start(self, model: Any, data: Any, **kw: Any) -> None:
        super().start(model, data, **kw)  # (samples the initial state: no tick's row)
        # views into the model's and data's buffers, which never move: taken once
        self._sources = (data.ctrl, data.eq_active, model.actuator_forcerange, model.eq_data)
        self._rows = [np.empty((4096, *a.shape), a.dtype) for a in self._sources]

    @property
    def next_sample(self) -> float:
        return -math.inf

    def sample(self, model: Any, data: Any) -> None:
        if self._sources:
            i = self._count
            if i == len(self._rows[0]):  # full: twice the room
                self._rows = [np.concatenate([rows, np.empty_like(rows)]) for rows in self._rows]
            ctrl, active, force, eq = self._rows
            c, a, f, e = self._sources
            ctrl[i], active[i], force[i], eq[i] = c, a, f, e
            self._count = i + 1
        if data.time + 1e-9 >= super().next_sample:
            super().sample(model, data)

    @property
    def count(self) -> int:
        """Ticks recorded so far."""
        return self._count

    def ticks(self, start: int, stop: int) -> list[tuple[Any, Any, Any, Any]]:
        """The recorded ticks ``start:stop``, copies: (ctrl, eq_active, actuator force ranges,
        eq_data: a weld's relative pose is set when it grasps)."""
        ctrl, active, force, eq = (rows[start:stop].copy() for rows in self._rows)
        return list(zip(ctrl, active, force, eq, strict=True))


class Window:
    """The measured stretch of one run, marked in the simulator's process (by the workload's
    :meth:`~benchmarks.sim._workload.Truth.mark`, or at the end of a time-limited run): wall
    and simulated time, the control ticks recorded, CPU seconds of this process (every
    thread: the router, the loop, the simulation, rerun) and of the client process."""

    def __init__(self, world: SimWorld, tap: Tap, client: int | None = None) -> None:
        self.world, self.tap, self.client = world, tap, client
        self.began, self.ended = anyio.Event(), anyio.Event()
        self.marks: list[tuple[float, float, int, float, float]] = []

    def mark(self, end: bool) -> None:
        if len(self.marks) != (1 if end else 0):
            return  # a second end (a limited run that finished anyway)
        client = cpu_seconds(self.client) if self.client is not None else 0.0
        now = (time.perf_counter(), self.world.snapshot.time, self.tap.count)
        self.marks.append((*now, time.process_time(), client))
        (self.ended if end else self.began).set()

    def figures(self) -> dict[str, Any]:
        (wall0, sim0, tick0, cpu0, client0), (wall1, sim1, tick1, cpu1, client1) = self.marks
        return {
            "wall": wall1 - wall0,
            "sim": sim1 - sim0,
            "cpu": cpu1 - cpu0,
            "client_cpu": client1 - client0,
            "ticks": self.tap.ticks(0, tick1),  # all: the replay starts where the run did
            "first_tick": tick0,
        }


class WorldTruth:
    """:class:`~benchmarks.sim._workload.Truth` read from the world itself (this process)."""

    def __init__(self, world: SimWorld, window: Window) -> None:
        self.world, self.window = world, window

    async def pose(self, name: str) -> WorldPose:
        return self.world.body_pose(name)

    async def object_in(self, label: str, container: str) -> bool:
        return self.world.object_in(label, container)

    async def sleep(self, seconds: float) -> None:
        await self.world.sleep(seconds)

    async def mark(self, end: bool) -> None:
        self.window.mark(end)


async def full_system(
    scenario: Scenario,
    *,
    layout: str,
    fast: bool,
    picks: int,
    rrd: Path,
    limit: float | None = None,
    sensor_period: float = 0.5,
) -> dict[str, Any]:
    """Run the workload on the whole stack in ``layout`` (see :data:`LAYOUTS`); return the
    window's figures, success, slips. With ``limit``: ``limit`` wall seconds of it, no success.
    ``sensor_period``: see :func:`~benchmarks.sim._workload.drive`."""
    tap = Tap(path=rrd, recording_id=f"bench-{scenario.name}")
    mesh = f"bench-{scenario.name}"
    try:
        with _router(apart=layout == "router-apart") as endpoint, contextlib.ExitStack() as stack:
            config = MeshConfig(connect=(endpoint,), mesh=mesh)
            child = None
            if layout != "in-process":  # it starts while the world is built
                args = ["--connect", endpoint, "--mesh", mesh, "--scenario", scenario.name]
                args += ["--picks", str(picks), "--sensor-period", str(sensor_period)]
                child = Child(["-m", "benchmarks.sim", "--role", "client", *args], name="client")
                stack.callback(child.stop)
            world = await SimWorld.create(scenario, WorldOptions(fast=fast), tap)
            settle_heap()  # as `skimesh sim` does once its world is built
            if child is not None:
                await child.expect_async("ready", timeout=60)
            async with open_mesh(config) as server, anyio.create_task_group() as tg:
                await tg.start(world.run)
                await tg.start(serve_devices, server, sim_devices(world))
                window = Window(world, tap, None if child is None else child.pid)
                truth = WorldTruth(world, window)
                if child is not None:
                    await tg.start(serve_truth, server, truth)
                    success = await _drive_remote(child, window, limit)
                    window.mark(end=True)
                    await anyio.to_thread.run_sync(child.stop)  # its stops still answered
                else:
                    async with open_mesh(config) as client:
                        devices = await connect_devices(client)
                        success = {}
                        with anyio.move_on_after(limit if limit else math.inf):
                            success = await drive(
                                truth, devices, scenario.name, picks, sensor_period
                            )
                        window.mark(end=True)
                stats = world.statistics()
                tg.cancel_scope.cancel()
    finally:
        await anyio.to_thread.run_sync(tap.close)
    return window.figures() | {"success": success if not limit else {}, "slips": stats.slips}


@contextlib.contextmanager
def _router(*, apart: bool) -> Iterator[str]:
    """A router's endpoint: in this process, or in a child process (stopped by PID)."""
    if not apart:
        with running_router() as endpoint:
            yield endpoint
        return
    with contextlib.ExitStack() as stack:
        yield start_router_child("benchmarks.sim", stack)


async def _drive_remote(child: Child, window: Window, limit: float | None) -> dict[str, bool]:
    """Let the client process drive (it marks the window); ``limit`` s of it if given."""
    child.send({"go": True})
    if limit is None:
        done: dict[str, bool] = (await child.expect_async("done", timeout=600))["done"]
        return done
    with anyio.fail_after(60):
        await window.began.wait()
    await anyio.sleep(limit)
    return {}
