"""The simulation benchmark's fleet case: ``n`` mobile manipulators driving at once, in real time.

:func:`fleet_scenario` generates a scenario of ``n`` robots (arm, gripper, base and a wrist
camera each: four devices a robot), in rows 1.6 m apart, each with a lane of its own 1.2 m
long. The measured process keeps the router, the world (real-time pacing, no recorder) and its
device server (states published at 25 Hz); a client process (``--role fleet-client``) drives
every base through the remote proxies, home -> end of its lane -> home ..., all at once, as
skill agents would. Figures over ``seconds`` of wall time once every robot has started: the
real-time factor (simulated over wall time) and the slips (times the simulation gave up
catching up, :class:`mujoco_sim.WorldStatistics`), and the CPU of the measured process.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Any

import anyio

from benchmarks.common import Child, emit, stdin_lines
from device_drivers import MobileBase, Pose2D
from device_drivers.remote import connect_devices, serve_devices
from meshlink import MeshConfig, open_mesh
from meshlink.testing import running_router
from mujoco_sim import SimWorld, WorldOptions, sim_devices
from mujoco_sim.recording import Recorder
from scenario import Scenario, parse_scenario
from skimesh.runtime import settle_heap

__all__ = ["child_fleet", "fleet_real_time", "fleet_scenario"]

_COLUMNS = 8
_LANE = 1.2  # m each base drives out and back
_ROW, _COLUMN = 1.6, 3.0  # m between robots


def _home(i: int) -> Pose2D:
    return Pose2D((i % _COLUMNS) * _COLUMN, (i // _COLUMNS) * _ROW, 0.0)


def _cell(i: int) -> str:
    """Robot ``r{i+1}``'s kitting cell, in scenario TOML (the layout of ``kitting``'s r1)."""
    r, home = f"r{i + 1}", _home(i)
    x, y = home.x + _LANE, home.y
    parts = "".join(
        f"""
[[parts]]
type = "Gear"
label = "Gear-{r}-{k}"
parent = "PartBox-{r}"
pose = {{ y = {0.09 * (k - 1):.2f} }}
shape = "cylinder"
size = [0.028, 0.025]
mass = 0.12
"""
        for k in range(3)
    )
    return f"""
[[robots]]
name = "{r}"
pose = {{ x = {home.x}, y = {y} }}

[[furniture]]
type = "Station"
label = "Station-{r}"
pose = {{ x = {x}, y = {y} }}
size = [0.8, 0.8, 0.01]

[[furniture]]
type = "Shelf"
label = "Shelf-{r}"
station = "Station-{r}"
pose = {{ x = {x + 0.68:.2f}, y = {y} }}
size = [0.6, 1.2, 0.70]

[[containers]]
type = "PartBox"
label = "PartBox-{r}"
parent = "Shelf-{r}"
pose = {{ x = -0.17 }}
size = [0.20, 0.30, 0.05]
fixed = true

[[containers]]
type = "KitBox"
label = "KitBox-{r}"
parent = "{r}"
size = [0.24, 0.30, 0.07]
{parts}
[[sensors]]
kind = "camera"
label = "{r}-camera"
mount = "{r}"
site = "wrist_camera"
"""


def fleet_scenario(n: int) -> Scenario:
    """``n`` generated mobile manipulators r1..rn, each with a wrist camera, a kit box on its
    deck and a kitting cell of its own (a station, a shelf, a part box of three gears)."""
    size = max(4.0, _COLUMNS * _COLUMN, (n // _COLUMNS + 1) * _ROW) + 2.0
    head = f'name = "fleet-{n}"\nfloor_size = {size}\n'
    return parse_scenario(head + "".join(_cell(i) for i in range(n)), source=f"fleet-{n}")


async def _drive(base: MobileBase, home: Pose2D, stop: anyio.Event) -> None:
    """Out and back along the lane, with a progress callback (as the navigate skill)."""
    out = Pose2D(home.x + _LANE, home.y, home.yaw)
    reported: list[float] = []
    while not stop.is_set():
        for target in (out, home):
            await base.go_to(target, progress=reported.append)
            reported.clear()


def child_fleet(args: argparse.Namespace) -> int:
    """The fleet client role: ``--connect ENDPOINT --mesh M --robots N``; writes ``{"ready":
    pid}``, waits for ``go``, writes ``{"driving": n}`` once every base has its first command
    under way, and drives until its stdin closes."""
    from skimesh.runtime import run_service

    async def main() -> int:
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            go, stop = anyio.Event(), anyio.Event()

            async def control() -> None:
                async for _ in stdin_lines():
                    go.set()
                stop.set()
                tg.cancel_scope.cancel()

            tg.start_soon(control)
            emit({"ready": os.getpid()})
            await go.wait()
            devices = await connect_devices(mesh)
            for i in range(args.robots):
                base = devices[(f"r{i + 1}", "base")]
                assert isinstance(base, MobileBase)
                tg.start_soon(_drive, base, _home(i), stop)
            emit({"driving": args.robots})
            await anyio.sleep_forever()
        return 0

    return run_service(main)


async def fleet_real_time(
    n: int, seconds: float, *, rrd: Path | None = None, options: WorldOptions | None = None
) -> dict[str, Any]:
    """Real-time factor, slips and CPU of ``n`` robots driving at once for ``seconds``; with
    ``rrd``, recorded with rerun to that file (as ``skimesh sim`` does by default)."""
    scenario = fleet_scenario(n)
    recorder = None if rrd is None else Recorder(path=rrd, recording_id=f"bench-fleet-{n}")
    mesh = f"bench-fleet-{n}-{os.getpid()}"
    with running_router() as endpoint:
        args = ["--connect", endpoint, "--mesh", mesh, "--robots", str(n)]
        with Child(
            ["-m", "benchmarks.sim", "--role", "fleet-client", *args], name="fleet"
        ) as child:
            world = await SimWorld.create(scenario, options or WorldOptions(), recorder)
            settle_heap()  # as `skimesh sim` does once its world is built
            await child.expect_async("ready", timeout=60)
            config = MeshConfig(connect=(endpoint,), mesh=mesh)
            async with open_mesh(config) as server, anyio.create_task_group() as tg:
                await tg.start(world.run)
                await tg.start(serve_devices, server, sim_devices(world))
                child.send({"go": True})
                await child.expect_async("driving", timeout=120)
                await world.sleep(0.5)  # every base under way
                before = world.statistics()
                cpu, wall = time.process_time(), time.perf_counter()
                await anyio.sleep(seconds)
                after = world.statistics()
                cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
                bases = [k for k, kind in world.devices.items() if kind == "base"]
                moving = sum(1 for key in bases if world.state(key).moving)
                tg.cancel_scope.cancel()
    if recorder is not None:
        await anyio.to_thread.run_sync(recorder.close)
    sim = (after.ticks - before.ticks) * world.plant.tick_time  # exact: snapshots may lag a tick
    return {
        "robots": n,
        "devices": len(world.devices),
        "wall_s": wall,
        "sim_s": sim,
        "real_time_factor": sim / wall,
        "slips": after.slips - before.slips,
        "cpu": cpu / wall,
        "moving_at_end": moving,
    }


SMALL = 4  # robots of the baseline fleet


async def measure_fleet(n: int, seconds: float, repeat: int, workdir: Path) -> dict[str, Any]:
    """The fleet case, ``repeat`` rounds (the cases take turns going first): ``n`` robots
    driving with the default pacing (every batch handed through the event loop), the small
    fleet of :data:`SMALL` robots (the baseline), and ``n`` robots in paced runs (``handover``
    1 s: the simulation thread keeps the clock, :mod:`mujoco_sim._paced_run`). Each recorded
    with rerun, as ``skimesh sim`` does."""
    cases = {
        "fleet": (n, WorldOptions()),
        "small": (SMALL, WorldOptions()),
        "paced": (n, WorldOptions(handover=1.0)),
    }
    runs: dict[str, list[dict[str, Any]]] = {case: [] for case in cases}
    names = list(cases)
    for i in range(repeat):
        for case in names if i % 2 == 0 else names[::-1]:
            robots, options = cases[case]
            rrd = workdir / f"fleet-{case}-{i}.rrd"
            runs[case].append(await fleet_real_time(robots, seconds, rrd=rrd, options=options))
    return {"robots": n, "seconds": seconds, "runs": runs}
