"""The RPC layer: codec, request-handler wrapper (fuzzed), and client-side raising by code."""

from __future__ import annotations

import gc
import logging
from collections.abc import Iterator
from typing import Any, TypeAlias

import anyio
import msgspec
import pytest
from hypothesis import HealthCheck, given, settings

from meshlink import IncomingQuery, RemoteError
from meshlink.rpc import (
    BAD_REQUEST,
    INTERNAL,
    TOO_LARGE,
    UNAVAILABLE,
    Decoder,
    ErrorReply,
    RequestHandler,
    WireError,
    coded_errors,
    decode_error,
    encode,
    error_for,
    errors_by_code,
    from_message,
    raise_for_error,
)
from meshlink.testing import check_reply, hostile_payloads, payloads

pytestmark = pytest.mark.anyio


# ------------------------------------------------------------- a toy service, as the real ones
class Echo(msgspec.Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    text: str
    extra: dict[str, Any] = {}


class Fail(msgspec.Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    how: str


class Info(msgspec.Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    pass


Request: TypeAlias = Echo | Fail | Info


class EchoReply(msgspec.Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    text: str


class DetailedError(ErrorReply, tag="ErrorReply", frozen=True, kw_only=True):
    """A service's own ErrorReply with more fields: same tag, so interchangeable."""

    hint: str = ""


Reply: TypeAlias = EchoReply | DetailedError


class ToyError(Exception):
    code = "toy_error"


class NotFound(ToyError):
    code = "not_found"


async def dispatch(request: Request) -> EchoReply | ErrorReply:
    match request:
        case Echo(text=text):
            return EchoReply(text=text)
        case Info():
            return EchoReply(text="info")
        case Fail(how="not_found"):
            raise NotFound("no such thing")
        case Fail(how="value"):
            raise ValueError("not a key segment")
        case Fail(how="reply"):
            return DetailedError(code="refused", message="no", hint="ask later")
        case Fail(how="unencodable"):
            return EchoReply(text=object())  # type: ignore[arg-type]
        case Fail(how="cancel"):
            raise anyio.get_cancelled_exc_class()()
    raise RuntimeError(f"boom {request!r}")


def handler(**kw: Any) -> RequestHandler[Request, EchoReply]:
    kw.setdefault("errors", coded_errors(ToyError, bad_request=(ValueError,)))
    return RequestHandler(Request, dispatch, error_type=DetailedError, name="toy", **kw)


REPLIES: Decoder[Reply] = Decoder(Reply, what="reply")


async def answer(h: RequestHandler[Request, EchoReply], data: bytes) -> Reply:
    payload, ok = await h.handle_bytes(data)
    check_reply(payload, ok, REPLIES)
    return REPLIES.decode(payload)


# ------------------------------------------------------------- codec
def test_decoder_turns_every_failure_into_one_wire_error() -> None:
    decoder: Decoder[Request] = Decoder(Request, max_bytes=64, what="request")
    assert decoder.decode(encode(Echo(text="hi"))) == Echo(text="hi")
    cases = {
        b"": "malformed request",
        b"\xc1": "malformed request",
        encode({"request": "Nope"}): "malformed request",
        encode({"request": "Echo", "text": 3}): "malformed request",
    }
    for data, text in cases.items():
        with pytest.raises(WireError, match=text) as info:
            decoder.decode(data)
        assert info.value.code == BAD_REQUEST
    with pytest.raises(WireError, match="exceeds the limit of 64 bytes") as info:
        decoder.decode(b"\x00" * 65)
    assert info.value.code == TOO_LARGE


def test_decoder_catches_invalid_utf8_and_deep_nesting() -> None:
    decoder: Decoder[Request] = Decoder(Request)
    bad_utf8 = b"\x82\xa7request\xa4Echo\xa4text\xa2\xff\xfe"
    with pytest.raises(WireError, match="invalid UTF-8"):
        decoder.decode(bad_utf8)
    deep = b"\x82\xa7request\xa4Echo\xa5extra" + b"\x81\xa1a" * 1000 + b"\xc0"
    with pytest.raises(WireError, match="nested too deeply"):
        decoder.decode(deep)


def test_error_reply_sits_in_a_service_reply_union() -> None:
    wire = encode(ErrorReply(code="x", message="y"))
    assert msgspec.msgpack.decode(wire)["reply"] == "ErrorReply"
    assert REPLIES.decode(wire) == DetailedError(code="x", message="y")
    assert Decoder[ErrorReply](ErrorReply).decode(
        encode(DetailedError(code="x", message="y", hint="h"))
    )


# ------------------------------------------------------------- the handler
async def test_handler_answers_replies_and_every_error_kind(
    caplog: pytest.LogCaptureFixture,
) -> None:
    h = handler(max_request_bytes=1024)
    assert await answer(h, encode(Echo(text="hi"))) == EchoReply(text="hi")
    expected = {
        encode(Fail(how="not_found")): ("not_found", "no such thing"),
        encode(Fail(how="value")): (BAD_REQUEST, "ValueError: not a key segment"),
        encode(Fail(how="reply")): ("refused", "no"),
        encode(Fail(how="boom")): (INTERNAL, "RuntimeError: boom"),
        encode(Fail(how="unencodable")): (INTERNAL, "unencodable reply"),
        b"": (BAD_REQUEST, "malformed request"),
        b"\x00" * 2000: (TOO_LARGE, "request of 2000 bytes exceeds the limit of 1024"),
    }
    with caplog.at_level(logging.ERROR, logger="meshlink.rpc._server"):
        for data, (code, text) in expected.items():
            reply = await answer(h, data)
            assert isinstance(reply, ErrorReply)
            assert (reply.code, reply.message[: len(text)]) == (code, text)
    assert any("request Fail failed" in r.getMessage() for r in caplog.records)
    refused = await answer(h, encode(Fail(how="reply")))
    assert isinstance(refused, DetailedError) and refused.hint == "ask later"


async def test_handler_empty_request_and_cancellation() -> None:
    h = handler(empty=Info())
    assert await answer(h, b"") == EchoReply(text="info")
    refused = await answer(h, b"\xc1")
    assert isinstance(refused, ErrorReply) and refused.code == BAD_REQUEST
    with pytest.raises(anyio.get_cancelled_exc_class()):
        await h.handle_bytes(encode(Fail(how="cancel")))


async def test_handler_serves_a_mesh_query() -> None:
    serve = handler().serve_on("skimesh/t/rpc")
    (answer_,) = await serve(IncomingQuery("skimesh/t/rpc", "", encode(Echo(text="q"))))
    assert (answer_.key, answer_.ok, answer_.encoding) == (
        "skimesh/t/rpc",
        True,
        "application/msgpack",
    )
    (refused,) = await serve(IncomingQuery("skimesh/t/rpc", "", None))
    assert not refused.ok
    assert decode_error(refused.payload).code == BAD_REQUEST


async def test_every_hostile_payload_gets_an_error_reply() -> None:
    h = handler()
    samples = [encode(Echo(text="hi", extra={"a": [1]})), encode(Fail(how="x")), encode(Info())]
    for data in hostile_payloads(samples):
        payload, ok = await h.handle_bytes(data)
        check_reply(payload, ok, REPLIES)


@pytest.fixture
def collect_garbage() -> Iterator[None]:
    """Free the event loops the fuzz test leaves behind now, so that a later test's loop step
    does not pay for their collection (the blocking detector would see it)."""
    yield
    gc.collect()


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=payloads([encode(Echo(text="hi", extra={"k": 1})), encode(Fail(how="not_found"))]))
@pytest.mark.usefixtures("collect_garbage")
def test_fuzz_every_reply_is_an_error_reply_or_a_valid_reply(data: bytes) -> None:
    async def one() -> None:
        payload, ok = await handler(max_request_bytes=4096).handle_bytes(data)
        check_reply(payload, ok, REPLIES)

    anyio.run(one)


# ------------------------------------------------------------- the client side
def test_error_for_maps_codes_and_falls_back_to_remote_error() -> None:
    codes = {"not_found": lambda r: NotFound(r.message)}
    exc = error_for(encode(ErrorReply(code="not_found", message="gone")), codes)
    assert isinstance(exc, NotFound) and str(exc) == "gone"
    other = error_for(ErrorReply(code="weird", message="hm"), codes, key_expr="k")
    assert isinstance(other, RemoteError)
    assert (other.code, other.message, other.key_expr) == ("weird", "hm", "k")
    assert "[weird] hm" in str(other)
    text = error_for(b"Cancelled: the server stopped before answering", codes)
    assert isinstance(text, RemoteError) and text.code == UNAVAILABLE
    fallback = error_for(b"\xc1", codes, fallback=lambda r: ToyError(r.code))
    assert isinstance(fallback, ToyError) and str(fallback) == UNAVAILABLE
    with pytest.raises(NotFound):
        raise_for_error(ErrorReply(code="not_found", message="gone"), codes)
    raise_for_error(EchoReply(text="fine"), codes)


def test_errors_by_code_rebuilds_each_class_from_its_code_and_message() -> None:
    codes = errors_by_code(ToyError, NotFound)
    assert set(codes) == {"toy_error", "not_found"}
    exc = error_for(ErrorReply(code="not_found", message="gone"), codes)
    assert type(exc) is NotFound and str(exc) == "gone"
    toy = from_message(ToyError)(ErrorReply(code="anything", message="m"))
    assert type(toy) is ToyError and str(toy) == "m"
