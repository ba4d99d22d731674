"""Shared subscriptions over real Zenoh (``Mesh.subscribe(key, via=wildcard)``): each gets
exactly the samples of its own key, a later one joins at once and gets what is published
after it entered, the wildcard subscriber goes when the last one leaves and comes back with
the next, a pattern works too, and a key outside the wildcard is refused."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import TYPE_CHECKING

import anyio
import pytest

from meshlink import Mesh, open_mesh

if TYPE_CHECKING:
    from tests.conftest import MeshConfigFactory as MakeConfig

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]


@pytest.fixture
async def pair(module_router: str, mesh_config: MakeConfig) -> AsyncIterator[tuple[Mesh, Mesh]]:
    config = mesh_config(module_router)
    async with open_mesh(config) as reader, open_mesh(config) as writer:
        yield reader, writer


def key(mesh: Mesh, run: str) -> str:
    return mesh.keys.run_progress("r1", run)


async def test_each_shared_subscription_gets_its_own_key(pair: tuple[Mesh, Mesh]) -> None:
    reader, writer = pair
    via = reader.keys.runs_progress("r1")
    async with (
        reader.subscribe(key(reader, "a"), via=via) as a,
        reader.subscribe(key(reader, "b"), via=via) as b,
    ):
        for run, payload in (("b", b"b1"), ("a", b"a1"), ("c", b"c1"), ("a", b"a2")):
            writer.put(key(writer, run), payload)
        with anyio.fail_after(5):
            assert [(await a.receive()).payload for _ in range(2)] == [b"a1", b"a2"]
            assert (await b.receive()).payload == b"b1"
        async with reader.subscribe(key(reader, "c"), via=via) as c:  # joins the subscriber
            writer.put(key(writer, "c"), b"c2")
            writer.put(key(writer, "b"), b"b2")
            with anyio.fail_after(5):
                assert (await c.receive()).payload == b"c2", "c1 came before it subscribed"
                assert (await b.receive()).payload == b"b2"
        with pytest.raises(anyio.WouldBlock):
            a.receive_nowait()


async def test_the_wildcard_subscriber_comes_back_after_the_last_left(
    pair: tuple[Mesh, Mesh],
) -> None:
    reader, writer = pair
    via = reader.keys.runs_progress("r1")
    for round_ in range(3):
        async with reader.subscribe(key(reader, f"run{round_}"), via=via) as sub:
            writer.put(key(writer, f"run{round_}"), str(round_).encode())
            with anyio.fail_after(5):
                assert (await sub.receive()).payload == str(round_).encode()


async def test_a_pattern_through_a_wildcard_and_a_key_outside_it(pair: tuple[Mesh, Mesh]) -> None:
    reader, writer = pair
    via = f"{reader.keys.prefix}/agents/*/runs/*/progress"
    async with reader.subscribe(reader.keys.runs_progress("r2"), via=via) as r2:
        writer.put(key(writer, "x"), b"r1")  # r1's: not for this pattern
        writer.put(writer.keys.run_progress("r2", "y"), b"r2")
        with anyio.fail_after(5):
            assert (await r2.receive()).payload == b"r2"
    with pytest.raises(ValueError, match="not under"):
        async with reader.subscribe(reader.keys.task_events("t1"), via=via):
            pass
