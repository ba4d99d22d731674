"""The mesh's services in this process, for integration tests: the world-model store, one skill
agent with simulated outcomes, the task service with its operator agent, and a device server
over a fake gripper, all served on ONE Zenoh session (a client of the test's router) by the
caller's event loop.

:func:`running_services` starts them in that order and stops them in the reverse order (the
task service aborts its tasks, the agents unregister while the store still answers, then the
store writes its final snapshot). No MuJoCo: the agent's one skill is ``noop`` (from
``docs/examples``), with simulated outcomes.
"""

from __future__ import annotations

import textwrap
from collections.abc import AsyncIterator, Callable, Coroutine
from contextlib import AsyncExitStack, asynccontextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import anyio
from anyio.abc import TaskStatus

from device_drivers import GripperState
from device_drivers.remote import serve_devices
from meshlink import Mesh, MeshConfig, open_mesh
from skill_agent.runtime import AgentConfig, parse_config
from skill_agent.server import run_agent
from wm_store import WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.server import StoreConfig, WmStore, serve_store

from .procs import ROOT

__all__ = ["AGENT", "DEVICE", "OPERATOR", "FakeGripper", "Services", "running_services"]

AGENT = "r1"
OPERATOR = "operator"
DEVICE = (AGENT, "gripper")
"""The device server's one device, (owner, device): ``devices/r1/gripper/cmd``."""


def agent_config(name: str = AGENT) -> AgentConfig:
    """A robot agent with a gripper and the ``noop`` skill, outcomes simulated."""
    noop = ROOT / "docs" / "examples" / "noop.py"
    return parse_config(
        textwrap.dedent(
            f"""
            name = "{name}"
            preempt_timeout = 2.0

            [robot]
            type = "MobileManipulator"
            label = "{name}"

            [[devices]]
            type = "Gripper"
            label = "{name}-gripper"

            [skills]
            paths = ["{noop}"]

            [simulation]
            enabled = true
            default = 1.0
            time_scale = 0.01
            seed = 1
            """
        ),
        source="services.agent_config",
    )


class FakeGripper:
    """A gripper that only counts what it is asked to do (``calls``)."""

    def __init__(self, name: str) -> None:
        self._name = name
        self.calls: list[str] = []
        self.opening = 0.085

    @property
    def name(self) -> str:
        return self._name

    async def stop(self) -> None:
        self.calls.append("stop")

    async def state(self) -> GripperState:
        return GripperState(opening=self.opening)

    async def open(self, width: float | None = None) -> None:
        self.calls.append("open")
        self.opening = 0.085 if width is None else width

    async def close(self, force: float = 20.0) -> GripperState:
        self.calls.append("close")
        self.opening = 0.0
        return await self.state()


@dataclass
class Services:
    """What runs: the services' session, the store and the fake gripper (to read their state
    directly) and the agent's name."""

    mesh: Mesh
    store: WmStore
    gripper: FakeGripper
    agent: str = AGENT
    operator: str = OPERATOR


@asynccontextmanager
async def _background(
    service: Callable[..., Coroutine[Any, Any, Any]], *args: Any, **kwargs: Any
) -> AsyncIterator[None]:
    """Run ``service(*args, **kwargs, task_status=...)`` once it reported started, while the
    block runs; then cancel it and wait until it has stopped."""
    async with anyio.create_task_group() as tg:
        await tg.start(partial(service, *args, **kwargs))
        try:
            yield
        finally:
            tg.cancel_scope.cancel()


async def _task_service(
    mesh: Mesh, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
) -> None:
    from task_agent.service import serve_tasks  # slow to import (the planners)

    async with WmClient.connect(ZenohTransport(mesh), author="task-agent") as wm:
        await serve_tasks(mesh, wm, operator=OPERATOR, task_status=task_status)


@asynccontextmanager
async def running_services(
    config: MeshConfig, data_dir: Path, *, devices: bool = True
) -> AsyncIterator[Services]:
    """Start the store (durable in ``data_dir``), the agent, the task service with the
    operator agent and (``devices``) the device server on one session of ``config``."""
    store = await WmStore.open(Ontology.default(), StoreConfig(data_dir=str(data_dir)))
    gripper = FakeGripper(f"{AGENT}-gripper")
    async with AsyncExitStack() as stack:
        stack.push_async_callback(store.aclose)  # if serve_store never ran
        mesh = await stack.enter_async_context(open_mesh(config))
        await stack.enter_async_context(_background(serve_store, mesh, store))
        await stack.enter_async_context(_background(run_agent, mesh, agent_config()))
        await stack.enter_async_context(_background(_task_service, mesh))
        if devices:
            await stack.enter_async_context(_background(serve_devices, mesh, {DEVICE: gripper}))
        yield Services(mesh=mesh, store=store, gripper=gripper)
