"""``ZenohRunner`` over real Zenoh on loopback with a scripted agent: a start whose answer is
lost (a router going away while it was on its way) is not a failure: the run is found by its
status and followed, or, when the agent never saw it, started again with the same id."""

from __future__ import annotations

import uuid

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from meshlink.rpc import ErrorReply, encode
from skill_agent.protocol import (
    AgentRequest,
    RunEvent,
    RunInfo,
    RunResult,
    RunsReply,
    RunStarted,
    RunStatus,
    StartRun,
)
from task_agent.execution import ZenohRunner
from tests.unit.skill_agent.test_client import fake_agent

pytestmark = [pytest.mark.anyio, pytest.mark.zenoh]


@pytest.fixture
def mesh_name() -> str:
    return f"ut-{uuid.uuid4().hex[:10]}"


def result_of(run_id: str) -> RunResult:
    return RunResult(run_id=run_id, agent="f", skill="s", seq=9, success=True, reason="ok")


async def test_a_start_whose_answer_is_lost_is_found_by_its_status(
    router_endpoint: str, mesh_name: str
) -> None:
    config = MeshConfig(connect=(router_endpoint,), mesh=mesh_name)
    async with open_mesh(config) as m, open_mesh(config) as agent_side:

        async def script(request: AgentRequest) -> bytes | None:
            if isinstance(request, StartRun):
                await anyio.sleep(1.0)  # the answer comes too late: lost for the runner
                return encode(RunStarted(run_id=request.run_id))
            assert isinstance(request, RunStatus)
            info = RunInfo(
                run_id=request.run_id,
                skill="s",
                state="succeeded",
                params={"x": 1},
                result=result_of(request.run_id),
            )
            return encode(RunsReply(runs=[info]))

        async with fake_agent(agent_side, "f", script) as seen:
            runner = ZenohRunner(m, start_timeout=0.3, lost_grace=5.0, alive=lambda _a: True)
            started: list[RunStarted] = []
            events: list[RunEvent] = []
            request = StartRun(skill="s", run_id="run-1")
            with anyio.fail_after(5):
                result = await runner.run(
                    "f", request, on_started=started.append, on_event=events.append
                )
        assert result == result_of("run-1")
        assert [s.run_id for s in started] == ["run-1"] and started[0].params == {"x": 1}
        kinds = [type(r).__name__ for r in seen]
        assert kinds[0] == "StartRun" and kinds.count("StartRun") == 1 and "RunStatus" in kinds


async def test_a_start_the_agent_never_saw_is_sent_again(
    router_endpoint: str, mesh_name: str
) -> None:
    config = MeshConfig(connect=(router_endpoint,), mesh=mesh_name)
    async with open_mesh(config) as m, open_mesh(config) as agent_side:
        starts = 0

        async def script(request: AgentRequest) -> bytes | None:
            nonlocal starts
            if isinstance(request, StartRun):
                starts += 1
                if starts == 1:
                    await anyio.sleep(1.0)  # "lost": the runner gave up on it
                    return encode(ErrorReply(code="internal", message="too late"))
                key = agent_side.keys.run_progress("f", request.run_id)
                agent_side.put(key, encode(result_of(request.run_id)))  # may precede the answer
                return encode(RunStarted(run_id=request.run_id))
            return encode(ErrorReply(code="unknown_run", message="no such run"))

        async with fake_agent(agent_side, "f", script) as seen:
            runner = ZenohRunner(m, start_timeout=0.3, lost_grace=5.0, alive=lambda _a: True)
            runner_request = StartRun(skill="s", run_id="run-2")
            with anyio.fail_after(10):
                result = await runner.run(
                    "f", runner_request, on_started=lambda _s: None, on_event=lambda _e: None
                )
        assert result.run_id == "run-2" and result.success
        assert [r.run_id for r in seen if isinstance(r, StartRun)] == ["run-2", "run-2"]
