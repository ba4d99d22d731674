"""Calling the task agent over the mesh: :class:`TaskClient`.

One call submits a goal and follows it to the end::

    async with open_mesh(config) as mesh:
        finished = await TaskClient(mesh).run_goal("contain(KitBox-1, Gear-3)")

It never waits forever (SkiROS2 #79): :meth:`TaskClient.watch` subscribes to the task's events
*before* the task is submitted (the client chooses the task id), asks the service for the
task's status whenever the stream stays quiet for ``quiet`` seconds (a ``TaskFinished`` missed
during a reconnect is rebuilt from the status), raises :class:`TaskTransportError` when the
service does not answer for ``lost_after`` seconds, and ``TimeoutError`` after ``deadline``.

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
from meshlink.rpc import ErrorReply, WireError, encode, error_for

from ._errors import (
    TASK_CODES,
    FileRefusedError,
    TaskTransportError,
    remote_task_error,
)
from ._goals import Goal
from .protocol import (
    AbortTask,
    AnswerPending,
    ListPending,
    ListTasks,
    OkReply,
    OperatorRequest,
    PendingReply,
    PendingStep,
    SeenAt,
    SubmitFile,
    SubmitGoal,
    TaskAccepted,
    TaskEvent,
    TaskFinished,
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

    # ------------------------------------------------------------------ requests

    async def request(self, request: TaskRequest, *, timeout: float | None = None) -> TaskReply:
        """One request to ``tasks/rpc``; an error reply raises (see the module doc)."""
        key, wait = self.mesh.keys.tasks_rpc(), timeout or self.timeout
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
        async with self.mesh.subscribe(self.mesh.keys.task_events(task_id)) as samples:
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
        last_seq, silent_since = 0, anyio.current_time()
        end = anyio.current_time() + deadline
        check = existing
        while True:
            if check:
                finished = await self._finished_by_status(task_id, last_seq, silent_since)
                if finished is not None:
                    yield finished
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
            if event.seq != last_seq + 1:
                _log.warning("task %s: events %d..%d missed", task_id, last_seq + 1, event.seq - 1)
            last_seq = event.seq
            yield event
            if isinstance(event, TaskFinished):
                return

    async def _finished_by_status(
        self, task_id: str, last_seq: int, silent_since: float
    ) -> TaskFinished | None:
        try:
            info = await self.status(task_id)
        except TaskTransportError:
            if anyio.current_time() - silent_since > self.lost_after:
                raise TaskTransportError(
                    f"the task agent stopped answering for {self.lost_after:g} s while task "
                    f"{task_id} was running"
                ) from None
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
        except NoReplyError:
            raise TaskTransportError(
                f"no operator agent answered on {key} within {self.timeout:g} s (it runs inside "
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
