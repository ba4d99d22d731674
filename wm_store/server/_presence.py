"""Agent presence: the ``available`` flag of Agent elements follows the agents' liveliness tokens.

Each skill agent declares a liveliness token ``agents/<name>``. The store watches those tokens
and keeps ``available`` on the Agent element labelled ``<name>`` equal to "its token is alive".
A registration that arrives before the token (or a token that outlives a crashed registration)
is reconciled as soon as either side changes, so the flag never stays wrong.

Liveliness is only as good as the router: if the router dies, every token disappears and all
agents turn unavailable; they come back by themselves when the router does.
"""

from __future__ import annotations

import logging
import math

import anyio
from anyio.abc import TaskStatus

from meshlink import Mesh
from wm_store._errors import WmError
from wm_store.protocol import Change, ElementPut, Transact, UpdateElement
from wm_store.server._store import WmStore

__all__ = ["AVAILABLE", "PresenceMonitor"]

_log = logging.getLogger(__name__)

AVAILABLE = "available"


class PresenceMonitor:
    """Reconciles Agent elements' ``available`` flag with liveliness tokens."""

    def __init__(self, mesh: Mesh, store: WmStore) -> None:
        self.mesh = mesh
        self.store = store
        self.alive: set[str] = set()
        self._agent_class = "Agent"

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        send, receive = anyio.create_memory_object_stream[str](math.inf)

        def on_change(change: Change) -> None:
            for delta in change.deltas:
                if isinstance(delta, ElementPut) and self._is_agent(delta.element.type):
                    send.send_nowait(delta.element.label)

        def listener(change: Change, _payload: bytes) -> None:
            on_change(change)

        self.store.add_listener(listener)
        try:
            async with (
                send,
                anyio.create_task_group() as tg,
                self.mesh.watch_liveliness(self.mesh.keys.agents()) as events,
            ):
                tg.start_soon(self._reconciler, receive)
                for element in list(self.store.state.elements.values()):
                    if self._is_agent(element.type):
                        send.send_nowait(element.label)
                task_status.started()
                async for event in events:
                    name = self.mesh.keys.name_of_agent_key(event.key)
                    if event.alive:
                        self.alive.add(name)
                    else:
                        self.alive.discard(name)
                    send.send_nowait(name)
        finally:
            self.store.remove_listener(listener)

    def _is_agent(self, element_type: str) -> bool:
        return self.store.ontology.is_a(element_type, self._agent_class)

    async def _reconciler(self, names: anyio.abc.ObjectReceiveStream[str]) -> None:
        async with names:
            async for name in names:
                try:
                    await self._reconcile(name)
                except WmError as exc:
                    _log.warning("could not update presence of agent %s: %s", name, exc)

    async def _reconcile(self, name: str) -> None:
        want = name in self.alive
        state = self.store.state
        agents = [state.elements[i] for i in sorted(state.ids_with_label(name))]
        ops = [
            UpdateElement(id=e.id, properties={AVAILABLE: want}, expect_rev=e.rev)
            for e in agents
            if self._is_agent(e.type) and e.properties.get(AVAILABLE) is not want
        ]
        if ops:
            _log.info("agent %s is %s", name, "available" if want else "unavailable")
            await self.store.transact(Transact(ops=list(ops), author="presence"))
