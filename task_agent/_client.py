"""Calling the task agent over the mesh: :class:`TaskClient`.

One call submits a goal and follows it to the end::

    async with open_mesh(config) as mesh:
        finished = await TaskClient(mesh).run_goal("contain(KitBox-1, Gear-3)")

It never waits forever (SkiROS2 #79): :meth:`TaskClient.watch` subscribes to the task's events
*before* the task is submitted (the client chooses the task id), asks the service for the
events it has not seen whenever the stream stays quiet for ``quiet`` seconds or skips a
``seq`` (``TaskHistory``: events missed during a reconnect are fetched, not lost), raises
:class:`TaskTransportError` when the service does not answer for ``lost_after`` seconds, and
``TimeoutError`` after ``deadline``.

Watching a task that runs already (or has ended) starts with its **history**: the client
subscribes, then fetches the events kept so far by ``seq`` (from ``TaskStarted``, the plan and
every step), yields them, then the live ones, each ``seq`` once (:class:`SeqMerge`). A task
agent without ``TaskHistory`` is followed from its status as before (a ``TaskFinished``
rebuilt from the status when the task ended).

Errors: an error reply raises the :mod:`task_agent` class of its code
(``GoalParseError``, ``VerificationError``, ...; codes the package has no class for raise
:class:`RemoteTaskError` with the ``code``); a task file refused by verification raises
:class:`FileRefusedError` with the problems; no reply or an undecodable one raises
:class:`TaskTransportError`.
"""

from __future__ import annotations

import logging
import math
import uuid
from collections.abc import AsyncGenerator, AsyncIterator, Callable, Sequence
from contextlib import asynccontextmanager
from typing import TypeVar

import anyio

from meshlink import KeySpace, Mesh, MeshlinkError, NoReplyError, RemoteError, Sample, Subscription
from meshlink.rpc import BAD_REQUEST, ErrorReply, WireError, encode, error_for

from ._errors import (
    TASK_CODES,
    FileRefusedError,
    RemoteTaskError,
    TaskTransportError,
    remote_task_error,
)
from ._goals import Goal
from .protocol import (
    READ_REQUESTS,
    AbortTask,
    AnswerPending,
    HistoryReply,
    ListPending,
    ListTasks,
    OkReply,
    OperatorRequest,
    PauseTask,
    PendingReply,
    PendingStep,
    ResumeTask,
    SeenAt,
    SubmitFile,
    SubmitGoal,
    TaskAccepted,
    TaskEvent,
    TaskFinished,
    TaskHistory,
    TaskInfo,
    TaskOptions,
    TaskReply,
    TaskRequest,
    TasksReply,
    TaskStatus,
    VerifyFile,
    VerifyReply,
    decode_event,
    decode_operator_reply,
    decode_reply,
)

__all__ = [
    "EventCallback",
    "OperatorClient",
    "SeqMerge",
    "TaskClient",
    "new_task_id",
    "operator_rpc_key",
]

_log = logging.getLogger(__name__)
R = TypeVar("R")
EventCallback = Callable[[TaskEvent], object]


def operator_rpc_key(keys: KeySpace) -> str:
    """``skimesh/<mesh>/operator/rpc``."""
    return keys.operator_rpc()


def new_task_id() -> str:
    """A fresh task id (a valid key segment)."""
    return f"t-{uuid.uuid4().hex[:10]}"


def _remote_error(payload: bytes) -> Exception:
    """The exception for an error reply's payload (see the module doc)."""
    return error_for(payload, TASK_CODES, fallback=remote_task_error)


class SeqMerge:
    """Each event of a task once, in ``seq`` order, from the history and the live stream
    together: :meth:`take` says whether an event is new (``seq`` above every one taken), and
    :meth:`gap` whether events lie between the last one taken and ``seq``."""

    def __init__(self) -> None:
        self.last_seq = 0

    def take(self, event: TaskEvent) -> bool:
        if event.seq <= self.last_seq:
            return False
        self.last_seq = event.seq
        return True

    def gap(self, seq: int) -> bool:
        return seq > self.last_seq + 1


class TaskClient:
    """Typed calls to the task agent (``tasks/rpc``) and its event streams."""

    def __init__(
        self, mesh: Mesh, *, timeout: float = 5.0, quiet: float = 5.0, lost_after: float = 15.0
    ) -> None:
        self.mesh = mesh
        self.timeout = timeout
        self.quiet = quiet
        """Seconds without an event after which the task's status is asked for."""
        self.lost_after = lost_after
        """Seconds the service may stay silent (while a task is watched) before giving up."""
        self._has_history = True
        """The task agent answers ``TaskHistory`` (False once it refused it)."""

    # ------------------------------------------------------------------ requests

    async def request(self, request: TaskRequest, *, timeout: float | None = None) -> TaskReply:
        """One request to ``tasks/rpc`` (a read: to the read-only ``tasks/query``, which an ACL
        may open to more users); an error reply raises (see the module doc)."""
        keys = self.mesh.keys
        key = keys.tasks_query() if isinstance(request, READ_REQUESTS) else keys.tasks_rpc()
        wait = timeout or self.timeout
        try:
            data = await self.mesh.request(key, encode(request), timeout=wait)
        except RemoteError as e:
            raise _remote_error(e.payload) from None
        except NoReplyError as e:
            raise TaskTransportError(
                f"the task agent did not answer on {key} {e.when}: is `skimesh "
                f"task-agent` running on mesh {self.mesh.keys.mesh!r}?"
            ) from None
        except MeshlinkError as e:
            raise TaskTransportError(f"task agent: {e}") from e
        try:
            return decode_reply(data)
        except WireError as e:
            raise TaskTransportError(f"undecodable reply from the task agent: {e}") from e

    async def _expect(self, request: TaskRequest, kind: type[R], timeout: float | None = None) -> R:
        reply = await self.request(request, timeout=timeout)
        if isinstance(reply, VerifyReply) and not reply.ok and kind is not VerifyReply:
            raise FileRefusedError(reply.problems)
        if not isinstance(reply, kind):
            raise TaskTransportError(
                f"the task agent answered {type(request).__name__} with {type(reply).__name__}"
            )
        return reply

    async def submit_goal(
        self, goal: str | Goal, *, options: TaskOptions | None = None, task_id: str = ""
    ) -> str:
        """Submit a goal; returns the task id once accepted (GoalParseError if refused)."""
        request = SubmitGoal(goal=goal, options=options or TaskOptions(), task_id=task_id)
        return (await self._expect(request, TaskAccepted)).task_id

    async def submit_file(
        self, text: str, *, options: TaskOptions | None = None, task_id: str = ""
    ) -> str:
        """Submit a task file (TOML text); FileRefusedError if it does not verify."""
        request = SubmitFile(text=text, options=options or TaskOptions(), task_id=task_id)
        return (await self._expect(request, TaskAccepted)).task_id

    async def verify(self, text: str) -> VerifyReply:
        return await self._expect(VerifyFile(text=text), VerifyReply)

    async def status(self, task_id: str) -> TaskInfo:
        reply = await self._expect(TaskStatus(task_id=task_id), TasksReply)
        if len(reply.tasks) != 1:
            raise TaskTransportError(f"the task agent sent {len(reply.tasks)} tasks for one")
        return reply.tasks[0]

    async def list(self, *, active_only: bool = False) -> list[TaskInfo]:
        return (await self._expect(ListTasks(active_only=active_only), TasksReply)).tasks

    async def history(self, task_id: str, after_seq: int = 0) -> HistoryReply:
        """The task's kept events with ``seq > after_seq`` (every page of them), oldest first;
        the last reply's ``outcome``, ``dropped`` and ``more=False``."""
        events: Sequence[TaskEvent] = ()
        while True:
            request = TaskHistory(task_id=task_id, after_seq=after_seq)
            reply = await self._expect(request, HistoryReply)
            events = [*events, *reply.events]
            if not reply.more or not reply.events:
                return HistoryReply(
                    task_id=task_id,
                    events=[*events],
                    outcome=reply.outcome,
                    dropped=reply.dropped,
                )
            after_seq = reply.events[-1].seq

    async def pause(self, task_id: str, reason: str = "") -> str:
        """Hold a task: no new step starts, its runs are paused on their agents. Returns the
        service's message (RequestError ``task_ended`` if the task has ended)."""
        return (await self._expect(PauseTask(task_id=task_id, reason=reason), OkReply)).message

    async def resume(self, task_id: str) -> str:
        """Release a held task; returns the service's message."""
        return (await self._expect(ResumeTask(task_id=task_id), OkReply)).message

    async def abort(self, task_id: str, reason: str = "") -> str:
        """Abort a task; returns once it ended (every run stopped) or the service's wait
        ran out. Returns the service's message."""
        request = AbortTask(task_id=task_id, reason=reason)
        return (await self._expect(request, OkReply, self.timeout + 15.0)).message

    # ------------------------------------------------------------------ events

    @asynccontextmanager
    async def watch(
        self, task_id: str, *, deadline: float = math.inf, existing: bool = True
    ) -> AsyncIterator[AsyncIterator[TaskEvent]]:
        """Subscribe to a task's events; yields an iterator that ends after ``TaskFinished``.
        ``existing``: the task was submitted already (its status is checked at once; an ended
        task yields only a ``TaskFinished`` rebuilt from its status). Enter with
        ``existing=False`` *before* submitting to miss no event."""
        keys = self.mesh.keys  # through one subscriber for every task: no router entry per task
        async with self.mesh.subscribe(
            keys.task_events(task_id), via=keys.tasks_events()
        ) as samples:
            events = self._events(task_id, samples, deadline, existing)
            try:
                yield events
            finally:
                await events.aclose()

    async def _events(
        self, task_id: str, samples: Subscription[Sample], deadline: float, existing: bool
    ) -> AsyncGenerator[TaskEvent, None]:
        # No cancel scope may span a ``yield`` (the consumer's code runs there): the deadline
        # is checked around each wait instead.
        merge, silent_since = SeqMerge(), anyio.current_time()
        end = anyio.current_time() + deadline
        check, self._has_history = existing, True
        while True:
            if check:
                for event in await self._backlog(task_id, merge.last_seq, silent_since):
                    if merge.take(event):
                        yield event
                        if isinstance(event, TaskFinished):
                            return
            left = end - anyio.current_time()
            if left <= 0:
                raise TimeoutError(f"task {task_id} did not finish within {deadline:g} s")
            sample = None
            with anyio.move_on_after(min(self.quiet, left)):
                try:
                    sample = await samples.receive()
                except anyio.EndOfStream:
                    raise TaskTransportError("the mesh session closed") from None
            check = sample is None
            if sample is None:
                continue
            try:
                event = decode_event(sample.payload)
            except WireError as e:
                _log.warning("undecodable event of task %s: %s", task_id, e)
                continue
            silent_since = anyio.current_time()
            if merge.gap(event.seq) and self._has_history:  # fetch what the stream skipped
                for missed in await self._backlog(task_id, merge.last_seq, silent_since):
                    if missed.seq < event.seq and merge.take(missed):
                        yield missed
            if merge.gap(event.seq):
                _log.warning(
                    "task %s: events %d..%d missed", task_id, merge.last_seq + 1, event.seq - 1
                )
            if not merge.take(event):
                continue  # had it from the history
            yield event
            if isinstance(event, TaskFinished):
                return

    async def _backlog(
        self, task_id: str, last_seq: int, silent_since: float
    ) -> Sequence[TaskEvent]:
        """The events after ``last_seq`` the service kept (from its status, a rebuilt
        ``TaskFinished`` once ended, if it keeps none); [] while it does not answer."""
        if self._has_history:
            try:
                return (await self.history(task_id, last_seq)).events
            except RemoteTaskError as e:
                if e.code != BAD_REQUEST:  # an older task agent: no TaskHistory
                    raise
                self._has_history = False
            except TaskTransportError:
                self._check_lost(task_id, silent_since)
                return []
        finished = await self._finished_by_status(task_id, last_seq, silent_since)
        return [] if finished is None else [finished]

    def _check_lost(self, task_id: str, silent_since: float) -> None:
        if anyio.current_time() - silent_since > self.lost_after:
            raise TaskTransportError(
                f"the task agent stopped answering for {self.lost_after:g} s while task "
                f"{task_id} was running"
            ) from None

    async def _finished_by_status(
        self, task_id: str, last_seq: int, silent_since: float
    ) -> TaskFinished | None:
        try:
            info = await self.status(task_id)
        except TaskTransportError:
            self._check_lost(task_id, silent_since)
            return None
        if info.outcome == "running":
            return None
        return TaskFinished(
            task_id=task_id,
            seq=last_seq + 1,
            stamp=info.finished_at,
            outcome=info.outcome,
            message=info.message,
            steps_run=info.steps_run,
            replans=info.replans,
            duration=info.finished_at - info.started_at,
            check=info.check,
            partial=info.partial,
        )

    async def run_goal(
        self,
        goal: str | Goal,
        *,
        options: TaskOptions | None = None,
        task_id: str = "",
        on_event: EventCallback | None = None,
        deadline: float = math.inf,
    ) -> TaskFinished:
        """Submit ``goal`` and follow it to its end; returns the ``TaskFinished`` event."""
        task_id = task_id or new_task_id()
        async with self.watch(task_id, deadline=deadline, existing=False) as events:
            await self.submit_goal(goal, options=options, task_id=task_id)
            return await _follow(events, on_event)

    async def run_file(
        self,
        text: str,
        *,
        options: TaskOptions | None = None,
        task_id: str = "",
        on_event: EventCallback | None = None,
        deadline: float = math.inf,
    ) -> TaskFinished:
        """Submit a task file and follow it to its end (FileRefusedError if refused)."""
        task_id = task_id or new_task_id()
        async with self.watch(task_id, deadline=deadline, existing=False) as events:
            await self.submit_file(text, options=options, task_id=task_id)
            return await _follow(events, on_event)


async def _follow(events: AsyncIterator[TaskEvent], on_event: EventCallback | None) -> TaskFinished:
    async for event in events:
        if on_event is not None:
            on_event(event)
        if isinstance(event, TaskFinished):
            return event
    raise TaskTransportError("the task's events ended without TaskFinished")  # pragma: no cover


class OperatorClient:
    """The operator agent's pending requests (``operator/rpc``): list and answer them."""

    def __init__(self, mesh: Mesh, *, timeout: float = 5.0) -> None:
        self.mesh = mesh
        self.timeout = timeout

    async def _call(self, request: OperatorRequest) -> PendingReply | OkReply:
        key = operator_rpc_key(self.mesh.keys)
        try:
            data = await self.mesh.request(key, encode(request), timeout=self.timeout)
            reply = decode_operator_reply(data)
        except RemoteError as e:
            raise _remote_error(e.payload) from None
        except NoReplyError as e:
            raise TaskTransportError(
                f"no operator agent answered on {key} {e.when} (it runs inside "
                "`skimesh task-agent` unless started with --no-operator)"
            ) from None
        except MeshlinkError as e:  # WireError too: an undecodable reply
            raise TaskTransportError(f"operator agent: {e}") from e
        if isinstance(reply, ErrorReply):  # pragma: no cover - errors come as error replies
            raise error_for(reply, TASK_CODES, fallback=remote_task_error)
        return reply

    async def pending(self) -> list[PendingStep]:
        reply = await self._call(ListPending())
        if not isinstance(reply, PendingReply):
            raise TaskTransportError(f"the operator agent answered {type(reply).__name__}")
        return reply.pending

    async def answer(
        self,
        request_id: str,
        success: bool,
        message: str = "",
        author: str = "",
        seen: Sequence[SeenAt] = (),
    ) -> str:
        """Answer a pending request (``seen``: where the person sees elements);
        RemoteTaskError (code ``unknown_request``, ``bad_request``) if there is no such
        request or a sighting names no element. Returns the agent's confirmation."""
        request = AnswerPending(
            id=request_id, success=success, message=message, author=author, seen=list(seen)
        )
        reply = await self._call(request)
        if not isinstance(reply, OkReply):
            raise TaskTransportError(f"the operator agent answered {type(reply).__name__}")
        return reply.message
