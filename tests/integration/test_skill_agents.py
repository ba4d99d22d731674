"""Skill agents over real Zenoh on loopback: a world-model store and two agents, each in its own
process (``python -m skimesh agent --agent-config ...``), driven by an AgentClient in the test.

Covers: skills listed and registered in the world model; parallel runs on disjoint devices
overlap in time; a start on a busy device is refused with ResourceBusyError across the wire
(or queued); a stop mid-run reaches the safe state; a hold-condition violation aborts the run;
a reload under load (runs in flight finish with their code, later runs use the new code); an
agent killed with SIGKILL is seen gone by a liveliness watcher, by a waiting client and by the
world model's ``available`` flag; fuzzed bad input on every queryable gets error replies and
leaves the agent healthy; ``skimesh run`` / ``skills`` / ``agents`` from the command line.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap
import uuid
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path

import anyio
import anyio.from_thread
import msgspec
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from meshlink import Mesh, MeshConfig, open_mesh
from meshlink.rpc import WireError, encode
from skill_agent import AgentTransportError, ResourceBusyError
from skill_agent.client import AgentClient, find_skills, list_agents
from skill_agent.protocol import (
    ErrorReply,
    ListSkills,
    Progress,
    RunEvent,
    RunInfo,
    RunResult,
    SkillDescription,
    SkillsReply,
    decode_reply,
    decode_request,
)
from wm_store import WmClient, ZenohTransport
from wm_store.protocol import Value

from .procs import ROOT, Child, start_store

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]

EXAMPLES = ROOT / "docs" / "examples"

PROBE = """
import anyio
from skill_agent.protocol import ParamSpec, SkillDescription
from skill_agent import Skill


class Probe(Skill):
    tag = "{tag}"
    description = SkillDescription(
        name="probe",
        doc="probe {tag}",
        parameters=[ParamSpec(name="seconds", type="float", kind="offline", default=0.0)],
    )

    async def execute(self, ctx):
        await ctx.progress("start " + self.tag)
        await anyio.sleep(ctx.params["seconds"])
        await ctx.progress("end " + self.tag)
"""


def agent_config(name: str, grippers: list[str], skills: list[str]) -> str:
    devices = "".join(f'\n[[devices]]\ntype = "Gripper"\nlabel = "{g}"\n' for g in grippers)
    paths = ", ".join(json.dumps(s) for s in skills)
    return textwrap.dedent(
        f"""
        name = "{name}"
        preempt_timeout = 2.0

        [robot]
        type = "Robot"
        label = "{name}-robot"
        {devices}
        [skills]
        paths = [{paths}]
        """
    )


@dataclass
class Site:
    endpoint: str
    mesh: str
    folder: Path

    def mesh_flags(self) -> list[str]:
        return ["--connect", self.endpoint, "--mesh", self.mesh]

    def start_agent(self, name: str, grippers: list[str]) -> Child:
        path = self.folder / f"{name}.toml"
        skills = [f"{EXAMPLES}/pick_part.py", f"{EXAMPLES}/noop.py", str(self.folder / "probe.py")]
        path.write_text(agent_config(name, grippers, skills))
        child = Child(
            ["-m", "skimesh", "agent", "--agent-config", str(path), *self.mesh_flags()],
            name=f"agent {name}",
        )
        child.wait_stderr(f"agent {name} ready")
        return child


@pytest.fixture(scope="module")
def site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    """A store and two agents (``picker``: two grippers, ``mover``: one), each a process."""
    folder = tmp_path_factory.mktemp("agents")
    (folder / "probe.py").write_text(PROBE.format(tag="v1"))
    s = Site(module_router, f"it-{uuid.uuid4().hex[:10]}", folder)
    store = start_store(s.endpoint, s.mesh, folder / "wm")
    agents: list[Child] = []
    try:
        agents.append(s.start_agent("picker", ["picker-left", "picker-right"]))
        agents.append(s.start_agent("mover", ["mover-gripper"]))
        yield s
    finally:
        for child in agents:
            assert child.stop() == 0, f"{child.name} did not stop cleanly:\n{child.log()}"
        store.stop()


@asynccontextmanager
async def connected(site: Site) -> AsyncIterator[tuple[Mesh, WmClient]]:
    config = MeshConfig(connect=(site.endpoint,), mesh=site.mesh)
    async with (
        open_mesh(config) as mesh,
        WmClient.connect(ZenohTransport(mesh), author="test") as wm,
    ):
        yield mesh, wm


async def part_in_box(wm: WmClient) -> tuple[str, str]:
    """A fresh PartBox holding a fresh Gear (labels are unique); returns (part, box)."""
    tag = uuid.uuid4().hex[:6]
    box = await wm.add_element("PartBox", f"box-{tag}")
    return await wm.add_branch(box, "contain", "Gear", f"gear-{tag}"), box


async def gripper(wm: WmClient, label: str) -> str:
    """The gripper labelled ``label``, emptied (earlier tests leave parts in it)."""
    grip = wm.resolve_element(type="Gripper", label=label)[0].id
    for rel in wm.query_relation(grip, "contain"):
        await wm.remove_element(rel.object)
    return grip


async def executing(events: AsyncIterator[RunEvent]) -> None:
    """Wait until the run reports its motion (it is inside ``execute``)."""
    async for event in events:
        if isinstance(event, Progress) and event.message.startswith("approaching"):
            return
    raise AssertionError("the run ended before it executed")


# --------------------------------------------------------------------------- discovery


@pytest.mark.anyio
async def test_skills_are_listed_and_registered(site: Site) -> None:
    async with connected(site) as (mesh, wm):
        assert {"picker", "mover"} <= set(await list_agents(mesh))
        found = await find_skills(mesh)
        for name in ("picker", "mover"):
            assert sorted(d.name for d in found[name].skills) == ["noop", "pick_part", "probe"]
        agent = wm.resolve_element(type="Agent", label="picker")[0]
        assert agent.properties["available"] is True
        skills = [wm.get_element(r.object) for r in wm.query_relation(agent.id, "hasSkill")]
        pick = next(s for s in skills if s.label == "pick_part")
        description = pick.properties["description"]
        assert isinstance(description, str)
        assert msgspec.json.decode(description, type=SkillDescription).name == "pick_part"
        robot = wm.query_relation(agent.id, "controls")[0].object
        labels = sorted(wm.get_element(r.object).label for r in wm.query_relation(robot, "hasA"))
        assert labels == ["picker-left", "picker-right"]


# --------------------------------------------------------------------------- devices


@pytest.mark.anyio
async def test_parallel_runs_on_disjoint_devices_overlap(site: Site) -> None:
    async with connected(site) as (mesh, wm):
        jobs = [
            ("picker", "picker-left"),
            ("picker", "picker-right"),
            ("mover", "mover-gripper"),
        ]
        results: list[RunResult] = []

        async def pick(agent: str, label: str) -> None:
            part, box = await part_in_box(wm)
            params: dict[str, Value] = {
                "part": part,
                "container": box,
                "gripper": await gripper(wm, label),
                "motion_time": 1.0,
            }
            results.append(await AgentClient(mesh, agent).run("pick_part", params))

        with anyio.fail_after(20):
            async with anyio.create_task_group() as tg:
                for agent, label in jobs:
                    tg.start_soon(pick, agent, label)
        assert all(r.success for r in results), [r.message for r in results]
        assert max(r.started_at for r in results) < min(r.finished_at for r in results), (
            "runs on different devices ran at the same time"
        )
        await wm.wait_for_revision(max(r.effects_revision for r in results))
        for r in results:
            part, held_by = r.params["part"], r.params["gripper"]
            assert isinstance(part, str) and wm.get_parent(part).id == held_by  # type: ignore[union-attr]


@pytest.mark.anyio
async def test_busy_device_is_refused_across_the_wire_or_queued(site: Site) -> None:
    async with connected(site) as (mesh, wm):
        client = AgentClient(mesh, "picker")
        left = await gripper(wm, "picker-left")
        (p1, b1), (p2, b2), (p3, b3) = [await part_in_box(wm) for _ in range(3)]
        first = await client.start(
            "pick_part", {"part": p1, "container": b1, "gripper": left, "motion_time": 2.0}
        )
        with pytest.raises(ResourceBusyError) as info:
            await client.start("pick_part", {"part": p2, "container": b2, "gripper": left})
        assert left in str(info.value) and first.run_id in str(info.value), (
            "names device and holder"
        )
        with anyio.fail_after(20):
            async with anyio.create_task_group() as tg:
                queued: list[RunResult] = []
                in_line = anyio.Event()

                def note(event: RunEvent) -> None:
                    if isinstance(event, Progress) and event.message.startswith("queued for"):
                        in_line.set()

                async def wait_queued() -> None:
                    params: dict[str, Value] = {
                        "part": p3,
                        "container": b3,
                        "gripper": left,
                        "motion_time": 0.1,
                    }
                    queued.append(await client.run("pick_part", params, queue=True, on_event=note))

                tg.start_soon(wait_queued)
                await in_line.wait()  # the agent put it in line behind the first run
                stopped = await client.stop(first.run_id)
            assert stopped.reason == "preempted"
            assert (
                queued[0].success
                and queued[0].started_at < stopped.finished_at <= queued[0].finished_at
            )


@pytest.mark.anyio
async def test_stop_mid_run_reaches_the_safe_state(site: Site) -> None:
    async with connected(site) as (mesh, wm):
        client = AgentClient(mesh, "mover")
        grip = await gripper(wm, "mover-gripper")
        await wm.update_element(grip, {"graspWidth": 0.0})
        part, box = await part_in_box(wm)
        with anyio.fail_after(20):
            async with client.watch("stop-me") as events:
                await client.start(
                    "pick_part",
                    {"part": part, "container": box, "gripper": grip, "motion_time": 30.0},
                    run_id="stop-me",
                )
                await executing(events)
                result = await client.stop("stop-me")
                rest = [e async for e in events]
        assert result.reason == "preempted" and not result.success
        assert any(isinstance(e, Progress) and e.step == "safe_state" for e in rest), (
            "on_preempt ran"
        )
        await wm.wait_for_revision((await wm.info()).revision)
        assert wm.get_element(grip).properties["graspWidth"] == 0.08, "gripper opened, in the WM"
        assert wm.get_parent(part).id == box, "no effect committed"  # type: ignore[union-attr]


@pytest.mark.anyio
async def test_hold_condition_violation_aborts_the_run(site: Site) -> None:
    async with connected(site) as (mesh, wm):
        client = AgentClient(mesh, "picker")
        part, box = await part_in_box(wm)
        other = await wm.add_element("PartBox", "elsewhere")
        params: dict[str, Value] = {
            "part": part,
            "container": box,
            "gripper": await gripper(wm, "picker-right"),
            "motion_time": 30.0,
        }
        with anyio.fail_after(20):
            async with client.watch("hold-1") as events:
                await client.start("pick_part", params, run_id="hold-1")
                await executing(events)
                await wm.unset_relation(box, "contain", part)  # someone takes the part away
                await wm.set_relation(other, "contain", part)
                result = [e async for e in events][-1]
        assert isinstance(result, RunResult)
        assert result.reason == "hold_violated" and "contain" in result.message


# --------------------------------------------------------------------------- reload


@pytest.mark.anyio
async def test_reload_under_load(site: Site) -> None:
    async with connected(site) as (mesh, _wm):
        client = AgentClient(mesh, "picker")
        events: list[RunEvent] = []
        in_flight: list[RunResult] = []
        noops: list[RunResult] = []
        reloaded, all_started = anyio.Event(), anyio.Event()

        def record(event: RunEvent) -> None:
            events.append(event)
            started = [e for e in events if isinstance(e, Progress) and e.message == "start v1"]
            if len(started) == 3:
                all_started.set()

        async def slow_probe() -> None:
            in_flight.append(await client.run("probe", {"seconds": 1.5}, on_event=record))

        async def noop_stream() -> None:
            while not reloaded.is_set() or len(noops) < 20:
                noops.append(await client.run("noop"))

        with anyio.fail_after(30):
            async with anyio.create_task_group() as tg:
                for _ in range(3):
                    tg.start_soon(slow_probe)
                tg.start_soon(noop_stream)
                await all_started.wait()
                (site.folder / "probe.py").write_text(PROBE.format(tag="v2"))
                message = await client.reload()
                reloaded.set()
            assert "probe" in message
            after = await client.run("probe", on_event=events.append)
        assert all(r.success for r in in_flight) and len(in_flight) == 3
        ends = {
            e.run_id: e.message
            for e in events
            if isinstance(e, Progress) and e.message.startswith("end")
        }
        assert all(ends[r.run_id] == "end v1" for r in in_flight), "runs in flight keep their code"
        assert ends[after.run_id] == "end v2", "later runs use the new code"
        assert all(r.success for r in noops), "other runs went on during the reload"
        doc = next(d.doc for d in await client.skills() if d.name == "probe")
        assert doc == "probe v2"
        (site.folder / "probe.py").write_text(PROBE.format(tag="v1"))  # as the other tests expect
        await client.reload()


# --------------------------------------------------------------------------- failure


@pytest.mark.anyio
async def test_sigkill_is_seen_by_watchers_clients_and_the_world_model(site: Site) -> None:
    victim = site.start_agent("victim", ["victim-gripper"])
    try:
        async with connected(site) as (mesh, wm):
            key = mesh.keys.agent("victim")
            with anyio.fail_after(30):
                async with (
                    mesh.watch_liveliness(mesh.keys.agents()) as watch,
                    anyio.create_task_group() as tg,
                ):
                    assert (await anext(aiter(watch))).alive  # history: the agents alive now
                    failures: list[BaseException] = []
                    running = anyio.Event()

                    def note(event: RunEvent) -> None:
                        if isinstance(event, Progress) and event.message.startswith("start "):
                            running.set()

                    async def waiting_client() -> None:
                        try:
                            await AgentClient(mesh, "victim", lost_grace=0.5).run(
                                "probe", {"seconds": 60.0}, on_event=note
                            )
                        except AgentTransportError as e:
                            failures.append(e)

                    tg.start_soon(waiting_client)
                    await running.wait()  # the client waits on a run inside execute
                    victim.kill()  # SIGKILL, by PID
                    async for change in watch:
                        if change.key == key and not change.alive:
                            break
                element = wm.resolve_element(type="Agent", label="victim")[0]
                while wm.get_element(element.id).properties.get("available") is not False:
                    async with wm.watch() as changes:
                        await anext(aiter(changes))
            assert failures and "disappeared" in str(failures[0])
            assert "victim" not in await list_agents(mesh)
    finally:
        victim.kill()


@pytest.mark.anyio
async def test_sigterm_stops_cleanly_and_unregisters(site: Site) -> None:
    leaver = site.start_agent("leaver", ["leaver-gripper"])
    try:
        async with connected(site) as (mesh, wm):
            agent = wm.resolve_element(type="Agent", label="leaver")[0].id
            skills = [r.object for r in wm.query_relation(agent, "hasSkill")]
            assert len(skills) == 3
            assert await anyio.to_thread.run_sync(leaver.stop) == 0, leaver.log()  # SIGTERM
            await wm.wait_for_revision((await wm.info()).revision)
            gone = [agent, *skills]
            assert not [i for i in gone if wm.find_element(i)], "agent and skills unregistered"
            assert wm.resolve_element(type="Robot", label="leaver-robot"), "the robot stays"
            assert "leaver" not in await list_agents(mesh)
    finally:
        leaver.kill()


# --------------------------------------------------------------------------- bad input

CODES = {
    "bad_request",
    "unknown_skill",
    "unknown_run",
    "parameter",
    "parameter_type",
    "unknown_parameter",
    "inference",
    "unspecified_parameter",
    "precondition",
    "run_state",
    "resource_busy",
}

_requests = st.sampled_from(["StopRun", "PauseRun", "ResumeRun", "RunStatus"])
_values = st.one_of(
    st.text(max_size=8),
    st.integers(-(2**63), 2**63 - 1),
    st.lists(st.booleans(), max_size=3),
    st.none(),
)
_wrong = st.one_of(
    st.text(max_size=8), st.integers(-(2**63), 2**63 - 1), st.floats(), st.lists(st.booleans())
)
"""Values that ``pick_part`` accepts for neither ``part`` nor ``motion_time`` (None would
mean "not given": inferred, or the default)."""
BAD = st.one_of(
    st.binary(max_size=48),
    st.builds(
        lambda t, v: msgspec.msgpack.encode({"request": t, "x": v}), st.text(max_size=10), _values
    ),
    st.builds(
        lambda r, i: msgspec.msgpack.encode({"request": r, "run_id": i}),
        _requests,
        st.text(max_size=12),
    ),
    st.builds(lambda r, i: msgspec.msgpack.encode({"request": r, "run_id": i}), _requests, _values),
    st.builds(
        lambda skill, v: msgspec.msgpack.encode(
            {"request": "StartRun", "skill": skill, "params": {"motion_time": v, "part": v}}
        ),
        st.sampled_from(["pick_part", "noop", "nope"]),
        _wrong,
    ),
)


def lists_skills(payload: bytes) -> bool:
    """Whether the ``skills`` queryable answers ``payload`` with the skills: empty, or a
    ``ListSkills`` (unknown fields are ignored, as everywhere); anything else is refused."""
    if not payload:
        return True
    try:
        return isinstance(decode_request(payload), ListSkills)
    except WireError:
        return False


def test_bad_input_on_every_queryable_gets_error_replies(site: Site) -> None:
    config = MeshConfig(connect=(site.endpoint,), mesh=site.mesh)
    with (
        anyio.from_thread.start_blocking_portal() as portal,
        portal.wrap_async_context_manager(open_mesh(config)) as mesh,
    ):
        rpc, skills = mesh.keys.agent_rpc("mover"), mesh.keys.agent_skills("mover")

        @settings(
            max_examples=120, deadline=None, suppress_health_check=list(HealthCheck), database=None
        )
        @given(payload=BAD)
        @example(payload=b"\xc1 not msgpack")
        @example(payload=encode(ListSkills()))
        def check(payload: bytes) -> None:
            listing = portal.call(lambda: mesh.get(skills, payload, timeout=5.0))
            assert len(listing) == 1, "the skills queryable: one answer, never silence"
            answer = decode_reply(listing[0].payload)
            if lists_skills(payload):
                assert listing[0].ok and isinstance(answer, SkillsReply), answer
                return  # a valid request: the rpc queryable would answer it too
            assert not listing[0].ok, f"bad input listed the skills: {payload!r}"
            assert isinstance(answer, ErrorReply) and answer.code == "bad_request", answer
            replies = portal.call(lambda: mesh.get(rpc, payload, timeout=5.0))
            assert len(replies) == 1, "exactly one answer, never a crash or silence"
            reply = replies[0]
            assert not reply.ok, f"bad input accepted: {payload!r}"
            error = msgspec.msgpack.decode(reply.payload, type=ErrorReply)
            assert error.code in CODES, error

        check()
        result = portal.call(lambda: AgentClient(mesh, "mover").run("noop"))
        assert result.success, "the agent is healthy after the fuzzing"


# --------------------------------------------------------------------------- command line


def skimesh(site: Site, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skimesh", *args, *site.mesh_flags()],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_cli_run_skills_and_agents(site: Site) -> None:
    done = skimesh(site, "run", "picker", "probe", "seconds=0.1")
    assert done.returncode == 0, done.stderr
    assert "start v1" in done.stdout and "succeeded" in done.stdout.splitlines()[-1]
    refused = skimesh(site, "run", "picker", "prob")
    assert refused.returncode == 2 and "did you mean 'probe'" in refused.stderr
    bad = skimesh(site, "run", "picker", "probe", "seconds=soon")
    assert bad.returncode == 2 and "no valid float" in bad.stderr
    unknown = skimesh(site, "run", "nobody", "noop", "--timeout", "0.5")  # not in the world model
    assert unknown.returncode == 2, unknown.stderr
    assert (
        "no agent 'nobody' on mesh" in unknown.stderr and "(alive: mover, picker)" in unknown.stderr
    )
    listing = skimesh(site, "skills", "mover", "--json")
    assert sorted(d["name"] for d in json.loads(listing.stdout)["mover"]) == [
        "noop",
        "pick_part",
        "probe",
    ]
    reloaded = skimesh(site, "reload", "mover")
    assert reloaded.returncode == 0 and "reloaded 3 skills" in reloaded.stdout
    agents = {row["agent"]: row for row in json.loads(skimesh(site, "agents", "--json").stdout)}
    assert agents["picker"]["alive"] and agents["picker"]["available"]
    events = [
        json.loads(line)
        for line in skimesh(site, "run", "mover", "noop", "--json").stdout.splitlines()
    ]
    assert events[-1]["event"] == "RunResult" and events[-1]["success"]


def test_cli_interrupt_stops_the_run_on_the_agent(site: Site) -> None:
    """Ctrl-C on ``skimesh run`` stops the run on the agent before the command exits."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "skimesh",
            "run",
            "mover",
            "probe",
            "seconds=60",
            *site.mesh_flags(),
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            if "start v1" in line:
                break
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130 and "interrupted" in err

    async def last_probe() -> RunInfo:
        async with connected(site) as (mesh, _wm):
            runs = await AgentClient(mesh, "mover").runs(active_only=False)
            return [r for r in runs if r.skill == "probe"][-1]

    info = anyio.run(last_probe)
    assert info.result is not None and info.result.reason == "preempted"
