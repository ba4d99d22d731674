"""The task client's reading of replies (no Zenoh: a mesh that answers one fixed payload): an
error reply raises the class of its code, a code without a class keeps it, anything that is no
reply raises TaskTransportError. Watching: the history, then the live events, each once."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any, cast

import anyio
import pytest

from meshlink import KeySpace, Mesh, RemoteError
from meshlink.rpc import BAD_REQUEST, TOO_LARGE, ErrorReply, encode
from task_agent import (
    GoalParseError,
    OperatorClient,
    RemoteTaskError,
    TaskClient,
    TaskError,
    TaskTransportError,
    VerificationError,
)
from task_agent.protocol import (
    HistoryReply,
    OkReply,
    Replanning,
    TaskEvent,
    TaskFinished,
    TaskHistory,
    TaskInfo,
    TasksReply,
    TaskStarted,
    TaskStatus,
    decode_request,
)


class OneAnswer:
    """A mesh whose every request gets ``payload`` back (an error reply if ``error``)."""

    keys = KeySpace("test")

    def __init__(self, payload: bytes, *, error: bool) -> None:
        self.payload, self.error = payload, error

    async def request(self, key: str, data: bytes, *, timeout: float) -> bytes:
        if self.error:
            raise RemoteError(self.payload, key)
        return self.payload


def error(code: str, message: str = "why") -> OneAnswer:
    return OneAnswer(encode(ErrorReply(code=code, message=message)), error=True)


@pytest.mark.parametrize(
    ("mesh", "raised", "code", "words"),
    [
        (error("goal_parse", "unknown element"), GoalParseError, "goal_parse", "unknown element"),
        (error("verification"), VerificationError, "verification", "why"),
        (error("task_error"), TaskError, "task_error", "why"),
        (error("unknown_task", "no task 'x'"), RemoteTaskError, "unknown_task", "no task 'x'"),
        (error(BAD_REQUEST), RemoteTaskError, BAD_REQUEST, "why"),
        (error(TOO_LARGE), RemoteTaskError, TOO_LARGE, "why"),
        (OneAnswer(b"RuntimeError: boom", error=True), TaskTransportError, "transport", "boom"),
        (OneAnswer(b"\xc1", error=False), TaskTransportError, "transport", "undecodable reply"),
        (OneAnswer(encode(OkReply()), error=False), TaskTransportError, "transport", "OkReply"),
    ],
)
@pytest.mark.anyio
async def test_task_client_raises_by_code(
    mesh: OneAnswer, raised: type[TaskError], code: str, words: str
) -> None:
    with pytest.raises(raised) as caught:
        await TaskClient(cast(Mesh, mesh)).list()
    assert type(caught.value) is raised and caught.value.code == code
    assert words in str(caught.value)


@pytest.mark.anyio
async def test_operator_client_raises_by_code() -> None:
    client = OperatorClient(cast(Mesh, error("unknown_request", "no pending request '7'")))
    with pytest.raises(RemoteTaskError, match="no pending request '7'") as caught:
        await client.answer("7", True)
    assert caught.value.code == "unknown_request"
    garbage = OperatorClient(cast(Mesh, OneAnswer(b"\x93garbage", error=False)))
    with pytest.raises(TaskTransportError, match="malformed operator reply"):
        await garbage.pending()


class Sample:
    def __init__(self, payload: bytes) -> None:
        self.payload = payload


class HistoryMesh:
    """A task agent that keeps ``kept(n)`` events at its ``n``-th history request (or answers
    ``bad_request`` to it, as a task agent without history would), and a live stream the test
    feeds."""

    keys = KeySpace("test")

    def __init__(self, kept: Callable[[int], list[TaskEvent]] | None) -> None:
        self.kept, self.asked = kept, 0
        self.send, self.receive = anyio.create_memory_object_stream[Sample](math.inf)

    async def request(self, key: str, data: bytes, *, timeout: float) -> bytes:
        request = decode_request(data)
        if isinstance(request, TaskHistory):
            if self.kept is None:
                raise RemoteError(encode(ErrorReply(code=BAD_REQUEST, message="no")), key)
            self.asked += 1
            events = [e for e in self.kept(self.asked) if e.seq > request.after_seq]
            return encode(HistoryReply(task_id="t", events=events))
        assert isinstance(request, TaskStatus), request
        return encode(TasksReply(tasks=[TaskInfo(task_id="t", outcome="running")]))

    @asynccontextmanager
    async def subscribe(self, key: str, *, via: str | None = None) -> AsyncIterator[Any]:
        yield self.receive

    def live(self, *events: TaskEvent) -> None:
        for event in events:
            self.send.send_nowait(Sample(encode(event)))


def task_events(n: int) -> list[TaskEvent]:
    events: list[TaskEvent] = [TaskStarted(task_id="t", seq=1, stamp=1.0)]
    events += [Replanning(task_id="t", seq=s, stamp=s, attempt=s, reason="") for s in range(2, n)]
    return [*events, TaskFinished(task_id="t", seq=n, stamp=n, outcome="succeeded")]


async def watched(mesh: HistoryMesh) -> list[int]:
    with mesh.send, mesh.receive:
        async with TaskClient(cast(Mesh, mesh), quiet=5).watch("t") as events:
            return [e.seq async for e in events]


@pytest.mark.anyio
async def test_watch_yields_the_history_then_the_live_events_each_once_filling_gaps() -> None:
    every = task_events(7)
    mesh = HistoryMesh(lambda n: every[:3] if n == 1 else every)
    mesh.live(every[1], every[2], every[3], every[5], every[6])  # 2 and 3 twice, 5 missing
    assert await watched(mesh) == [1, 2, 3, 4, 5, 6, 7]
    assert mesh.asked == 2  # at the start, and for the gap before 6


@pytest.mark.anyio
async def test_watch_follows_a_task_agent_without_history_from_the_stream() -> None:
    mesh = HistoryMesh(None)
    mesh.live(*task_events(3))
    assert await watched(mesh) == [1, 2, 3]
