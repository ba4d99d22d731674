"""WmService: every bad input gets an error reply naming the problem; the state is unchanged."""

from __future__ import annotations

import anyio
import msgspec
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from meshlink.rpc import Decoder, ErrorReply, encode
from meshlink.testing import check_reply, hostile_payloads
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    ChangesSince,
    ElementsReply,
    GetElements,
    Info,
    InfoReply,
    Query,
    Relation,
    Relations,
    RelationsReply,
    Reply,
    Resolve,
    Transact,
    TransactReply,
    decode_reply,
)
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio


async def make_service(ontology: Ontology) -> WmService:
    store = await WmStore.open(ontology)
    service = WmService(store, max_request_bytes=64 * 1024)
    reply = await service.handle(
        Transact(
            ops=[
                AddElement(type="Box", ref="$b"),
                AddElement(type="Gear", relations=[Relation("$b", "contain", "$")]),
            ]
        )
    )
    assert isinstance(reply, TransactReply)
    return service


async def call(service: WmService, data: bytes) -> tuple[object, bool]:
    out, ok = await service.handle_bytes(data)
    return decode_reply(out), ok


async def test_good_requests(ontology: Ontology) -> None:
    service = await make_service(ontology)
    reply, ok = await call(service, encode(GetElements(ids=["Gear-1"])))
    assert ok and isinstance(reply, ElementsReply) and reply.elements[0].type == "Gear"
    reply, ok = await call(service, encode(Resolve(query=Query(type="Part"))))
    assert isinstance(reply, ElementsReply) and [e.id for e in reply.elements] == ["Gear-1"]
    reply, ok = await call(service, encode(Relations(predicate="contain")))
    assert isinstance(reply, RelationsReply) and reply.relations == [
        Relation("Box-1", "contain", "Gear-1")
    ]
    reply, ok = await call(service, encode(Info()))
    assert isinstance(reply, InfoReply) and reply.revision == 1 and reply.elements == 2


@pytest.mark.parametrize(
    ("data", "code", "words"),
    [
        (b"", "bad_request", "malformed"),
        (b"\xc1\xff\x00garbage", "bad_request", "malformed"),
        (msgspec.msgpack.encode({"request": "Nope"}), "bad_request", "Nope"),
        (msgspec.msgpack.encode({"request": "GetElements", "ids": 5}), "bad_request", "ids"),
        (encode(GetElements(ids=["Gear-99"])), "not_found", "Gear-99"),
        (encode(Resolve(query=Query(type="Gaer"))), "unknown_class", "Gear"),
        (
            encode(Transact(ops=[AddElement(type="Gear", properties={"mass": "x"})])),
            "property_value",
            "mass",
        ),
        (encode(ChangesSince(revision=50)), "conflict", "ahead"),
        (b"\x00" * (70 * 1024), "too_large", "limit"),
    ],
)
async def test_bad_input_gets_named_error(
    ontology: Ontology, data: bytes, code: str, words: str
) -> None:
    service = await make_service(ontology)
    before = service.store.snapshot()
    reply, ok = await call(service, data)
    assert not ok
    assert isinstance(reply, ErrorReply)
    assert reply.code == code
    assert words in reply.message
    assert service.store.snapshot() == before


@settings(
    max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.binary(max_size=512))
def test_fuzzed_bytes_never_crash_or_change_state(ontology: Ontology, data: bytes) -> None:
    async def check() -> None:
        service = await make_service(ontology)
        before = service.store.snapshot()
        reply, ok = await call(service, data)
        assert (
            isinstance(
                reply, ErrorReply | ElementsReply | RelationsReply | InfoReply | TransactReply
            )
            or ok
        )
        if not ok:
            assert service.store.snapshot() == before

    anyio.run(check)


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    payload=st.dictionaries(
        st.sampled_from(["request", "ids", "query", "ops", "revision", "type", "op"]),
        st.one_of(
            st.sampled_from(["GetElements", "Resolve", "Transact", "AddElement", "Info", "Gear"]),
            st.integers(min_value=-(2**63), max_value=2**63 - 1),
            st.lists(st.text(max_size=5), max_size=3),
            st.none(),
        ),
    )
)
def test_fuzzed_structured_requests(ontology: Ontology, payload: dict[str, object]) -> None:
    async def check() -> None:
        service = await make_service(ontology)
        before = service.store.snapshot()
        reply, ok = await call(service, msgspec.msgpack.encode(payload))
        if not ok:
            assert isinstance(reply, ErrorReply) and reply.message
            assert service.store.snapshot() == before

    anyio.run(check)


INFO_WITH = b"\x82\xa7request\xa4Info\xa1x"  # {"request": "Info", "x": <what follows>}


@pytest.mark.parametrize("read_only", [False, True], ids=["wm-rpc", "wm-query"])
@pytest.mark.parametrize(
    ("data", "words"),
    [
        (b"\x81\xa7request\xa1\xff", "UTF-8"),  # {"request": "<0xff>"}
        (b"\x82\xa7request\xabGetElements\xa3ids\x91\xa1\xff", "UTF-8"),  # ids=["<0xff>"]
        (INFO_WITH + b"\x91" * 1000 + b"\xc0", "nested"),  # arrays 1,000 deep
        (INFO_WITH + b"\x81\xa1a" * 1000 + b"\xc0", "nested"),  # maps 1,000 deep
    ],
    ids=["utf8-tag", "utf8-value", "deep-arrays", "deep-maps"],
)
async def test_malformed_utf8_and_deep_nesting_are_named(
    ontology: Ontology, data: bytes, words: str, read_only: bool
) -> None:
    """Invalid UTF-8 (UnicodeDecodeError) and nesting 1,000 deep (RecursionError) escape
    msgspec's own errors: both still answer a ``bad_request`` ErrorReply."""
    service = await make_service(ontology)
    out, ok = await service.handle_bytes(data, read_only=read_only)
    reply = decode_reply(out)
    assert not ok and isinstance(reply, ErrorReply), reply
    assert reply.code == "bad_request" and words in reply.message, reply


@pytest.mark.parametrize("read_only", [False, True], ids=["wm-rpc", "wm-query"])
async def test_hostile_payloads_get_typed_replies(ontology: Ontology, read_only: bool) -> None:
    """Empty, undecodable, invalid UTF-8, deep nesting, unknown tags, huge payloads and the
    mutations of valid requests: every reply decodes as a :data:`Reply`, an ErrorReply exactly
    when ``ok`` is False, and the state is unchanged (a transaction, even empty, commits a
    revision: only the read-only endpoint, which refuses it, gets one)."""
    service = await make_service(ontology)
    before = service.store.snapshot()
    samples = [
        encode(Info()),
        encode(GetElements(ids=["Gear-1"])),
        encode(Resolve(query=Query(type="Part"))),
    ]
    if read_only:
        samples.append(encode(Transact(ops=[AddElement(type="Gear")])))
    replies = Decoder[Reply](Reply)
    payloads = hostile_payloads(samples, huge=service.max_request_bytes + 1)
    codes: set[str] = set()
    for payload in payloads:
        out, ok = await service.handle_bytes(payload, read_only=read_only)
        check_reply(out, ok, replies)
        reply = decode_reply(out)
        assert ok != isinstance(reply, ErrorReply), (payload[:80], reply)
        if isinstance(reply, ErrorReply):
            codes.add(reply.code)
    assert {"bad_request", "too_large"} <= codes
    assert codes <= {"bad_request", "too_large", "protocol_error", "not_found"}, codes
    assert service.store.snapshot() == before
