"""Simulated sensors: a camera sees what is in its field of view, with noise; the smart
platform reports what stands on it."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from device_drivers import ObjectSensor, Pose2D
from mujoco_sim import (
    SimArm,
    SimBase,
    SimSensor,
    SimWorld,
    WorldOptions,
    running_world,
    sim_devices,
)
from mujoco_sim.motion import tool_down
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


def sensor(world: SimWorld, owner: str, device: str) -> SimSensor:
    found = sim_devices(world)[(owner, device)]
    assert isinstance(found, SimSensor) and isinstance(found, ObjectSensor)
    return found


def error(world: SimWorld, name: str, x: float, y: float, z: float) -> float:
    truth = world.body_pose(name)
    return math.dist((x, y, z), (truth.x, truth.y, truth.z))


async def test_fixed_camera_sees_the_parts_with_noise() -> None:
    async with running_world(load_scenario(SCENARIOS / "kitting" / "scenario.toml")) as world:
        camera = sensor(world, "Camera-1", "sensor")
        first, second = await camera.detect(), await camera.detect()
    names = {d.name for d in first}
    assert {f"Gear-{i}" for i in (1, 2, 3)} <= names
    assert {"Bolt-1", "Bracket-2", "PartBox-4"} <= names
    by_name = {d.name: d for d in second}
    for det in first:
        assert det.source == "Camera-1" and 0.05 <= det.confidence <= 1.0
        p = det.pose
        assert error(world, det.name, p.x, p.y, p.z) < 0.05  # noise ~4 mm/m, 2 m away
        assert (p.x, p.y, p.z) != (
            by_name[det.name].pose.x,
            by_name[det.name].pose.y,
            by_name[det.name].pose.z,
        )  # fresh noise each time
    gear = next(d for d in first if d.name == "Gear-1")
    assert gear.type == "Gear"


async def test_wrist_camera_respects_its_field_of_view() -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    async with running_world(scenario, WorldOptions(fast=True)) as world:
        camera = sensor(world, "r1", "camera")
        assert await camera.detect() == []  # the arm points up at the start
        found = sim_devices(world, "r1")
        arm, base = found[("r1", "arm")], found[("r1", "base")]
        assert isinstance(arm, SimArm) and isinstance(base, SimBase)
        await base.go_to(Pose2D(0.55, -1.0, 0.0))
        await arm.move_joints({"shoulder_lift": 0.4, "elbow": 1.5, "wrist_pitch": 1.24})
        box = world.body_pose("PartBox-1")
        await arm.move_tcp(tool_down(box.x, box.y, box.z + 0.25), straight=False)
        names = {d.name for d in await camera.detect()}
    assert {"Gear-1", "Gear-2", "Gear-3", "PartBox-1"} <= names
    assert not names & {"Shaft-1", "Shaft-2", "Bolt-1"}  # out of the field of view


async def test_smart_platform_reports_what_stands_on_it() -> None:
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    async with running_world(scenario, WorldOptions(fast=True)) as world:
        await world.wait_time(0.5)
        platform = sensor(world, "Worktop-1", "sensor")
        found = {d.name: d for d in await platform.detect()}
    assert set(found) == {"MealBox-1", "Tray-1"}
    meal = found["MealBox-1"]
    assert meal.type == "MealBox" and meal.source == "Worktop-1"
    truth = world.body_pose("MealBox-1")
    assert math.hypot(meal.pose.x - truth.x, meal.pose.y - truth.y) < 0.015
    assert meal.pose.z == pytest.approx(0.75)  # on the surface
