"""The simulated devices over real Zenoh on loopback: the same skill-like routine runs
unchanged in-process and through the remote proxies (also one driving the base by velocity),
errors keep their class, cancelling a remote motion halts the device, states are published;
and ``skimesh sim`` as a process."""

from __future__ import annotations

import math
import subprocess
import sys
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import msgspec
import pytest

from device_drivers import (
    Arm,
    CommandError,
    Device,
    DeviceBusyError,
    Gripper,
    MobileBase,
    MotionStoppedError,
    ObjectSensor,
    Pose2D,
    UnreachableError,
)
from device_drivers import protocol as p
from device_drivers.remote import RemoteArm, connect_devices, serve_devices
from meshlink import Mesh, open_mesh
from mujoco_sim import SimWorld, WorldOptions, running_world, sim_devices
from mujoco_sim.motion import tool_down
from scenario import load_scenario
from tests.conftest import MeshConfigFactory

from .procs import ROOT, Child

pytestmark = [pytest.mark.zenoh, pytest.mark.sim, pytest.mark.anyio]

KITTING = ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml"
READY = {"shoulder_lift": 0.4, "elbow": 1.5, "wrist_pitch": 1.24}


async def routine(
    arm: Arm, gripper: Gripper, base: MobileBase, camera: ObjectSensor
) -> dict[str, Any]:
    """Skill-like code written against the device Protocols only."""
    steps: list[float] = []
    await base.go_to(Pose2D(-0.3, -1.0, 0.3), progress=steps.append)
    await arm.move_joints(READY, duration=1.0)
    tcp = (await arm.state()).tcp
    await arm.move_tcp(tool_down(tcp.x, tcp.y + 0.05, tcp.z + 0.05), speed=0.1)
    closed = await gripper.close()
    await gripper.open()
    refused: list[str] = []
    for bad in (arm.move_joints({"elbow": 9.0}), arm.move_tcp(tool_down(4.0, 4.0, 0.5))):
        try:
            await bad
        except (CommandError, UnreachableError) as exc:
            refused.append(type(exc).__name__)
    pose = (await base.state()).pose
    end = (await arm.state()).tcp
    return {
        "base": (pose.x, pose.y, pose.yaw),
        "tcp": (end.x, end.y, end.z),
        "holding": closed.holding,
        "opening": (await gripper.state()).opening,
        "refused": refused,
        "progress_done": steps[-1] if steps else None,
        "seen": sorted(d.name for d in await camera.detect()),
    }


async def drive(base: MobileBase, pause: Callable[[], Awaitable[None]]) -> dict[str, Any]:
    """Velocity control written against the MobileBase Protocol only (``pause``: wait 2 s of
    the device's time): a timed twist, an open-ended spin read back from the state, refusals,
    and a stop that ends the spin."""
    await base.set_velocity(0.0, 0.3, 0.0, duration=1.5)  # sideways: base y = world y
    after = await base.state()
    outcome: list[str] = []

    async def spin() -> None:
        try:
            await base.set_velocity(0.0, 0.0, 0.5)
            outcome.append("ended")
        except MotionStoppedError:
            outcome.append("stopped")

    refused: list[str] = []
    async with anyio.create_task_group() as tg:
        tg.start_soon(spin)
        await pause()  # ramped up (0.5 s) and spinning
        spinning = await base.state()
        for bad in (base.go_to(Pose2D(-0.6, -1.2, 0.0)), base.set_velocity(math.inf, 0.0, 0.0)):
            try:
                await bad
            except (DeviceBusyError, CommandError) as exc:
                refused.append(type(exc).__name__)
        await base.stop()
    halted = await base.state()
    return {
        "pose": (after.pose.x, after.pose.y, after.pose.yaw),
        "moving_after": after.moving,
        "spin": (spinning.velocity.vx, spinning.velocity.vy, spinning.velocity.wz),
        "refused": refused,
        "outcome": outcome,
        "halted": (halted.moving, abs(halted.velocity.wz)),
    }


def r1(devices: dict[tuple[str, str], Device]) -> tuple[Arm, Gripper, MobileBase, ObjectSensor]:
    arm, gripper = devices[("r1", "arm")], devices[("r1", "gripper")]
    base, camera = devices[("r1", "base")], devices[("r1", "camera")]
    assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
    assert isinstance(base, MobileBase) and isinstance(camera, ObjectSensor)
    return arm, gripper, base, camera


@asynccontextmanager
async def served_world(
    endpoint: str, mesh_config: MeshConfigFactory
) -> AsyncIterator[tuple[SimWorld, Mesh]]:
    """A kitting world served on one session; yields it and a second (client) session."""
    async with (
        running_world(load_scenario(KITTING), WorldOptions(fast=True)) as world,
        open_mesh(mesh_config(endpoint)) as server,
        open_mesh(mesh_config(endpoint)) as client,
        anyio.create_task_group() as tg,
    ):
        await tg.start(serve_devices, server, sim_devices(world))
        yield world, client
        tg.cancel_scope.cancel()


async def test_same_routine_in_process_and_remote(
    router_endpoint: str, mesh_config: MeshConfigFactory
) -> None:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as world:
        local = await routine(*r1(sim_devices(world)))
    async with served_world(router_endpoint, mesh_config) as (_, client):
        devices = await connect_devices(client, "r1")
        assert all(d.name.startswith("r1") for d in devices.values())
        remote = await routine(*r1(devices))
    assert remote["refused"] == local["refused"] == ["CommandError", "UnreachableError"]
    assert remote["holding"] == local["holding"] == ""
    assert remote["seen"] == local["seen"]
    assert remote["progress_done"] == local["progress_done"] == 1.0
    assert math.dist(remote["base"], local["base"]) < 0.01
    assert math.dist(remote["tcp"], local["tcp"]) < 0.005
    assert remote["opening"] == pytest.approx(local["opening"], abs=0.002)


async def test_velocity_control_in_process_and_remote(
    router_endpoint: str, mesh_config: MeshConfigFactory
) -> None:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as world:
        local = await drive(r1(sim_devices(world))[2], partial(world.sleep, 2.0))
    async with served_world(router_endpoint, mesh_config) as (world, client):
        base = r1(await connect_devices(client, "r1"))[2]
        remote = await drive(base, partial(world.sleep, 2.0))
    for result in (local, remote):
        assert result["pose"] == pytest.approx((-0.6, -1.0 + 0.45, 0.0), abs=0.01)
        assert not result["moving_after"]
        assert result["spin"] == pytest.approx((0.0, 0.0, 0.5), abs=0.01)
        assert result["refused"] == ["DeviceBusyError", "CommandError"]
        assert result["outcome"] == ["ended"]  # stop() is how an open-ended twist ends
        assert result["halted"][0] is False and result["halted"][1] < 0.01
    assert math.dist(remote["pose"], local["pose"]) < 0.005


async def test_the_loop_never_blocks_while_serving_motions(
    router_endpoint: str, mesh_config: MeshConfigFactory, blocking_detector: Any
) -> None:
    async with served_world(router_endpoint, mesh_config) as (_, client):
        arm, gripper, base, _ = r1(await connect_devices(client, "r1"))
        await base.go_to(Pose2D(-0.4, -1.0, 0.0))
        await arm.move_joints(READY, duration=1.0)
        await gripper.close()
        await gripper.open()
        await arm.move_joints({"elbow": 1.0}, duration=0.5)
    assert blocking_detector.reports == []


async def test_remote_errors_cancellation_and_states(
    router_endpoint: str, mesh_config: MeshConfigFactory
) -> None:
    async with served_world(router_endpoint, mesh_config) as (world, client):
        found = await connect_devices(client)
        assert {("r1", "arm"), ("r2", "gripper"), ("Camera-1", "sensor")} <= set(found)
        arm = found[("r1", "arm")]
        assert isinstance(arm, RemoteArm)
        with pytest.raises(UnreachableError) as info:
            await arm.move_tcp(tool_down(4.0, 4.0, 0.5))
        assert info.value.position_error > 1.0  # the attributes travelled too

        async with anyio.create_task_group() as tg:  # busy is reported as such
            moving = anyio.Event()
            tg.start_soon(
                partial(arm.move_joints, READY, duration=3.0, progress=lambda _: moving.set())
            )
            with anyio.fail_after(5):
                await moving.wait()  # the server reports the motion under way
            with pytest.raises(DeviceBusyError):
                await arm.move_joints({"elbow": 0.2})
            tg.cancel_scope.cancel()  # cancelling the caller stops the remote arm
        await world.sleep(0.3)
        held = (await arm.state()).joints
        assert held["elbow"] < 1.45  # it did not carry on to READY
        await world.sleep(0.5)
        assert (await arm.state()).joints == pytest.approx(held, abs=2e-3)

        key = client.keys.device_state("r1", "gripper")
        async with client.subscribe(key) as states:
            with anyio.fail_after(5):
                sample = await states.receive()
        state = msgspec.msgpack.decode(sample.payload, type=p.StateMessage)
        assert isinstance(state, p.GripperStateReply)
        assert state.state.opening == pytest.approx(0.085, abs=0.003)

        bad = await client.get(client.keys.device_cmd("r1", "arm"), b"\x00nonsense")
        assert len(bad) == 1 and not bad[0].ok
        assert isinstance(p.error_from_reply(bad[0].payload), CommandError)


def test_skimesh_sim_serves_and_stops_cleanly(
    router_endpoint: str, mesh_name: str, tmp_path: Path
) -> None:
    record = tmp_path / "sim.rrd"
    args = ["-m", "skimesh", "sim", "--scenario", "meal", "--connect", router_endpoint]
    args += ["--mesh", mesh_name, "--rerun", str(record)]
    child = Child(args, name="skimesh sim")
    try:
        child.wait_stderr("serving", timeout=60)

        async def use() -> tuple[list[str], bool]:
            config = msgspec.structs.replace(_client_config(router_endpoint), mesh=mesh_name)
            async with open_mesh(config) as mesh:
                devices = await connect_devices(mesh)
                platform = devices[("Worktop-1", "sensor")]
                oven = devices[("Microwave-1", "appliance")]
                assert isinstance(platform, ObjectSensor)
                names = [d.name for d in await platform.detect()]
                state = await oven.state()  # type: ignore[attr-defined]
                return names, bool(state.door_open)

        names, door_open = anyio.run(use)
        assert names == ["MealBox-1", "Tray-1"] and not door_open
    finally:
        code = child.stop()
    assert code == 0, child.log()
    assert record.stat().st_size > 10_000


def _client_config(endpoint: str) -> Any:
    from meshlink import MeshConfig

    return MeshConfig(connect=(endpoint,))


def test_skimesh_sim_help_lists_the_flags() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "skimesh", "sim", "--help"],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    ).stdout
    for flag in ("--scenario", "--fast", "--rerun", "--no-rerun", "--rerun-connect", "--mesh"):
        assert flag in out
