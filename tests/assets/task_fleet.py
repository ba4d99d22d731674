"""An in-process kitting fleet for task-layer tests: an in-memory world-model store, robots
registered the way their agents register, one :class:`AgentCore` per robot in simulated-outcome
mode running the standard skills (navigate, pick, place, serve), live :class:`Discovery` fed
by hand, and a :class:`CoreRunner`. No Zenoh.

Scene (element ids in :class:`Fleet` fields)::

    depot (Location)          robots r1..rN at the depot (or where ``start`` says)
    Station-1, Station-2      each: a PartBox (at the station) with gears, a Tray (at it)
    (the depot is open floor; each station has room for every robot: ``robotCapacity``)
    robot-i contain KitBox-i  each robot carries its kit box

Goals that need both robots: fill each robot's kit (``kit_goal``); goals either robot can
reach: serve onto the trays (``tray_goal``).
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Mapping
from contextlib import asynccontextmanager
from typing import Any

import anyio
import msgspec

from skill_agent import Skill
from skill_agent.runtime import AgentCore, SimulatedOutcomes, SkillEntry
from skill_agent.skills import Navigate, Pick, Place, Serve
from task_agent.discovery import Discovery
from task_agent.execution import CoreRunner, Executor
from task_agent.planning import Planner
from task_agent.protocol import TaskEvent, TaskOptions
from task_agent.service import TaskService
from tests.assets.planning.fleet import mobile_manipulator, skill_specs
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Op, Pose, Position, Relation, SetRelation, Value
from wm_store.server import WmService, WmStore

__all__ = ["SKILLS", "Fleet", "fleet"]

SKILLS: tuple[type[Skill], ...] = (Navigate, Pick, Place, Serve)
PLANNER = Planner()


class Fleet(msgspec.Struct, kw_only=True):
    wm: WmClient
    cores: dict[str, AgentCore]
    runner: CoreRunner
    discovery: Discovery
    robots: list[str]
    kits: list[str]
    trays: list[str]
    stations: list[str]
    parts: list[str]
    events: list[TaskEvent] = []
    changed: anyio.Event = msgspec.field(default_factory=anyio.Event)

    def publish(self, event: TaskEvent) -> None:
        self.events.append(event)
        changed, self.changed = self.changed, anyio.Event()
        changed.set()

    async def wait_for(self, kind: type[TaskEvent], agent: str = "", timeout: float = 10) -> None:
        """Until an event of ``kind`` (of ``agent``) was published."""
        with anyio.fail_after(timeout):
            while not any(
                isinstance(e, kind) and (not agent or getattr(e, "agent", "") == agent)
                for e in self.events
            ):
                await self.changed.wait()

    def executor(self, task_id: str = "t-1", **options: object) -> Executor:
        """An executor publishing into ``events`` (options: TaskOptions fields)."""
        return Executor(
            task_id=task_id,
            wm=self.wm,
            discovery=self.discovery,
            runner=self.runner,
            publish=self.publish,
            options=msgspec.convert(options, TaskOptions),
            planner=PLANNER,
        )

    def kit_goal(self, *parts: int) -> str:
        """Part ``parts[i]`` into robot ``i``'s kit."""
        return " and ".join(
            f"contain({self.kits[i]}, {self.parts[p]})" for i, p in enumerate(parts)
        )

    def tray_goal(self, *parts: int) -> str:
        """Part ``parts[i]`` onto tray ``i``."""
        return " and ".join(
            f"contain({self.trays[i]}, {self.parts[p]})" for i, p in enumerate(parts)
        )

    def of(self, kind: type[TaskEvent]) -> list[TaskEvent]:
        return [e for e in self.events if isinstance(e, kind)]

    def service(self, **options: Any) -> TaskService:
        """A task service on this fleet, publishing into ``events`` (``options``: more
        :class:`TaskService` arguments). Start its ``run`` in a task group."""
        return TaskService(
            wm=self.wm,
            discovery=self.discovery,
            runner=self.runner,
            publish=self.publish,
            planners=lambda _options: PLANNER,
            **options,
        )


def _pose(x: float, y: float) -> dict[str, Value]:
    return {"pose": Pose(Position(x, y, 0.0))}


async def _scene(wm: WmClient, parts: int, robots: int) -> dict[str, list[str]]:
    ops: list[Op] = [
        AddElement(type="Location", label="depot", ref="$depot", properties=_pose(0, 0))
    ]
    for s in (1, 2):
        ops += [
            AddElement(
                type="Station",
                label=f"station-{s}",
                ref=f"$s{s}",
                properties={**_pose(2, 2 * s), "robotCapacity": max(robots, 2)},
            ),
            AddElement(
                type="PartBox",
                label=f"box-{s}",
                ref=f"$b{s}",
                relations=[Relation(f"$s{s}", "contain", "$"), Relation("$", "at", f"$s{s}")],
            ),
            AddElement(
                type="Tray",
                label=f"tray-{s}",
                ref=f"$t{s}",
                properties={"capacity": 20},
                relations=[Relation(f"$s{s}", "contain", "$"), Relation("$", "at", f"$s{s}")],
            ),
        ]
    for p in range(parts):
        ops.append(
            AddElement(
                type="Gear",
                label=f"gear-{p + 1}",
                ref=f"$p{p}",
                properties={"mass": 0.1},
                relations=[Relation(f"$b{p % 2 + 1}", "contain", "$")],
            )
        )
    ids = (await wm.transact(ops)).ids
    return {
        "depot": [ids["$depot"]],
        "stations": [ids["$s1"], ids["$s2"]],
        "trays": [ids["$t1"], ids["$t2"]],
        "parts": [ids[f"$p{p}"] for p in range(parts)],
    }


@asynccontextmanager
async def fleet(
    robots: int = 2,
    parts: int = 6,
    *,
    probabilities: Mapping[str, Mapping[str, float]] | None = None,
    time_scale: float = 0.01,
    start: Mapping[str, int] | None = None,
) -> AsyncIterator[Fleet]:
    """``robots`` agents ``r1..`` (``probabilities``: per agent, per skill; default 1.0),
    each at the depot or at station ``start[agent]`` (1 or 2)."""
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        transport = InMemoryTransport(WmService(store))
        async with WmClient.connect(transport, ontology, author="test") as wm:
            scene = await _scene(wm, parts, robots)
            specs = skill_specs(c.description for c in SKILLS)
            cores, robot_ids, kits = {}, [], []
            for r in range(1, robots + 1):
                name = f"r{r}"
                registered = await wm.register_robot(mobile_manipulator(r, specs))
                robot = registered["$robot"]
                at = (start or {}).get(name)
                where = scene["stations"][at - 1] if at else scene["depot"][0]
                kit = (
                    await wm.transact(
                        [
                            AddElement(type="KitBox", label=f"kit-{r}", ref="$kit",
                                       properties={"capacity": 20},
                                       relations=[Relation(robot, "contain", "$")]),
                            SetRelation(subject=robot, predicate="at", object=where),
                        ]
                    )
                ).ids["$kit"]  # fmt: skip
                probs = {c.description.name: 1.0 for c in SKILLS}
                probs.update((probabilities or {}).get(name, {}))
                cores[name] = AgentCore(
                    name=name,
                    wm=wm,
                    skills={
                        c.description.name: SkillEntry(description=c.description, factory=c)
                        for c in SKILLS
                    },
                    simulated=SimulatedOutcomes(probs, time_scale=time_scale),
                    robot=robot,
                )
                robot_ids.append(robot)
                kits.append(kit)
            for core in cores.values():
                await tg.start(core.run)
            discovery = Discovery(wm)
            discovery.reset_alive(set(cores))
            yield Fleet(
                wm=wm,
                cores=cores,
                runner=CoreRunner(cores),
                discovery=discovery,
                robots=robot_ids,
                kits=kits,
                trays=scene["trays"],
                stations=scene["stations"],
                parts=scene["parts"],
            )
        tg.cancel_scope.cancel()
