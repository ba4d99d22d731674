"""Fake devices for the skill-library tests: small implementations of the device Protocols
over a toy "world" of object poses, and a harness running an :class:`AgentCore` on an
in-memory world model loaded from a scenario (``scenario.wm``).

The toy world: the arm's tcp goes where it is told; the gripper grasps the object whose centre
is nearest the tcp (if within 6 cm) when it closes, and the held object moves with the tcp;
sensors report every object's centre (exactly). Failures are injected per device
(``fail_next``), and a motion can be held mid-way (``hold``) to test stops. Other test modules
import from here; the tests at the bottom check the fakes themselves.
"""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Mapping
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Literal

import anyio
import anyio.lowlevel
import pytest

from device_drivers import (
    Appliance,
    ApplianceState,
    Arm,
    ArmState,
    BaseState,
    Detection,
    DeviceError,
    GraspLostError,
    Gripper,
    GripperState,
    MobileBase,
    ObjectSensor,
    Pose2D,
    ProgressCallback,
    WorldPose,
)
from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent import Skill
from skill_agent.protocol import RunResult, StartRun
from skill_agent.runtime import AgentCore, SimulatedOutcomes, SkillEntry
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import Pose
from wm_store.server import WmService, WmStore

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


class ToyWorld:
    """Object centres (world frame) shared by the fake devices."""

    def __init__(self) -> None:
        self.objects: dict[str, WorldPose] = {}
        self.hidden: set[str] = set()


class FakeDevice:
    def __init__(self, name: str, world: ToyWorld) -> None:
        self._name, self.world = name, world
        self.calls: list[str] = []
        self.stops = 0
        self.fail_next: dict[str, DeviceError] = {}
        self.hold: anyio.Event | None = None
        self.moving = False
        self.started = anyio.Event()
        """Set when a motion begins (a test waits for it instead of polling)."""

    @property
    def name(self) -> str:
        return self._name

    async def stop(self) -> None:
        self.stops += 1
        self.moving = False

    async def _motion(self, kind: str, progress: ProgressCallback | None) -> None:
        self.calls.append(kind)
        error = self.fail_next.pop(kind, None)
        if error is not None:
            raise error
        self.moving = True
        self.started.set()
        if progress is not None:
            progress(0.5)
        if self.hold is not None:
            await self.hold.wait()
        await anyio.lowlevel.checkpoint()
        if progress is not None:
            progress(1.0)
        self.moving = False


class FakeGripper(FakeDevice):
    def __init__(self, name: str, world: ToyWorld, arm: FakeArm) -> None:
        super().__init__(name, world)
        self.arm = arm
        self.holding = ""
        self.opening = 0.085
        self.slip = False
        """Close on the object but do not hold it (a failed grasp)."""
        arm.gripper = self

    async def state(self) -> GripperState:
        return GripperState(
            opening=self.opening, holding=self.holding, pads_in_contact=2 * bool(self.holding)
        )

    async def open(self, width: float | None = None) -> None:
        await self._motion("open", None)
        self.holding = ""
        self.opening = 0.085 if width is None else width

    async def close(self, force: float = 20.0) -> GripperState:
        await self._motion("close", None)
        tcp = self.arm.tcp
        distance = {
            label: math.dist((p.x, p.y, p.z), (tcp.x, tcp.y, tcp.z))
            for label, p in self.world.objects.items()
        }
        nearest = min(distance, key=lambda label: distance[label], default="")
        if nearest and distance[nearest] < 0.06 and not self.slip:
            label, pose = nearest, self.world.objects[nearest]
            if label:
                self.holding = label
                self.arm.offset = (pose.x - tcp.x, pose.y - tcp.y, pose.z - tcp.z)
                self.opening = 0.05
                return await self.state()
        self.opening = 0.0
        return await self.state()


class FakeArm(FakeDevice):
    def __init__(self, name: str, world: ToyWorld, tcp: WorldPose, dof: int = 6) -> None:
        super().__init__(name, world)
        self.tcp = tcp
        self.joints = {f"j{i}": 0.0 for i in range(dof)}
        self.gripper: FakeGripper | None = None
        self.offset = (0.0, 0.0, 0.0)
        self.drop_during: str = ""
        """``"tcp"``: the held object falls during the next tool motion (GraspLostError)."""

    async def state(self) -> ArmState:
        return ArmState(joints=dict(self.joints), tcp=self.tcp, moving=self.moving)

    async def move_joints(
        self,
        target: Mapping[str, float],
        *,
        duration: float | None = None,
        progress: ProgressCallback | None = None,
    ) -> None:
        await self._motion("joints", progress)
        self.joints.update(target)

    async def move_tcp(
        self,
        target: WorldPose,
        *,
        straight: bool = True,
        speed: float = 0.2,
        whole_body: bool = False,
        progress: ProgressCallback | None = None,
    ) -> None:
        kind = "line" if straight else "free"
        held = self.gripper.holding if self.gripper is not None else ""
        if held and self.drop_during == kind and self.gripper is not None:
            self.drop_during = ""
            self.calls.append(kind)
            self.gripper.holding = ""
            raise GraspLostError(f"{self.gripper.name} lost {held}")
        await self._motion(kind, progress)
        self.tcp = target
        if held:
            dx, dy, dz = self.offset
            self.world.objects[held] = WorldPose(target.x + dx, target.y + dy, target.z + dz)


class FakeBase(FakeDevice):
    def __init__(self, name: str, world: ToyWorld, pose: Pose2D) -> None:
        super().__init__(name, world)
        self.pose = pose

    async def state(self) -> BaseState:
        return BaseState(pose=self.pose, moving=self.moving)

    async def go_to(
        self, target: Pose2D, *, speed: float = 0.5, progress: ProgressCallback | None = None
    ) -> None:
        await self._motion("go_to", progress)
        self.pose = target

    async def set_velocity(
        self, vx: float, vy: float, wz: float, *, duration: float | None = None
    ) -> None:
        await self._motion("velocity", None)  # the pose stays: no skill here drives by twist


class FakeSensor(FakeDevice):
    async def detect(self) -> list[Detection]:
        self.calls.append("detect")
        return [
            Detection(name=label, type="Part", pose=pose, confidence=0.9, source=self.name)
            for label, pose in self.world.objects.items()
            if label not in self.world.hidden
        ]


class FakeAppliance(FakeDevice):
    def __init__(self, name: str, world: ToyWorld) -> None:
        super().__init__(name, world)
        self.door_open = False
        self.heating = False
        self.contents: list[str] = []
        self.stuck = False

    async def state(self) -> ApplianceState:
        return ApplianceState(
            door_angle=1.5 if self.door_open else 0.0,
            door_open=self.door_open,
            heating=self.heating,
            contents=list(self.contents),
        )

    async def set_door(self, open: bool, *, progress: ProgressCallback | None = None) -> None:
        await self._motion("door", progress)
        if not self.stuck:
            self.door_open = open

    async def heat(
        self, duration: float, *, power: float = 1.0, progress: ProgressCallback | None = None
    ) -> None:
        self.heating = True
        try:
            await self._motion("heat", progress)
        finally:
            self.heating = False

    async def press(self, button: Literal["start", "stop", "open"]) -> None:
        self.calls.append(f"press {button}")


def world_pose(pose: Pose) -> WorldPose:
    p, o = pose.position, pose.orientation
    return WorldPose(p.x, p.y, p.z, o.x, o.y, o.z, o.w)


def entries(*classes: type[Skill]) -> dict[str, SkillEntry]:
    return {c.description.name: SkillEntry(c.description, c, c.__module__) for c in classes}


class Rig:
    """A scenario's world model, the toy world (objects where the world model says) and the
    fake devices of one robot or appliance, by world-model label."""

    def __init__(self, wm: WmClient, ids: dict[str, str], world: ToyWorld) -> None:
        self.wm, self.ids, self.world = wm, ids, world
        self.devices: dict[str, FakeDevice] = {}

    def __getitem__(self, label: str) -> str:
        return self.ids[label]

    def robot_devices(self, robot: str, *, base_pose: Pose2D, camera: str, dof: int = 6) -> None:
        arm = FakeArm(
            f"{robot}-arm",
            self.world,
            WorldPose(base_pose.x + 0.2, base_pose.y, 0.93, 1.0, 0.0, 0.0, 0.0),
            dof,
        )
        self.devices = {
            f"{robot}-arm": arm,
            f"{robot}-gripper": FakeGripper(f"{robot}-gripper", self.world, arm),
            f"{robot}-base": FakeBase(f"{robot}-base", self.world, base_pose),
            camera: FakeSensor(camera, self.world),
        }

    def by_id(self) -> dict[str, object]:
        return {self.ids[label]: device for label, device in self.devices.items()}

    @asynccontextmanager
    async def agent(
        self,
        robot: str,
        *classes: type[Skill],
        simulated: SimulatedOutcomes | None = None,
        **kw: object,
    ) -> AsyncIterator[AgentCore]:
        core = AgentCore(
            name=f"{robot}-agent",
            wm=self.wm,
            skills=entries(*classes),
            devices=self.by_id(),
            robot=self.ids[robot],
            simulated=simulated,
            preempt_timeout=2.0,
            **kw,  # type: ignore[arg-type]
        )
        async with anyio.create_task_group() as tg:
            await tg.start(core.run)
            yield core
            tg.cancel_scope.cancel()


@asynccontextmanager
async def rig(scenario: str) -> AsyncIterator[Rig]:
    """The scenario's initial scene in an in-memory world model; objects in the toy world at
    their world-model poses."""
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm:
            s = load_scenario(SCENARIOS / scenario / "scenario.toml")
            reply = await wm.transact(scenario_ops(s))
            ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
            world = ToyWorld()
            movable = [p.label for p in s.parts] + [c.label for c in s.containers if c.closed]
            for label in movable:
                pose = wm.get_element(ids[label]).properties["pose"]
                assert isinstance(pose, Pose)
                world.objects[label] = world_pose(pose)
            yield Rig(wm, ids, world)
        tg.cancel_scope.cancel()


async def run(core: AgentCore, skill: str, **params: object) -> RunResult:
    """Start ``skill`` and wait for its result."""
    started = await core.start(StartRun(skill=skill, params=dict(params)))  # type: ignore[arg-type]
    return await core.wait(started.run_id)


# --------------------------------------------------------------------------- the fakes' own tests


@pytest.mark.anyio
async def test_the_fakes_satisfy_the_device_protocols() -> None:
    world = ToyWorld()
    arm = FakeArm("a", world, WorldPose(0, 0, 1))
    assert isinstance(arm, Arm)
    assert isinstance(FakeGripper("g", world, arm), Gripper)
    assert isinstance(FakeBase("b", world, Pose2D()), MobileBase)
    assert isinstance(FakeSensor("s", world), ObjectSensor)
    assert isinstance(FakeAppliance("m", world), Appliance)


@pytest.mark.anyio
async def test_a_grasped_object_follows_the_tool() -> None:
    world = ToyWorld()
    world.objects["Gear-1"] = WorldPose(1.0, 0.0, 0.5)
    arm = FakeArm("a", world, WorldPose(1.005, 0.0, 0.51))
    gripper = FakeGripper("g", world, arm)
    assert (await gripper.close()).holding == "Gear-1"
    await arm.move_tcp(WorldPose(0.0, 0.0, 1.01))
    assert world.objects["Gear-1"].z == pytest.approx(1.0)
    await gripper.open()
    assert (await gripper.state()).holding == ""
