"""The store's queryables over real Zenoh: hostile request bytes on ``wm/rpc`` and
``wm/query`` all get a typed reply (an ErrorReply or a valid reply) and change nothing; an
unexpected failure answers ``internal``, which the client raises as a RemoteError."""

from __future__ import annotations

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from meshlink.rpc import Decoder, encode
from meshlink.testing import fuzz_queryable, hostile_payloads
from wm_store import RemoteError, WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, GetElements, Info, Reply, Transact
from wm_store.server import MAX_REQUEST_BYTES, WmStore, serve_store

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]


async def test_hostile_payloads_get_typed_replies(
    router_endpoint: str, mesh_config: object
) -> None:
    config: MeshConfig = mesh_config(router_endpoint)  # type: ignore[operator]
    store = await WmStore.open(Ontology.default())
    replies = Decoder[Reply](Reply)
    reads = [encode(Info()), encode(GetElements(ids=["Nope-1"]))]
    async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
        await tg.start(serve_store, mesh, store)
        before = store.snapshot()
        keys = mesh.keys
        answered = await fuzz_queryable(mesh, keys.wm_rpc(), replies, hostile_payloads(reads))
        # The read-only endpoint refuses every transaction, so one may be mutated freely.
        write = encode(Transact(ops=[AddElement(type="Gear")]))
        answered += await fuzz_queryable(
            mesh, keys.wm_query(), replies, hostile_payloads([*reads, write], huge=0)
        )
        big = await mesh.get(keys.wm_query(), b"\x00" * (MAX_REQUEST_BYTES + 1), timeout=10)
        assert [a.ok for a in big] == [False]
        assert store.snapshot() == before
        assert answered > 100
        tg.cancel_scope.cancel()


async def test_an_unexpected_failure_answers_internal(
    router_endpoint: str, mesh_config: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    config: MeshConfig = mesh_config(router_endpoint)  # type: ignore[operator]
    store = await WmStore.open(Ontology.default())

    def broken() -> object:
        raise RuntimeError("the disk is on fire")

    async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
        await tg.start(serve_store, mesh, store)
        async with WmClient.connect(ZenohTransport(mesh)) as wm:
            monkeypatch.setattr(store, "info", broken)
            with pytest.raises(RemoteError, match="RuntimeError: the disk is on fire") as caught:
                await wm.info()
            assert caught.value.remote_code == "internal"
        tg.cancel_scope.cancel()
