"""Agents of one process sharing one world-model replica over Zenoh (``run_agent(...,
wm=client)``): each teaches, registers and unregisters as itself, each runs its skills, and the
process keeps one replica (one snapshot loaded, each change applied once)."""

from __future__ import annotations

from contextlib import AsyncExitStack
from functools import partial

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from skill_agent.client import AgentClient
from skill_agent.server import run_agent
from wm_store import WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.server import WmStore, serve_store

from .services import agent_config

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]


def _agents(wm: WmClient) -> set[str]:
    return {e.label for e in wm.resolve_element(type="Agent")}


async def test_agents_of_one_process_share_one_replica(
    router_endpoint: str, mesh_name: str
) -> None:
    store = await WmStore.open(Ontology.default())
    async with AsyncExitStack() as stack:
        stack.push_async_callback(store.aclose)
        mesh = await stack.enter_async_context(
            open_mesh(MeshConfig(connect=(router_endpoint,), mesh=mesh_name))
        )
        serving = await stack.enter_async_context(anyio.create_task_group())
        await serving.start(serve_store, mesh, store)
        wm = await stack.enter_async_context(WmClient.connect(ZenohTransport(mesh)))
        async with anyio.create_task_group() as agents:
            for name in ("a1", "a2"):
                await agents.start(partial(run_agent, mesh, agent_config(name), wm=wm))
            assert {"a1", "a2"} <= _agents(wm)
            for name in ("a1", "a2"):  # each controls its own robot: registered as itself
                (agent,) = wm.resolve_element(type="Agent", label=name)
                (robot,) = wm.query_relation(agent.id, "controls")
                assert wm.get_element(robot.object).label == name
            for name in ("a1", "a2"):
                result = await AgentClient(mesh, name, timeout=5.0).run("noop", deadline=10)
                assert result.success, result.message
            with anyio.fail_after(10):
                await wm.wait_for_revision(store.revision)
            assert wm.replica.statistics().snapshots == 1  # the one replica, never reloaded
            agents.cancel_scope.cancel()  # both stop: each unregisters, as itself
        with anyio.fail_after(10):
            await wm.wait_for_revision(store.revision)
        assert not {"a1", "a2"} & _agents(wm)
        serving.cancel_scope.cancel()
