"""The services of ``skimesh demo``, composed in one process on loopback.

::

    router (tcp/127.0.0.1:<free port>, multicast off)
      ^ every component below is a Zenoh client of it, with its own session
      |-- world-model store   durable log + snapshots in the data directory
      |-- demo client         loads the scenario's scene (ONE transaction), watches changes
      |-- MuJoCo world        SimWorld (fast or real time) + rerun Recorder; in-process drivers;
      |                       its ground truth served on sim/truth (as ``skimesh sim`` does)
      |-- skill agents        one per robot / appliance the scenario names (run_agent), devices
      |                       bound by label to the world's drivers
      '-- task agent          discovery, planning, execution (serve_tasks)

:func:`demo_stack` enters them in that order and leaves them in the reverse order, so on the
way out the task agent aborts its task first, then each agent preempts its runs (its skills'
``on_preempt`` moves the robot to safety while the world still steps), then the world stops,
the store writes its final snapshot and the router goes. The caller closes the recording
afterwards (which finishes the ``.rrd``; a gRPC server sink keeps serving until then).
The world steps only from :meth:`Stack.start_world` on (until then, a fast world would
race through idle simulated time while the agents start).
"""

from __future__ import annotations

import logging
import os
import socket
import sys
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import AsyncExitStack, asynccontextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import anyio
from anyio.abc import TaskStatus

from device_drivers.truth import serve_truth
from meshlink import Mesh, MeshConfig, open_mesh, run_router
from mujoco_sim import SimTruth, SimWorld, WorldOptions, sim_devices
from mujoco_sim.recording import Recorder
from scenario import Scenario
from scenario.wm import scenario_terms, scene_ops
from skill_agent.runtime import AgentConfig, load_config
from skill_agent.server import run_agent
from wm_store import WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.server import StoreConfig, WmStore, serve_store

from ..errors import DemoError

__all__ = ["Stack", "StackOptions", "agent_configs", "demo_stack", "free_port"]

_log = logging.getLogger("skimesh.demo")
Say = Callable[[str], None]


@dataclass(frozen=True, kw_only=True)
class StackOptions:
    scenario: Scenario
    agents: dict[str, AgentConfig]
    """The agents' configurations by name (:func:`agent_configs`)."""
    data_dir: Path
    fast: bool = True
    seed: int = 0
    mesh: str = "demo"
    port: int = 0
    """Router port on 127.0.0.1 (0: a free one)."""
    durations: Path | None = None
    """The task agent's learned run times file (None: in memory)."""


@dataclass(kw_only=True)
class Stack:
    """What runs: the router's endpoint, the demo's own world-model client, the world and the
    agents' configurations by agent name."""

    endpoint: str
    mesh_config: MeshConfig
    mesh: Mesh
    """The demo's own session (its world-model client and task client use it)."""
    wm: WmClient
    world: SimWorld
    agents: dict[str, AgentConfig]
    ids: dict[str, str]
    """Element id by scenario label, as the scene was loaded."""
    _go: anyio.Event

    def start_world(self) -> None:
        """Let the world step (it waited while the services started)."""
        self._go.set()


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@asynccontextmanager
async def background(service: Callable[..., Awaitable[Any]], *args: Any) -> AsyncIterator[None]:
    """Run ``service(*args, task_status=...)`` while the block runs; once the block ends, cancel
    it and wait until it has stopped."""
    async with anyio.create_task_group() as tg:
        await tg.start(partial(service, *args))  # type: ignore[arg-type]  # any service
        try:
            yield
        finally:
            tg.cancel_scope.cancel()


def agent_configs(scenario: Scenario) -> dict[str, AgentConfig]:
    """The skill-agent configurations the scenario names (robots and appliances), by agent
    (reads the files: call it before the event loop runs).

    Raises:
        DemoError: the scenario names none. SkillLoadError: a config does not load.
    """
    configs = [load_config(path) for path in scenario.agents.values()]
    if not configs:
        raise DemoError(f"scenario {scenario.name!r} names no agent config ([[robots]] agent)")
    return {c.name: c for c in configs}


async def _world(
    world: SimWorld, go: anyio.Event, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
) -> None:
    task_status.started()
    await go.wait()
    await world.run()
    await anyio.sleep_forever()  # a failed world stays inspectable until the demo ends


async def _agent(
    config: MeshConfig,
    agent: AgentConfig,
    drivers: dict[str, object],
    *,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    async with open_mesh(config) as mesh:
        await run_agent(mesh, agent, drivers=drivers, task_status=task_status)


async def _task_agent(
    config: MeshConfig,
    durations: Path | None = None,
    *,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    from task_agent.service import serve_tasks  # slow to import (docs/benchmarks.md, Planning)

    async with (
        open_mesh(config) as mesh,
        WmClient.connect(ZenohTransport(mesh), author="task-agent") as wm,
    ):
        await serve_tasks(mesh, wm, operator=None, durations=durations, task_status=task_status)


def _quietly(fn: Callable[[], SimWorld]) -> SimWorld:
    """``fn()`` with the process's stdout muted (placo prints "Loading model: ..." from C++
    for every robot it loads)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            return fn()
    finally:
        os.dup2(saved, 1)
        os.close(saved)


async def _open_store(options: StackOptions) -> WmStore:
    store = await WmStore.open(Ontology.default(), StoreConfig(data_dir=str(options.data_dir)))
    if store.state.elements:
        await store.aclose()
        raise DemoError(
            f"the data directory {options.data_dir} already holds a world model "
            f"({len(store.state.elements)} elements); give an empty or new directory"
        )
    return store


@asynccontextmanager
async def demo_stack(
    options: StackOptions,
    recorder: Recorder | None,
    *,
    say: Say = print,
    on_wm: Callable[[WmClient], object] | None = None,
) -> AsyncIterator[Stack]:
    """Start every service (see the module doc) and yield what runs; ``recorder`` records the
    world (close it after this context ended: the world has stopped then). ``on_wm`` is called
    with the demo's world-model client as soon as it is connected, before the scene is loaded
    (to watch every change).

    Raises:
        DemoError: see the class. SkillLoadError / WmError / MeshlinkError: a part failed.
    """
    scenario, agents = options.scenario, options.agents
    store = await _open_store(options)  # first: a busy data directory stops nothing else
    async with AsyncExitStack() as stack:
        stack.push_async_callback(store.aclose)  # after serve_store stopped (it closes it too)
        endpoint = f"tcp/127.0.0.1:{options.port or free_port()}"
        await stack.enter_async_context(background(run_router, [endpoint]))
        client = MeshConfig(connect=(endpoint,), mesh=options.mesh)
        say(f"router on {endpoint} (loopback only, multicast off), mesh {options.mesh!r}")

        server_mesh = await stack.enter_async_context(open_mesh(client))
        await stack.enter_async_context(background(serve_store, server_mesh, store))
        mesh = await stack.enter_async_context(open_mesh(client))
        wm = await stack.enter_async_context(WmClient.connect(ZenohTransport(mesh), author="demo"))
        if on_wm is not None:
            on_wm(wm)
        terms = await anyio.to_thread.run_sync(scenario_terms, scenario)
        reply = await wm.transact(scene_ops(scenario, wm.replica.state, wm.ontology, terms=terms))
        ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
        say(
            f"world model: {len(wm.replica.state.elements)} elements of scenario "
            f"{scenario.name!r} in one transaction (revision {reply.revision}), "
            f"durable in {options.data_dir}"
        )

        world_options = WorldOptions(fast=options.fast, seed=options.seed)
        world = await anyio.to_thread.run_sync(
            _quietly, partial(SimWorld, scenario, world_options, recorder)
        )
        go = anyio.Event()
        await stack.enter_async_context(background(_world, world, go))
        await stack.enter_async_context(background(serve_truth, server_mesh, SimTruth(world)))
        drivers: dict[str, object] = {d.name: d for d in sim_devices(world).values()}
        pace = "as fast as possible" if options.fast else "in real time"
        say(f"MuJoCo world: {len(drivers)} devices, stepping {pace}")

        for name, agent in agents.items():
            await stack.enter_async_context(background(_agent, client, agent, drivers))
            say(f"skill agent {name}: {_agent_line(agent, drivers)}")
        await stack.enter_async_context(background(_task_agent, client, options.durations))
        say("task agent: discovery, planning (Kairos), execution")
        yield Stack(
            endpoint=endpoint,
            mesh_config=client,
            mesh=mesh,
            wm=wm,
            world=world,
            agents=agents,
            ids=ids,
            _go=go,
        )


def _agent_line(agent: AgentConfig, drivers: dict[str, object]) -> str:
    used = [label for label in agent.device_labels if label in drivers]
    shared = [label for label in agent.hardware.values() if label in drivers]
    extra = f" (shared: {', '.join(shared)})" if shared else ""
    return f"controls {agent.robot_label}; devices {', '.join(used) or 'none'}{extra}"
