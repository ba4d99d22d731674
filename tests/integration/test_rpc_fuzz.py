"""Every RPC queryable of the mesh, attacked with raw Zenoh: the store (``wm/rpc``,
``wm/query``, and the storage-style ``wm/elements/<id>``), a skill agent and the operator agent
(``agents/<a>/rpc``, ``agents/<a>/skills``), the operator's ``operator/rpc``, the task service
(``tasks/rpc``) and a device server (``devices/r1/gripper/cmd``), all served in this process
(:mod:`tests.integration.services`) behind one router on loopback.

Each queryable gets the fixed hostile payloads of :func:`meshlink.testing.hostile_payloads`
(empty, undecodable bytes, invalid UTF-8 strings, maps and arrays nested 1,000 deep, unknown
tags, truncated MessagePack, wrong types, the mutations of valid requests, and payloads one
byte over the default size limit), then a hypothesis variant (:func:`meshlink.testing.payloads`,
a bounded number of examples per queryable). Every reply must decode as an
:class:`meshlink.rpc.ErrorReply` (error replies) or as a reply of the service's own union (ok
replies); a request that does not decode to the service's request schema gets ``bad_request``,
one over the limit ``too_large``; and nothing changes: same store revision, no run started, no
task created, no operator request opened, no device command executed.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import anyio.from_thread
import msgspec
import pytest
from hypothesis import HealthCheck, given, settings

from device_drivers import protocol as dev
from meshlink import KeySpace, Mesh, MeshConfig, Reply, open_mesh
from meshlink.rpc import (
    BAD_REQUEST,
    DEFAULT_MAX_REQUEST_BYTES,
    TOO_LARGE,
    Decoder,
    ErrorReply,
    WireError,
    encode,
)
from meshlink.testing import check_reply, hostile_payloads, payloads
from skill_agent import protocol as agent
from task_agent import protocol as task
from wm_store import protocol as wm

from .services import AGENT, DEVICE, OPERATOR, Services, running_services

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]

EXAMPLES = 100
"""Hypothesis examples per queryable (derandomized: the same ones on every run)."""
TIMEOUT = 10.0
"""Seconds a query may take (a huge payload crosses the router twice)."""


@dataclass(frozen=True)
class Queryable:
    """One RPC queryable: its key, the request schema it accepts, the decoder of its ok
    replies, valid requests that change nothing (for the mutations), and whether an empty
    payload is a valid request there."""

    key: str
    requests: Any
    replies: Decoder[Any]
    samples: tuple[bytes, ...]
    empty_ok: bool = False
    max_bytes: int = DEFAULT_MAX_REQUEST_BYTES

    def expected(self, payload: bytes) -> str | None:
        """The code ``payload`` must get (``"ok"``: a valid reply), or None if it decodes to
        a request, whose answer is the service's business."""
        if len(payload) > self.max_bytes:
            return TOO_LARGE
        if not payload and self.empty_ok:
            return "ok"
        try:
            Decoder[Any](self.requests).decode(payload)
        except WireError:
            return BAD_REQUEST
        return None


def queryables(keys: KeySpace) -> dict[str, Queryable]:
    wm_replies = Decoder[Any](wm.Reply, what="reply")
    agent_replies = Decoder[Any](agent.AgentReply, what="reply")
    wm_samples = (encode(wm.Info()), encode(wm.GetElements(ids=["no-such-element"])))
    agent_samples = (
        encode(agent.ListSkills()),
        encode(agent.ListRuns(active_only=False)),
        encode(agent.RunStatus(run_id="no-such-run")),
    )
    listing = (encode(agent.ListSkills()),)
    return {
        "wm/rpc": Queryable(keys.wm_rpc(), wm.Request, wm_replies, wm_samples),
        "wm/query": Queryable(keys.wm_query(), wm.Request, wm_replies, wm_samples),
        "agent/rpc": Queryable(
            keys.agent_rpc(AGENT), agent.AgentRequest, agent_replies, agent_samples
        ),
        "agent/skills": Queryable(
            keys.agent_skills(AGENT), agent.AgentRequest, agent_replies, listing, empty_ok=True
        ),
        "operator-agent/rpc": Queryable(
            keys.agent_rpc(OPERATOR), agent.AgentRequest, agent_replies, agent_samples
        ),
        "operator-agent/skills": Queryable(
            keys.agent_skills(OPERATOR), agent.AgentRequest, agent_replies, listing, empty_ok=True
        ),
        "operator/rpc": Queryable(
            keys.operator_rpc(),
            task.OperatorRequest,
            Decoder[Any](task.OperatorReply, what="reply"),
            (
                encode(task.ListPending()),
                encode(task.AnswerPending(id="no-such-request", success=False)),
            ),
        ),
        "tasks/rpc": Queryable(
            keys.tasks_rpc(),
            task.TaskRequest,
            Decoder[Any](task.TaskReply, what="reply"),
            (encode(task.ListTasks()), encode(task.TaskStatus(task_id="no-such-task"))),
        ),
        "device/cmd": Queryable(
            keys.device_cmd(*DEVICE),
            dev.Request,
            Decoder[Any](dev.Reply, what="reply"),
            (
                encode(dev.Request(command=dev.GetState())),
                encode(dev.Request(command=dev.Describe())),
            ),
        ),
    }


NAMES = list(queryables(KeySpace("names")))


@dataclass(frozen=True)
class State:
    """What a request could change: the store's revision, the runs of both agents, the tasks,
    the operator's pending requests and what the gripper was asked to do."""

    revision: int
    runs: tuple[str, ...]
    operator_runs: tuple[str, ...]
    tasks: tuple[str, ...]
    pending: tuple[str, ...]
    device_calls: tuple[str, ...]


@dataclass
class Site:
    portal: anyio.from_thread.BlockingPortal
    services: Services
    client: Mesh
    """The attacker's own session."""

    def queryable(self, name: str) -> Queryable:
        return queryables(self.client.keys)[name]

    def get(self, key: str, payload: bytes) -> list[Reply]:
        return self.portal.call(partial(self.client.get, key, payload, timeout=TIMEOUT))

    def call(self, key: str, request: object, replies: Any) -> Any:
        payload = self.portal.call(partial(self.client.request, key, encode(request)))
        return Decoder[Any](replies).decode(payload)

    def state(self) -> State:
        keys = self.client.keys
        listing = agent.ListRuns(active_only=False)
        runs = self.call(keys.agent_rpc(AGENT), listing, agent.AgentReply)
        operator_runs = self.call(keys.agent_rpc(OPERATOR), listing, agent.AgentReply)
        tasks = self.call(keys.tasks_rpc(), task.ListTasks(), task.TaskReply)
        pending = self.call(keys.operator_rpc(), task.ListPending(), task.OperatorReply)
        return State(
            revision=self.services.store.revision,
            runs=tuple(r.run_id for r in runs.runs),
            operator_runs=tuple(r.run_id for r in operator_runs.runs),
            tasks=tuple(t.task_id for t in tasks.tasks),
            pending=tuple(p.id for p in pending.pending),
            device_calls=tuple(self.services.gripper.calls),
        )


@pytest.fixture(scope="module")
def site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    config = MeshConfig(connect=(module_router,), mesh=f"fuzz-{uuid.uuid4().hex[:10]}")
    data: Path = tmp_path_factory.mktemp("fuzz") / "wm"
    with (
        anyio.from_thread.start_blocking_portal(backend="asyncio") as portal,
        portal.wrap_async_context_manager(running_services(config, data)) as services,
        portal.wrap_async_context_manager(open_mesh(config)) as client,
    ):
        yield Site(portal, services, client)


def check_answer(q: Queryable, payload: bytes, answers: list[Reply]) -> None:
    """One answer, an ErrorReply or a valid reply, with the code ``payload`` calls for."""
    assert len(answers) == 1, f"{len(answers)} answers"
    (answer,) = answers
    reply = check_reply(answer.payload, answer.ok, q.replies)
    want = q.expected(payload)
    if want == "ok":
        assert answer.ok, f"a valid request answered {reply!r}"
    elif want is not None:
        assert isinstance(reply, ErrorReply), f"accepted: {reply!r}"
        assert reply.code == want, f"code {reply.code!r}, not {want!r}: {reply.message[:120]}"


def describe(payload: bytes) -> str:
    return f"{len(payload)} bytes {payload[:32]!r}"


@pytest.mark.parametrize("name", NAMES)
def test_hostile_payloads_get_error_replies_and_change_nothing(site: Site, name: str) -> None:
    q = site.queryable(name)
    before = site.state()
    failures: list[str] = []
    sent = hostile_payloads(q.samples, huge=q.max_bytes + 1)
    for payload in sent:
        try:
            check_answer(q, payload, site.get(q.key, payload))
        except AssertionError as e:
            failures.append(f"{describe(payload)}: {str(e).splitlines()[0][:300]}")
    assert site.state() == before
    assert not failures, f"{len(failures)} of {len(sent)} payloads:\n" + "\n".join(failures)


@pytest.mark.parametrize("name", NAMES)
def test_fuzzed_payloads_get_error_or_valid_replies_and_change_nothing(
    site: Site, name: str
) -> None:
    q = site.queryable(name)
    before = site.state()

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        suppress_health_check=list(HealthCheck),
        database=None,
        derandomize=True,  # the same examples on every run: a failure is reproducible
    )
    @given(payload=payloads(q.samples))
    def check(payload: bytes) -> None:
        check_answer(q, payload, site.get(q.key, payload))

    check()
    assert site.state() == before


def test_hostile_payloads_to_an_element_key_get_the_element_or_an_error(site: Site) -> None:
    """``wm/elements/<id>`` is storage-style: it answers with the element as JSON whatever
    the payload, or (a size limit) with an ErrorReply."""
    store = site.services.store
    robot = next(e.id for e in store.state.elements.values() if e.label == AGENT)
    key = site.client.keys.wm_element(robot)
    revision = store.revision
    for payload in hostile_payloads(huge=DEFAULT_MAX_REQUEST_BYTES + 1):
        (answer,) = site.get(key, payload)
        if answer.ok:
            assert msgspec.json.decode(answer.payload)["id"] == robot
        else:
            error = check_reply(answer.payload, answer.ok, Decoder[Any](ErrorReply))
            assert isinstance(error, ErrorReply)
            assert error.code in (TOO_LARGE, BAD_REQUEST), error
    assert store.revision == revision
