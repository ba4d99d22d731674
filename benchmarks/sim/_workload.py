"""The simulation benchmark's workloads, written against the device Protocols and a
:class:`Truth` (ground truth and the simulated clock), so that the same code drives the
devices in the simulator's process or from a client process over Zenoh (``benchmarks.sim``).

*kitting*: both robots at once drive to their station and put two parts each into their kit
box; *meal*: the wheelchair robot puts the meal box on the tray while the microwave opens,
closes and heats 3 s. Meanwhile every sensor is read every 0.5 s of simulated time (by
default; ``--sensor-period``).
"""

from __future__ import annotations

import math
from collections.abc import Awaitable, Callable
from typing import Protocol

import anyio

from device_drivers import (
    Appliance,
    Arm,
    Device,
    DeviceKey,
    Gripper,
    MobileBase,
    ObjectSensor,
    Pose2D,
    WorldPose,
)
from mujoco_sim.motion import tool_down

__all__ = ["WORKLOADS", "Devices", "Truth", "drive", "kitting", "meal", "pick_place", "watch"]

READY7 = {"shoulder_lift": 0.0, "elbow": 1.6, "wrist_pitch": 1.54}
CARRY = {"shoulder_lift": -0.3, "elbow": 1.6, "wrist_pitch": 1.0}  # arm up, gripper down-ish
PICKS = {  # robot -> station pose, parts (in order) and their kit box
    "r1": (Pose2D(0.55, -1.0, 0.0), ["Gear-1", "Shaft-1"], "KitBox-1"),
    "r2": (Pose2D(0.55, 1.0, 0.0), ["Bracket-1", "Bolt-1"], "KitBox-2"),
}
Devices = dict[DeviceKey, Device]


class Truth(Protocol):
    """What a workload reads from the world besides its devices, and the measured window."""

    async def pose(self, name: str) -> WorldPose:
        """World pose of a body (a label) now."""
        ...

    async def object_in(self, label: str, container: str) -> bool:
        """Whether ``label`` lies in ``container`` now, at rest and not held."""
        ...

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of simulated time."""
        ...

    async def mark(self, end: bool) -> None:
        """The workload begins (``end`` false) or has ended: the measured window."""
        ...


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


async def part_grasp(
    truth: Truth, part: str, floor: float
) -> tuple[tuple[float, float, float], float]:
    """Grasp point of a part standing on ``floor`` (pads 4 cm tall: the tcp stays 2.2 cm up)."""
    p = await truth.pose(part)
    half = p.z - floor  # a part's origin is its centre
    z = max(p.z, floor + 0.022)
    return (p.x, p.y, z), z - floor if half > 0 else 0.0


async def kitting(truth: Truth, devices: Devices, picks: int) -> dict[str, bool]:
    done: dict[str, bool] = {}

    async def robot(name: str) -> None:
        station, parts, kit = PICKS[name]
        arm, gripper, base = (devices[(name, d)] for d in ("arm", "gripper", "base"))
        assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
        assert isinstance(base, MobileBase)
        await base.go_to(station)
        await arm.move_joints(CARRY)
        for i, part in enumerate(parts[:picks]):
            box = await truth.pose(kit)  # a box's origin is its bottom; its floor 8 mm up
            floor = (await truth.pose(f"PartBox-{1 if name == 'r1' else 3}")).z + 0.008
            grasp, above = await part_grasp(truth, part, floor)
            spot = (box.x, box.y + (-0.07 if i % 2 == 0 else 0.07), box.z + 0.008)
            await pick_place(arm, gripper, grasp, spot, above_bottom=above, via=CARRY)
            done[part] = False
        for part in parts[:picks]:
            done[part] = await truth.object_in(part, kit)

    async with anyio.create_task_group() as tg:
        for name in PICKS:
            tg.start_soon(robot, name)
    return done


async def meal(truth: Truth, devices: Devices, picks: int) -> dict[str, bool]:
    arm, gripper, base = (devices[("friend", d)] for d in ("arm", "gripper", "base"))
    oven = devices[("Microwave-1", "appliance")]
    assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
    assert isinstance(base, MobileBase) and isinstance(oven, Appliance)

    async def serve_meal() -> None:
        await base.go_to(Pose2D(0.1, -0.3, 0.0))
        await arm.move_joints(READY7)
        box, tray = await truth.pose("MealBox-1"), await truth.pose("Tray-1")
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
    return {"MealBox-1": await truth.object_in("MealBox-1", "Tray-1")}


WORKLOADS: dict[str, Callable[[Truth, Devices, int], Awaitable[dict[str, bool]]]] = {
    "kitting": kitting,
    "meal": meal,
}


async def watch(truth: Truth, devices: Devices, period: float = 0.5) -> None:
    """Every sensor reads every ``period`` s of simulated time, forever (0: never)."""
    sensors = [d for d in devices.values() if isinstance(d, ObjectSensor)]
    if period <= 0:
        return
    while True:
        for sensor in sensors:
            await sensor.detect()
        await truth.sleep(period)


async def drive(
    truth: Truth, devices: Devices, scenario: str, picks: int, sensor_period: float = 0.5
) -> dict[str, bool]:
    """The scenario's workload with the sensors read every ``sensor_period`` s of simulated
    time (0: not at all), between the window's two marks; returns whether each placed object
    ended where it belongs."""
    async with anyio.create_task_group() as tg:
        await truth.mark(end=False)
        tg.start_soon(watch, truth, devices, sensor_period)
        success = await WORKLOADS[scenario](truth, devices, picks)
        await truth.mark(end=True)
        tg.cancel_scope.cancel()
    return success
