"""One robot run by two agents (a component split) over real Zenoh on loopback, each component
in its own process: a world-model store, the example agents of
``configs/agents/kitting/split/`` (``r1-base``: navigate and the mobile base; ``r1-arm``:
locate, pick, place with the arm, the gripper and the cameras) in simulated-outcome mode
(``skimesh agent --agent-config ... --simulate``), and the task agent.

Covers: both agents register for the same robot (one Robot element, each agent ``controls``
it, the devices of both are its parts) and discovery sees that robot with the union of their
skills; each agent runs its own skills, and runs on the two overlap in time; the task agent
plans a goal across the split (navigate on the base agent, then pick and place on the arm
agent) and runs it; stopping one agent unregisters it and leaves the other registered and
working (a goal that needs only its skills still succeeds); started again, it registers again.
The agents start one after the other: two agents registering a robot that is not in the world
model yet at the same instant each add one (see tests/unit/task_agent/test_split_robot.py).
The same registrations and plans without Zenoh: tests/unit/task_agent/test_split_robot.py.
"""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path

import anyio
import pytest

from meshlink import Mesh, MeshConfig, open_mesh
from skill_agent.client import AgentClient, find_skills, list_agents
from skill_agent.protocol import RunResult
from skill_agent.runtime import load_config
from task_agent import TaskClient
from task_agent.discovery import AgentInfo, Discovery
from task_agent.protocol import StepStarted, TaskEvent
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

SPLIT = ROOT / "configs" / "agents" / "kitting" / "split"
AGENTS = ("r1-base", "r1-arm")
TIME_SCALE = 0.2
"""A simulated run lasts ``duration * TIME_SCALE``: navigate 1 s, pick / place 0.8 s, locate
0.1 s."""


def split_config(name: str) -> str:
    """The example config of agent ``name``, its simulated outcomes made certain and slower."""
    path = SPLIT / f"{name}.toml"
    text = path.read_text(encoding="utf-8")
    skills = load_config(path).simulation.probabilities
    sure = ", ".join(f"{skill} = 1.0" for skill in skills)
    simulation = f"[simulation]\nprobabilities = {{ {sure} }}\ntime_scale = {TIME_SCALE}\n"
    return text[: text.index("[simulation]")] + simulation


@dataclass
class Site:
    endpoint: str
    mesh: str
    folder: Path
    agents: dict[str, Child] = field(default_factory=dict)

    def flags(self) -> list[str]:
        return ["--connect", self.endpoint, "--mesh", self.mesh]

    def spawn_agent(self, name: str) -> Child:
        path = self.folder / f"{name}.toml"
        path.write_text(split_config(name), encoding="utf-8")
        args = ["-m", "skimesh", "agent", "--agent-config", str(path), "--simulate", *self.flags()]
        self.agents[name] = Child(args, name=f"agent {name}")
        return self.agents[name]

    @asynccontextmanager
    async def connected(self) -> AsyncIterator[tuple[Mesh, WmClient]]:
        config = MeshConfig(connect=(self.endpoint,), mesh=self.mesh)
        async with (
            open_mesh(config) as mesh,
            WmClient.connect(ZenohTransport(mesh), author="test") as wm,
        ):
            yield mesh, wm


def pose(x: float, y: float) -> dict[str, Value]:
    return {"pose": Pose(Position(x, y, 0.0))}


async def add_scene(wm: WmClient) -> None:
    """depot; station-1 with box-1 (gears), station-2; the overhead Camera-1 (r1-arm binds it
    to ``sensor``, so it must exist before that agent starts)."""
    ops: list[Op] = [
        AddElement(type="Location", label="depot", properties=pose(0, 0)),
        AddElement(type="Station", label="station-1", ref="$s1", properties=pose(2, 2)),
        AddElement(type="Station", label="station-2", properties=pose(2, 4)),
        AddElement(
            type="PartBox",
            label="box-1",
            ref="$box",
            properties={"capacity": 50},
            relations=[Relation("$s1", "contain", "$"), Relation("$", "at", "$s1")],
        ),
        AddElement(type="Camera", label="Camera-1"),
    ]
    ops += [
        AddElement(type="Gear", label=f"gear-{g}", properties={"mass": 0.1},
                   relations=[Relation("$box", "contain", "$")])
        for g in range(1, 5)
    ]  # fmt: skip
    await wm.transact(ops)


async def add_kit(wm: WmClient) -> None:
    """kit-r1 on the robot the agents registered."""
    robot = wm.resolve_element(type="Robot", label="r1")[0].id
    await wm.transact(
        [
            AddElement(type="KitBox", label="kit-r1", properties={"capacity": 50},
                       relations=[Relation(robot, "contain", "$")]),
        ]
    )  # fmt: skip


async def place_robot(wm: WmClient, where: str) -> None:
    """Put robot r1 at the location labelled ``where`` (in the world model)."""
    robot = wm.resolve_element(type="Robot", label="r1")[0].id
    target = wm.resolve_element(type="Location", label=where)[0].id
    ops: list[Op] = [UnsetRelation(subject=robot, predicate="at", object=r.object)
                     for r in wm.query_relation(robot, "at")]  # fmt: skip
    await wm.transact([*ops, SetRelation(subject=robot, predicate="at", object=target)])


@pytest.fixture(scope="module")
def site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    folder = tmp_path_factory.mktemp("split")
    s = Site(module_router, f"it-{uuid.uuid4().hex[:10]}", folder)
    store = start_store(s.endpoint, s.mesh, folder / "wm")
    task_agent: Child | None = None
    try:

        async def scene() -> None:
            async with s.connected() as (_, wm):
                await add_scene(wm)

        anyio.run(scene)
        for name in AGENTS:  # one after the other: the first adds robot r1, the second joins
            s.spawn_agent(name).wait_stderr(f"agent {name} ready")

        async def kit() -> None:
            async with s.connected() as (_, wm):
                await add_kit(wm)

        anyio.run(kit)
        task_agent = Child(["-m", "skimesh", "task-agent", *s.flags()], name="task agent")
        task_agent.wait_stderr("task agent ready")
        yield s
    finally:
        codes = {}
        if task_agent is not None:
            codes[task_agent.name] = (task_agent.stop(), task_agent.log())
        for child in s.agents.values():
            codes[child.name] = (child.stop(), child.log())
        store.stop()
        unclean = {name: log for name, (code, log) in codes.items() if code != 0}
        assert not unclean, f"did not stop cleanly: {unclean}"


@asynccontextmanager
async def discovery(mesh: Mesh, wm: WmClient) -> AsyncIterator[Discovery]:
    """The task agent's discovery (world-model registrations + liveliness) in the test."""
    found = Discovery(wm)
    async with anyio.create_task_group() as tg:
        await tg.start(found.watch, mesh)
        yield found
        tg.cancel_scope.cancel()


def of_robot(agents: list[AgentInfo], robot: str) -> dict[str, AgentInfo]:
    return {a.name: a for a in agents if a.robot == robot}


# --------------------------------------------------------------------------- registration


async def test_both_agents_register_for_one_robot(site: Site) -> None:
    async with site.connected() as (mesh, wm), discovery(mesh, wm) as found:
        robots = wm.resolve_element(type="Robot", label="r1")
        assert len(robots) == 1, f"one robot, not one per agent: {robots}"
        robot = robots[0].id
        parts = sorted(wm.get_element(r.object).label for r in wm.query_relation(robot, "hasA"))
        assert parts == ["r1-arm", "r1-base", "r1-camera", "r1-gripper"]
        for name in AGENTS:
            agent = wm.resolve_element(type="Agent", label=name)[0]
            assert [r.object for r in wm.query_relation(agent.id, "controls")] == [robot]
            assert agent.properties["available"] is True

        listed = await find_skills(mesh)
        assert [d.name for d in listed["r1-base"].skills] == ["navigate"]
        assert sorted(d.name for d in listed["r1-arm"].skills) == [
            "locate",
            "pick",
            "place",
            "place_on",
        ]

        agents = of_robot(found.agents(), robot)
        assert sorted(agents) == ["r1-arm", "r1-base"]
        assert not any(a.problems for a in agents.values())
        skills = {s.name for a in agents.values() for s in a.skills}
        assert skills == {"locate", "navigate", "pick", "place", "place_on"}, (
            "the union of their skills"
        )


# --------------------------------------------------------------------------- runs


async def test_each_agent_runs_its_skills_and_runs_overlap(site: Site) -> None:
    async with site.connected() as (mesh, wm):
        await place_robot(wm, "depot")
        gear = wm.resolve_element(type="Gear", label="gear-4")[0].id
        station = wm.resolve_element(type="Station", label="station-2")[0].id
        results: dict[str, RunResult] = {}

        async def run(agent: str, skill: str, params: dict[str, str]) -> None:
            results[agent] = await AgentClient(mesh, agent).run(skill, params)

        with anyio.fail_after(20):
            async with anyio.create_task_group() as tg:
                tg.start_soon(run, "r1-base", "navigate", {"goal": station})
                tg.start_soon(run, "r1-arm", "locate", {"object": gear})
        assert all(r.success for r in results.values()), [r.message for r in results.values()]
        assert max(r.started_at for r in results.values()) < min(
            r.finished_at for r in results.values()
        ), "the base drove while the arm's agent located the part"
        await wm.wait_for_revision(max(r.effects_revision for r in results.values()))
        robot = wm.resolve_element(type="Robot", label="r1")[0].id
        assert [r.object for r in wm.query_relation(robot, "at")] == [station]


# --------------------------------------------------------------------------- planning


async def test_a_goal_is_planned_and_run_across_the_split(site: Site) -> None:
    async with site.connected() as (mesh, wm):
        await place_robot(wm, "depot")  # the part is at station-1: drive, then pick
        events: list[TaskEvent] = []
        done = await TaskClient(mesh, timeout=10.0).run_goal(
            "contain(kit-r1, gear-1)", on_event=events.append, deadline=60
        )
        assert done.outcome == "succeeded", done.message
        ran = [(e.agent, e.skill) for e in events if isinstance(e, StepStarted)]
        assert ran == [("r1-base", "navigate"), ("r1-arm", "pick"), ("r1-arm", "place")]
        await wm.wait_for_revision((await wm.info()).revision)
        kit = wm.resolve_element(type="KitBox", label="kit-r1")[0].id
        gear = wm.resolve_element(type="Gear", label="gear-1")[0].id
        assert wm.query_relation(kit, "contain", gear)


# --------------------------------------------------------------------------- one agent leaves


async def test_stopping_one_agent_leaves_the_other_working(site: Site) -> None:
    async with site.connected() as (mesh, wm), discovery(mesh, wm) as found:
        await place_robot(wm, "station-1")  # a goal the arm's agent reaches alone
        base = site.agents["r1-base"]
        assert await anyio.to_thread.run_sync(base.stop) == 0, base.log()  # SIGTERM
        await wm.wait_for_revision((await wm.info()).revision)
        assert not wm.resolve_element(type="Agent", label="r1-base"), "unregistered"
        robot = wm.resolve_element(type="Robot", label="r1")[0].id
        arm = wm.resolve_element(type="Agent", label="r1-arm")[0]
        assert [r.object for r in wm.query_relation(arm.id, "controls")] == [robot]
        assert arm.properties["available"] is True
        assert wm.resolve_element(type="MobileBase", label="r1-base"), "the robot keeps its base"
        assert "r1-base" not in await list_agents(mesh)
        with anyio.fail_after(10):
            while "r1-base" in (found.alive or ()):
                await found.wait_changed()
        assert sorted(of_robot(found.agents(), robot)) == ["r1-arm"]

        gear = wm.resolve_element(type="Gear", label="gear-3")[0].id
        located = await AgentClient(mesh, "r1-arm").run("locate", {"object": gear})
        assert located.success, located.message
        events: list[TaskEvent] = []
        done = await TaskClient(mesh, timeout=10.0).run_goal(
            "contain(kit-r1, gear-2)", on_event=events.append, deadline=60
        )
        assert done.outcome == "succeeded", done.message
        assert {e.agent for e in events if isinstance(e, StepStarted)} == {"r1-arm"}

        back = site.spawn_agent("r1-base")  # and it comes back
        await anyio.to_thread.run_sync(back.wait_stderr, "agent r1-base ready")
        with anyio.fail_after(10):
            while "r1-base" not in (found.alive or ()):
                await found.wait_changed()
        await wm.wait_for_revision((await wm.info()).revision)
        assert sorted(of_robot(found.agents(), robot)) == ["r1-arm", "r1-base"]
        assert len(wm.resolve_element(type="Robot", label="r1")) == 1
