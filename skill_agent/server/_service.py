"""The agent's requests -> replies over an :class:`AgentCore`, independent of the transport: its
two queryables, each a :class:`meshlink.rpc.RequestHandler`."""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable

import anyio
import msgspec

from meshlink import check_name
from meshlink.rpc import BAD_REQUEST, RequestHandler
from skill_agent._errors import (
    BadRequestError,
    ParameterError,
    RunStateError,
    SkillError,
    UnknownRunError,
)
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
    RunEvents,
    RunEventsReply,
    RunFinished,
    RunInfo,
    RunResult,
    RunsReply,
    RunState,
    RunStatus,
    SkillsReply,
    StartRun,
    StopRun,
)
from skill_agent.runtime._agent import AgentCore
from skill_agent.runtime._plugins import SkillRegistry
from skill_agent.server._history import RunHistory

__all__ = ["AgentService"]

_log = logging.getLogger(__name__)


class AgentService:
    """Requests -> replies for one agent, independent of the transport (unit-testable)."""

    def __init__(
        self,
        core: AgentCore,
        *,
        registry: SkillRegistry | None = None,
        on_reload: Callable[[], Awaitable[None]] | None = None,
        before_reload: Callable[[], Awaitable[None]] | None = None,
    ) -> None:
        self.core = core
        self.registry = registry
        self.on_reload = on_reload
        self.before_reload = before_reload
        """Run before a reload checks the skills (the agent teaches the world model its
        skills' terms and takes the world model's current ontology)."""
        self._reload_lock = anyio.Lock()
        self.history = RunHistory()
        """The recent runs' events (``RunEvents``), bounded: :class:`RunHistory`."""
        core.subscribe(self.history.add)
        self.rpc: RequestHandler[AgentRequest, AgentReply] = RequestHandler(
            AgentRequest,
            self.handle,
            errors=_to_reply,
            error_type=ErrorReply,
            name=f"agent {core.name} rpc",
        )
        """The ``agents/<a>/rpc`` queryable."""
        self.skills: RequestHandler[AgentRequest, SkillsReply] = RequestHandler(
            AgentRequest,
            self._skills,
            errors=_to_reply,
            empty=ListSkills(),
            error_type=ErrorReply,
            name=f"agent {core.name} skills",
        )
        """The ``agents/<a>/skills`` queryable (an empty payload stands for ``ListSkills``)."""

    def skills_reply(self) -> SkillsReply:
        return SkillsReply(
            agent=self.core.name,
            skills=self.core.descriptions(),
            simulated=self.core.simulated is not None,
        )

    async def handle_bytes(self, data: bytes) -> tuple[bytes, bool]:
        """The ``rpc`` queryable: decode, dispatch, encode. Returns ``(payload, ok)``; never
        raises an Exception."""
        return await self.rpc.handle_bytes(data)

    async def _skills(self, request: AgentRequest) -> SkillsReply:
        return self._list_skills(request)

    def _list_skills(self, request: AgentRequest) -> SkillsReply:
        if not isinstance(request, ListSkills):
            name = type(request).__name__
            raise BadRequestError(f"the skills queryable answers ListSkills, not {name}")
        return self.skills_reply()

    async def handle(self, request: AgentRequest) -> AgentReply:
        """Answer one request; refusals raise the :mod:`skill_agent` class."""
        core = self.core
        match request:
            case ListSkills():
                return self.skills_reply()
            case StartRun(run_id=run_id):
                if run_id:
                    check_name(run_id, "run id")
                started = await core.start(request)
                if not request.wait:
                    return started
                result = await core.wait(started.run_id)
                return RunFinished(result=result, inferred=started.inferred)
            case StopRun(run_id=run_id):
                result = await core.stop(run_id)
                try:
                    info = core.status(run_id)
                except UnknownRunError:  # forgotten meanwhile: rebuild from the result
                    info = RunInfo(run_id=run_id, skill=result.skill, state="preempted")
                return RunsReply(runs=[msgspec.structs.replace(info, result=result)])
            case PauseRun(run_id=run_id):
                await core.pause(run_id)
                return OkReply(message=f"run {run_id} paused")
            case ResumeRun(run_id=run_id):
                await core.resume(run_id)
                return OkReply(message=f"run {run_id} resumed")
            case RunStatus(run_id=run_id):
                return RunsReply(runs=[core.status(run_id)])
            case ListRuns(active_only=active_only):
                return RunsReply(runs=core.runs(active_only=active_only))
            case RunEvents(run_id=run_id, after_seq=after_seq):
                return self._run_events(run_id, after_seq)
            case Reload():
                return await self._reload()
        raise RunStateError(f"unsupported request {type(request).__name__}")  # pragma: no cover

    def _run_events(self, run_id: str, after_seq: int) -> RunEventsReply:
        """The run's state (from the core, or from its kept result once the core forgot it)
        and its kept events; UnknownRunError if neither knows the run."""
        kept = self.history.events(run_id, after_seq)
        try:
            info = self.core.status(run_id)
        except UnknownRunError:
            result = kept[0][-1] if kept and kept[0] else None
            if not isinstance(result, RunResult):
                raise
            state: RunState = "succeeded" if result.success else "failed"
            info = RunInfo(
                run_id=run_id,
                skill=result.skill,
                state="preempted" if result.reason == "preempted" else state,
                params=result.params,
                started_at=result.started_at,
                result=result,
            )
        events, dropped = kept if kept is not None else ([], 0)
        return RunEventsReply(run=info, events=events, dropped=dropped)

    async def _reload(self) -> OkReply:
        registry = self.registry
        if registry is None:
            raise RunStateError(f"agent {self.core.name} has no plug-in registry to reload")
        async with self._reload_lock:
            if self.before_reload is not None:
                await self.before_reload()
            entries = await anyio.to_thread.run_sync(registry.reload)
            self.core.replace_skills(entries)
            if self.on_reload is not None:
                await self.on_reload()
        names = ", ".join(sorted(entries)) or "none"
        _log.warning("agent %s reloaded %d skills: %s", self.core.name, len(entries), names)
        return OkReply(message=f"reloaded {len(entries)} skills: {names}")


def _to_reply(exc: Exception) -> ErrorReply | None:
    """The agent's exceptions -> error replies (None: unexpected, answered ``internal``)."""
    if isinstance(exc, ParameterError):
        return ErrorReply(code=exc.code, message=str(exc), param_states=dict(exc.param_states))
    if isinstance(exc, SkillError):
        return ErrorReply(code=exc.code, message=str(exc))
    if isinstance(exc, ValueError):  # e.g. a run id that is no valid key segment
        return ErrorReply(code=BAD_REQUEST, message=str(exc))
    return None
