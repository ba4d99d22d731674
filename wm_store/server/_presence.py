"""Agent presence: the ``available`` flag of Agent elements follows the agents' liveliness tokens.

Each skill agent declares a liveliness token ``agents/<name>``. The store watches those tokens
and keeps ``available`` on the Agent element labelled ``<name>`` equal to "its token is alive".
A registration that arrives before the token (or a token that outlives a crashed registration)
is reconciled as soon as either side changes, so the flag never stays wrong.

When an agent is lost, the places its robot reserved for driving (``reservedBy`` on locations,
written by the navigate skill) are released in the same transaction, unless another live agent
controls the robot too: a lost robot no longer claims where it was going. Where it stands still
counts (its ``at`` stays), so no other robot is planned or driven into it.

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
from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import Change, ElementPut, Op, Transact, UpdateElement
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
        ops: list[Op] = [
            UpdateElement(id=e.id, properties={AVAILABLE: want}, expect_rev=e.rev)
            for e in agents
            if self._is_agent(e.type) and e.properties.get(AVAILABLE) is not want
        ]
        if ops:
            _log.info("agent %s is %s", name, "available" if want else "unavailable")
        if not want:
            ops += self._release_ops([e.id for e in agents if self._is_agent(e.type)])
        if ops:
            await self.store.transact(Transact(ops=list(ops), author="presence"))

    def _release_ops(self, agents: list[str]) -> list[Op]:
        """Ops removing the robots of the lost ``agents`` from every location's
        ``reservedBy``, but robots another live agent controls."""
        state = self.store.state
        robots = set()
        for agent in agents:
            for robot in state.objects(agent, Rel.controls):
                others = state.subjects(robot, Rel.controls) - set(agents)
                if not any(self._alive_agent(a) for a in others):
                    robots.add(robot)
        if not robots:
            return []
        ops: list[Op] = []
        places = state.ids_of_types(self.store.ontology.subclasses(Cls.Location))
        for place in sorted(places):
            element = state.elements[place]
            held = element.properties.get(Prop.reservedBy)
            if isinstance(held, list) and robots & set(held):
                _log.info("released %s at %s (agent lost)", sorted(robots & set(held)), place)
                rest = [r for r in held if r not in robots]
                ops.append(
                    UpdateElement(
                        id=place, properties={Prop.reservedBy: rest}, expect_rev=element.rev
                    )
                )
        return ops

    def _alive_agent(self, agent_id: str) -> bool:
        element = self.store.state.elements.get(agent_id)
        return element is not None and element.label in self.alive
