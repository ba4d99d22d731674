"""The task layer over real Zenoh on loopback, every component in its own process: a world-model
store, two kitting robots' agents (``skimesh agent --agent-config ... --simulate``: the standard
navigate / pick / place / serve skills with simulated outcomes), the task agent (``skimesh
task-agent``, with the operator agent) and clients (a TaskClient in the test, ``skimesh task``
and ``skimesh operator`` in subprocesses).

Covers: a kitting goal for two robots planned and run with steps overlapping in time; a step
that fails (its part was moved after planning) replanned from the world model to success; an
abort that preempts every run; the operator fallback answered from the command line; ``skimesh
task submit`` (exit 0 with its progress, exit 2 with the reason for an unsolvable goal) and
``skimesh task verify``; an agent killed with SIGKILL mid-task, after which the other robot
finishes the task.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import uuid
from collections import Counter
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import anyio
import pytest

from meshlink import Mesh, MeshConfig, open_mesh
from meshlink.rpc import Decoder, encode
from meshlink.testing import fuzz_queryable, hostile_payloads
from skill_agent.client import AgentClient
from task_agent import TaskClient, new_task_id
from task_agent.protocol import (
    ListPending,
    ListTasks,
    OperatorReply,
    Planned,
    Replanning,
    StepFinished,
    StepStarted,
    TaskEvent,
    TaskFinished,
    TaskOptions,
    TaskReply,
    TaskStatus,
)
from wm_store import WmClient, ZenohTransport
from wm_store.protocol import (
    AddElement,
    Op,
    Pose,
    Position,
    Relation,
    SetRelation,
    UnsetRelation,
    Value,
)

from .procs import ROOT, Child, start_store

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.anyio]

SKILLS = ["Navigate", "Pick", "Place", "Serve"]
DEVICES = (("Arm", "arm"), ("Gripper", "gripper"), ("MobileBase", "base"), ("Camera", "camera"))
TIME_SCALE = 0.05
"""A simulated run lasts ``duration * TIME_SCALE``: navigate 0.25 s, pick / place 0.2 s."""


def agent_config(name: str, pick: float, time_scale: float = TIME_SCALE) -> str:
    devices = "".join(
        f'\n[[devices]]\ntype = "{t}"\nlabel = "{name}-{label}"\n' for t, label in DEVICES
    )
    paths = ", ".join(f'"skill_agent.skills:{s}"' for s in SKILLS)
    return textwrap.dedent(
        f"""
        name = "{name}"
        preempt_timeout = 2.0

        [robot]
        type = "MobileManipulator"
        label = "{name}"
        {devices}
        [skills]
        paths = [{paths}]

        [simulation]
        probabilities = {{ navigate = 1.0, pick = {pick}, place = 1.0, serve = 1.0 }}
        time_scale = {time_scale}
        seed = 1
        """
    )


@dataclass
class Site:
    endpoint: str
    mesh: str
    folder: Path
    agents: dict[str, Child] = field(default_factory=dict)

    def flags(self) -> list[str]:
        return ["--connect", self.endpoint, "--mesh", self.mesh]

    def spawn_agent(self, name: str, pick: float = 1.0, time_scale: float = TIME_SCALE) -> Child:
        path = self.folder / f"{name}.toml"
        path.write_text(agent_config(name, pick, time_scale))
        args = ["-m", "skimesh", "agent", "--agent-config", str(path), "--simulate", *self.flags()]
        self.agents[name] = Child(args, name=f"agent {name}")
        return self.agents[name]

    def skimesh(self, *args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "skimesh", *args, *self.flags()],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
        )

    @asynccontextmanager
    async def connected(self) -> AsyncIterator[tuple[Mesh, WmClient, TaskClient]]:
        config = MeshConfig(connect=(self.endpoint,), mesh=self.mesh)
        async with (
            open_mesh(config) as mesh,
            WmClient.connect(ZenohTransport(mesh), author="test") as wm,
        ):
            yield mesh, wm, TaskClient(mesh, timeout=10.0)


def pose(x: float, y: float) -> dict[str, Value]:
    return {"pose": Pose(Position(x, y, 0.0))}


async def add_scene(wm: WmClient, robots: list[str]) -> None:
    """depot; station-1/2, each with box-i (gears) and tray-i; kit-<robot> on each robot."""
    ops: list[Op] = [AddElement(type="Location", label="depot", properties=pose(0, 0), ref="$d")]
    for s in (1, 2):
        ops.append(
            AddElement(
                type="Station",
                label=f"station-{s}",
                ref=f"$s{s}",
                properties={**pose(2, 2 * s), "robotCapacity": 4},  # no geometry: room for all
            )
        )
        for kind, label in (("PartBox", f"box-{s}"), ("Tray", f"tray-{s}")):
            where = [Relation(f"$s{s}", "contain", "$"), Relation("$", "at", f"$s{s}")]
            ops.append(
                AddElement(type=kind, label=label, properties={"capacity": 50}, relations=where)
            )
    await wm.transact(ops)
    box_ids = {b: wm.resolve_element(type="PartBox", label=b)[0].id for b in ("box-1", "box-2")}
    await wm.transact(
        [
            AddElement(type="Gear", label=f"gear-{g}", properties={"mass": 0.1},
                       relations=[Relation(box_ids[f"box-{2 - g % 2}"], "contain", "$")])
            for g in range(1, 17)
        ]
    )  # fmt: skip
    await add_robots(wm, robots)


async def add_robots(wm: WmClient, robots: list[str]) -> None:
    depot = wm.resolve_element(type="Location", label="depot")[0].id
    for name in robots:
        robot = wm.resolve_element(type="Robot", label=name)[0].id
        await wm.transact(
            [
                AddElement(type="KitBox", label=f"kit-{name}", properties={"capacity": 50},
                           relations=[Relation(robot, "contain", "$")]),
                SetRelation(subject=robot, predicate="at", object=depot),
            ]
        )  # fmt: skip


async def place_robot(wm: WmClient, name: str, where: str) -> None:
    """Move robot ``name`` to the location labelled ``where`` (in the world model)."""
    robot = wm.resolve_element(type="Robot", label=name)[0].id
    target = wm.resolve_element(type="Location", label=where)[0].id
    ops: list[Op] = [UnsetRelation(subject=robot, predicate="at", object=r.object)
                     for r in wm.query_relation(robot, "at")]  # fmt: skip
    await wm.transact([*ops, SetRelation(subject=robot, predicate="at", object=target)])


@pytest.fixture(scope="module")
def site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    with running_site(module_router, tmp_path_factory.mktemp("tasks")) as s:
        yield s


@contextmanager
def running_site(endpoint: str, folder: Path, time_scale: float = TIME_SCALE) -> Iterator[Site]:
    """A fresh mesh on ``endpoint``: the store, agents r1 and r2 (simulated runs last
    ``duration * time_scale``), the scene, the task agent."""
    s = Site(endpoint, f"it-{uuid.uuid4().hex[:10]}", folder)
    store = start_store(s.endpoint, s.mesh, folder / "wm")
    task_agent: Child | None = None
    try:
        for name in ("r1", "r2"):
            s.spawn_agent(name, time_scale=time_scale)
        for name in ("r1", "r2"):
            s.agents[name].wait_stderr(f"agent {name} ready")

        async def scene() -> None:
            async with s.connected() as (_, wm, _client):
                await add_scene(wm, ["r1", "r2"])

        anyio.run(scene)
        task_agent = Child(["-m", "skimesh", "task-agent", *s.flags()], name="task agent")
        task_agent.wait_stderr("task agent ready")
        yield s
    finally:
        if task_agent is not None:
            assert task_agent.stop() == 0, f"task agent did not stop cleanly:\n{task_agent.log()}"
        for child in s.agents.values():
            child.stop()
        store.stop()


def steps(events: list[TaskEvent]) -> dict[int, tuple[StepStarted, StepFinished]]:
    begun = {e.step: e for e in events if isinstance(e, StepStarted)}
    return {
        e.step: (begun[e.step], e)
        for e in events
        if isinstance(e, StepFinished) and e.step in begun
    }


async def test_two_robots_kit_in_parallel(site: Site) -> None:
    async with site.connected() as (_, _wm, client):
        events: list[TaskEvent] = []
        done = await client.run_goal(
            "contain(kit-r1, gear-1) and contain(kit-r2, gear-2)",
            on_event=events.append,
            deadline=60,
        )
        assert done.outcome == "succeeded", done.message
        assert [e.seq for e in events] == list(range(1, len(events) + 1))
        runs = steps(events)
        assert {s.agent for s, _ in runs.values()} == {"r1", "r2"}
        r1 = [(s.stamp, f.stamp) for s, f in runs.values() if s.agent == "r1"]
        r2 = [(s.stamp, f.stamp) for s, f in runs.values() if s.agent == "r2"]
        overlap = max(min(a1, b1) - max(a0, b0) for a0, a1 in r1 for b0, b1 in r2)
        assert overlap > 0.1, f"the robots' steps did not overlap: {r1} {r2}"


async def test_a_failed_step_is_replanned_from_the_world_model(site: Site) -> None:
    async with site.connected() as (_, wm, client):
        await place_robot(wm, "r1", "depot")  # it drives first: the part moves meanwhile
        task_id, events = new_task_id(), []
        gear = wm.resolve_element(type="Gear", label="gear-3")[0].id
        box1, box2 = (wm.resolve_element(type="PartBox", label=b)[0].id for b in ("box-1", "box-2"))
        async with client.watch(task_id, existing=False, deadline=60) as stream:
            await client.submit_goal("contain(kit-r1, gear-3)", task_id=task_id)
            async for event in stream:
                events.append(event)
                if isinstance(event, Planned) and event.attempt == 0:  # someone moves the part
                    await wm.transact(
                        [
                            UnsetRelation(subject=box1, predicate="contain", object=gear),
                            SetRelation(subject=box2, predicate="contain", object=gear),
                        ]
                    )
        done = events[-1]
        assert isinstance(done, TaskFinished) and done.outcome == "succeeded", done
        failed = [e for e in events if isinstance(e, StepFinished) and not e.success]
        assert [(e.skill, e.reason) for e in failed] == [("pick", "precondition")]
        replan = [e for e in events if isinstance(e, Replanning)]
        assert len(replan) == 1 and "pick on r1 failed (precondition)" in replan[0].reason
        assert done.replans == 1 and "1 replan" in done.message
        kit = wm.resolve_element(type="KitBox", label="kit-r1")[0].id
        assert wm.query_relation(kit, "contain", gear)


async def test_abort_preempts_every_run(site: Site) -> None:
    async with site.connected() as (mesh, _wm, client):
        task_id, events = new_task_id(), []
        goal = "contain(kit-r1, gear-5) and contain(kit-r2, gear-6)"
        async with client.watch(task_id, existing=False, deadline=60) as stream:
            await client.submit_goal(goal, task_id=task_id)
            async for event in stream:
                events.append(event)
                running = {e.agent for e in events if isinstance(e, StepStarted)}
                if isinstance(event, StepStarted) and running == {"r1", "r2"}:
                    assert "aborted" in await client.abort(task_id, "test abort")
        done = events[-1]
        assert isinstance(done, TaskFinished) and done.outcome == "aborted", done
        begun = [e for e in events if isinstance(e, StepStarted)]
        ended = {e.step: e for e in events if isinstance(e, StepFinished)}
        assert len(begun) == 2 and all(ended[e.step].reason == "preempted" for e in begun)
        for e in begun:  # and the agents agree
            info = await AgentClient(mesh, e.agent).status(e.run_id)
            assert info.result is not None and info.result.reason == "preempted", info


async def test_operator_answers_a_failed_step_from_the_command_line(site: Site) -> None:
    r3 = site.spawn_agent("r3", pick=0.0)  # r3 cannot pick
    r3.wait_stderr("agent r3 ready")
    try:
        async with site.connected() as (_, wm, client):
            await add_robots(wm, ["r3"])
            options = TaskOptions(operator_fallback=True, max_replans=0)
            async with anyio.create_task_group() as tg:
                outcome: list[TaskFinished] = []
                events: list[TaskEvent] = []

                async def run() -> None:
                    goal = "contain(kit-r3, gear-7)"
                    done = await client.run_goal(
                        goal, options=options, on_event=events.append, deadline=60
                    )
                    outcome.append(done)

                tg.start_soon(run)
                listed = await anyio.to_thread.run_sync(
                    site.skimesh, "operator", "--wait", "30", "--json"
                )
                assert listed.returncode == 0, listed.stderr
                (request,) = json.loads(listed.stdout)
                assert request["skill"] == "pick" and "failed (execution)" in request["note"]
                answered = await anyio.to_thread.run_sync(
                    site.skimesh,
                    "operator",
                    "--answer",
                    request["id"],
                    "success",
                    "--message",
                    "by hand",
                )
                assert answered.returncode == 0 and "answered: done" in answered.stdout, (
                    answered.stderr
                )
            (done,) = outcome
            assert done.outcome == "succeeded", done.message
            by_hand = [e for e in events if isinstance(e, StepFinished) and e.by_operator]
            assert [(e.agent, e.skill, e.success) for e in by_hand] == [("operator", "pick", True)]
    finally:
        assert r3.stop() == 0


def test_cli_submit_verify_and_an_unsolvable_goal(site: Site) -> None:
    ok = site.skimesh(
        "task", "submit", "--goal", "contain(kit-r1, gear-9) and contain(kit-r2, gear-10)"
    )
    assert ok.returncode == 0, ok.stdout + ok.stderr
    lines = ok.stdout.splitlines()
    assert lines[0].startswith("task t-") and lines[1].startswith("plan 0 (kairos")
    assert any(" r1 " in line and "started" in line for line in lines)
    assert any(" r2 " in line and "succeeded" in line for line in lines)
    summary = next(
        i for i, line in enumerate(lines) if " succeeded in " in line and line.startswith("task")
    )
    # one line per robot, its step count being the steps it was seen to finish above
    done = Counter(line.split()[1] for line in lines[:summary] if line.endswith(" succeeded"))
    robot_line = re.compile(r"  (r\d): (\d+) steps, \d+\.\d\d s busy")
    per_robot = [robot_line.fullmatch(line) for line in lines[summary + 1 : summary + 3]]
    counts = {m[1]: int(m[2]) for m in per_robot if m}
    assert counts == dict(done) and set(counts) == {"r1", "r2"}, lines[summary:]
    assert f": {sum(counts.values())} steps run, 0 replans" in lines[summary]
    no = site.skimesh("task", "submit", "--goal", "not contain(station-1, box-1)", "--json")
    assert no.returncode == 2, no.stdout + no.stderr
    last = json.loads(no.stdout.splitlines()[-1])
    assert last["event"] == "TaskFinished" and last["outcome"] == "unsolvable"
    assert "no skill's post-condition undoes it" in last["message"]
    bad = site.folder / "bad.toml"
    bad.write_text('name = "x"\n[root]\nblock = "call"\nagent = "r9"\nskill = "pick"\n')
    verified = site.skimesh("task", "verify", str(bad))
    assert verified.returncode == 1 and "no agent 'r9'" in verified.stderr, verified.stderr


def test_cli_plan_dry_run_and_emit_pddl(site: Site) -> None:
    out = site.folder / "pddl"
    planned = site.skimesh(
        "task", "plan", "--goal", "contain(kit-r1, gear-13)", "--emit-pddl", str(out)
    )
    assert planned.returncode == 0, planned.stdout + planned.stderr
    assert "pick" in planned.stdout and "place" in planned.stdout, planned.stdout
    domain = (out / "domain.pddl").read_text()
    problem = (out / "problem.pddl").read_text()
    assert "(:action pick__r1" in domain.lower()
    assert "(:goal" in problem.lower()
    no = site.skimesh("task", "plan", "--goal", "not contain(station-1, box-1)")
    assert no.returncode == 2, no.stdout + no.stderr
    assert "unsolvable" in no.stderr


async def test_hostile_payloads_get_typed_replies_over_zenoh(site: Site) -> None:
    """Every reply of tasks/rpc and operator/rpc to malformed, hostile or oversized requests
    is an ErrorReply (or a valid reply), and no task appears."""
    async with site.connected() as (mesh, _, client):
        queryables: list[tuple[str, Decoder[Any], list[bytes]]] = [
            (
                mesh.keys.tasks_rpc(),
                Decoder(TaskReply),
                [encode(ListTasks()), encode(TaskStatus(task_id="abcd"))],
            ),
            (mesh.keys.operator_rpc(), Decoder(OperatorReply), [encode(ListPending())]),
        ]
        before = await client.list()
        for key, replies, samples in queryables:
            count = await fuzz_queryable(mesh, key, replies, hostile_payloads(samples))
            assert count >= len(hostile_payloads(samples, huge=0))
        assert await client.list() == before


async def test_killing_an_agent_mid_task_lets_the_other_robot_finish(site: Site) -> None:
    async with site.connected() as (_, wm, client):
        await place_robot(wm, "r1", "station-1")
        await place_robot(wm, "r2", "station-2")
        task_id, events = new_task_id(), []
        async with client.watch(task_id, existing=False, deadline=60) as stream:
            await client.submit_goal(
                "contain(tray-1, gear-11) and contain(tray-2, gear-12)", task_id=task_id
            )
            async for event in stream:
                events.append(event)
                if isinstance(event, StepStarted) and event.agent == "r2":
                    os.kill(site.agents["r2"].pid, signal.SIGKILL)
        site.agents["r2"].kill()
        done = events[-1]
        assert isinstance(done, TaskFinished) and done.outcome == "succeeded", done
        lost = [e for e in events if isinstance(e, StepFinished) and e.agent == "r2"]
        assert len(lost) == 1 and lost[0].reason == "agent_lost", lost
        replan = next(e for e in events if isinstance(e, Replanning))
        later = [e for e in events if isinstance(e, StepStarted) and e.seq > replan.seq]
        assert later and all(e.agent == "r1" for e in later)


async def test_two_users_submitting_at_once_never_command_one_robot_from_two_tasks(
    site: Site,
) -> None:
    """Two users, each on a session of their own, submit a goal for r1's kit at the same time:
    the task that claims r1 first runs; the other waits for it (``task list`` says for what)
    and then runs, so r1's steps of the two tasks never overlap, and both succeed."""
    config = MeshConfig(connect=(site.endpoint,), mesh=site.mesh)
    events: dict[str, list[TaskEvent]] = {"a": [], "b": []}
    waiting_seen: list[str] = []

    async def user(name: str, goal: str) -> TaskFinished:
        async with open_mesh(config) as mesh:
            client = TaskClient(mesh, timeout=10.0)
            return await client.run_goal(goal, on_event=events[name].append, deadline=90)

    async def watch_list() -> None:
        async with open_mesh(config) as mesh:
            client = TaskClient(mesh, timeout=10.0)
            while True:
                waiting_seen.extend(i.waiting for i in await client.list() if i.waiting)
                await anyio.sleep(0.05)

    results: dict[str, TaskFinished] = {}
    async with anyio.create_task_group() as tg:
        tg.start_soon(watch_list)

        async def run(name: str, goal: str) -> None:
            results[name] = await user(name, goal)

        async with anyio.create_task_group() as users:
            users.start_soon(run, "a", "contain(kit-r1, gear-14)")
            users.start_soon(run, "b", "contain(kit-r1, gear-16)")
        tg.cancel_scope.cancel()
    assert results["a"].outcome == results["b"].outcome == "succeeded", results
    spans = {
        name: [(s.stamp, f.stamp) for s, f in steps(evs).values() if s.agent == "r1"]
        for name, evs in events.items()
    }
    assert spans["a"] and spans["b"]
    first, second = sorted(spans.values(), key=lambda sp: min(s for s, _ in sp))
    assert max(f for _, f in first) <= min(s for s, _ in second), f"interleaved on r1: {spans}"
    assert any("r1" in w for w in waiting_seen), "the second task said what it waited for"
