"""Calling a skill agent over the mesh: :class:`AgentClient` and :func:`list_agents`.

One call starts a skill and waits for its result (SkiROS2 #42: a plain call, no GUI)::

    async with open_mesh(config) as mesh:
        result = await AgentClient(mesh, "r1").run("pick", {"part": "Gear-1"})

``run`` never waits forever (SkiROS2 #79): it subscribes to the run's progress *before* it
starts the run (so no event is missed), watches the agent's liveliness token (the agent
disappearing for longer than ``lost_grace`` raises :class:`AgentTransportError`), asks the
agent for the run's status when the progress stream stays quiet (a result publication missed
during a reconnect is found that way) and gives up after ``deadline`` seconds
(``TimeoutError``). When ``run`` is cancelled or gives up, it stops the run on the agent.

Used as ``async with AgentClient(mesh, agent) as client:``, the client keeps one subscription to
every run of the agent and one liveliness watch for all its calls (no set-up per run: the
fast path for many runs); used without ``async with``, each ``run`` / ``watch`` sets up its own.

Errors: an agent's error reply raises the matching :mod:`skill_agent` class (rebuilt
from its code, so ``except ResourceBusyError`` works across processes); no reply, a closed
session or an undecodable reply raise :class:`AgentTransportError`.
"""

from __future__ import annotations

import logging
import math
import uuid
from collections.abc import AsyncGenerator, AsyncIterator, Callable, Iterator, Mapping
from contextlib import AsyncExitStack, asynccontextmanager, contextmanager
from types import TracebackType
from typing import Self, TypeVar

import anyio
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream

from meshlink import (
    Liveness,
    Mesh,
    MeshlinkError,
    NoReplyError,
    RemoteError,
    Sample,
    Subscription,
)
from meshlink.rpc import WireError
from skill_agent._errors import AgentTransportError, SkillError, error_for_reply
from skill_agent.protocol._codec import decode_event, decode_reply, encode
from skill_agent.protocol._runs import (
    AgentReply,
    AgentRequest,
    ErrorReply,
    ListRuns,
    ListSkills,
    OkReply,
    PauseRun,
    Reload,
    ResumeRun,
    RunEvent,
    RunFinished,
    RunInfo,
    RunResult,
    RunsReply,
    RunStarted,
    RunStatus,
    SkillsReply,
    StartRun,
    StopRun,
)
from skill_agent.protocol._skills import SkillDescription
from wm_store.protocol import Value

__all__ = [
    "AgentClient",
    "EventCallback",
    "RunFeed",
    "find_skills",
    "list_agents",
    "liveliness_get",
    "new_run_id",
]

_log = logging.getLogger(__name__)
R = TypeVar("R")
EventCallback = Callable[[RunEvent], object]


def new_run_id() -> str:
    """A fresh run id (a valid key segment)."""
    return uuid.uuid4().hex


class RunFeed:
    """Routes one agent's progress events to per-run inboxes, and tells every inbox when the
    agent's liveliness token disappears or comes back (as :class:`~meshlink.Liveness`)."""

    def __init__(self) -> None:
        self._inboxes: dict[str, MemoryObjectSendStream[RunEvent | Liveness]] = {}

    @classmethod
    @asynccontextmanager
    async def open(cls, mesh: Mesh, agent: str, key: str) -> AsyncIterator[RunFeed]:
        """Subscribe to ``key`` (one run's or every run's progress) and watch ``agent``."""
        feed = cls()
        try:
            async with (
                mesh.subscribe(key) as samples,
                mesh.watch_liveliness(mesh.keys.agent(agent)) as presence,
                anyio.create_task_group() as tg,
            ):
                tg.start_soon(feed._pump_events, samples)
                tg.start_soon(feed._pump_presence, presence)
                try:
                    yield feed
                finally:
                    tg.cancel_scope.cancel()
        except BaseExceptionGroup as group:  # the caller's error, not a group of ours
            if len(group.exceptions) == 1 and isinstance(group.exceptions[0], Exception):
                raise group.exceptions[0] from None
            raise

    @contextmanager
    def register(self, run_id: str) -> Iterator[MemoryObjectReceiveStream[RunEvent | Liveness]]:
        send, receive = anyio.create_memory_object_stream[RunEvent | Liveness](math.inf)
        self._inboxes[run_id] = send
        try:
            with receive:
                yield receive
        finally:
            del self._inboxes[run_id]
            send.close()

    async def _pump_events(self, samples: Subscription[Sample]) -> None:
        async for sample in samples:
            # ``.../runs/<run>/progress``: other clients' runs are skipped undecoded.
            inbox = self._inboxes.get(sample.key.rsplit("/", 2)[-2])
            if inbox is None:
                continue
            try:
                event = decode_event(sample.payload)
            except WireError as e:
                _log.warning("undecodable progress event on %s: %s", sample.key, e)
                continue
            inbox.send_nowait(event)

    async def _pump_presence(self, presence: Subscription[Liveness]) -> None:
        async for change in presence:
            for inbox in list(self._inboxes.values()):
                inbox.send_nowait(change)


async def liveliness_get(mesh: Mesh, key_expr: str, *, timeout: float) -> list[str]:
    """Keys of the liveliness tokens alive now that match ``key_expr``."""
    return await mesh.alive(key_expr, timeout=timeout)


class AgentClient:
    """Typed calls to one agent (``agents/<agent>/rpc`` and ``/skills``) and its runs."""

    def __init__(
        self,
        mesh: Mesh,
        agent: str,
        *,
        timeout: float = 5.0,
        lost_grace: float = 1.0,
        status_every: float = 5.0,
    ) -> None:
        self.mesh = mesh
        self.agent = agent
        self.timeout = timeout
        self.lost_grace = lost_grace
        """Seconds the agent's token may be gone (router restart) before a run is given up."""
        self.status_every = status_every
        """Seconds of silence on a run's progress after which its status is asked for."""
        self._rpc = mesh.keys.agent_rpc(agent)
        self._feed: RunFeed | None = None
        self._stack: AsyncExitStack | None = None

    # ------------------------------------------------------------------ shared feed

    async def __aenter__(self) -> Self:
        stack = AsyncExitStack()
        self._feed = await stack.enter_async_context(
            RunFeed.open(self.mesh, self.agent, self.mesh.keys.runs_progress(self.agent))
        )
        self._stack = stack
        return self

    async def __aexit__(
        self, et: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None
    ) -> None:
        stack, self._stack, self._feed = self._stack, None, None
        if stack is not None:
            await stack.aclose()

    # ------------------------------------------------------------------ requests

    async def request(self, request: AgentRequest, *, timeout: float | None = None) -> AgentReply:
        """Send one request to the agent's rpc queryable; an error reply raises."""
        return await self._ask(self._rpc, request, timeout or self.timeout)

    async def _ask(self, key: str, request: AgentRequest, timeout: float) -> AgentReply:
        try:
            data = await self.mesh.request(key, encode(request), timeout=timeout)
        except RemoteError as e:
            raise error_for_reply(e.payload) from None
        except NoReplyError:
            raise AgentTransportError(
                f"agent {self.agent!r} did not answer on {key} within {timeout:g} s: is it "
                f"running on mesh {self.mesh.keys.mesh!r} (`skimesh agents` lists live agents), "
                "and does the router's ACL let this user query it? (denials are silent)"
            ) from None
        except MeshlinkError as e:
            raise AgentTransportError(f"agent {self.agent!r}: {e}") from e
        try:
            reply = decode_reply(data)
        except WireError as e:
            raise AgentTransportError(f"undecodable reply from agent {self.agent!r}: {e}") from e
        if isinstance(reply, ErrorReply):
            raise error_for_reply(reply)
        return reply

    async def _expect(
        self, request: AgentRequest, kind: type[R], timeout: float | None = None
    ) -> R:
        reply = await self.request(request, timeout=timeout)
        if not isinstance(reply, kind):
            raise AgentTransportError(
                f"agent {self.agent!r} answered {type(request).__name__} with "
                f"{type(reply).__name__}, expected {kind.__name__}"
            )
        return reply

    async def skills_reply(self) -> SkillsReply:
        """The agent's skills, from its ``skills`` queryable."""
        key = self.mesh.keys.agent_skills(self.agent)
        reply = await self._ask(key, ListSkills(), self.timeout)
        if not isinstance(reply, SkillsReply):
            raise AgentTransportError(f"agent {self.agent!r} sent {type(reply).__name__}")
        return reply

    async def skills(self) -> list[SkillDescription]:
        return (await self.skills_reply()).skills

    async def start(
        self,
        skill: str,
        params: Mapping[str, Value] | None = None,
        *,
        queue: bool = False,
        run_id: str = "",
        timeout: float | None = None,
        simulate: bool = False,
        author: str = "",
        request_timeout: float | None = None,
    ) -> RunStarted:
        """Start a run; returns once the agent accepted it (parameters specified, resources
        locked, pre-conditions true). ``timeout`` is the run's own time limit on the agent;
        ``request_timeout`` the wait for the reply (longer with ``queue``)."""
        request = StartRun(
            skill=skill,
            params=dict(params or {}),
            queue=queue,
            run_id=run_id or new_run_id(),
            timeout=timeout,
            simulate=simulate,
            author=author,
        )
        return await self._expect(request, RunStarted, request_timeout)

    async def call(
        self,
        skill: str,
        params: Mapping[str, Value] | None = None,
        *,
        timeout: float = 30.0,
        queue: bool = False,
        simulate: bool = False,
        author: str = "",
    ) -> RunResult:
        """Run a short skill in ONE round trip: the agent answers with the final result.

        For skills that finish within ``timeout`` seconds (no progress stream is watched; use
        :meth:`run` for long skills). If no answer comes in time, or the caller is cancelled,
        the run is stopped on the agent before this raises.

        Raises:
            SkillError subclasses: the agent refused the start. TimeoutError: no result in time.
        """
        run_id = new_run_id()
        request = StartRun(
            skill=skill,
            params=dict(params or {}),
            queue=queue,
            run_id=run_id,
            timeout=timeout,
            simulate=simulate,
            author=author,
            wait=True,
        )
        try:
            reply = await self._expect(request, RunFinished, timeout + 1.0)
        except AgentTransportError as exc:
            await self._stop_quietly(run_id)
            raise TimeoutError(f"{skill} on {self.agent!r}: no result in {timeout} s") from exc
        except SkillError:
            raise  # refused: nothing runs
        except BaseException:  # cancelled: the run must not go on alone
            await self._stop_quietly(run_id)
            raise
        return reply.result

    async def stop(self, run_id: str, *, timeout: float | None = None) -> RunResult:
        """Stop a run; returns its result once it is preempted (safe state reached). The
        default wait is ``timeout + 10`` s: the skill's ``on_preempt`` may take a while."""
        request = StopRun(run_id=run_id)
        reply = await self._expect(request, RunsReply, timeout or self.timeout + 10.0)
        info = reply.runs[0] if reply.runs else None
        if info is None or info.result is None:
            raise AgentTransportError(f"agent {self.agent!r} stopped {run_id} without a result")
        return info.result

    async def pause(self, run_id: str) -> None:
        await self._expect(PauseRun(run_id=run_id), OkReply)

    async def resume(self, run_id: str) -> None:
        await self._expect(ResumeRun(run_id=run_id), OkReply)

    async def status(self, run_id: str) -> RunInfo:
        reply = await self._expect(RunStatus(run_id=run_id), RunsReply)
        if len(reply.runs) != 1:
            raise AgentTransportError(f"agent {self.agent!r} sent {len(reply.runs)} runs")
        return reply.runs[0]

    async def runs(self, *, active_only: bool = True) -> list[RunInfo]:
        return (await self._expect(ListRuns(active_only=active_only), RunsReply)).runs

    async def reload(self, *, timeout: float = 30.0) -> str:
        """Re-import the agent's skill plug-ins; returns the agent's summary."""
        return (await self._expect(Reload(), OkReply, timeout)).message

    # ------------------------------------------------------------------ runs

    @asynccontextmanager
    async def watch(self, run_id: str) -> AsyncIterator[AsyncIterator[RunEvent]]:
        """Subscribe to a run's events; enter *before* starting it. Yields an async iterator of
        :data:`RunEvent` that ends with the :class:`RunResult` (or raises
        :class:`AgentTransportError` when the agent is gone for longer than ``lost_grace``)."""
        async with AsyncExitStack() as stack:
            feed = self._feed
            if feed is None:
                key = self.mesh.keys.run_progress(self.agent, run_id)
                feed = await stack.enter_async_context(RunFeed.open(self.mesh, self.agent, key))
            with feed.register(run_id) as inbox:
                events = self._events(run_id, inbox)
                try:
                    yield events
                finally:
                    await events.aclose()

    async def _events(
        self, run_id: str, inbox: MemoryObjectReceiveStream[RunEvent | Liveness]
    ) -> AsyncGenerator[RunEvent, None]:
        lost_since: float | None = None
        while True:
            wait = self.status_every if lost_since is None else self.lost_grace
            item: RunEvent | Liveness | None = None
            try:
                item = inbox.receive_nowait()  # a burst of events needs no timer each
            except anyio.WouldBlock:
                with anyio.move_on_after(wait):
                    item = await inbox.receive()
            if item is None:  # quiet for `wait` seconds
                if lost_since is not None:
                    raise AgentTransportError(
                        f"agent {self.agent!r} disappeared (liveliness token gone for "
                        f"{self.lost_grace:g} s) while run {run_id} was running"
                    )
                result = await self._result_if_done(run_id)
            elif isinstance(item, Liveness):
                if not item.alive:
                    lost_since = anyio.current_time()
                    continue
                if lost_since is None:
                    continue  # the first "alive" of the watch's history
                lost_since = None  # back (router restart): a result may have been missed
                result = await self._result_if_done(run_id)
            else:
                yield item
                if isinstance(item, RunResult):
                    return
                continue
            if result is not None:
                yield result
                return

    async def _result_if_done(self, run_id: str) -> RunResult | None:
        info = await self.status(run_id)
        return info.result

    async def run(
        self,
        skill: str,
        params: Mapping[str, Value] | None = None,
        *,
        queue: bool = False,
        timeout: float | None = None,
        simulate: bool = False,
        deadline: float = 600.0,
        on_event: EventCallback | None = None,
        stop_on_exit: bool = True,
        author: str = "",
    ) -> RunResult:
        """Start ``skill`` and wait for its result (see the module docstring).

        Raises:
            SkillError subclasses: the agent refused the start (unknown skill, parameters,
                busy resource, false pre-condition...).
            AgentTransportError: the agent cannot be reached or disappeared.
            TimeoutError: no result within ``deadline`` seconds (the run is stopped).
        """
        run_id = new_run_id()
        finished = False
        async with self.watch(run_id) as events:
            try:
                with anyio.fail_after(deadline):
                    await self.start(
                        skill,
                        params,
                        queue=queue,
                        run_id=run_id,
                        timeout=timeout,
                        simulate=simulate,
                        author=author,
                        request_timeout=deadline if queue else None,
                    )
                    async for event in events:
                        if on_event is not None:
                            on_event(event)
                        if isinstance(event, RunResult):
                            finished = True
                            return event
            except SkillError as e:
                finished = finished or not isinstance(e, AgentTransportError)
                raise
            finally:
                if stop_on_exit and not finished:
                    await self._stop_quietly(run_id)
        raise AgentTransportError(f"the progress of run {run_id} ended without a result")

    async def _stop_quietly(self, run_id: str) -> None:
        with anyio.CancelScope(shield=True), anyio.move_on_after(self.timeout):
            try:
                await self.stop(run_id, timeout=min(self.timeout, 2.0))
            except SkillError as e:
                _log.debug("could not stop run %s on %s: %s", run_id, self.agent, e)


async def list_agents(mesh: Mesh, *, timeout: float = 2.0) -> list[str]:
    """Names of the agents whose liveliness token is alive now, sorted."""
    keys = await liveliness_get(mesh, mesh.keys.agents(), timeout=timeout)
    names: set[str] = set()
    for key in keys:
        try:
            names.add(mesh.keys.name_of_agent_key(key))
        except ValueError:
            _log.debug("ignored liveliness key %s", key)
    return sorted(names)


async def find_skills(mesh: Mesh, *, timeout: float = 2.0) -> dict[str, SkillsReply]:
    """Every reachable agent's skills at once (one query on ``agents/*/skills``), by agent."""
    found: dict[str, SkillsReply] = {}
    for reply in await mesh.get(mesh.keys.agents_skills(), encode(ListSkills()), timeout=timeout):
        if not reply.ok:
            continue
        try:
            decoded = decode_reply(reply.payload)
        except WireError:
            _log.warning("undecodable skills reply from %s", reply.key)
            continue
        if isinstance(decoded, SkillsReply):
            found[decoded.agent] = decoded
    return dict(sorted(found.items()))
