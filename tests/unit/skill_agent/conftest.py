"""Shared fixtures of the skill-agent tests: an in-memory world model holding a small kitting
scene, a probe the example skills report to, and an :class:`AgentCore` factory.

Scene (ids in ``kitting.ids`` by short name)::

    station-a contain shelf-a contain box-gears contain gear-1, gear-2   (Gear, a Part)
    r1 (MobileManipulator) hasA left, right (Grippers); r1 contain kit-1 (KitBox)
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Mapping
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import Any, Protocol

import anyio
import msgspec
import pytest

from skill_agent.protocol import RunEvent
from skill_agent.runtime import AgentCore, SkillEntry
from tests.assets.skills import Probe, entries
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Op, Relation, SetRelation, UnsetRelation
from wm_store.server import WmService, WmStore

SCENE_OPS = [
    AddElement(type="Station", label="station-a", ref="$station"),
    AddElement(
        type="Shelf",
        label="shelf-a",
        ref="$shelf",
        relations=[Relation("$station", "contain", "$")],
    ),
    AddElement(
        type="Box", label="box-gears", ref="$box", relations=[Relation("$shelf", "contain", "$")]
    ),
    AddElement(
        type="Gear",
        label="gear-1",
        ref="$gear1",
        properties={"mass": 0.2},
        relations=[Relation("$box", "contain", "$")],
    ),
    AddElement(
        type="Gear",
        label="gear-2",
        ref="$gear2",
        properties={"mass": 0.25},
        relations=[Relation("$box", "contain", "$")],
    ),
    AddElement(type="MobileManipulator", label="r1", ref="$robot"),
    AddElement(
        type="Gripper", label="r1-left", ref="$left", relations=[Relation("$robot", "hasA", "$")]
    ),
    AddElement(
        type="Gripper", label="r1-right", ref="$right", relations=[Relation("$robot", "hasA", "$")]
    ),
    AddElement(
        type="KitBox", label="kit-1", ref="$kit", relations=[Relation("$robot", "contain", "$")]
    ),
]


class Kitting(msgspec.Struct):
    """The world-model client and the scene's element ids by short name."""

    wm: WmClient
    ids: dict[str, str]

    def __getitem__(self, name: str) -> str:
        return self.ids[name]

    async def move(self, element: str, into: str) -> int:
        """Make ``into`` contain ``element`` (one transaction); returns the revision."""
        parent = self.wm.get_parent(element)
        ops: list[Op] = [SetRelation(subject=into, predicate="contain", object=element)]
        if parent is not None:
            ops.insert(0, UnsetRelation(subject=parent.id, predicate="contain", object=element))
        return (await self.wm.transact(ops)).revision


class AgentFactory(Protocol):
    """Type of ``make_agent``: ``async with make_agent(skills=None, **AgentCore kwargs) as
    core`` runs an agent for robot r1 (devices: its two grippers) until the block ends."""

    def __call__(
        self, skills: Mapping[str, SkillEntry] | None = None, **kwargs: Any
    ) -> AbstractAsyncContextManager[AgentCore]: ...


class Recorder:
    """Collects every run event of an agent, in order."""

    def __init__(self) -> None:
        self.events: list[RunEvent] = []

    def __call__(self, event: RunEvent) -> None:
        self.events.append(event)

    def of(self, run_id: str) -> list[RunEvent]:
        return [e for e in self.events if e.run_id == run_id]


@pytest.fixture(scope="session")
def ontology() -> Ontology:
    return Ontology.default()


@asynccontextmanager
async def store_service(ontology: Ontology) -> AsyncIterator[WmService]:
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        yield WmService(store)
        tg.cancel_scope.cancel()


@pytest.fixture
async def kitting(ontology: Ontology) -> AsyncIterator[Kitting]:
    async with (
        store_service(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology, author="test") as wm,
    ):
        reply = await wm.transact(SCENE_OPS)
        ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
        yield Kitting(wm=wm, ids=ids)


@pytest.fixture
def probe() -> Probe:
    return Probe()


@pytest.fixture
def make_agent(kitting: Kitting, probe: Probe) -> AgentFactory:
    @asynccontextmanager
    async def make(
        skills: Mapping[str, SkillEntry] | None = None, **kwargs: Any
    ) -> AsyncIterator[AgentCore]:
        core = AgentCore(
            name="r1-agent",
            wm=kitting.wm,
            skills=entries(probe) if skills is None else skills,
            robot=kitting["robot"],
            **kwargs,
        )
        async with anyio.create_task_group() as tg:
            await tg.start(core.run)
            yield core
            tg.cancel_scope.cancel()

    return make
