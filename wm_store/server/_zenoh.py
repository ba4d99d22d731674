"""``skimesh wm``: the world-model store served over Zenoh.

This module, :mod:`~wm_store.server._presence` and :mod:`~wm_store._zenoh_transport` are the
only parts of ``wm_store`` that talk to the network. It serves:

- ``wm/rpc``: typed requests (:mod:`wm_store.protocol`), answered by :class:`WmService`; an error
  is sent as a Zenoh error reply carrying a :class:`meshlink.rpc.ErrorReply`;
- ``wm/query``: the same for every request but transactions (read-only), so a router ACL can
  let read-only users read the world model without letting them write;
- ``wm/write/<writer>``: transactions of one writer, committed with ``<writer>`` as their
  author (a router ACL lets each identity query only its own key, so the store decides what an
  agent may change by who it is: ``wm_store.scene.check_writer``);
- ``wm/elements/<id>``: storage-style reads, each element as JSON, so any Zenoh tool
  (``z_get -s 'skimesh/default/wm/elements/**'``) can read the world model;
- ``wm/changes``: one publication per durable change, congestion control BLOCK (a dropped
  change would force every replica to resync).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import anyio
import msgspec
from anyio.abc import TaskStatus

from meshlink import Answer, IncomingQuery, InvalidKeyError, Mesh, intersects
from meshlink.rpc import BAD_REQUEST, MSGPACK, ErrorReply, encode
from wm_store.protocol import Change
from wm_store.server._presence import PresenceMonitor
from wm_store.server._service import WmService
from wm_store.server._store import WmStore

__all__ = ["serve_store"]

_log = logging.getLogger(__name__)
_json = msgspec.json.Encoder()


async def serve_store(
    mesh: Mesh,
    store: WmStore,
    *,
    presence: bool = True,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve ``store`` on ``mesh`` until cancelled; ``started`` once every endpoint is declared.

    Runs the store's log writer too; on exit the store writes a final snapshot and closes.
    """
    keys = mesh.keys
    service = WmService(store)
    rpc_key = keys.wm_rpc()

    read_key = keys.wm_query()

    async def elements(query: IncomingQuery) -> list[Answer]:
        return _element_answers(store, keys.wm_element, query.key_expr)

    async def writes(query: IncomingQuery) -> list[Answer]:
        try:
            writer = keys.writer_of_write_key(query.key_expr)
        except InvalidKeyError as e:
            refused = ErrorReply(code=BAD_REQUEST, message=f"{e}: name one writer")
            return [Answer(key=query.key_expr, payload=encode(refused), ok=False)]
        data, ok = await service.handle_write(query.payload or b"", writer)
        return [Answer(key=keys.wm_write(writer), payload=data, ok=ok, encoding=MSGPACK)]

    try:
        with mesh.publisher(keys.wm_changes()) as publisher:

            def publish(_change: Change, payload: bytes) -> None:
                publisher.put(payload)

            store.add_listener(publish)
            async with anyio.create_task_group() as tg:
                await tg.start(store.run)
                await tg.start(mesh.serve, rpc_key, service.rpc.serve_on(rpc_key))
                await tg.start(mesh.serve, read_key, service.query.serve_on(read_key))
                await tg.start(mesh.serve, keys.wm_writes(), writes)
                await tg.start(mesh.serve, keys.wm_elements(), elements)
                if presence:
                    await tg.start(PresenceMonitor(mesh, store).run)
                _log.info(
                    "world model serving on %s (revision %d, %d elements)",
                    keys.wm_rpc(),
                    store.revision,
                    len(store.state.elements),
                )
                task_status.started()
    finally:
        with anyio.CancelScope(shield=True):
            await service.aclose()
        await store.aclose()


def _element_answers(store: WmStore, key_of: Callable[[str], str], selector: str) -> list[Answer]:
    """Every element whose ``wm/elements/<id>`` key intersects the query's key expression."""
    elements = store.state.elements
    if "*" not in selector and "$" not in selector:
        element_id = selector.rsplit("/", 1)[-1]
        ids = [element_id] if element_id in elements and key_of(element_id) == selector else []
    else:
        ids = [i for i in sorted(elements) if intersects(selector, key_of(i))]
    return [
        Answer(key=key_of(i), payload=_json.encode(elements[i]), encoding="application/json")
        for i in ids
    ]
