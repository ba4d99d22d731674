"""Simulation benchmark: each scenario with every robot and driver working, beside bare
``mj_step`` of the same model driven by the same set-points, in the same run.

    python -m benchmarks.sim            # full run (~35 s on 2 cores)
    python -m benchmarks.sim --quick    # smoke run
    python -m benchmarks.sim --json results.json

Per scenario (method and results: ``docs/benchmarks.md``, section "Simulation"):

1. **full system, fast mode**: ``SimWorld`` (controllers at 100 Hz, IK every tick of straight
   moves, grasp logic, sensors) with every device served over Zenoh (commands from a second
   session through a loopback router, states published at 25 Hz) and rerun logging to a file.
   Workload: pick-and-place on every robot at once (kitting: parts into the kit boxes; meal:
   the meal box onto the tray while the microwave opens, closes and heats), sensors read every
   0.5 s. Figure: wall time per simulated second.
2. **baseline**: a fresh copy of the same model stepped with bare ``mj_step(m, d, nstep=5)``
   per control tick, replaying the exact set-points, weld switches and gripper force limits
   the controllers produced in run 1 (recorded every tick), right after it. Ratio = overhead;
   target < 2x. Runs 1 and 2 are repeated (``--repeat``, 3 by default): figures are medians,
   the ratio the median of the pairs' ratios (a shared machine drifts between runs).
3. bare stepping at rest (no motion); real time: the same system paced by the wall clock
   (target: real-time factor 1, no slips); pick-and-place success; stop-to-halt time.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import statistics
import sys
import tempfile
import time
from collections.abc import Awaitable, Callable, Sequence
from pathlib import Path
from typing import Any

import anyio
import msgspec
import mujoco
import numpy as np

from benchmarks.common import ROOT, Row, calibrate, format_table, load_average, machine_info
from device_drivers.drivers import sim_devices
from device_drivers.errors import MotionStoppedError
from device_drivers.interfaces import Appliance, Arm, Device, Gripper, MobileBase, ObjectSensor
from device_drivers.motion_math import tool_down
from device_drivers.plant import Plant
from device_drivers.protocol import Stop
from device_drivers.recorder import Recorder
from device_drivers.remote import serve_devices
from device_drivers.remote_client import connect_devices
from device_drivers.robot_spec import Pose2D
from device_drivers.scenario import Scenario
from device_drivers.scenario_load import load_scenario
from device_drivers.world import SimWorld, WorldOptions, running_world
from meshlink import MeshConfig, open_mesh
from meshlink.testing import running_router

READY7 = {"shoulder_lift": 0.0, "elbow": 1.6, "wrist_pitch": 1.54}
CARRY = {"shoulder_lift": -0.3, "elbow": 1.6, "wrist_pitch": 1.0}  # arm up, gripper down-ish
PICKS = {  # robot -> station pose, parts (in order) and their kit box
    "r1": (Pose2D(0.55, -1.0, 0.0), ["Gear-1", "Shaft-1"], "KitBox-1"),
    "r2": (Pose2D(0.55, 1.0, 0.0), ["Bracket-1", "Bolt-1"], "KitBox-2"),
}
Devices = dict[tuple[str, str], Device]


class Tap(Recorder):
    """A recorder that also keeps, every control tick, what run 2 replays (so the plant calls
    it every tick; it records at its own rate as usual)."""

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self.ticks: list[tuple[np.ndarray[Any, Any], np.ndarray[Any, Any], np.ndarray[Any, Any]]]
        self.ticks = []

    @property
    def next_sample(self) -> float:
        return -math.inf

    def sample(self, model: Any, data: Any) -> None:
        self.ticks.append(
            (data.ctrl.copy(), data.eq_active.copy(), model.actuator_forcerange.copy())
        )
        if data.time + 1e-9 >= super().next_sample:
            super().sample(model, data)


def replay(scenario: Scenario, ticks: Sequence[Any]) -> float:
    """Wall seconds to step a fresh copy of the world through ``ticks`` with bare mj_step."""
    plant = Plant(scenario)
    m, d, n = plant.model, plant.data, plant.steps_per_tick
    start = time.perf_counter()
    for ctrl, active, force in ticks:
        d.ctrl[:] = ctrl
        d.eq_active[:] = active
        m.actuator_forcerange[:] = force
        mujoco.mj_step(m, d, nstep=n)
    return time.perf_counter() - start


def at_rest(scenario: Scenario, seconds: float) -> float:
    """Wall seconds per simulated second of bare stepping with nothing moving."""
    plant = Plant(scenario)
    steps = round(seconds / plant.model.opt.timestep)
    start = time.perf_counter()
    mujoco.mj_step(plant.model, plant.data, nstep=steps)
    return (time.perf_counter() - start) / seconds


# ------------------------------------------------------------------ workloads (Protocols only)
async def pick_place(
    arm: Arm,
    gripper: Gripper,
    grasp: tuple[float, float, float],
    place: tuple[float, float, float],
    *,
    above_bottom: float,
    yaw: float = 0.0,
    via: dict[str, float] | None = None,
) -> None:
    """Top-down pick with the tcp at ``grasp``, ``above_bottom`` m over the object's bottom;
    release it 2 cm above the surface point ``place``; pass the joint pose ``via`` on the way
    there and back (no collision-free planning here: the caller picks safe waypoints)."""
    x, y, z = grasp
    await arm.move_tcp(tool_down(x, y, z + 0.12, yaw), straight=False)
    await arm.move_tcp(tool_down(x, y, z, yaw), speed=0.1)
    await gripper.close()
    await arm.move_tcp(tool_down(x, y, z + 0.15, yaw), speed=0.2)
    if via:
        await arm.move_joints(via)
    px, py, top = place
    await arm.move_tcp(tool_down(px, py, top + above_bottom + 0.12, yaw), straight=False)
    await arm.move_tcp(tool_down(px, py, top + above_bottom + 0.02, yaw), speed=0.1)
    await gripper.open()
    await arm.move_tcp(tool_down(px, py, top + 0.25, yaw), speed=0.2)
    if via:
        await arm.move_joints(via)


def part_grasp(
    world: SimWorld, part: str, floor: float
) -> tuple[tuple[float, float, float], float]:
    """Grasp point of a part standing on ``floor`` (pads 4 cm tall: the tcp stays 2.2 cm up)."""
    p = world.body_pose(part)
    half = p.z - floor  # a part's origin is its centre
    z = max(p.z, floor + 0.022)
    return (p.x, p.y, z), z - floor if half > 0 else 0.0


async def kitting(world: SimWorld, devices: Devices, picks: int) -> dict[str, bool]:
    done: dict[str, bool] = {}

    async def robot(name: str) -> None:
        station, parts, kit = PICKS[name]
        arm, gripper, base = (devices[(name, d)] for d in ("arm", "gripper", "base"))
        assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
        assert isinstance(base, MobileBase)
        await base.go_to(station)
        await arm.move_joints(CARRY)
        for i, part in enumerate(parts[:picks]):
            box = world.body_pose(kit)  # a box's origin is its bottom; its floor 8 mm up
            floor = world.body_pose(f"PartBox-{1 if name == 'r1' else 3}").z + 0.008
            grasp, above = part_grasp(world, part, floor)
            spot = (box.x, box.y + (-0.07 if i % 2 == 0 else 0.07), box.z + 0.008)
            await pick_place(arm, gripper, grasp, spot, above_bottom=above, via=CARRY)
            done[part] = False
        for part in parts[:picks]:
            done[part] = world.object_in(part, kit)

    async with anyio.create_task_group() as tg:
        for name in PICKS:
            tg.start_soon(robot, name)
    return done


async def meal(world: SimWorld, devices: Devices, picks: int) -> dict[str, bool]:
    arm, gripper, base = (devices[("friend", d)] for d in ("arm", "gripper", "base"))
    oven = devices[("Microwave-1", "appliance")]
    assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
    assert isinstance(base, MobileBase) and isinstance(oven, Appliance)

    async def serve_meal() -> None:
        await base.go_to(Pose2D(0.1, -0.3, 0.0))
        await arm.move_joints(READY7)
        box, tray = world.body_pose("MealBox-1"), world.body_pose("Tray-1")
        grasp = (box.x, box.y, box.z + 0.03)  # its origin is its bottom; 6 cm tall
        place = (tray.x, tray.y, tray.z + 0.006)  # on the tray's floor
        await pick_place(arm, gripper, grasp, place, above_bottom=0.03, yaw=math.pi / 2)

    async def cook() -> None:
        for _ in range(picks):
            await oven.set_door(True)
            await oven.set_door(False)
            await oven.heat(3.0)

    async with anyio.create_task_group() as tg:
        tg.start_soon(serve_meal)
        tg.start_soon(cook)
    return {"MealBox-1": world.object_in("MealBox-1", "Tray-1")}


WORKLOADS: dict[str, Callable[[SimWorld, Devices, int], Awaitable[dict[str, bool]]]] = {
    "kitting": kitting,
    "meal": meal,
}


async def watch(world: SimWorld, devices: Devices) -> None:
    """Every sensor reads every 0.5 s of simulated time, forever."""
    sensors = [d for d in devices.values() if isinstance(d, ObjectSensor)]
    while True:
        for sensor in sensors:
            await sensor.detect()
        await world.sleep(0.5)


async def full_system(
    scenario: Scenario, *, fast: bool, picks: int, rrd: Path, limit: float | None = None
) -> dict[str, Any]:
    """Run the workload on the whole stack; return timings, success and the tick log."""
    tap = Tap(path=rrd, recording_id=f"bench-{scenario.name}")
    with running_router() as endpoint:
        config = MeshConfig(connect=(endpoint,), mesh=f"bench-{scenario.name}")
        async with (
            running_world(scenario, WorldOptions(fast=fast), tap) as world,
            open_mesh(config) as server,
            open_mesh(config) as client,
            anyio.create_task_group() as tg,
        ):
            await tg.start(serve_devices, server, sim_devices(world))
            devices = await connect_devices(client)
            tg.start_soon(watch, world, devices)
            sim0, wall0, ticks0 = world.snapshot.time, time.perf_counter(), len(tap.ticks)
            with anyio.move_on_after(limit if limit else math.inf):
                success = await WORKLOADS[scenario.name](world, devices, picks)
            wall, sim = time.perf_counter() - wall0, world.snapshot.time - sim0
            stats = world.statistics()
            tg.cancel_scope.cancel()
    await anyio.to_thread.run_sync(tap.close)
    return {
        "wall": wall,
        "sim": sim,
        "success": success if not limit else {},
        "slips": stats.slips,
        "ticks": tap.ticks[ticks0:] if not limit else [],
        "all_ticks": tap.ticks,
    }


async def _move_until_stopped(arm: Arm, goal: dict[str, float]) -> None:
    with contextlib.suppress(MotionStoppedError):
        await arm.move_joints(goal, duration=2.0)


async def stop_to_halt(scenario: Scenario, repeats: int) -> list[float]:
    """Simulated seconds from ``stop()`` to the arm standing still (< 0.02 rad/s), stopped
    0.8 s into a 2 s move (near its top speed), to one control tick (10 ms)."""
    found: list[float] = []
    async with running_world(scenario, WorldOptions(fast=True)) as world:
        robot = scenario.robots[0].name
        arm = sim_devices(world, robot)[(robot, "arm")]
        assert isinstance(arm, Arm)
        for i in range(repeats):
            goal = {"shoulder_lift": 0.9, "elbow": 1.4} if i % 2 == 0 else {"shoulder_lift": 0.1}
            async with anyio.create_task_group() as tg:
                tg.start_soon(_move_until_stopped, arm, goal)
                await world.sleep(0.8)
                # the driver's stop() is this command; its result is the settling time
                found.append(await world.execute((robot, "arm"), Stop()))
    return found


async def measure(name: str, quick: bool, repeat: int, workdir: Path) -> dict[str, Any]:
    """Runs 1 and 2 ``repeat`` times (each fast run right before the replay of its own ticks,
    so that both see about the same machine); the figures are the medians, the overhead
    ratio the median of the pairs' ratios."""
    scenario = load_scenario(ROOT / "configs" / "scenarios" / name / "scenario.toml")
    picks = 1 if quick else 2
    runs: list[dict[str, Any]] = []
    for i in range(repeat):
        rrd = workdir / f"{name}-{i}.rrd"
        fast = await full_system(scenario, fast=True, picks=picks, rrd=rrd)
        bare = await anyio.to_thread.run_sync(replay, scenario, fast["ticks"])
        sim = fast["sim"]
        runs.append(
            {
                "sim_s": sim,
                "full": fast["wall"] / sim,
                "bare": bare / sim,
                "success": fast["success"],
                "rrd_bytes": rrd.stat().st_size,
            }
        )
    rest = await anyio.to_thread.run_sync(at_rest, scenario, 5.0 if quick else 20.0)
    real = await full_system(
        scenario, fast=False, picks=picks, rrd=workdir / f"{name}-rt.rrd", limit=4 if quick else 10
    )
    halts = await stop_to_halt(scenario, 3 if quick else 10)
    success = {p: all(r["success"][p] for r in runs) for p in runs[0]["success"]}
    return {
        "sim_s": statistics.median(r["sim_s"] for r in runs),
        "full_wall_per_sim_s": statistics.median(r["full"] for r in runs),
        "bare_wall_per_sim_s": statistics.median(r["bare"] for r in runs),
        "overhead": statistics.median(r["full"] / r["bare"] for r in runs),
        "overheads": [r["full"] / r["bare"] for r in runs],
        "runs": runs,
        "rest_wall_per_sim_s": rest,
        "success": success,
        "real_time_factor": real["sim"] / real["wall"],
        "real_time_slips": real["slips"],
        "stop_to_halt_s": halts,
        "rrd_bytes": runs[0]["rrd_bytes"],
    }


def make_rows(results: dict[str, dict[str, Any]]) -> list[Row]:
    rows: list[Row] = []
    for name, r in results.items():
        overhead = r["overhead"]
        ok = sum(r["success"].values())
        pairs = "/".join(f"{x:.2f}" for x in r["overheads"])
        rows += [
            Row(
                figure=f"{name}: wall ms per simulated s, full system",
                value=1e3 * r["full_wall_per_sim_s"],
                unit="ms",
                baseline="bare mj_step, same set-points",
                baseline_value=1e3 * r["bare_wall_per_sim_s"],
                target="< 2x",
                met=overhead < 2.0,
                note=f"median of {len(r['overheads'])}; run ratios {pairs}",
            ),
            Row(
                figure=f"{name}: real-time factor, fast mode",
                value=1.0 / r["full_wall_per_sim_s"],
                unit="x",
                baseline="bare at rest",
                baseline_value=1.0 / r["rest_wall_per_sim_s"],
            ),
            Row(
                figure=f"{name}: real-time factor, real-time mode",
                value=r["real_time_factor"],
                unit="x",
                target=">= 0.98, no slip",
                met=r["real_time_factor"] >= 0.98 and r["real_time_slips"] == 0,
            ),
            Row(
                figure=f"{name}: pick-and-place success",
                value=ok,
                unit=f"of {len(r['success'])}",
                target="all",
                met=ok == len(r["success"]),
            ),
            Row(
                figure=f"{name}: stop-to-halt, worst (simulated)",
                value=1e3 * max(r["stop_to_halt_s"]),
                unit="ms",
                target="< 500 ms",
                met=max(r["stop_to_halt_s"]) < 0.5,
            ),
        ]
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write results as JSON")
    parser.add_argument("--scenario", action="append", choices=sorted(WORKLOADS))
    parser.add_argument(
        "--repeat", type=int, metavar="N", help="fast runs (and replays) per scenario (3; quick: 1)"
    )
    args = parser.parse_args(argv)
    repeat = max(1, args.repeat or (1 if args.quick else 3))
    info = machine_info(("mujoco", "rerun-sdk", "eclipse-zenoh", "placo"))
    conditions = {"load_start": load_average(), "calibration_ms_start": calibrate()}
    started = time.perf_counter()
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="skimesh-bench-sim-") as tmp:
        for name in args.scenario or sorted(WORKLOADS):
            print(f"{name}: measuring...", file=sys.stderr, flush=True)
            results[name] = anyio.run(measure, name, args.quick, repeat, Path(tmp))
    conditions |= {"load_end": load_average(), "calibration_ms_end": calibrate()}
    rows = make_rows(results)
    print("machine: " + ", ".join(f"{k} {v}" for k, v in info.items()))
    print(
        f"run: {'quick' if args.quick else 'full'}, {time.perf_counter() - started:.0f} s; load "
        f"average {conditions['load_start']} at start, {conditions['load_end']} at end\n"
    )
    print(format_table(rows))
    for name, r in results.items():
        halts = ", ".join(f"{1e3 * h:.0f}" for h in r["stop_to_halt_s"])
        print(
            f"{name}: {r['sim_s']:.1f} s simulated; success {r['success']}; stop-to-halt ms "
            f"[{halts}]; .rrd {r['rrd_bytes'] / 1e6:.1f} MB"
        )
    if args.json is not None:
        doc = {"machine": info, "conditions": conditions, "rows": rows, "results": results}
        args.json.write_bytes(msgspec.json.format(msgspec.json.encode(doc)))
    return 0 if all(row.met is not False for row in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
