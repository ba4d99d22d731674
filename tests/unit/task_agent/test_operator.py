"""The operator agent (semi-autonomy): pending requests, the operator/rpc service, the mirrored
skills, and the executor handing a failed step to a person (in-process agents, no Zenoh)."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager

import anyio
import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshlink.rpc import (
    BAD_REQUEST,
    DEFAULT_MAX_REQUEST_BYTES,
    INTERNAL,
    TOO_LARGE,
    Decoder,
    ErrorReply,
    encode,
)
from meshlink.testing import check_reply, hostile_payloads, payloads
from skill_agent.runtime import AgentCore
from task_agent import parse_goal
from task_agent.execution import OPERATOR_NOTE
from task_agent.operator import OperatorDesk, OperatorService, SkillMirror
from task_agent.protocol import (
    AnswerPending,
    Call,
    ListPending,
    OkReply,
    OperatorReply,
    PendingReply,
    Replanning,
    SeenAt,
    StepFinished,
    StepStarted,
    TaskFile,
    decode_operator_reply,
)
from task_agent.protocol import (
    Sequence as SequenceBlock,
)
from tests.assets.task_fleet import Fleet, fleet
from wm_store.protocol import AddElement, Pose, Value


class Person:
    """Answers every request that shows up on the desk, through operator/rpc's service."""

    def __init__(
        self, desk: OperatorDesk, *, success: bool, sightings: Sequence[SeenAt] = ()
    ) -> None:
        self.service = OperatorService("operator", desk)
        self.desk, self.success, self.sightings = desk, success, list(sightings)
        self.seen: list[str] = []

    async def call(
        self, request: ListPending | AnswerPending
    ) -> PendingReply | OkReply | ErrorReply:
        data, _ = await self.service.handle_bytes(encode(request))
        return decode_operator_reply(data)

    async def run(self) -> None:
        while True:
            listed = await self.call(ListPending())
            assert isinstance(listed, PendingReply)
            for step in listed.pending:
                self.seen.append(step.note)
                answer = AnswerPending(
                    id=step.id, success=self.success, message="by hand", seen=self.sightings
                )
                assert isinstance(await self.call(answer), OkReply)
            await self.desk.wait_changed()


@asynccontextmanager
async def with_operator(
    f: Fleet, *, success: bool = True, sightings: Sequence[SeenAt] = ()
) -> AsyncIterator[Person]:
    desk = OperatorDesk()
    mirror = SkillMirror(f.discovery, desk)
    mirror.refresh()
    core = AgentCore(name="operator", wm=f.wm, skills=mirror.entries())
    person = Person(desk, success=success, sightings=sightings)
    async with anyio.create_task_group() as tg:
        await tg.start(core.run)
        f.runner.cores["operator"] = core
        f.discovery.set_alive("operator", True)
        tg.start_soon(person.run)
        yield person
        tg.cancel_scope.cancel()


@pytest.mark.anyio
async def test_desk_requests_are_listed_answered_and_withdrawn() -> None:
    desk = OperatorDesk()
    service = OperatorService("operator", desk)
    garbage, ok = await service.handle_bytes(b"\x93garbage")
    assert not ok and isinstance(decode_operator_reply(garbage), ErrorReply)
    unknown, ok = await service.handle_bytes(encode(AnswerPending(id="7", success=True)))
    reply = decode_operator_reply(unknown)
    assert not ok and isinstance(reply, ErrorReply) and reply.code == "unknown_request"
    with pytest.raises(KeyError, match="no pending operator request '1'"):
        desk.answer("1", True)


@pytest.mark.anyio
async def test_mirror_offers_the_robots_skills_with_a_note_and_no_time_limit() -> None:
    async with fleet() as f:
        mirror = SkillMirror(f.discovery, OperatorDesk())
        assert mirror.refresh() and not mirror.refresh()
        assert sorted(mirror.descriptions) == ["navigate", "pick", "place", "serve"]
        pick = mirror.descriptions["pick"]
        assert pick.parameters[-1].name == OPERATOR_NOTE and pick.timeout is None
        assert pick.pre == f.discovery.agents()[0].skill("pick").pre  # type: ignore[union-attr]


@pytest.mark.anyio
async def test_a_failed_step_is_done_by_the_operator() -> None:
    async with fleet(probabilities={"r1": {"pick": 0.0}}, start={"r1": 1}) as f:
        goal = parse_goal(f"contain({f.kits[0]}, {f.parts[0]})", f.wm)
        async with with_operator(f) as person:
            done = await f.executor(operator_fallback=True).run_goal(goal)
        assert done.outcome == "succeeded", done.message
        assert not f.of(Replanning)
        ends = [e for e in f.events if isinstance(e, StepFinished)]
        assert [(e.agent, e.skill, e.success, e.by_operator) for e in ends] == [
            ("r1", "pick", False, False),
            ("operator", "pick", True, True),
            ("r1", "place", True, False),
        ]
        assert len(person.seen) == 1 and "step 0 pick on r1 failed (execution)" in person.seen[0]
        by_hand = next(e for e in f.events if isinstance(e, StepStarted) and e.agent == "operator")
        assert by_hand.params["object"] == f.parts[0]
        assert f.wm.query_relation(f.kits[0], "contain", f.parts[0])


@pytest.mark.anyio
async def test_what_the_operator_saw_is_written_as_their_observation() -> None:
    """An answer with ``seen`` (``skimesh operator --seen``) writes a pose observation of the
    element by the ``Operator`` element, beside the step's predicted effects."""
    async with fleet(probabilities={"r1": {"pick": 0.0}}, start={"r1": 1}) as f:
        reply = await f.wm.transact([AddElement(type="Operator", label="operator", ref="$op")])
        part = f.wm.get_element(f.parts[0])
        seen = SeenAt(element=part.label or part.id, position=(0.5, -0.25, 0.8), yaw=0.3)
        goal = parse_goal(f"contain({f.kits[0]}, {f.parts[0]})", f.wm)
        async with with_operator(f, sightings=[seen]):
            done = await f.executor(operator_fallback=True).run_goal(goal)
        assert done.outcome == "succeeded", done.message
        [obs] = f.wm.get_element(f.parts[0]).observations["pose"]
        assert obs.source == reply.ids["$op"] and obs.confidence == pytest.approx(0.9)
        assert isinstance(obs.value, Pose) and obs.value.position.z == pytest.approx(0.8)
        assert obs.value.orientation.z == pytest.approx(math.sin(0.15))
        finished = [e for e in f.events if isinstance(e, StepFinished) and e.by_operator]
        assert len(finished) == 1 and finished[0].success


@pytest.mark.anyio
async def test_an_operator_failure_fails_the_step() -> None:
    async with fleet(probabilities={"r1": {"pick": 0.0}}, start={"r1": 1}) as f:
        goal = parse_goal(f"contain({f.kits[0]}, {f.parts[0]})", f.wm)
        async with with_operator(f, success=False):
            done = await f.executor(operator_fallback=True, max_replans=0).run_goal(goal)
        assert done.outcome == "failed"
        assert "pick on operator failed (execution): the operator could not do it: by hand" in (
            done.message
        )


@pytest.mark.anyio
async def test_fallback_for_pick_only_hands_a_failing_pick_to_the_operator() -> None:
    async with fleet(probabilities={"r1": {"pick": 0.0}}, start={"r1": 1}) as f:
        goal = parse_goal(f"contain({f.kits[0]}, {f.parts[0]})", f.wm)
        async with with_operator(f) as person:
            executor = f.executor(operator_fallback_skills=["pick"], max_replans=0)
            done = await executor.run_goal(goal)
        assert done.outcome == "succeeded", done.message
        assert len(person.seen) == 1 and not f.of(Replanning)
        ends = [e for e in f.events if isinstance(e, StepFinished)]
        assert [(e.agent, e.skill) for e in ends if e.by_operator] == [("operator", "pick")]


@pytest.mark.anyio
async def test_fallback_for_pick_only_replans_a_failing_navigate() -> None:
    """r1 cannot drive; the operator may only pick: r1's navigate is replanned, onto r2."""
    async with fleet(probabilities={"r1": {"navigate": 0.0}}) as f:
        goal = parse_goal(f.tray_goal(0), f.wm)
        async with with_operator(f) as person:
            done = await f.executor(operator_fallback_skills=["pick"]).run_goal(goal)
        assert done.outcome == "succeeded", done.message
        ends = [e for e in f.events if isinstance(e, StepFinished)]
        assert [(e.agent, e.skill) for e in ends if not e.success] == [("r1", "navigate")]
        assert not person.seen and not any(e.by_operator for e in ends)
        (replan,) = f.of(Replanning)
        assert (
            isinstance(replan, Replanning) and "navigate on r1 failed (execution)" in replan.reason
        )
        assert {e.agent for e in ends if e.success} == {"r2"}


@pytest.mark.anyio
async def test_a_call_may_ask_for_the_operator_and_a_refusal_does_not() -> None:
    async with fleet(probabilities={"r1": {"pick": 0.0}}, start={"r1": 1}) as f:
        params: dict[str, Value] = {"object": f.parts[0], "location": f.stations[0]}
        wrong: dict[str, Value] = {
            **params,
            "holder": "PartBox-2",
        }  # the gear is in PartBox-1: pre-condition
        by_hand = Call(agent="r1", skill="pick", params=params, fallback_operator=True)
        refused = Call(agent="r1", skill="pick", params=wrong, fallback_operator=True)
        async with with_operator(f) as person:
            ok = await f.executor("a").run_file(TaskFile(root=SequenceBlock(children=[by_hand])))
            no = await f.executor("b").run_file(TaskFile(root=SequenceBlock(children=[refused])))
        assert ok.outcome == "succeeded" and len(person.seen) == 1
        assert no.outcome == "failed" and "(precondition)" in no.message


SAFE_SAMPLES = [encode(ListPending()), encode(AnswerPending(id="abcd", success=True))]
REPLIES: Decoder[OperatorReply] = Decoder(OperatorReply)


@pytest.mark.anyio
async def test_hostile_operator_requests_get_a_decodable_reply() -> None:
    desk = OperatorDesk()
    service = OperatorService("operator", desk)
    bad_utf8 = SAFE_SAMPLES[1].replace(b"\xa4abcd", b"\xa4\xff\xfe\xc3\x28")
    cases = [  # payload, code, words of the message
        (b"", BAD_REQUEST, "malformed request"),
        (bad_utf8, BAD_REQUEST, "invalid UTF-8"),
        (b"\x81\xa1a" * 1000 + b"\xc0", BAD_REQUEST, "nested too deeply"),
        (b"\x91" * 1000 + b"\xc0", BAD_REQUEST, "malformed request"),
        (msgspec.msgpack.encode({"request": "Nope"}), BAD_REQUEST, "'Nope'"),
        (b"\x00" * (DEFAULT_MAX_REQUEST_BYTES + 1), TOO_LARGE, "exceeds the limit"),
        (SAFE_SAMPLES[1], "unknown_request", "no pending operator request 'abcd'"),
    ]
    for payload, code, words in cases:
        data, ok = await service.handle_bytes(payload)
        reply = check_reply(data, ok, REPLIES)
        assert isinstance(reply, ErrorReply) and reply.code == code and words in reply.message
    for payload in hostile_payloads(SAFE_SAMPLES):
        data, ok = await service.handle_bytes(payload)
        reply = check_reply(data, ok, REPLIES)
        assert not isinstance(reply, ErrorReply) or reply.code != INTERNAL, reply
    assert desk.pending() == []


@settings(max_examples=150, deadline=None, database=None)
@given(
    payload=st.one_of(
        payloads(SAFE_SAMPLES),
        st.builds(
            lambda r, i, ok: msgspec.msgpack.encode({"request": r, "id": i, "success": ok}),
            st.sampled_from(["ListPending", "AnswerPending", "Nope"]),
            st.one_of(st.text(max_size=4), st.integers(-5, 5), st.none()),
            st.one_of(st.booleans(), st.text(max_size=3), st.none()),
        ),
    )
)
def test_fuzzed_operator_requests_get_a_reply_and_answer_nothing(payload: bytes) -> None:
    desk = OperatorDesk()
    data, ok = anyio.run(OperatorService("operator", desk).handle_bytes, payload)
    reply = check_reply(data, ok, REPLIES)
    if ok:
        assert isinstance(reply, PendingReply), reply
    else:
        assert isinstance(reply, ErrorReply) and reply.code != INTERNAL, reply
    assert desk.pending() == []
