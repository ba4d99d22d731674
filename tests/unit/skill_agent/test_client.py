"""AgentClient over real Zenoh on loopback (an in-process router): against a real agent
(AgentCore + serve_agent, in-memory world model) and against scripted fake agents for the
failure paths: a missed result publication, an agent that disappears, a deadline, garbage."""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager

import anyio
import anyio.lowlevel
import pytest

from meshlink import Answer, IncomingQuery, KeySpace, Mesh, MeshConfig, open_mesh
from meshlink.rpc import encode
from skill_agent import (
    AgentTransportError,
    BadRequestError,
    ParameterTypeError,
    RunStateError,
    Skill,
    SkillContext,
    UnknownRunError,
    UnknownSkillError,
    UnspecifiedParameterError,
)
from skill_agent.client import AgentClient, find_skills, list_agents
from skill_agent.protocol import (
    AgentRequest,
    ErrorReply,
    ListSkills,
    OkReply,
    ParamSpec,
    Progress,
    RunEvent,
    RunInfo,
    RunResult,
    RunsReply,
    RunStarted,
    RunStatus,
    SkillDescription,
    SkillsReply,
    StartRun,
    StopRun,
    decode_event,
    decode_reply,
    decode_request,
)
from skill_agent.runtime import AgentConfig, AgentCore, SkillEntry
from skill_agent.server import RunEventPublisher, serve_agent
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.server import WmService, WmStore

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]


class Echo(Skill):
    description = SkillDescription(
        name="echo", parameters=[ParamSpec(name="n", type="int", kind="offline", default=2)]
    )

    async def execute(self, ctx: SkillContext) -> None:
        n = ctx.params["n"]
        assert isinstance(n, int)
        for i in range(n):
            await ctx.progress(f"echo {i}", fraction=i / n)


class Slow(Skill):
    description = SkillDescription(name="slow")

    async def execute(self, ctx: SkillContext) -> None:
        for _ in range(1000):
            await ctx.checkpoint()
            await anyio.sleep(0.01)


class Needy(Skill):
    description = SkillDescription(
        name="needy",
        parameters=[
            ParamSpec(name="speed", type="float"),
            ParamSpec(name="note", type="str", optional=True),
            ParamSpec(name="n", type="int", default=1),
        ],
    )


SKILLS = {c.description.name: SkillEntry(c.description, c, "test") for c in (Echo, Slow, Needy)}


@pytest.fixture
def mesh_name() -> str:
    return f"client-{uuid.uuid4().hex[:10]}"


@asynccontextmanager
async def session(endpoint: str, mesh: str) -> AsyncIterator[Mesh]:
    async with open_mesh(MeshConfig(connect=(endpoint,), mesh=mesh)) as m:
        yield m


@asynccontextmanager
async def real_agent(endpoint: str, mesh: str, name: str = "a1") -> AsyncIterator[AgentCore]:
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with (
            WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm,
            session(endpoint, mesh) as agent_mesh,
        ):
            core = AgentCore(name=name, wm=wm, skills=SKILLS)
            await tg.start(
                lambda task_status: serve_agent(
                    agent_mesh, core, config=AgentConfig(name=name), wm=wm, task_status=task_status
                )
            )
            yield core
            tg.cancel_scope.cancel()


Script = Callable[[AgentRequest], Awaitable[bytes | None]]


@asynccontextmanager
async def fake_agent(mesh: Mesh, name: str, script: Script) -> AsyncIterator[list[AgentRequest]]:
    """Serves ``agents/<name>/rpc`` with ``script`` (None -> an OkReply) and holds the token."""
    seen: list[AgentRequest] = []

    async def rpc(query: IncomingQuery) -> list[Answer]:
        request = decode_request(query.payload or b"")
        seen.append(request)
        payload = await script(request)
        return [Answer(mesh.keys.agent_rpc(name), payload or encode(OkReply()))]

    async with anyio.create_task_group() as tg:
        await tg.start(mesh.serve, mesh.keys.agent_rpc(name), rpc)
        with mesh.declare_token(mesh.keys.agent(name)):
            yield seen
        tg.cancel_scope.cancel()


def result_of(run_id: str) -> RunResult:
    return RunResult(run_id=run_id, agent="f", skill="s", seq=9, success=True, reason="ok")


# --------------------------------------------------------------------------- real agent


@pytest.mark.parametrize("shared", [False, True], ids=["per-run", "shared-feed"])
async def test_run_streams_progress_then_the_result(
    router_endpoint: str, mesh_name: str, shared: bool
) -> None:
    async with real_agent(router_endpoint, mesh_name), session(router_endpoint, mesh_name) as m:
        client = AgentClient(m, "a1")
        events: list[RunEvent] = []
        with anyio.fail_after(10):
            if shared:
                async with client:
                    results = [
                        await client.run("echo", {"n": 3}, on_event=events.append) for _ in range(2)
                    ]
                result = results[-1]
            else:
                result = await client.run("echo", {"n": 3}, on_event=events.append)
        assert result.success and result.reason == "ok" and result.params == {"n": 3}
        mine = [e for e in events if e.run_id == result.run_id]
        assert mine[-1] == result
        assert [e.seq for e in mine] == sorted({e.seq for e in mine}), "in order, no duplicates"
        assert [
            e.message for e in mine if isinstance(e, Progress) and e.step == "execute" and e.message
        ] == [
            "echo 0",
            "echo 1",
            "echo 2",
        ]


async def test_refusals_are_rebuilt_as_their_classes(router_endpoint: str, mesh_name: str) -> None:
    async with real_agent(router_endpoint, mesh_name), session(router_endpoint, mesh_name) as m:
        client = AgentClient(m, "a1")
        with pytest.raises(UnknownSkillError, match="did you mean 'echo'"):
            await client.start("ecko")
        with pytest.raises(ParameterTypeError):
            await client.start("echo", {"n": "three"})
        with pytest.raises(UnknownRunError):
            await client.status("no-such-run")
        with pytest.raises(BadRequestError, match="contains '/'"):
            await client.start("echo", run_id="a/b")
        with pytest.raises(RunStateError, match="no plug-in registry"):
            await client.reload()
        with pytest.raises(UnspecifiedParameterError) as unspecified:
            await client.start("needy")
        assert unspecified.value.param_states == {
            "speed": "initialized",
            "note": "initialized",
            "n": "specified",
        }
        assert "(still initialized: speed, note (optional); specified: n)" in str(unspecified.value)
        started = await client.start("needy", {"speed": 0.5})
        states = (await client.status(started.run_id)).param_states
        assert states == {"speed": "specified", "note": "initialized", "n": "specified"}


async def test_watch_stop_pause_resume_status(router_endpoint: str, mesh_name: str) -> None:
    async with real_agent(router_endpoint, mesh_name), session(router_endpoint, mesh_name) as m:
        client = AgentClient(m, "a1")
        with anyio.fail_after(10):
            async with client.watch("run-1") as events:
                started = await client.start("slow", run_id="run-1")
                assert started.run_id == "run-1"
                await client.pause("run-1")
                assert (await client.status("run-1")).state in {"executing", "paused"}
                await client.resume("run-1")
                assert [r.run_id for r in await client.runs()] == ["run-1"]
                result = await client.stop("run-1")
                assert result.reason == "preempted" and not result.success
                seen = [e async for e in events]
            assert seen[-1] == result
            assert await client.runs() == []
            assert [r.run_id for r in await client.runs(active_only=False)] == ["run-1"]


async def test_list_agents_and_find_skills(router_endpoint: str, mesh_name: str) -> None:
    async with (
        real_agent(router_endpoint, mesh_name, "a1"),
        real_agent(router_endpoint, mesh_name, "a2"),
        session(router_endpoint, mesh_name) as m,
    ):
        assert await list_agents(m) == ["a1", "a2"]
        found = await find_skills(m)
        assert sorted(found) == ["a1", "a2"]
        assert sorted(d.name for d in found["a1"].skills) == ["echo", "needy", "slow"]
        assert [d.name for d in await AgentClient(m, "a2").skills()] == ["echo", "slow", "needy"]


async def test_the_skills_queryable_answers_list_skills_and_refuses_other_payloads(
    router_endpoint: str, mesh_name: str
) -> None:
    async with real_agent(router_endpoint, mesh_name), session(router_endpoint, mesh_name) as m:
        key = m.keys.agent_skills("a1")
        for payload in (None, b"", encode(ListSkills())):
            (listing,) = await m.get(key, payload)
            reply = decode_reply(listing.payload)
            assert listing.ok and isinstance(reply, SkillsReply) and reply.agent == "a1"
        for payload, why in (
            (b"\xc1 not msgpack", "malformed request"),
            (encode(StartRun(skill="echo")), "answers ListSkills, not StartRun"),
        ):
            (refused,) = await m.get(key, payload)
            error = decode_reply(refused.payload)
            assert not refused.ok and isinstance(error, ErrorReply), error
            assert error.code == "bad_request" and why in error.message
        assert [r.run_id for r in await AgentClient(m, "a1").runs(active_only=False)] == []


async def test_cancelling_run_stops_it_on_the_agent(router_endpoint: str, mesh_name: str) -> None:
    async with (
        real_agent(router_endpoint, mesh_name) as core,
        session(router_endpoint, mesh_name) as m,
    ):
        client = AgentClient(m, "a1")
        with anyio.move_on_after(0.5):
            await client.run("slow")
        runs = core.runs(active_only=False)
        assert len(runs) == 1 and runs[0].result is not None
        assert runs[0].result.reason == "preempted"


# --------------------------------------------------------------------------- scripted agents


async def test_missed_result_is_found_by_a_status_query(
    router_endpoint: str, mesh_name: str
) -> None:
    async def script(request: AgentRequest) -> bytes | None:
        if isinstance(request, StartRun):
            return encode(RunStarted(run_id=request.run_id))
        if isinstance(request, RunStatus):
            info = RunInfo(
                run_id=request.run_id,
                skill="s",
                state="succeeded",
                result=result_of(request.run_id),
            )
            return encode(RunsReply(runs=[info]))
        return None

    async with session(router_endpoint, mesh_name) as m, fake_agent(m, "f", script) as seen:
        client = AgentClient(m, "f", status_every=0.2)
        with anyio.fail_after(5):
            result = await client.run("s")  # the agent never publishes anything
        assert result.success
        assert any(isinstance(r, RunStatus) for r in seen)


async def test_agent_disappearing_raises_transport_error(
    router_endpoint: str, mesh_name: str
) -> None:
    async with (
        session(router_endpoint, mesh_name) as m,
        session(router_endpoint, mesh_name) as agent_side,
    ):

        async def script(request: AgentRequest) -> bytes | None:
            if isinstance(request, StartRun):
                step = Progress(
                    run_id=request.run_id, agent="f", skill="s", seq=1, state="executing"
                )
                agent_side.put(agent_side.keys.run_progress("f", request.run_id), encode(step))
                return encode(RunStarted(run_id=request.run_id))
            return encode(ErrorReply(code="unknown_run", message="gone"))

        client = AgentClient(m, "f", lost_grace=0.2)
        running = anyio.Event()
        async with anyio.create_task_group() as tg, fake_agent(agent_side, "f", script):

            async def go() -> None:
                with (
                    anyio.fail_after(5),
                    pytest.raises(AgentTransportError, match="disappeared"),
                ):
                    await client.run("s", on_event=lambda _: running.set())

            tg.start_soon(go)
            await running.wait()  # the client follows the run's progress
            # the token goes now (the fake agent leaves)


async def test_deadline_gives_up_and_stops_the_run(router_endpoint: str, mesh_name: str) -> None:
    async def script(request: AgentRequest) -> bytes | None:
        if isinstance(request, StartRun):
            return encode(RunStarted(run_id=request.run_id))
        if isinstance(request, RunStatus):
            return encode(
                RunsReply(runs=[RunInfo(run_id=request.run_id, skill="s", state="executing")])
            )
        if isinstance(request, StopRun):
            return encode(
                RunsReply(
                    runs=[
                        RunInfo(
                            run_id=request.run_id,
                            skill="s",
                            state="preempted",
                            result=result_of(request.run_id),
                        )
                    ]
                )
            )
        return None

    async with session(router_endpoint, mesh_name) as m, fake_agent(m, "f", script) as seen:
        client = AgentClient(m, "f", status_every=0.1)
        with anyio.fail_after(5), pytest.raises(TimeoutError):
            await client.run("s", deadline=0.5)
        assert isinstance(seen[-1], StopRun), "the run is stopped when the caller gives up"


async def test_garbage_and_silence(router_endpoint: str, mesh_name: str) -> None:
    async def script(request: AgentRequest) -> bytes | None:
        return b"\xc1 not msgpack"

    async with session(router_endpoint, mesh_name) as m, fake_agent(m, "f", script):
        with pytest.raises(AgentTransportError, match="undecodable reply"):
            await AgentClient(m, "f").runs()
        with pytest.raises(AgentTransportError, match="skimesh agents"):
            await AgentClient(m, "nobody", timeout=0.3).runs()


# --------------------------------------------------------------------------- publisher


class RecordingMesh:
    """The two things RunEventPublisher uses of a Mesh."""

    def __init__(self) -> None:
        self.keys = KeySpace("m")
        self.puts: list[tuple[str, RunEvent]] = []
        self.first = anyio.Event()

    def put(self, key: str, payload: bytes) -> None:
        self.puts.append((key, decode_event(payload)))
        self.first.set()


async def test_publisher_bursts_progress_and_never_delays_a_result() -> None:
    mesh = RecordingMesh()
    publisher = RunEventPublisher(mesh, "a1", max_delay=0.05)  # type: ignore[arg-type]
    progress = [
        Progress(run_id="r1", agent="a1", skill="s", seq=i, state="executing") for i in (1, 2)
    ]
    async with anyio.create_task_group() as tg:
        tg.start_soon(publisher.run)
        for p in progress:
            publisher.publish(p)
        assert mesh.puts == [], "progress waits for company"
        with anyio.fail_after(2):
            await mesh.first.wait()
        assert [e for _, e in mesh.puts] == progress, "flushed together, in order"
        publisher.publish(progress[0])
        result = RunResult(run_id="r1", agent="a1", skill="s", seq=3, success=True, reason="ok")
        publisher.publish(result)
        with anyio.fail_after(2):
            while len(mesh.puts) < 4:  # the next loop turns, not max_delay
                await anyio.lowlevel.checkpoint()
        assert [e for _, e in mesh.puts[2:]] == [progress[0], result], "a result flushes at once"
        assert {k for k, _ in mesh.puts} == {"skimesh/m/agents/a1/runs/r1/progress"}
        tg.cancel_scope.cancel()


async def test_call_answers_with_the_result_in_one_round_trip(
    router_endpoint: str, mesh_name: str
) -> None:
    async with real_agent(router_endpoint, mesh_name), session(router_endpoint, mesh_name) as m:
        client = AgentClient(m, "a1")
        result = await client.call("echo", {"n": 3})
        assert result.success
        assert result.reason == "ok"
        assert result.skill == "echo"
        with pytest.raises(UnknownSkillError):
            await client.call("ecko")
        late = await client.call("slow", timeout=0.3)
        assert (late.success, late.reason) == (False, "timeout"), "the agent enforces the limit"
        assert not await client.runs(), "nothing is left running"
