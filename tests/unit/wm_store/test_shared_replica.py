"""Agents of one process sharing one replica (``WmClient.with_author``): each writes as itself,
each reads its own writes and the others', each change is applied once, and the shared replica
still detects divergence from the store."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import pytest

from tests.unit.wm_store.stores import running
from tests.unit.wm_store.test_divergence import ForgeableTransport
from wm_store import DeviceSpec, ForbiddenError, InMemoryTransport, RobotRegistration, WmClient
from wm_store.ontology import Ontology
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio


@asynccontextmanager
async def shared(ontology: Ontology) -> AsyncIterator[WmClient]:
    """A client (and its replica) of a fresh in-memory store."""
    async with (
        running(WmStore(ontology)) as store,
        WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm,
    ):
        yield wm


def _robot(agent: str) -> RobotRegistration:
    return RobotRegistration(
        agent=agent,
        robot_type="MobileManipulator",
        robot_label=f"robot-{agent}",
        devices=[DeviceSpec(type="Gripper", label=f"gripper-{agent}")],
    )


async def test_agents_share_one_replica_and_write_as_themselves(ontology: Ontology) -> None:
    async with shared(ontology) as wm:
        r1, r2 = wm.with_author("r1"), wm.with_author("r2")
        assert r1.replica is wm.replica and r2.replica is wm.replica
        assert (r1.author, r2.author, wm.author) == ("r1", "r2", "")
        robot1 = (await r1.register_robot(_robot("r1")))["$robot"]
        robot2 = (await r2.register_robot(_robot("r2")))["$robot"]
        # read your writes, and the other agent's, from the one replica
        assert r2.get_element(robot1).label == "robot-r1"
        assert r1.get_element(robot2).label == "robot-r2"
        before = wm.replica.statistics().applied
        place = await r1.add_element("Location", label="dock")
        await r1.set_relation(robot1, "at", place)
        assert wm.replica.statistics().applied == before + 2  # once each, not once per agent
        # the store knows who wrote: r2 may not change r1's robot, r1 may
        await r1.update_element(robot1, {"mass": 3.0})
        with pytest.raises(ForbiddenError):
            await r2.update_element(robot1, {"mass": 3.0})


async def test_every_agent_hears_each_change_once(ontology: Ontology) -> None:
    async with shared(ontology) as wm:
        r1, r2 = wm.with_author("r1"), wm.with_author("r2")
        heard: dict[str, list[int]] = {"r1": [], "r2": []}
        off1 = r1.on_change(lambda c: heard["r1"].append(c.revision))
        off2 = r2.on_change(lambda c: heard["r2"].append(c.revision))
        await r1.add_element("Location", label="a")
        await r2.add_element("Location", label="b")
        off1()
        await r1.add_element("Location", label="c")
        off2()
        assert len(heard["r1"]) == 2 and len(heard["r2"]) == 3
        assert heard["r2"] == sorted(set(heard["r2"]))


async def test_a_shared_replica_still_finds_a_forged_change(ontology: Ontology) -> None:
    """The divergence check runs on the one replica: a change the store never committed is
    found by the check against the store, and every agent reads the store's state again."""
    store = WmStore(ontology)
    async with running(store) as s:
        transport = ForgeableTransport(WmService(s))
        async with WmClient.connect(transport) as wm:
            r1, r2 = wm.with_author("r1"), wm.with_author("r2")
            await r1.add_element("Location", label="real")
            wm.replica.check_every = 0.05
            await transport.forge(s.revision + 1, "forged")
            with anyio.fail_after(10):
                await r2.wait_for_revision(s.revision + 1)
            assert r2.resolve_element(type="Gear", label="forged"), "the replica applied it"
            with anyio.fail_after(10):
                await wm.replica.wait_for_snapshot(2)
            assert wm.replica.divergences == 1
            for agent in (r1, r2):
                assert not agent.resolve_element(type="Gear", label="forged")
                assert agent.revision == s.revision
                assert agent.resolve_element(label="real")
