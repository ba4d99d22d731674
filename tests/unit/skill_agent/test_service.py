"""AgentService, the agent's two queryables (``rpc`` and ``skills``) without the network:
every payload, however hostile, answers a decodable ErrorReply or a valid reply, with the
standard codes of :mod:`meshlink.rpc`; the agent's own refusals keep their codes (and the
parameters' states)."""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator

import msgspec
import pytest

from meshlink.rpc import DEFAULT_MAX_REQUEST_BYTES, Decoder, encode
from meshlink.testing import check_reply, hostile_payloads
from skill_agent import (
    AgentInternalError,
    BadRequestError,
    InferenceError,
    RemoteSkillError,
    UnspecifiedParameterError,
)
from skill_agent._errors import error_for_reply
from skill_agent.protocol import (
    AgentReply,
    ErrorReply,
    ListRuns,
    ListSkills,
    ParamSpec,
    ParamState,
    RunsReply,
    RunStatus,
    SkillDescription,
    SkillsReply,
    StartRun,
    decode_reply,
)
from skill_agent.server import AgentService
from tests.assets.skills import Noop, Probe, entries

from .conftest import AgentFactory

pytestmark = pytest.mark.anyio

REPLIES: Decoder[AgentReply] = Decoder(AgentReply, what="reply")
SAMPLES = [encode(ListRuns()), encode(RunStatus(run_id="nope")), encode(ListSkills())]

_BAD_UTF8 = b"\xa4\xff\xfe\xfd\xfc"  # a 4-byte string that is no UTF-8
INVALID_UTF8 = b"\x82\xa7request\xa9RunStatus\xa6run_id" + _BAD_UTF8
INVALID_UTF8_TAG = b"\x81\xa7request" + _BAD_UTF8
DEEP = b"\x81\xa1x" * 1000 + b"\xc0"  # maps nested 1,000 deep
DEEP_IN_REQUEST = b"\x82\xa7request\xa8ListRuns\xa1x" + b"\x91" * 1000 + b"\xc0"  # skipped field
UNKNOWN_TAG = msgspec.msgpack.encode({"request": "NoSuchRequest"})
HUGE = encode(StartRun(skill="noop", params={"x": "y" * DEFAULT_MAX_REQUEST_BYTES}))


class Speedy(Noop):
    description = SkillDescription(
        name="speedy",
        parameters=[
            ParamSpec(name="speed", type="float"),
            ParamSpec(name="note", type="str", optional=True),
        ],
    )


@pytest.fixture
async def service(make_agent: AgentFactory, probe: Probe) -> AsyncIterator[AgentService]:
    async with make_agent(entries(probe, Speedy)) as core:
        yield AgentService(core)


def error_of(payload: bytes, ok: bool) -> ErrorReply:
    reply = check_reply(payload, ok, REPLIES)  # a meshlink ErrorReply, sent as an error
    assert not ok, reply
    decoded = decode_reply(payload)  # the agent's own ErrorReply, param_states included
    assert isinstance(decoded, ErrorReply)
    return decoded


@pytest.mark.parametrize(
    ("payload", "code", "why"),
    [
        (INVALID_UTF8, "bad_request", "invalid UTF-8"),
        (INVALID_UTF8_TAG, "bad_request", "invalid UTF-8"),
        (DEEP, "bad_request", "nested too deeply"),
        (DEEP_IN_REQUEST, "bad_request", "nested too deeply"),
        (UNKNOWN_TAG, "bad_request", "malformed request"),
        (b"\xc1 not msgpack", "bad_request", "malformed request"),
        (HUGE, "too_large", "exceeds the limit"),
    ],
    ids=["utf8", "utf8-tag", "deep", "deep-field", "unknown-tag", "garbage", "huge"],
)
async def test_malformed_and_oversized_requests_answer_the_standard_codes_on_both_queryables(
    service: AgentService, payload: bytes, code: str, why: str
) -> None:
    answers = {
        "rpc": await service.handle_bytes(payload),
        "skills": await service.skills.handle_bytes(payload),
    }
    for queryable, (data, ok) in answers.items():
        error = error_of(data, ok)
        assert (error.code, error.param_states) == (code, {}), queryable
        assert why in error.message, (queryable, error.message)


async def test_an_empty_payload_lists_the_skills_and_is_no_rpc_request(
    service: AgentService,
) -> None:
    for data, ok in (await service.skills.handle_bytes(b""),):
        listing = check_reply(data, ok, REPLIES)
        assert isinstance(listing, SkillsReply) and listing.agent == "r1-agent"
        assert "speedy" in [d.name for d in listing.skills]
    assert error_of(*await service.handle_bytes(b"")).code == "bad_request"


async def test_every_hostile_payload_gets_a_typed_reply_and_the_agent_stays_healthy(
    service: AgentService,
) -> None:
    payloads = hostile_payloads(SAMPLES)
    assert len(payloads) > 50
    for payload in payloads:
        check_reply(*await service.handle_bytes(payload), REPLIES)
        check_reply(*await service.skills.handle_bytes(payload), REPLIES)
    assert service.core.runs(active_only=False) == [], "no hostile payload started a run"
    runs = check_reply(*await service.handle_bytes(encode(ListRuns())), REPLIES)
    assert runs == RunsReply(runs=[])


async def test_the_skills_queryable_refuses_other_requests(service: AgentService) -> None:
    for data, ok in (await service.skills.handle_bytes(encode(StartRun(skill="noop"))),):
        error = error_of(data, ok)
        assert error.code == "bad_request"
        assert error.message == "the skills queryable answers ListSkills, not StartRun"
    assert service.core.runs(active_only=False) == []


async def test_refusals_keep_the_agents_codes_and_parameter_states(
    service: AgentService,
) -> None:
    error = error_of(*await service.handle_bytes(encode(StartRun(skill="speedy"))))
    assert error.code == "unspecified_parameter" and "speed" in error.message
    assert error.param_states == {"speed": "initialized", "note": "initialized"}
    refused = error_for_reply(error)
    assert isinstance(refused, UnspecifiedParameterError)
    assert refused.param_states == error.param_states

    error = error_of(*await service.handle_bytes(encode(RunStatus(run_id="nope"))))
    assert error.code == "unknown_run" and error.param_states == {}

    error = error_of(*await service.handle_bytes(encode(StartRun(skill="noop", run_id="a/b"))))
    assert error.code == "bad_request" and "run id" in error.message


async def test_an_unexpected_exception_answers_internal_and_is_logged(
    service: AgentService, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    def broken(*, active_only: bool = True) -> list[object]:
        raise RuntimeError("boom")

    monkeypatch.setattr(service.core, "runs", broken)
    with caplog.at_level(logging.ERROR, logger="meshlink.rpc"):
        error = error_of(*await service.handle_bytes(encode(ListRuns())))
    assert (error.code, error.message) == ("internal", "RuntimeError: boom")
    assert any("ListRuns" in r.getMessage() for r in caplog.records)


def test_the_client_rebuilds_the_standard_codes_and_keeps_unknown_ones() -> None:
    for code in ("bad_request", "too_large"):
        refused = error_for_reply(ErrorReply(code=code, message="m"))
        assert isinstance(refused, BadRequestError) and str(refused) == "m"
    assert isinstance(error_for_reply(ErrorReply(code="internal", message="m")), AgentInternalError)
    unknown = error_for_reply(encode(ErrorReply(code="brand_new", message="m")))
    assert isinstance(unknown, RemoteSkillError)
    assert (unknown.remote_code, unknown.message) == ("brand_new", "m")
    unavailable = error_for_reply(b"plain text from no RPC server")
    assert isinstance(unavailable, RemoteSkillError)
    assert (unavailable.remote_code, unavailable.message) == (
        "remote_error",
        "plain text from no RPC server",
    )
    states: dict[str, ParamState] = {"speed": "initialized"}
    payload = encode(ErrorReply(code="inference", message="m", param_states=states))
    refused = error_for_reply(payload)
    assert isinstance(refused, InferenceError) and refused.param_states == states
