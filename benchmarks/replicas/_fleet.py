"""The measured fleet: one store, ``robots`` simulated-outcome agents in this process, each with
a kitting cell, driven in a loop of navigate steps.

The store is in-memory in this process (``transport`` None: every cost on one loop, the
changes recorded for the replay of :mod:`~benchmarks.replicas._cost`), or ``skimesh wm``'s
store in another process reached over Zenoh (a :class:`~wm_store.ZenohTransport` given: each
replica a subscription of its own, the store's work on the other core).

Scene, per robot ``i``: a station (``Station``, with a pose) holding a part box with two gears,
the robot registered the way ``skimesh agent`` registers it (agent, robot, arm, gripper, base,
camera, the four kitting skills), a kit box on the robot; one depot for all. Each agent is an
:class:`~skill_agent.runtime.AgentCore` in simulated-outcome mode running the standard
``navigate`` skill (pre-conditions checked in the world model, a sleep of ``duration *
time_scale``, its effects committed as one transaction). Every robot drives depot -> its
station -> depot ... for ``steps`` steps, all robots at once.

``replicas``:

- ``own``: every agent has its own :class:`~wm_store.WmClient` and so its own replica that
  receives, decodes and applies every change: what one ``skimesh agent`` process per robot
  does, here on one event loop (the agents of a 2-core host share its cores either way);
- ``shared``: the agents share one replica (:meth:`wm_store.WmClient.with_author`), what
  ``run_agent(..., wm=client)`` does for the agents of one process.

``anonymous``: the agents' step writes name no author, so the store skips its check that no
agent changes what another registered (:mod:`wm_store.scene._ownership`, whose cost grows
with the number of agents): an ablation that separates the store's cost from the replicas'.

A step's *overhead* is its wall time from ``start`` to its result minus the simulated sleep:
the pre-condition check, the transaction and the wait for this agent's replica to show it,
and every other replica's work that shares the loop.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import AsyncIterator, Callable
from contextlib import AsyncExitStack, asynccontextmanager

import anyio
import msgspec

from skill_agent.protocol import RunEvent, RunResult, StartRun
from skill_agent.runtime import AgentCore, SimulatedOutcomes, SkillEntry
from skill_agent.skills import Navigate, Pick, Place, Serve
from tests.assets.planning.fleet import mobile_manipulator, skill_specs
from wm_store import (
    InMemoryTransport,
    RobotRegistration,
    WmClient,
    WmTransport,
)
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Op, Pose, Position, Relation, SetRelation, Value
from wm_store.server import WmService, WmStore

__all__ = ["Agent", "Fleet", "drive", "fleet"]

_SKILLS = (Navigate, Pick, Place, Serve)


class Agent(msgspec.Struct, kw_only=True):
    name: str
    core: AgentCore
    robot: str
    station: str


class Fleet(msgspec.Struct, kw_only=True):
    store: WmStore | None
    """The in-process store (None: the store is elsewhere)."""
    wm: WmClient
    """The set-up client (its replica also follows the store)."""
    depot: str
    agents: list[Agent]
    time_scale: float
    replicas: int
    """How many replicas follow the store (the set-up client's included)."""


def _cell_ops(i: int) -> list[Op]:
    pose: dict[str, Value] = {"pose": Pose(Position(3.0 * i, 4.0, 0.0))}
    return [
        AddElement(type="Station", label=f"station-{i}", ref=f"$s{i}", properties=pose),
        AddElement(
            type="PartBox",
            label=f"box-{i}",
            ref=f"$b{i}",
            relations=[Relation(f"$s{i}", "contain", "$"), Relation("$", "at", f"$s{i}")],
        ),
        *(
            AddElement(
                type="Gear",
                label=f"gear-{i}-{g}",
                properties={"mass": 0.1},
                relations=[Relation(f"$b{i}", "contain", "$")],
            )
            for g in (1, 2)
        ),
    ]


def _registration(i: int) -> RobotRegistration:
    return mobile_manipulator(i, skill_specs(s.description for s in _SKILLS))


@asynccontextmanager
async def fleet(
    robots: int,
    *,
    replicas: str,
    time_scale: float,
    anonymous: bool = False,
    transport: WmTransport | None = None,
) -> AsyncIterator[Fleet]:
    """``robots`` agents with ``replicas`` ``own`` or ``shared`` (see the module doc), on an
    empty store: in this process, or the one ``transport`` reaches."""
    ontology = Ontology.default()
    async with AsyncExitStack() as stack:
        tg = await stack.enter_async_context(anyio.create_task_group())
        store = None
        if transport is None:
            store = await WmStore.open(ontology)
            await tg.start(store.run)
            transport = InMemoryTransport(WmService(store))
        wm = await stack.enter_async_context(WmClient.connect(transport, ontology, author="set-up"))
        depot_pose: dict[str, Value] = {"pose": Pose(Position(0.0, 0.0, 0.0))}
        ops: list[Op] = [
            AddElement(type="Location", label="depot", ref="$d", properties=depot_pose)
        ]
        for i in range(1, robots + 1):
            ops += _cell_ops(i)
        ids = (await wm.transact(ops)).ids
        agents = []
        for i in range(1, robots + 1):
            name = f"r{i}"
            if replicas == "own":
                client = await stack.enter_async_context(
                    WmClient.connect(transport, ontology, author=name)
                )
            else:
                client = wm.with_author(name)
            robot = (await client.register_robot(_registration(i)))["$robot"]
            await client.transact(
                [
                    AddElement(
                        type="KitBox",
                        label=f"kit-{i}",
                        properties={"capacity": 20},
                        relations=[Relation(robot, "contain", "$")],
                    ),
                    SetRelation(subject=robot, predicate="at", object=ids["$d"]),
                ]
            )
            core = AgentCore(
                name=name,
                wm=client.with_author("") if anonymous else client,
                skills={
                    s.description.name: SkillEntry(description=s.description, factory=s)
                    for s in _SKILLS
                },
                simulated=SimulatedOutcomes({"navigate": 1.0}, 1.0, time_scale=time_scale),
                robot=robot,
            )
            await tg.start(core.run)
            agents.append(Agent(name=name, core=core, robot=robot, station=ids[f"$s{i}"]))
        await wm.wait_for_revision((await wm.info()).revision)
        yield Fleet(
            store=store,
            wm=wm,
            depot=ids["$d"],
            agents=agents,
            time_scale=time_scale,
            replicas=1 + (robots if replicas == "own" else 0),
        )
        tg.cancel_scope.cancel()


async def _step(agent: Agent, start: str, goal: str) -> tuple[float, RunResult]:
    """One navigate run: (wall seconds from start to result, the result)."""
    done = anyio.Event()
    result: list[RunResult] = []
    run_id = uuid.uuid4().hex

    def on_event(event: RunEvent) -> None:
        if isinstance(event, RunResult) and event.run_id == run_id:
            result.append(event)
            done.set()

    unsubscribe = agent.core.subscribe(on_event)
    try:
        began = time.perf_counter()
        await agent.core.start(
            StartRun(
                skill="navigate",
                params={"robot": agent.robot, "start": start, "goal": goal},
                run_id=run_id,
            )
        )
        await done.wait()
        return time.perf_counter() - began, result[0]
    finally:
        unsubscribe()


async def drive(
    f: Fleet, steps: int, on_step: Callable[[float], None] | None = None
) -> list[float]:
    """Every robot drives ``steps`` steps at once; the overheads (seconds), in finish order.
    Raises RuntimeError when a step fails (the benchmark measures only successful steps)."""
    sleep = Navigate.description.duration * f.time_scale
    overheads: list[float] = []

    async def robot(index: int, agent: Agent) -> None:
        await anyio.sleep(sleep * index / len(f.agents))  # a fleet's steps are not in lockstep
        here, there = f.depot, agent.station
        for _ in range(steps):
            wall, result = await _step(agent, here, there)
            if not result.success:
                raise RuntimeError(f"{agent.name}: navigate failed: {result.message}")
            overheads.append(wall - sleep)
            if on_step is not None:
                on_step(wall - sleep)
            here, there = there, here

    async with anyio.create_task_group() as tg:
        for index, agent in enumerate(f.agents):
            tg.start_soon(robot, index, agent)
    return overheads
