"""The task client's reading of replies (no Zenoh: a mesh that answers one fixed payload): an
error reply raises the class of its code, a code without a class keeps it, anything that is no
reply raises TaskTransportError."""

from __future__ import annotations

from typing import cast

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
from task_agent.protocol import OkReply


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
