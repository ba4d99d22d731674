"""Live discovery: the agents the task layer may use right now.

Two sources, combined:

- **registrations** in the world model (agent, robot, devices, skill descriptions; read by
  :func:`~task_agent.discovery.agents_from_view` from the local replica, so a read never
  waits for the network);
- **liveliness** tokens ``agents/<name>``: a token that disappears makes its agent unavailable
  (Zenoh reports a SIGKILLed agent in a few ms), a token that comes back makes it usable
  again. The store's ``available`` flag follows the same tokens but a transaction later; the
  token is what the executor reacts to.

**Lost or unknown.** A token that vanishes is judged ``settle`` seconds later, together with
every other token that vanished meanwhile (:meth:`Discovery.token_gone`, judged by
:meth:`Discovery.judge`). One agent's token gone while other agents' tokens stay is a dead
agent: it is **lost** (the presence listeners hear ``alive=False``). Two or more tokens gone
together, or the last agent's token gone, is what a lost router or a network partition looks
like from here (the robots are most likely still running): those agents are **unknown** for
``grace`` seconds. An unknown agent is not planned for and no step starts on it, but nobody
is told it is lost: its runs go on being followed (the clients reconnect and ask for the
runs' status). A token that comes back within the grace period makes it known again; at the
end of the grace period it is lost.

:class:`Discovery` is the pure core (it knows no Zenoh): :meth:`Discovery.set_alive` feeds it,
:meth:`Discovery.watch` is the Zenoh adapter that feeds it from a liveliness watch. Agents of
class ``Operator`` (a person answering skills, :mod:`task_agent.operator`) are never offered to
the planner; :meth:`Discovery.is_alive` still tells whether one is there.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import anyio
from anyio.abc import TaskStatus

from meshlink import Mesh
from skill_agent import WorldView

from ._registrations import AgentInfo, agents_from_view

__all__ = ["OPERATOR_CLASS", "Discovery", "PresenceCallback"]

_log = logging.getLogger(__name__)

OPERATOR_CLASS = "Operator"
PresenceCallback = Callable[[str, bool], None]
"""``callback(agent, alive)``: called on the event loop when a token appears or disappears."""


class Discovery:
    """The agents registered in ``view`` whose liveliness token is alive.

    ``alive`` starts unknown (``None``): until liveliness is fed, the world model's
    ``available`` flag alone decides. Reads never block. ``grace``: seconds an agent whose
    token vanished with others stays unknown before it is lost; ``settle``: seconds a
    vanished token waits for others to vanish with it (see the module docstring)."""

    def __init__(self, view: WorldView, *, grace: float = 15.0, settle: float = 0.25) -> None:
        self.view = view
        self.grace = grace
        self.settle = settle
        self._alive: set[str] | None = None
        self._gone: dict[str, float] = {}
        """Tokens gone, not judged yet: name -> when (``anyio.current_time``)."""
        self._unknown: dict[str, float] = {}
        """Agents of unknown state: name -> when they become lost."""
        self._judge_wake = anyio.Event()
        self.outages = 0
        """How many times tokens vanished together (each a lost router or a partition)."""
        self._listeners: list[PresenceCallback] = []
        self._changed = anyio.Event()
        self._cache: tuple[object, list[AgentInfo]] | None = None

    # ------------------------------------------------------------------ reads

    @property
    def alive(self) -> frozenset[str] | None:
        """Names whose token is alive (None: liveliness not known)."""
        return None if self._alive is None else frozenset(self._alive)

    @property
    def unknown(self) -> frozenset[str]:
        """Agents whose token vanished and who are not judged lost yet (a lost router or a
        partition, for at most ``grace`` seconds; see the module docstring)."""
        return frozenset(self._gone) | frozenset(self._unknown)

    def is_unknown(self, name: str) -> bool:
        return name in self._gone or name in self._unknown

    async def wait_known(self, name: str) -> None:
        """Until ``name`` is alive or lost (at once unless it is unknown)."""
        while self.is_unknown(name):
            await self._changed.wait()

    def is_alive(self, name: str) -> bool:
        """Whether ``name``'s token is alive (without liveliness: whether it is registered
        and available in the world model)."""
        if self._alive is not None:
            return name in self._alive
        return any(a.name == name for a in self._registered() if a.available)

    def agents(self, *, include_unavailable: bool = False) -> list[AgentInfo]:
        """The agents the planner may use (operators left out), sorted by name."""
        agents = self._registered()
        return agents if include_unavailable else [a for a in agents if a.available]

    def agent(self, name: str) -> AgentInfo | None:
        """One agent, available or not (None if not registered)."""
        return next((a for a in self._registered() if a.name == name), None)

    def offering(self, skill: str) -> list[AgentInfo]:
        """The available agents offering ``skill``, sorted by name."""
        return [a for a in self.agents() if a.skill(skill) is not None]

    def _registered(self) -> list[AgentInfo]:
        revision = getattr(self.view, "revision", None)
        key = (revision, self.alive)
        if revision is not None and self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        agents = [
            a
            for a in agents_from_view(self.view, alive=self._alive, include_unavailable=True)
            if not self._is_operator(a)
        ]
        self._cache = (key, agents)
        return agents

    def _is_operator(self, agent: AgentInfo) -> bool:
        ontology = self.view.ontology
        element = self.view.find_element(agent.id) if agent.id else None
        if element is None or OPERATOR_CLASS not in ontology.classes:
            return False
        return ontology.is_a(element.type, OPERATOR_CLASS)

    # ------------------------------------------------------------------ presence

    def set_alive(self, name: str, alive: bool) -> None:
        """Record that ``name``'s token appeared or disappeared; tells the listeners when that
        changes what is known."""
        if self._alive is None:
            self._alive = set()
        self._gone.pop(name, None)
        self._unknown.pop(name, None)
        if (name in self._alive) == alive:
            self._wake()
            return
        if alive:
            self._alive.add(name)
        else:
            self._alive.discard(name)
        _log.info("agent %s %s", name, "is back" if alive else "vanished")
        self._notify(name, alive)

    def reset_alive(self, names: set[str]) -> None:
        """Replace what is known with ``names`` (the answer of a liveliness query)."""
        before = self._alive or set()
        self._alive = set(names)
        self._gone.clear()
        self._unknown.clear()
        self._wake()
        for name in sorted(before - names):
            self._notify(name, False)
        for name in sorted(names - before):
            self._notify(name, True)

    def token_gone(self, name: str) -> None:
        """``name``'s token vanished: it is judged lost or unknown ``settle`` seconds later
        (by :meth:`judge`, with every token gone meanwhile)."""
        if self._alive is None or name not in self._alive:
            return
        self._alive.discard(name)
        self._gone[name] = anyio.current_time()
        self._wake()
        self._judge_wake.set()

    def token_back(self, name: str) -> None:
        """``name``'s token is there (again)."""
        if self.is_unknown(name):
            _log.warning("agent %s is back within its grace period", name)
        self.set_alive(name, True)

    async def judge(self) -> None:
        """Judge vanished tokens (lost or unknown) and unknown agents whose grace period ended,
        until cancelled."""
        while True:
            due = [t + self.settle for t in self._gone.values()] + list(self._unknown.values())
            if not due:
                await self._judge_wake.wait()
            else:
                with anyio.move_on_after(max(0.0, min(due) - anyio.current_time())):
                    await self._judge_wake.wait()
            self._judge_wake = anyio.Event()
            self._decide(anyio.current_time())

    def _decide(self, now: float) -> None:
        if self._gone and min(self._gone.values()) + self.settle <= now:
            burst, self._gone = sorted(self._gone), {}
            registered = {a.name for a in self._registered()}
            left = registered & (self._alive or set())
            if len(burst) >= 2 or (registered & set(burst) and not left):
                _log.warning(
                    "the tokens of %s vanished together: a lost router or a partition? Their "
                    "state is unknown for %g s (their runs are followed on)",
                    ", ".join(burst),
                    self.grace,
                )
                for name in burst:
                    self._unknown[name] = now + self.grace
                self.outages += 1
                self._wake()
            else:
                for name in burst:
                    self._lost(name, "vanished")
        for name, until in sorted(self._unknown.items()):
            if until <= now:
                del self._unknown[name]
                self._lost(name, f"did not come back within the grace period of {self.grace:g} s")

    def _lost(self, name: str, why: str) -> None:
        _log.info("agent %s %s: lost", name, why)
        self._notify(name, False)

    def on_presence(self, callback: PresenceCallback) -> Callable[[], None]:
        """Call ``callback(agent, alive)`` on every change; returns the unsubscribe function."""
        self._listeners.append(callback)

        def unsubscribe() -> None:
            if callback in self._listeners:
                self._listeners.remove(callback)

        return unsubscribe

    async def wait_changed(self) -> None:
        """Block until the next presence change."""
        await self._changed.wait()

    def _wake(self) -> None:
        changed, self._changed = self._changed, anyio.Event()
        changed.set()

    def _notify(self, name: str, alive: bool) -> None:
        self._wake()
        for callback in list(self._listeners):
            try:
                callback(name, alive)
            except Exception:
                _log.exception("presence callback failed for %s", name)

    # ------------------------------------------------------------------ Zenoh adapter

    async def watch(
        self, mesh: Mesh, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Follow the agents' liveliness tokens on ``mesh`` until cancelled; ``started`` once
        the tokens alive now are known.

        The watch is declared first, then the tokens alive now are asked for (a complete
        answer, unlike the watch's history, which has no end marker); the watch's events,
        queued meanwhile, are applied afterwards in order, so nothing is lost either way.
        Vanished tokens are judged lost or unknown by :meth:`judge`, run here."""
        keys = mesh.keys
        async with (
            mesh.watch_liveliness(keys.agents()) as events,
            anyio.create_task_group() as tg,
        ):
            tg.start_soon(self.judge)
            names = set()
            for key in await mesh.alive(keys.agents()):
                try:
                    names.add(keys.name_of_agent_key(key))
                except ValueError:
                    _log.debug("ignored liveliness key %s", key)
            self.reset_alive(names)
            task_status.started()
            async for change in events:
                try:
                    name = keys.name_of_agent_key(change.key)
                except ValueError:
                    continue
                if change.alive:
                    self.token_back(name)
                else:
                    self.token_gone(name)
            tg.cancel_scope.cancel()  # the session closed: nothing more to judge
