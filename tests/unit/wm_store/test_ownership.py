"""An agent may not change what another agent registered (``wm_store.scene.check_writer``):
the store refuses it whole, names both agents, and changes nothing; the facts of the world
stay open to every agent, and writers that are no agent are not restricted here."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import AsyncExitStack, asynccontextmanager

import pytest

from wm_store import (
    DeviceSpec,
    ForbiddenError,
    InMemoryTransport,
    RobotRegistration,
    SkillSpec,
    WmClient,
)
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Op, RemoveElement, SetRelation, UpdateElement
from wm_store.server import StoreConfig, WmService, WmStore

from .stores import running

pytestmark = pytest.mark.anyio


def registration(agent: str, robot: str, devices: tuple[str, ...] = ("arm",)) -> RobotRegistration:
    return RobotRegistration(
        agent=agent,
        robot_type="MobileManipulator",
        robot_label=robot,
        devices=[DeviceSpec(type="Arm", label=f"{robot}-{d}") for d in devices],
        skills=[SkillSpec(name="pick")],
    )


class Site:
    def __init__(self, store: WmStore, stack: AsyncExitStack) -> None:
        self.store, self.stack = store, stack

    async def client(self, author: str) -> WmClient:
        transport = InMemoryTransport(WmService(self.store))
        return await self.stack.enter_async_context(WmClient.connect(transport, author=author))


@asynccontextmanager
async def site(config: StoreConfig | None = None) -> AsyncIterator[Site]:
    store = await WmStore.open(Ontology.default(), config)
    async with running(store), AsyncExitStack() as stack:
        yield Site(store, stack)


async def test_an_agent_cannot_change_or_unregister_another_agents_elements() -> None:
    async with site() as s:
        r1, r2 = await s.client("r1"), await s.client("r2")
        ids1 = await r1.register_robot(registration("r1", "robot-1"))
        ids2 = await r2.register_robot(registration("r2", "robot-2"))
        arm1 = ids1["$device:robot-1-arm"]
        await r2.wait_for_revision(r1.revision)
        gear = (await r2.transact([AddElement(type="Gear", label="gear-x", ref="$g")])).ids["$g"]
        before = s.store.revision
        attempts: list[Op] = [
            UpdateElement(id=ids1["$robot"], properties={"available": False}),
            UpdateElement(id=arm1, properties={"available": False}),
            RemoveElement(id=ids1["$agent"]),
            RemoveElement(id=ids1["$skill:pick"]),
            SetRelation(subject=ids1["$robot"], predicate="hasA", object=gear),
            AddElement(type="RobotAgent", label="r3"),  # registering someone else
        ]
        for op in attempts:
            with pytest.raises(ForbiddenError, match="'r2' may not") as refused:
                await r2.transact([op])
            assert "r1" in str(refused.value) or "r3" in str(refused.value)
        assert s.store.revision == before, "nothing committed"
        # its own elements, and the facts of the world, stay open to it
        await r2.transact([UpdateElement(id=ids2["$robot"], properties={"available": True})])
        await r2.transact([SetRelation(subject=arm1, predicate="contain", object=gear)])


async def test_writers_that_are_no_agent_are_not_restricted_by_the_store() -> None:
    async with site() as s:
        r1, task_agent = await s.client("r1"), await s.client("task-agent")
        ids = await r1.register_robot(registration("r1", "robot-1"))
        await task_agent.wait_for_revision(r1.revision)
        await task_agent.transact(
            [UpdateElement(id=ids["$agent"], properties={"available": False})]
        )
        await task_agent.transact([RemoveElement(id=ids["$skill:pick"])])


async def test_a_split_robot_is_joined_unless_the_store_names_its_controllers() -> None:
    async with site() as s:
        arm, base = await s.client("r1-arm"), await s.client("r1-base")
        await arm.register_robot(registration("r1-arm", "r1", ("arm",)))
        await base.wait_for_revision(arm.revision)
        ids = await base.register_robot(registration("r1-base", "r1", ("base",)))
        assert ids["$device:r1-base"]
        robot = base.resolve_element(type="MobileManipulator")[0].id
        await base.transact([UpdateElement(id=robot, properties={"available": True})])
    async with site(StoreConfig(controllers={"r1": ["r1-arm", "r1-base"]})) as s:
        arm, base, intruder = (
            await s.client("r1-arm"),
            await s.client("r1-base"),
            await s.client("r2"),
        )
        await arm.register_robot(registration("r1-arm", "r1", ("arm",)))
        await base.wait_for_revision(arm.revision)
        await base.register_robot(registration("r1-base", "r1", ("base",)))
        await intruder.wait_for_revision(base.revision)
        with pytest.raises(ForbiddenError, match="controllers setting names r1-arm, r1-base"):
            await intruder.register_robot(registration("r2", "r1", ("camera",)))


async def test_the_store_knows_of_a_registration_made_after_its_last_check() -> None:
    """The store keeps who-owns-what between writes and makes it again after a change to the
    registrations: a device r1 adds later is r1's at once."""
    async with site() as s:
        r1, r2 = await s.client("r1"), await s.client("r2")
        await r1.register_robot(registration("r1", "robot-1"))
        await r2.register_robot(registration("r2", "robot-2"))
        gear = (await r2.transact([AddElement(type="Gear", label="g", ref="$g")])).ids["$g"]
        await r2.transact([UpdateElement(id=gear, properties={"mass": 0.2})])  # map made, kept
        ids = await r1.register_robot(registration("r1", "robot-1", ("arm", "camera")))
        camera = ids["$device:robot-1-camera"]
        await r2.wait_for_revision(r1.revision)
        with pytest.raises(ForbiddenError, match="belongs to agent r1"):
            await r2.transact([UpdateElement(id=camera, properties={"available": False})])
