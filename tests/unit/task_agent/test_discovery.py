"""Live discovery: registrations in the world model combined with liveliness; operators left
out; over real Zenoh, a token that goes away makes its agent unavailable at once and one that
comes back makes it usable again."""

from __future__ import annotations

import time

import anyio
import anyio.lowlevel
import pytest

from meshlink import open_mesh
from task_agent.discovery import Discovery
from tests.assets.task_fleet import fleet
from tests.conftest import MeshConfigFactory
from wm_store.protocol import AddElement

pytestmark = pytest.mark.anyio


def names(discovery: Discovery) -> list[str]:
    return [a.name for a in discovery.agents()]


async def test_liveliness_decides_at_once_and_is_told() -> None:
    async with fleet() as f:
        seen: list[tuple[str, bool]] = []
        unsubscribe = f.discovery.on_presence(lambda name, alive: seen.append((name, alive)))
        assert names(f.discovery) == ["r1", "r2"]
        assert [s.name for s in f.discovery.agent("r1").skills] == [  # type: ignore[union-attr]
            "navigate",
            "pick",
            "place",
            "serve",
        ]
        f.discovery.set_alive("r2", False)
        assert names(f.discovery) == ["r1"] and not f.discovery.is_alive("r2")
        assert [a.name for a in f.discovery.offering("pick")] == ["r1"]
        assert f.discovery.agent("r2") is not None  # still registered, just unavailable
        f.discovery.set_alive("r2", False)  # no change: no callback
        f.discovery.set_alive("r2", True)
        assert names(f.discovery) == ["r1", "r2"]
        assert seen == [("r2", False), ("r2", True)]
        unsubscribe()
        f.discovery.reset_alive({"r1"})
        assert seen == [("r2", False), ("r2", True)]
        assert names(f.discovery) == ["r1"]


async def test_without_liveliness_the_world_model_flag_decides() -> None:
    async with fleet() as f:
        discovery = Discovery(f.wm)
        assert discovery.alive is None and names(discovery) == ["r1", "r2"]
        agent = f.wm.resolve_element(type="Agent", label="r2")[0]
        await f.wm.update_element(agent.id, properties={"available": False})
        assert names(discovery) == ["r1"] and not discovery.is_alive("r2")


async def test_operators_are_never_planned_for() -> None:
    async with fleet() as f:
        await f.wm.transact([AddElement(type="Operator", label="operator")])
        f.discovery.set_alive("operator", True)
        assert names(f.discovery) == ["r1", "r2"]
        assert f.discovery.is_alive("operator")


@pytest.mark.zenoh
async def test_tokens_over_zenoh(router_endpoint: str, mesh_config: MeshConfigFactory) -> None:
    config = mesh_config(router_endpoint)
    async with fleet() as f, open_mesh(config) as watcher, open_mesh(config) as agents:
        r1 = agents.declare_token(agents.keys.agent("r1"))
        agents.declare_token(agents.keys.agent("r2"))
        tokens = {agents.keys.agent("r1"), agents.keys.agent("r2")}
        with anyio.fail_after(5):  # the declarations reach the router (another session's)
            while not tokens <= set(await watcher.alive(agents.keys.agents())):
                await anyio.lowlevel.checkpoint()
        discovery = Discovery(f.wm)
        changes: list[tuple[str, bool, float]] = []
        discovery.on_presence(lambda n, alive: changes.append((n, alive, time.perf_counter())))
        async with anyio.create_task_group() as tg:
            await tg.start(discovery.watch, watcher)
            assert discovery.alive == frozenset({"r1", "r2"})
            assert names(discovery) == ["r1", "r2"]
            gone = time.perf_counter()
            r1.undeclare()
            with anyio.fail_after(2):  # one token of two gone: lost once settled
                while discovery.is_alive("r1") or discovery.is_unknown("r1"):
                    await discovery.wait_changed()
            assert names(discovery) == ["r2"]
            assert changes[-1][:2] == ("r1", False) and changes[-1][2] - gone < 0.5
            r1 = agents.declare_token(agents.keys.agent("r1"))
            with anyio.fail_after(2):
                while not discovery.is_alive("r1"):
                    await discovery.wait_changed()
            assert names(discovery) == ["r1", "r2"]
            tg.cancel_scope.cancel()
