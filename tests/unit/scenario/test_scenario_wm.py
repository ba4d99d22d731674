"""A scenario becomes the initial world-model scene in one transaction: elements by scenario
label and class, the spatial tree, centre poses and sizes, devices, locations (``at``), prior
knowledge (home postures, door geometry, side grasps), and re-use of elements already there."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator
from pathlib import Path

import msgspec
import mujoco
import numpy as np
import pytest

from mujoco_sim.models import build_scene
from scenario import Scenario, load_scenario, resolve_placements
from scenario.wm import HOME_6, HOME_7, scenario_ops
from skill_agent.primitives.poses import to_transform
from tests.unit.wm_store.stores import memory_client
from wm_store import DeviceSpec, RobotRegistration, WmClient
from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import AddElement, Pose, SizeCuboid, SizeCylinder

pytestmark = pytest.mark.anyio

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    async with memory_client() as client:
        yield client


async def load(wm: WmClient, name: str) -> dict[str, str]:
    reply = await wm.transact(scenario_ops(load_scenario(SCENARIOS / name / "scenario.toml")))
    return {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}


def label_of(wm: WmClient, element: str) -> str:
    return wm.get_element(element).label


async def test_every_scenario_label_becomes_one_element(wm: WmClient) -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    ids = await load(wm, "kitting")
    for label in scenario.labels:
        assert label in ids
        assert [e.id for e in wm.resolve_element(label=label)] == [ids[label]]
    assert wm.get_element(ids["Gear-1"]).type == Cls.Gear
    assert wm.get_element(ids["Station-1"]).type == Cls.Station


async def test_the_kitting_tree(wm: WmClient) -> None:
    ids = await load(wm, "kitting")

    def parent(label: str) -> str:
        p = wm.get_parent(ids[label])
        return p.label if p is not None else ""

    assert parent("Gear-1") == "PartBox-1"
    assert parent("PartBox-1") == "Shelf-1"
    assert parent("Shelf-1") == "Station-1"
    assert parent("KitBox-1") == "r1"
    assert {label_of(wm, r.object) for r in wm.query_relation(ids["r1"], Rel.hasA)} == {
        "r1-arm",
        "r1-gripper",
        "r1-base",
        "r1-camera",
    }
    at = {
        (label_of(wm, r.subject), label_of(wm, r.object))
        for r in wm.query_relation(predicate=Rel.at)
    }
    assert (
        ("r1", "r1-home") in at
        and ("PartBox-3", "Station-2") in at
        and ("Shelf-2", "Station-2") in at
    )
    assert not any(s.startswith(("KitBox", "Gear")) for s, _ in at)


async def test_poses_are_world_centres_and_sizes_are_set(wm: WmClient) -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    placed = resolve_placements(scenario)
    ids = await load(wm, "kitting")
    gear = wm.get_element(ids["Gear-1"])
    pose, size = gear.properties[Prop.pose], gear.properties[Prop.size]
    assert isinstance(pose, Pose) and isinstance(size, SizeCylinder)
    bottom = placed["Gear-1"]
    # rough prior knowledge: x and y off by the scenario's prior_noise (at most 3 sigma)
    error = math.hypot(pose.position.x - bottom.x, pose.position.y - bottom.y)
    assert scenario.prior_noise > 0 and 0 < error <= 3 * math.sqrt(2) * scenario.prior_noise
    assert pose.position.z == pytest.approx(bottom.z + size.height / 2)
    assert wm.spatial.is_inside(ids["Gear-1"], ids["PartBox-1"])
    assert wm.spatial.is_inside(ids["KitBox-1"], ids["KitBox-1"])
    kit = wm.get_element(ids["KitBox-1"]).properties[Prop.size]
    assert kit == SizeCuboid(x=0.24, y=0.30, z=0.07)
    station = wm.spatial.world_pose(ids["Station-1"]).position
    assert (station.x, station.y) == pytest.approx((0.55, -1.0))


def test_rough_priors_are_the_same_every_time_and_exact_without_noise() -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    placed = resolve_placements(scenario)

    def part_xy(s: Scenario) -> dict[str, tuple[float, float]]:
        out = {}
        for op in scenario_ops(s):
            if isinstance(op, AddElement) and op.type in {p.type for p in s.parts}:
                pose = op.properties[Prop.pose]
                assert isinstance(pose, Pose)
                out[op.label] = (pose.position.x, pose.position.y)
        return out

    rough, again = part_xy(scenario), part_xy(scenario)
    exact = part_xy(msgspec.structs.replace(scenario, prior_noise=0.0))
    assert rough == again and len(rough) == len(scenario.parts)
    errors = [math.dist(rough[k], exact[k]) for k in rough]
    assert all(0 < e <= 3 * math.sqrt(2) * scenario.prior_noise for e in errors)
    assert len(set(errors)) == len(errors), "each part has its own error"
    assert all(exact[k] == pytest.approx((placed[k].x, placed[k].y)) for k in exact)


async def test_arms_carry_their_home_posture(wm: WmClient) -> None:
    ids = await load(wm, "kitting")
    assert wm.get_element(ids["r1-arm"]).properties[Prop.jointPositions] == list(HOME_6)


async def test_a_7_joint_arm_carries_its_home_posture(wm: WmClient) -> None:
    ids = await load(wm, "meal")  # (not beside kitting: both scenes name a camera Camera-1)
    assert wm.get_element(ids["friend-arm"]).properties[Prop.jointPositions] == list(HOME_7)


async def test_the_meal_scene(wm: WmClient) -> None:
    ids = await load(wm, "meal")
    oven = wm.get_element(ids["Microwave-1"])
    assert oven.properties[Prop.doorOpen] is False and oven.properties[Prop.heating] is False
    assert oven.properties[Prop.heatingPower] == 800.0
    door = wm.get_element(ids["Microwave-1-door"])
    assert door.type == Cls.MicrowaveDoor
    assert wm.get_parent(door.id).id == oven.id  # type: ignore[union-attr]
    # the door panel stands in front of the cavity (the oven faces -x)
    front = wm.spatial.world_pose(door.id).position.x
    assert front < wm.spatial.world_pose(oven.id).position.x - 0.18
    assert wm.get_element(ids["Worktop-1"]).type == Cls.SmartPlatform
    assert wm.get_parent(ids["MealBox-1"]).id == ids["Worktop-1"]  # type: ignore[union-attr]
    assert Prop.graspPose in wm.get_element(ids["MealBox-1"]).properties  # closed: side grasp
    home = ids["friend-home"]
    reachable = {label_of(wm, r.subject) for r in wm.query_relation(predicate=Rel.at, obj=home)}
    assert reachable == {"friend", "Worktop-1", "Table-1", "Tray-1", "Microwave-1", "Cabinet-1"}
    # the cabinet's drawer: closed, its handle a grasp that lands on the bar of the scene
    drawer = wm.get_element(ids["Drawer-1"])
    assert drawer.type == Cls.Drawer and drawer.properties[Prop.drawerOpen] is False
    assert wm.get_parent(drawer.id).id == ids["Cabinet-1"]  # type: ignore[union-attr]
    grasp = drawer.properties[Prop.graspPose]
    assert isinstance(grasp, Pose)
    handle = to_transform(wm.spatial.world_pose(drawer.id)).compose(to_transform(grasp))
    model = build_scene(load_scenario(SCENARIOS / "meal" / "scenario.toml")).compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    bar = data.geom("Drawer-1/handle").xpos
    assert np.allclose(handle.translation, bar, atol=1e-9)
    assert drawer.properties[Prop.graspWidth] == pytest.approx(
        2 * model.geom("Drawer-1/handle").size[0]
    )


async def test_elements_already_there_are_reused(wm: WmClient) -> None:
    await wm.register_robot(
        RobotRegistration(
            agent="r1",
            robot_type=Cls.MobileManipulator,
            robot_label="r1",
            devices=[DeviceSpec(type=Cls.Gripper, label="r1-gripper")],
        )
    )
    existing = {e.label: e.id for e in wm.resolve_element(type=Cls.PhysicalObject)}
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    ops = scenario_ops(scenario, existing)
    added = {op.label for op in ops if isinstance(op, AddElement)}
    assert "r1" not in added and "r1-gripper" not in added and "r1-arm" in added
    await wm.transact(ops)
    [robot] = wm.resolve_element(type=Cls.Robot, label="r1")
    assert isinstance(robot.properties[Prop.pose], Pose)
    assert wm.get_parent(wm.resolve_element(label="KitBox-1")[0].id).id == robot.id  # type: ignore[union-attr]
