"""How the executor runs one skill on one agent: the :class:`SkillRunner` protocol and its two
transports, like ``wm_store``'s Zenoh and in-memory transports:

- :class:`ZenohRunner` calls agents over the mesh with :class:`~skill_agent.client.AgentClient`;
- :class:`CoreRunner` calls :class:`~skill_agent.runtime.AgentCore` objects in this process (unit
  tests, one-process set-ups), through the very same requests and events.

Contract of :meth:`SkillRunner.run`: subscribe to the run's events, start it, call
``on_started`` once the agent accepted it (parameters specified, pre-conditions true), call
``on_event`` for every progress event, return the :class:`RunResult`. A refusal raises the
:mod:`skill_agent` class (``PreconditionError``, ``ResourceBusyError``, ...); an agent
that cannot be reached or disappears raises ``AgentTransportError``. When the caller is
cancelled (abort, agent loss, a failed branch), the run is stopped on the agent (its
``on_preempt`` brings the robot to a safe state), shielded and within ``stop_timeout``, and the
result of the stopped run is passed to ``on_event`` before the cancellation goes on.
:meth:`SkillRunner.pause` and :meth:`SkillRunner.resume` hold and release a started run on its
agent (a task-level pause); they raise the :mod:`skill_agent` class of a refusal
(``RunStateError`` for a run that ended meanwhile, ``UnknownRunError``).
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Callable, Mapping
from typing import Protocol

import anyio

from meshlink import Mesh
from skill_agent import AgentTransportError, SkillError, UnknownRunError
from skill_agent.client import AgentClient
from skill_agent.protocol import RunEvent, RunResult, RunStarted, StartRun
from skill_agent.runtime import AgentCore

__all__ = ["CoreRunner", "OnEvent", "OnStarted", "SkillRunner", "ZenohRunner"]

_log = logging.getLogger(__name__)

OnStarted = Callable[[RunStarted], None]
OnEvent = Callable[[RunEvent], None]


class SkillRunner(Protocol):
    """Runs skills on agents (see the module docstring)."""

    async def run(
        self, agent: str, request: StartRun, *, on_started: OnStarted, on_event: OnEvent
    ) -> RunResult: ...

    async def pause(self, agent: str, run_id: str) -> None: ...

    async def resume(self, agent: str, run_id: str) -> None: ...


class _Recovered(RunStarted, frozen=True, kw_only=True):
    """A start whose answer was lost, found by the run's status (with its result if it has
    ended meanwhile)."""

    result: RunResult | None = None


class ZenohRunner:
    """Runs skills on agents over ``mesh``. ``start_timeout``: the wait for a start's answer,
    which comes after the agent's pre-sensing and pre-condition check. ``alive(agent)``, when
    given, says whether an agent may still be reached (its token there, or its state unknown
    for a grace period): a lost agent is not asked to stop (nobody would answer).

    A start whose answer is lost (the router went away while it was on its way) is not a
    failure yet: the run may have started. For up to ``lost_grace`` seconds, while ``alive``
    says the agent may be reached, the agent is asked for the run's status (the run id is the
    caller's): a run it knows is followed as if the answer had come, one it does not know is
    started again with the same id."""

    def __init__(
        self,
        mesh: Mesh,
        *,
        timeout: float = 5.0,
        start_timeout: float = 60.0,
        lost_grace: float = 1.0,
        stop_timeout: float = 10.0,
        alive: Callable[[str], bool] | None = None,
    ) -> None:
        self.mesh = mesh
        self.timeout = timeout
        self.start_timeout = start_timeout
        self.lost_grace = lost_grace
        self.stop_timeout = stop_timeout
        self.alive = alive

    async def run(
        self, agent: str, request: StartRun, *, on_started: OnStarted, on_event: OnEvent
    ) -> RunResult:
        client = AgentClient(self.mesh, agent, timeout=self.timeout, lost_grace=self.lost_grace)
        ended = False
        async with client.watch(request.run_id) as events:
            try:
                try:
                    started = await self._start(client, request)
                except SkillError as e:
                    ended = not isinstance(e, AgentTransportError)  # refused: nothing to stop
                    raise
                on_started(started)
                if isinstance(started, _Recovered) and started.result is not None:
                    ended = True  # it ended while the answer was lost
                    return started.result
                async for event in events:
                    if isinstance(event, RunResult):
                        ended = True
                        return event
                    on_event(event)
            finally:
                if not ended:
                    await self._stop(client, request.run_id, on_event)
        raise AgentTransportError(f"the events of run {request.run_id} ended without a result")

    async def _start(self, client: AgentClient, request: StartRun) -> RunStarted:
        async def start() -> RunStarted:
            return await client.start(
                request.skill,
                request.params,
                run_id=request.run_id,
                timeout=request.timeout,
                simulate=request.simulate,
                author=request.author,
                request_timeout=self.start_timeout,
            )

        try:
            return await start()
        except AgentTransportError as lost:
            since = anyio.current_time()
            while anyio.current_time() - since < self.lost_grace:
                if self.alive is not None and not self.alive(client.agent):
                    break
                await anyio.sleep(0.5)
                try:
                    info = await client.status(request.run_id)
                except UnknownRunError:
                    _log.info(
                        "run %s never reached %s: starting it again", request.run_id, client.agent
                    )
                    return await start()
                except AgentTransportError:
                    continue
                _log.info(
                    "run %s on %s started though its answer was lost", info.run_id, client.agent
                )
                return _Recovered(run_id=info.run_id, params=info.params, result=info.result)
            raise lost

    async def pause(self, agent: str, run_id: str) -> None:
        await AgentClient(self.mesh, agent, timeout=self.timeout).pause(run_id)

    async def resume(self, agent: str, run_id: str) -> None:
        await AgentClient(self.mesh, agent, timeout=self.timeout).resume(run_id)

    async def _stop(self, client: AgentClient, run_id: str, on_event: OnEvent) -> None:
        if self.alive is not None and not self.alive(client.agent):
            return
        with anyio.CancelScope(shield=True), anyio.move_on_after(self.stop_timeout):
            try:
                on_event(await client.stop(run_id, timeout=self.stop_timeout))
            except SkillError as e:
                _log.info("could not stop run %s on %s: %s", run_id, client.agent, e)


class CoreRunner:
    """Runs skills on agent cores of this process, by agent name. :meth:`vanish` makes an
    agent unreachable (its runs are stopped), as a killed process would be."""

    def __init__(self, cores: Mapping[str, AgentCore]) -> None:
        self.cores = dict(cores)
        self.gone: set[str] = set()

    async def vanish(self, agent: str) -> None:
        self.gone.add(agent)
        core = self.cores.get(agent)
        if core is not None:
            for info in core.runs():
                with anyio.CancelScope(shield=True):
                    await core.stop(info.run_id)

    def _core(self, agent: str) -> AgentCore:
        core = self.cores.get(agent)
        if core is None or agent in self.gone:
            raise AgentTransportError(f"agent {agent!r} is not reachable")
        return core

    async def pause(self, agent: str, run_id: str) -> None:
        await self._core(agent).pause(run_id)

    async def resume(self, agent: str, run_id: str) -> None:
        await self._core(agent).resume(run_id)

    async def run(
        self, agent: str, request: StartRun, *, on_started: OnStarted, on_event: OnEvent
    ) -> RunResult:
        core = self.cores.get(agent)
        if core is None or agent in self.gone:
            raise AgentTransportError(f"agent {agent!r} is not reachable")
        send, receive = anyio.create_memory_object_stream[RunEvent](math.inf)

        def forward(event: RunEvent) -> None:
            if event.run_id == request.run_id:
                send.send_nowait(event)

        unsubscribe = core.subscribe(forward)
        ended = False
        try:
            with send, receive:
                try:
                    started = await core.start(request)
                except SkillError:
                    ended = True  # refused: nothing runs
                    raise
                on_started(started)
                async for event in receive:
                    if isinstance(event, RunResult):
                        ended = True
                        if agent in self.gone:
                            raise AgentTransportError(f"agent {agent!r} vanished")
                        return event
                    on_event(event)
        finally:
            unsubscribe()
            if not ended and agent not in self.gone:  # cancelled, even while starting
                with anyio.CancelScope(shield=True):
                    with contextlib.suppress(UnknownRunError):
                        on_event(await core.stop(request.run_id))
        raise AgentTransportError(f"the events of run {request.run_id} ended")  # pragma: no cover
