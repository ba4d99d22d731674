"""Calling a skill agent over the mesh: :class:`AgentClient`.

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
import uuid
from collections.abc import AsyncIterator, Callable, Mapping
from contextlib import AsyncExitStack, asynccontextmanager
from types import TracebackType
from typing import Self, TypeVar

import anyio

from meshlink import Mesh, MeshlinkError, NoReplyError, RemoteError
from meshlink.rpc import WireError, encode
from skill_agent._errors import AgentTransportError, SkillError, error_for_reply
from skill_agent.client._progress import RunFeed, follow_run
from skill_agent.protocol._codec import decode_reply
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
    RunEvents,
    RunEventsReply,
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

__all__ = ["AgentClient", "EventCallback", "new_run_id"]

_log = logging.getLogger(__name__)
R = TypeVar("R")
EventCallback = Callable[[RunEvent], object]


def new_run_id() -> str:
    """A fresh run id (a valid key segment)."""
    return uuid.uuid4().hex[:16]


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
        except NoReplyError as e:
            raise AgentTransportError(
                f"agent {self.agent!r} did not answer on {key} {e.when}: is it "
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
        began = anyio.current_time()
        try:
            reply = await self._expect(request, RunFinished, timeout + 1.0)
        except AgentTransportError as exc:
            waited = anyio.current_time() - began
            await self._stop_quietly(run_id)
            raise TimeoutError(
                f"{skill} on {self.agent!r}: no result after {waited:.1f} s (limit {timeout:g} "
                f"s): {exc}"
            ) from exc
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

    async def run_events(self, run_id: str, after_seq: int = 0) -> RunEventsReply:
        """A run's state and the events the agent kept of it with ``seq > after_seq`` (its
        history; UnknownRunError once the agent forgot the run)."""
        return await self._expect(RunEvents(run_id=run_id, after_seq=after_seq), RunEventsReply)

    @asynccontextmanager
    async def follow(self, run_id: str) -> AsyncIterator[tuple[RunInfo, AsyncIterator[RunEvent]]]:
        """A run that started already (by anyone): its state, and an iterator of its events
        so far (the agent's history) then the live ones, each ``seq`` once, ending with its
        result. Subscribes before it asks for the history, so no event falls in between."""
        async with self.watch(run_id) as live:
            reply = await self.run_events(run_id)
            yield reply.run, _history_then_live(reply.events, live)

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
                every = self.mesh.keys.runs_progress(self.agent)  # one router entry per agent
                feed = await stack.enter_async_context(
                    RunFeed.open(self.mesh, self.agent, key, via=every)
                )
            with feed.register(run_id) as inbox:
                events = follow_run(self, run_id, inbox)
                try:
                    yield events
                finally:
                    await events.aclose()

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


async def _history_then_live(
    history: list[RunEvent], live: AsyncIterator[RunEvent]
) -> AsyncIterator[RunEvent]:
    last_seq = 0
    for event in history:
        last_seq = event.seq
        yield event
        if isinstance(event, RunResult):
            return
    async for event in live:
        if event.seq <= last_seq:
            continue  # had it from the history
        yield event
        if isinstance(event, RunResult):
            return
