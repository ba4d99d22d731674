"""Goals checked in the physics on a split deployment: the store, a skill agent, the task agent
and the simulator's ground truth (``sim/truth``, a fast MuJoCo world of the meal scenario) are
separate services, each on its own Zenoh session behind one router on loopback; the task agent
finds the simulator over the mesh only.

- A goal that holds ends with each fact's verdict in the world model and the physics, and the
  simulated time of the check, in ``TaskFinished`` and in ``task status``.
- A world model told a story the physics does not back (a ``contain`` relation written
  directly) is contradicted: the verdict says so, and ``skimesh task submit`` (a separate
  process) prints it and exits 5.
- Without a simulator the check says it was made in the world model only.
- Hostile payloads to ``sim/truth`` get typed error replies.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import uuid
from collections.abc import AsyncIterator, Iterator
from contextlib import AsyncExitStack, asynccontextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import anyio.from_thread
import pytest
from hypothesis import HealthCheck, given, settings

from device_drivers import truth as t
from device_drivers.truth import serve_truth, truth_key
from meshlink import Mesh, MeshConfig, open_mesh
from meshlink.rpc import DEFAULT_MAX_REQUEST_BYTES, Decoder, ErrorReply, WireError, encode
from meshlink.testing import check_reply, fuzz_queryable, hostile_payloads, payloads
from mujoco_sim import SimTruth, WorldOptions, running_world
from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.runtime import parse_config
from skill_agent.server import run_agent
from task_agent import NO_SIMULATOR, TaskClient, parse_goal
from task_agent.protocol import GoalCheck, TaskFinished
from wm_store import WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.protocol import Op, SetRelation, UnsetRelation
from wm_store.server import StoreConfig, WmStore, serve_store

from .procs import ROOT

pytestmark = [pytest.mark.zenoh, pytest.mark.sim, pytest.mark.slow]

MEAL = ROOT / "configs" / "scenarios" / "meal" / "scenario.toml"
HOLDS = "doorOpen(Microwave-1) = false and contain(Worktop-1, MealBox-1)"
"""True in the scene as loaded: the microwave's door is shut (the physics can tell), the box
stands on the worktop (furniture: the physics cannot tell)."""
STORY = "contain(Tray-1, MealBox-1)"
"""What the world model is told below, and the physics does not back."""


AGENT = textwrap.dedent(
    """
    name = "r1"
    preempt_timeout = 2.0

    [robot]
    type = "MobileManipulator"
    label = "r1"

    [[devices]]
    type = "Arm"
    label = "r1-arm"

    [[devices]]
    type = "Gripper"
    label = "r1-gripper"

    [[devices]]
    type = "MobileBase"
    label = "r1-base"

    [[devices]]
    type = "Camera"
    label = "r1-camera"

    [skills]
    paths = ["skill_agent.skills:Pick", "skill_agent.skills:Place"]

    [simulation]
    enabled = true
    default = 1.0
    time_scale = 0.01
    seed = 1
    """
)
"""A robot agent with outcomes simulated: skills the planner can use (the goals already hold)."""


@asynccontextmanager
async def _background(service: Any, *args: Any) -> AsyncIterator[None]:
    async with anyio.create_task_group() as tg:
        await tg.start(partial(service, *args))
        try:
            yield
        finally:
            tg.cancel_scope.cancel()


async def _tasks(config: MeshConfig, *, task_status: Any = anyio.TASK_STATUS_IGNORED) -> None:
    from task_agent.service import serve_tasks

    async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        await serve_tasks(mesh, wm, operator=None, task_status=task_status)


async def _sim(config: MeshConfig, *, task_status: Any = anyio.TASK_STATUS_IGNORED) -> None:
    async with (
        open_mesh(config) as mesh,
        running_world(load_scenario(MEAL), WorldOptions(fast=True)) as world,
    ):
        await serve_truth(mesh, SimTruth(world), task_status=task_status)


async def _agent(config: MeshConfig, *, task_status: Any = anyio.TASK_STATUS_IGNORED) -> None:
    async with open_mesh(config) as mesh:
        config_ = parse_config(AGENT, source="test_truth_split.AGENT")
        await run_agent(mesh, config_, task_status=task_status)


@dataclass
class Site:
    portal: anyio.from_thread.BlockingPortal
    config: MeshConfig
    client: Mesh
    wm: WmClient

    async def run(self, goal: str) -> TaskFinished:
        client = TaskClient(self.client, timeout=10.0)
        task_id = f"t-{uuid.uuid4().hex[:8]}"
        async with client.watch(task_id, deadline=60.0, existing=False) as events:
            await client.submit_goal(goal, task_id=task_id)
            async for event in events:
                if isinstance(event, TaskFinished):
                    return event
        raise AssertionError("no TaskFinished")


@pytest.fixture(scope="module")
def site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    config = MeshConfig(connect=(module_router,), mesh=f"truth-{uuid.uuid4().hex[:10]}")
    data: Path = tmp_path_factory.mktemp("truth") / "wm"

    @asynccontextmanager
    async def services() -> AsyncIterator[Site]:
        store = await WmStore.open(Ontology.default(), StoreConfig(data_dir=str(data)))
        async with AsyncExitStack() as stack:
            stack.push_async_callback(store.aclose)
            client = await stack.enter_async_context(open_mesh(config))
            await stack.enter_async_context(_background(serve_store, client, store))
            wm = await stack.enter_async_context(WmClient.connect(ZenohTransport(client)))
            await wm.transact(scenario_ops(load_scenario(MEAL)))
            await stack.enter_async_context(_background(_agent, config))
            await stack.enter_async_context(_background(_sim, config))
            await stack.enter_async_context(_background(_tasks, config))
            yield Site(portal, config, client, wm)

    with (
        anyio.from_thread.start_blocking_portal(backend="asyncio") as portal,
        portal.wrap_async_context_manager(services()) as running,
    ):
        yield running


def _verdicts(check: GoalCheck | None) -> list[tuple[str, bool, bool | None]]:
    assert check is not None, "a succeeded goal carries its check"
    return [(f.fact, f.in_wm, f.physics) for f in check.facts]


def test_a_goal_that_holds_ends_with_physics_verdicts_and_the_simulated_time(site: Site) -> None:
    finished = site.portal.call(site.run, HOLDS)
    assert finished.outcome == "succeeded", finished.message
    check = finished.check
    assert _verdicts(check) == [
        ("doorOpen(Microwave-1) = false", True, True),
        ("contain(Worktop-1, MealBox-1)", True, None),  # furniture: no physics object
    ]
    assert check is not None and check.simulator and check.holds and not check.contradicted
    assert check.sim_time is not None and check.sim_time >= 0.5, "settled in simulated time"
    assert check.facts[0].detail == "door closed (0.00 rad)"
    assert check.facts[1].detail.startswith("cannot tell:")
    status = site.portal.call(TaskClient(site.client).status, finished.task_id)
    assert status.check == check, "task status shows the same verdicts"


def test_a_world_model_the_physics_contradicts_is_reported(site: Site) -> None:
    def ids() -> dict[str, str]:
        want = ("MealBox-1", "Tray-1", "Worktop-1")
        return {e.label: e.id for e in site.wm.resolve_element() if e.label in want}

    found = ids()
    box, tray, worktop = found["MealBox-1"], found["Tray-1"], found["Worktop-1"]
    ops: list[Op] = [
        UnsetRelation(subject=worktop, predicate="contain", object=box),
        SetRelation(subject=tray, predicate="contain", object=box),
    ]
    site.portal.call(site.wm.transact, ops)
    parse_goal(STORY, site.wm)  # the goal names elements the world model has
    finished = site.portal.call(site.run, STORY)
    assert finished.outcome == "succeeded", "the world model holds the goal"
    assert _verdicts(finished.check) == [("contain(Tray-1, MealBox-1)", True, False)]
    assert finished.check is not None and not finished.check.holds
    assert "MealBox-1 does not lie in Tray-1" in finished.check.facts[0].detail

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cli = [sys.executable, "-m", "skimesh", "task", "submit", "--goal", STORY]
    cli += ["--connect", site.config.connect[0], "--mesh", site.config.mesh, "--no-progress"]
    done = subprocess.run(cli, capture_output=True, text=True, timeout=90, env=env, check=False)
    assert done.returncode == 5, done.stdout + done.stderr
    assert "physics NO" in done.stdout and "at simulated time" in done.stdout, done.stdout
    assert "THE PHYSICS CONTRADICTS THE WORLD MODEL: contain(Tray-1, MealBox-1)" in done.stdout


@pytest.mark.anyio
async def test_without_a_simulator_the_goal_is_checked_in_the_world_model_only(
    router_endpoint: str, mesh_name: str
) -> None:
    from task_agent.service import mesh_verifier

    store = await WmStore.open(Ontology.default())
    async with (
        open_mesh(MeshConfig(connect=(router_endpoint,), mesh=mesh_name)) as mesh,
        _background(serve_store, mesh, store),
        WmClient.connect(ZenohTransport(mesh)) as wm,
    ):
        await wm.transact(scenario_ops(load_scenario(MEAL)))
        check = await mesh_verifier(mesh, wm, find_timeout=1.0)(parse_goal(HOLDS, wm))
    assert not check.simulator and check.sim_time is None
    assert check.note.startswith(NO_SIMULATOR)
    assert _verdicts(check) == [
        ("doorOpen(Microwave-1) = false", True, None),
        ("contain(Worktop-1, MealBox-1)", True, None),
    ]


def _refusal(requests: Decoder[Any], payload: bytes) -> str | None:
    """The code a payload that is no request must get; None for a request."""
    try:
        requests.decode(payload)
    except WireError as exc:
        return exc.code
    return None


def test_hostile_payloads_to_the_ground_truth_get_error_replies(site: Site) -> None:
    """``sim/truth`` attacked over Zenoh with the fixed hostile payloads, then a bounded
    hypothesis variant: every reply decodes as an ``ErrorReply`` or a ``TruthReply``, and a
    payload that is no request gets ``bad_request`` (``too_large`` over the limit)."""
    key = truth_key(site.client.keys)
    samples = (
        encode(t.SimClock()),
        encode(t.ObjectIn(thing="MealBox-1", holder="Tray-1")),
        encode(t.Poses(labels=["MealBox-1"])),
    )
    requests: Decoder[Any] = Decoder(
        t.TruthRequest, max_bytes=DEFAULT_MAX_REQUEST_BYTES, what="request"
    )
    replies: Decoder[Any] = Decoder(t.TruthReply, what="reply")
    for payload in hostile_payloads(samples):
        (answer,) = site.portal.call(partial(site.client.get, key, payload, timeout=10.0))
        reply = check_reply(answer.payload, answer.ok, replies)
        want = _refusal(requests, payload)
        if want is not None:
            assert isinstance(reply, ErrorReply) and reply.code == want, (payload[:40], reply)
    count = site.portal.call(fuzz_queryable, site.client, key, replies, samples)
    assert count == len(samples), "each valid request gets one answer"

    @settings(
        max_examples=60,
        deadline=None,
        suppress_health_check=list(HealthCheck),
        database=None,
        derandomize=True,
    )
    @given(payload=payloads(samples))
    def check(payload: bytes) -> None:
        (answer,) = site.portal.call(partial(site.client.get, key, payload, timeout=10.0))
        reply = check_reply(answer.payload, answer.ok, replies)
        want = _refusal(requests, payload)
        assert want is None or (isinstance(reply, ErrorReply) and reply.code == want), reply

    check()
