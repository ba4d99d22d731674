"""The mobile base: paths around furniture footprints (pure), and go_to in the simulation."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from device_drivers.base_control import plan_path
from device_drivers.drivers import SimBase, sim_devices
from device_drivers.errors import CollisionError
from device_drivers.motion_math import rect_corners, rects_overlap
from device_drivers.placement import Footprint
from device_drivers.robot_spec import Pose2D
from device_drivers.scenario_load import load_scenario
from device_drivers.world import SimWorld, WorldOptions, running_world

KITTING = (
    Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "kitting" / "scenario.toml"
)
HALF = (0.3, 0.225)
PILLAR = Footprint("Pillar-1", 1.0, 0.0, 0.0, 0.2, 0.2)


def test_rectangles_overlap_with_rotation() -> None:
    a = rect_corners(0.0, 0.0, 0.0, 1.0, 0.1)
    assert rects_overlap(a, rect_corners(0.9, 0.0, 0.0, 0.1, 0.1))
    assert not rects_overlap(a, rect_corners(0.0, 0.5, 0.0, 0.1, 0.1))
    assert rects_overlap(a, rect_corners(0.0, 0.5, math.pi / 2, 0.5, 0.1))


def test_a_free_line_is_taken_straight() -> None:
    path = plan_path((0.0, 1.0, 0.0), (2.0, 1.0, 0.5), HALF, [PILLAR])
    assert path == [(0.0, 1.0, 0.0), (2.0, 1.0, 0.5)]


def test_a_blocked_line_gets_a_detour() -> None:
    path = plan_path((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), HALF, [PILLAR])
    assert len(path) == 3
    via = path[1]
    assert abs(via[1]) >= 0.6  # beside the pillar


def test_a_target_inside_furniture_is_refused() -> None:
    with pytest.raises(CollisionError, match="overlaps Pillar-1"):
        plan_path((0.0, 0.0, 0.0), (1.1, 0.0, 0.0), HALF, [PILLAR])


def test_no_free_detour_is_a_collision_error() -> None:
    wall = Footprint("Wall-1", 1.0, 0.0, 0.0, 0.1, 5.0)
    with pytest.raises(CollisionError, match="blocked by Wall-1"):
        plan_path((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), HALF, [wall])


@pytest.fixture
async def world() -> AsyncIterator[SimWorld]:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as w:
        yield w


@pytest.mark.sim
@pytest.mark.anyio
async def test_go_to_reaches_the_pose(world: SimWorld) -> None:
    base = sim_devices(world, "r1")[("r1", "base")]
    assert isinstance(base, SimBase)
    seen: list[float] = []
    await base.go_to(Pose2D(0.0, -1.6, math.pi / 2), progress=seen.append)
    pose = (await base.state()).pose
    assert math.hypot(pose.x - 0.0, pose.y + 1.6) < 0.01
    assert pose.yaw == pytest.approx(math.pi / 2, abs=0.02)
    assert seen == sorted(seen) and seen[-1] == 1.0
    kit = world.body_pose("KitBox-1")  # the kit box rides along, turned with the base
    assert kit.y == pytest.approx(-1.6 - 0.105, abs=0.01)


@pytest.mark.sim
@pytest.mark.anyio
async def test_go_to_into_a_shelf_is_refused(world: SimWorld) -> None:
    base = sim_devices(world, "r1")[("r1", "base")]
    assert isinstance(base, SimBase)
    with pytest.raises(CollisionError, match="Shelf-1"):
        await base.go_to(Pose2D(1.2, -1.0, 0.0))
    assert not (await base.state()).moving
