"""The task service without Zenoh (in-process agents): submit, status, list, abort, task files
verified before they run, refusals with codes, and hostile or fuzzed input that always gets a
decodable reply and never crashes the service or creates a task."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager

import anyio
import anyio.from_thread
import msgspec
import pytest
from hypothesis import HealthCheck, given, settings
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
from task_agent.protocol import (
    AbortTask,
    ListTasks,
    OkReply,
    StepStarted,
    SubmitFile,
    SubmitGoal,
    TaskAccepted,
    TaskFinished,
    TaskOptions,
    TaskReply,
    TaskRequest,
    TasksReply,
    TaskStatus,
    VerifyFile,
    VerifyReply,
    decode_reply,
)
from task_agent.service import TaskService
from tests.assets.task_fleet import Fleet, fleet

FILE = """
name = "kit one gear"
[root]
block = "sequence"
[[root.children]]
block = "call"
agent = "r1"
skill = "pick"
id = "pick1"
params = {{ object = "{part}", holder = "PartBox-1", location = "{station}" }}
[[root.children]]
block = "call"
agent = "r1"
skill = "place"
params = {{ object = "@pick1.object", container = "{kit}" }}
"""


@asynccontextmanager
async def service(**kwargs: object) -> AsyncIterator[tuple[Fleet, TaskService]]:
    async with fleet(start={"r1": 1}, **kwargs) as f:  # type: ignore[arg-type]
        tasks = f.service()
        async with anyio.create_task_group() as tg:
            await tg.start(tasks.run)
            yield f, tasks
            tg.cancel_scope.cancel()


async def call(tasks: TaskService, request: TaskRequest | bytes) -> tuple[TaskReply, bool]:
    data, ok = await tasks.handle_bytes(request if isinstance(request, bytes) else encode(request))
    return decode_reply(data), ok


async def refused(tasks: TaskService, request: TaskRequest | bytes, code: str, words: str) -> None:
    reply, ok = await call(tasks, request)
    assert not ok and isinstance(reply, ErrorReply), reply
    assert reply.code == code and words in reply.message, reply


@pytest.mark.anyio
async def test_submit_runs_the_task_and_the_registry_follows() -> None:
    async with service() as (f, tasks):
        goal = f"contain({f.kits[0]}, {f.parts[0]}) and contain({f.kits[1]}, {f.parts[1]})"
        reply, ok = await call(tasks, SubmitGoal(goal=goal, task_id="kit-1"))
        assert ok and reply == TaskAccepted(task_id="kit-1")
        await f.wait_for(TaskFinished)
        reply, _ = await call(tasks, TaskStatus(task_id="kit-1"))
        assert isinstance(reply, TasksReply)
        (info,) = reply.tasks
        assert info.outcome == "succeeded" and info.steps_run == 5 and info.goal == goal
        assert info.finished_at >= info.started_at > 0
        listed, _ = await call(tasks, ListTasks())
        assert isinstance(listed, TasksReply) and [t.task_id for t in listed.tasks] == ["kit-1"]
        active, _ = await call(tasks, ListTasks(active_only=True))
        assert active == TasksReply(tasks=[])
        await refused(tasks, SubmitGoal(goal=goal, task_id="kit-1"), "task_exists", "kit-1")
        done, _ = await call(tasks, AbortTask(task_id="kit-1"))
        assert isinstance(done, OkReply) and "already ended: succeeded" in done.message


@pytest.mark.anyio
async def test_refusals_carry_codes() -> None:
    async with service() as (_, tasks):
        await refused(tasks, SubmitGoal(goal="contain(KitBox-1, Gear-77)"), "goal_parse", "Gear-7")
        await refused(tasks, SubmitGoal(goal="contain(KitBox-1 Gear-1)"), "goal_parse", "column")
        await refused(tasks, SubmitGoal(goal="contain(KitBox-1, Gear-1)", task_id="a/b"),
                      "bad_request", "'/'")  # fmt: skip
        await refused(tasks, TaskStatus(task_id="nope"), "unknown_task", "no task 'nope'")
        await refused(tasks, AbortTask(task_id="nope"), "unknown_task", "no task 'nope'")
        await refused(tasks, b"\xc1", "bad_request", "malformed request")
        await refused(tasks, SubmitFile(text="[root"), "verification", "invalid TOML")
        typo = TaskOptions(operator_fallback_skills=frozenset({"pick", "pik"}))
        why = "operator fallback: no registered agent offers pik (skills: navigate, pick,"
        await refused(tasks, SubmitGoal(goal="contain(KitBox-1, Gear-1)", options=typo),
                      "bad_request", why)  # fmt: skip
        assert tasks.tasks() == []


class OldTaskOptions(msgspec.Struct, frozen=True, kw_only=True):
    """``TaskOptions`` before ``operator_fallback_skills``."""

    operator_fallback: bool = False


def test_operator_fallback_skills_keep_the_wire_compatible() -> None:
    new = TaskOptions(operator_fallback_skills=frozenset({"pick"}))
    assert msgspec.msgpack.decode(encode(new), type=OldTaskOptions) == OldTaskOptions()
    old = msgspec.msgpack.decode(encode(OldTaskOptions(operator_fallback=True)), type=TaskOptions)
    assert old == TaskOptions(operator_fallback=True)
    assert msgspec.json.decode(b'{"operator_fallback_skills": ["pick"]}', type=TaskOptions) == new


@pytest.mark.anyio
async def test_abort_answers_once_every_run_is_stopped() -> None:
    async with service(time_scale=0.2) as (f, tasks):
        goal = f"contain({f.kits[0]}, {f.parts[0]})"
        await call(tasks, SubmitGoal(goal=goal, task_id="slow"))
        await f.wait_for(StepStarted)
        reply, ok = await call(tasks, AbortTask(task_id="slow", reason="stop!"))
        assert ok and reply == OkReply(message="task slow: aborted")
        finished = f.of(TaskFinished)
        assert len(finished) == 1 and isinstance(finished[0], TaskFinished)
        assert finished[0].outcome == "aborted" and finished[0].message == "stop!"
        runs = f.cores["r1"].runs(active_only=False)
        assert runs and all(r.result is not None and r.result.reason == "preempted" for r in runs)


@pytest.mark.anyio
async def test_task_files_are_verified_before_they_run() -> None:
    async with service() as (f, tasks):
        good = FILE.format(part=f.parts[0], station=f.stations[0], kit=f.kits[0])
        reply, _ = await call(tasks, VerifyFile(text=good))
        assert reply == VerifyReply(ok=True)
        bad = good.replace('"PartBox-1"', '"PartBox-2"').replace('"r1"', '"r9"', 1)
        reply, ok = await call(tasks, SubmitFile(text=bad))
        assert ok and isinstance(reply, VerifyReply) and not reply.ok
        assert {p.kind for p in reply.problems} == {"unknown"} and "r9" in reply.problems[0].message
        assert tasks.tasks() == []
        broken, _ = await call(tasks, VerifyFile(text="root = 3"))
        assert isinstance(broken, VerifyReply) and broken.problems[0].kind == "structure"
        accepted, _ = await call(tasks, SubmitFile(text=good, task_id="file"))
        assert accepted == TaskAccepted(task_id="file")
        await f.wait_for(TaskFinished)
        assert tasks.tasks()[0].outcome == "succeeded", tasks.tasks()[0].message
        assert tasks.tasks()[0].name == "kit one gear"


SAFE_SAMPLES = [  # valid requests that start nothing
    encode(ListTasks()),
    encode(TaskStatus(task_id="abcd")),
    encode(AbortTask(task_id="abcd")),
    encode(VerifyFile(text="root = 3")),
]
REPLIES: Decoder[TaskReply] = Decoder(TaskReply)


@pytest.mark.anyio
async def test_hostile_payloads_get_a_decodable_reply() -> None:
    bad_utf8 = encode(TaskStatus(task_id="abcd")).replace(b"\xa4abcd", b"\xa4\xff\xfe\xc3\x28")
    cases = [  # payload, code, words of the message
        (b"", BAD_REQUEST, "malformed request"),
        (bad_utf8, BAD_REQUEST, "invalid UTF-8"),
        (b"\x81\xa1a" * 1000 + b"\xc0", BAD_REQUEST, "nested too deeply"),
        (b"\x91" * 1000 + b"\xc0", BAD_REQUEST, "malformed request"),
        (msgspec.msgpack.encode({"request": "Nope"}), BAD_REQUEST, "'Nope'"),
        (b"\x00" * (DEFAULT_MAX_REQUEST_BYTES + 1), TOO_LARGE, "exceeds the limit"),
    ]
    async with service() as (_, tasks):
        for payload, code, words in cases:
            await refused(tasks, payload, code, words)
        for payload in hostile_payloads(SAFE_SAMPLES):
            data, ok = await tasks.handle_bytes(payload)
            reply = check_reply(data, ok, REPLIES)
            assert not isinstance(reply, ErrorReply) or reply.code != INTERNAL, reply
        assert tasks.tasks() == []


@pytest.fixture(scope="module")
def fuzz_target() -> Iterator[tuple[anyio.from_thread.BlockingPortal, TaskService]]:
    with (
        anyio.from_thread.start_blocking_portal() as portal,
        portal.wrap_async_context_manager(service()) as (_, tasks),
    ):
        yield portal, tasks


_requests = st.sampled_from(
    ["SubmitGoal", "SubmitFile", "VerifyFile", "TaskStatus", "ListTasks", "AbortTask", "Nope"]
)
_ints = st.integers(min_value=-(2**63), max_value=2**63 - 1)
_values = st.one_of(
    st.none(),
    st.booleans(),
    _ints,
    st.text(max_size=12),
    st.lists(_ints, max_size=3),
    st.dictionaries(st.text(max_size=4), _ints, max_size=2),
)
FUZZ = st.one_of(
    payloads(SAFE_SAMPLES),
    st.builds(lambda r, v: msgspec.msgpack.encode({"request": r, "x": v}), _requests, _values),
    st.builds(
        lambda r, k, v: msgspec.msgpack.encode({"request": r, k: v}),
        _requests,
        st.sampled_from(["goal", "text", "task_id", "options", "active_only", "reason"]),
        _values,
    ),
    st.builds(
        lambda goal, tid: encode(SubmitGoal(goal=goal, task_id=tid)),
        st.text(max_size=30),
        st.text(max_size=8),
    ),
    st.builds(lambda text: encode(SubmitFile(text=text)), st.text(max_size=40)),
)


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck), database=None)
@given(payload=FUZZ)
def test_fuzzed_requests_never_crash_or_start_a_task(
    fuzz_target: tuple[anyio.from_thread.BlockingPortal, TaskService], payload: bytes
) -> None:
    portal, tasks = fuzz_target
    before = len(tasks.tasks())
    data, ok = portal.call(tasks.handle_bytes, payload)
    reply = check_reply(data, ok, REPLIES)
    if not ok:
        assert isinstance(reply, ErrorReply) and reply.code and reply.message
        assert reply.code != INTERNAL, reply
    if not isinstance(reply, TaskAccepted):
        assert len(tasks.tasks()) == before
