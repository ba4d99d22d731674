"""Agent presence: the ``available`` flag of Agent elements follows the agents' liveliness tokens.

Each skill agent declares a liveliness token ``agents/<name>``. The store watches those tokens
and keeps ``available`` on the Agent element labelled ``<name>`` equal to "its token is alive".
A registration that arrives before the token (or a token that outlives a crashed registration)
is reconciled as soon as either side changes, so the flag never stays wrong.

When an agent has stayed lost for ``release_after`` seconds (default 15), the places its robot
reserved for driving (``reservedBy`` on locations, written by the navigate skill) are released
(``wm_store/server/_reservations.py``): a lost robot no longer claims where it was going, and
a router blip releases nothing. Where it stands still counts (its ``at`` stays), so no other
robot is planned or driven into it.

Liveliness is only as good as the router: if the router dies, every token disappears and all
agents turn unavailable; they come back by themselves when the router does.
"""

from __future__ import annotations

import logging
import math
import time

import anyio
from anyio.abc import TaskStatus

from meshlink import Mesh
from wm_store._errors import ConflictError, WmError
from wm_store.protocol import Change, ElementPut, Transact, UpdateElement
from wm_store.server._reservations import RELEASE_AFTER, release_ops
from wm_store.server._store import WmStore

__all__ = ["AVAILABLE", "PresenceMonitor"]

_log = logging.getLogger(__name__)

AVAILABLE = "available"


class PresenceMonitor:
    """Reconciles Agent elements' ``available`` flag with liveliness tokens, and releases the
    place reservations of agents lost for ``release_after`` seconds."""

    def __init__(self, mesh: Mesh, store: WmStore, *, release_after: float = RELEASE_AFTER) -> None:
        self.mesh = mesh
        self.store = store
        self.alive: set[str] = set()
        self.release_after = release_after
        self._agent_class = "Agent"
        self._lost_at: dict[str, float] = {}
        """Agent name -> when it was last seen going (monotonic), while it stays lost."""
        self._releasing: set[str] = set()
        self._tg: anyio.abc.TaskGroup | None = None

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
                self._tg = tg
                tg.start_soon(self._reconciler, receive)
                for element in list(self.store.state.elements.values()):
                    if self._is_agent(element.type):
                        send.send_nowait(element.label)
                task_status.started()
                async for event in events:
                    name = self.mesh.keys.name_of_agent_key(event.key)
                    if event.alive:
                        self.alive.add(name)
                        self._lost_at.pop(name, None)
                    else:
                        self.alive.discard(name)
                        self._lost_at[name] = time.monotonic()
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
        if not want and name not in self._releasing:
            self._lost_at.setdefault(name, time.monotonic())
            self._releasing.add(name)
            assert self._tg is not None  # set by run before reconciling
            self._tg.start_soon(self._release_later, name)

    async def _release_later(self, name: str) -> None:
        """Once agent ``name`` has been lost for ``release_after`` seconds, release its robots'
        place reservations (nothing if it came back meanwhile)."""
        try:
            while True:
                since = self._lost_at.get(name)
                if since is None or name in self.alive:
                    return
                left = since + self.release_after - time.monotonic()
                if left <= 0:
                    break
                await anyio.sleep(left)
            for _ in range(5):  # compare-and-set: a place changed meanwhile, read again
                state = self.store.state
                lost = [i for i in sorted(state.ids_with_label(name)) if self._is_agent_id(i)]
                ops = release_ops(self.store, lost, self._alive_agent)
                if not ops:
                    return
                try:
                    await self.store.transact(Transact(ops=list(ops), author="presence"))
                    _log.info("agent %s lost: released its robots' places", name)
                    return
                except ConflictError:
                    continue
        except WmError as exc:
            _log.warning("could not release the places of agent %s: %s", name, exc)
        finally:
            self._releasing.discard(name)

    def _is_agent_id(self, element_id: str) -> bool:
        element = self.store.state.elements.get(element_id)
        return element is not None and self._is_agent(element.type)

    def _alive_agent(self, agent_id: str) -> bool:
        element = self.store.state.elements.get(agent_id)
        return element is not None and element.label in self.alive
