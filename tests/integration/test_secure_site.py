"""A site secured with generated credentials (``skimesh.secure``) over real Zenoh on loopback:
a router with TLS, mutual TLS and the least-privilege ACL made from the site's components,
the store and a skill agent ``r1`` each logged in with its own certificate.

Each attack a site operator must not suffer fails: a client without a certificate of the site
CA cannot open a session; the read-only ``viewer`` cannot write the world model (on any write
key), command r1's devices, publish a forged change on ``wm/changes`` or a forged run result on
r1's progress key (subscribers get only the real ones), nor start a skill; the robot agent
``r2`` cannot declare another agent's liveliness token, write as r1, or change r1's
registration (the store refuses it by identity); and the store is unchanged throughout.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from dataclasses import dataclass

import anyio
import pytest

from meshlink import Mesh, MeshConfig, NoReplyError, SessionError, open_mesh
from meshlink.rpc import encode
from meshlink.testing import free_port
from skill_agent.client import AgentClient, list_agents
from skill_agent.protocol import RunResult
from skimesh.secure import Component, SiteSecurity
from wm_store import ForbiddenError, RobotRegistration, WmClient, ZenohTransport
from wm_store.protocol import AddElement, RemoveElement, Transact, decode_change

from .procs import Child, noop_agent
from .test_security import start_router

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.anyio]

COMPONENTS = (
    Component("wm", "wm"),
    Component("agents-host-a", "agent", {"r1": "r1"}),
    Component("agent-r2", "agent", {"r2": "r2"}),
    Component("ops", "operator"),
    Component("viewer", "viewer"),
)


@dataclass
class SecureSite:
    endpoint: str
    mesh: str
    security: SiteSecurity

    def config(self, component: str) -> MeshConfig:
        path = self.security.client_config(component, [self.endpoint])
        return MeshConfig(connect=(self.endpoint,), mesh=self.mesh, config_file=str(path))

    @asynccontextmanager
    async def session(self, component: str) -> AsyncIterator[Mesh]:
        async with open_mesh(self.config(component)) as mesh:
            yield mesh

    def flags(self, component: str) -> list[str]:
        path = self.security.client_config(component, [self.endpoint])
        return ["--connect", self.endpoint, "--mesh", self.mesh, "--config", str(path)]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SecureSite]:
    folder = tmp_path_factory.mktemp("secure")
    security = SiteSecurity(folder / "site", COMPONENTS, hosts=["localhost", "127.0.0.1"])
    security.ensure()
    endpoint = f"tls/127.0.0.1:{free_port()}"
    site = SecureSite(endpoint, f"sec-{uuid.uuid4().hex[:8]}", security)
    agent_toml = noop_agent(folder / "r1.toml", "r1")
    router = start_router(security.router_config([endpoint]), endpoint)
    children: list[Child] = []
    try:
        store = Child(["-m", "skimesh", "wm", *site.flags("wm")], name="store")
        children.append(store)
        store.wait_stderr("world model ready")
        agent = ["-m", "skimesh", "agent", "--agent-config", str(agent_toml)]
        children.append(Child([*agent, *site.flags("agents-host-a")], name="agent r1"))
        children[-1].wait_stderr("agent r1 ready")
        yield site
    finally:
        for child in reversed(children):
            child.stop()
        router.stop()


async def revision(site: SecureSite) -> int:
    async with site.session("ops") as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        return wm.revision


async def test_a_client_without_a_site_certificate_cannot_open_a_session(site: SecureSite) -> None:
    t0 = time.monotonic()
    with pytest.raises(SessionError):
        async with open_mesh(MeshConfig(connect=(site.endpoint,), mesh=site.mesh)):
            pass
    assert time.monotonic() - t0 < 10


async def test_the_viewer_can_read_but_not_write_nor_command(site: SecureSite) -> None:
    before = await revision(site)
    forged = encode(Transact(ops=[AddElement(type="Gear", label="forged")], author="cli"))
    async with site.session("viewer") as viewer:
        async with WmClient.connect(ZenohTransport(viewer), timeout=2.0) as wm:
            assert wm.find_element("r1") is not None or wm.resolve_element(label="r1")
        for key in (viewer.keys.wm_rpc(), viewer.keys.wm_write("cli"), viewer.keys.wm_write("r1")):
            with pytest.raises(NoReplyError, match="ACL"):
                await viewer.request(key, forged, timeout=1.0)
        with pytest.raises(NoReplyError, match="ACL"):  # r1's gripper: the agent's alone
            await viewer.request(viewer.keys.device_cmd("r1", "gripper"), b"", timeout=1.0)
        with pytest.raises(NoReplyError, match="ACL"):  # starting a skill
            await viewer.request(viewer.keys.agent_rpc("r1"), b"", timeout=1.0)
    assert await revision(site) == before


async def test_forged_changes_and_run_results_never_reach_subscribers(site: SecureSite) -> None:
    """The viewer publishes a forged change and a forged run result, then closes its session
    (which sends what it queued); only then the real change and run follow. A subscriber that
    got a forged message would have got it first."""
    async with (
        site.session("ops") as ops,
        ops.subscribe(ops.keys.wm_changes()) as changes,
        ops.subscribe(ops.keys.runs_progress("r1")) as progress,
        WmClient.connect(ZenohTransport(ops), author="ops") as wm,
    ):
        now = wm.revision
        async with site.session("viewer") as viewer:
            fake = Transact(ops=[RemoveElement(id="r1")], author="r1")
            viewer.put(viewer.keys.wm_changes(), encode(fake))
            result = RunResult(
                run_id="forged", agent="r1", skill="noop", seq=1, success=True, reason="ok"
            )
            viewer.put(viewer.keys.run_progress("r1", "forged"), encode(result))
        await wm.add_element("Gear", "gear-real")
        with anyio.fail_after(10):
            first = await changes.receive()
        assert decode_change(first.payload).revision == now + 1, "the forged change arrived"
        run = await AgentClient(ops, "r1", timeout=5.0).run("noop", deadline=10)
        assert run.success
        with anyio.fail_after(10):
            sample = await progress.receive()
        assert "forged" not in sample.key, "the forged run result arrived"


async def test_a_robot_agent_cannot_pose_as_another(site: SecureSite) -> None:
    async with (
        site.session("ops") as ops,
        ops.watch_liveliness(ops.keys.agents()) as tokens,
        site.session("agent-r2") as mesh,
    ):
        ghost = mesh.declare_token(mesh.keys.agent("r1-ghost"))  # not its name: dropped
        own = mesh.declare_token(mesh.keys.agent("r2"))  # declared after: arrives after
        seen: list[str] = []
        with anyio.fail_after(10):
            async for token in tokens:
                seen.append(token.key.rsplit("/", 1)[-1])
                if seen[-1] == "r2":
                    break
        assert "r1-ghost" not in seen and "r1-ghost" not in await list_agents(ops)
        ghost.undeclare()
        own.undeclare()
        async with WmClient.connect(ZenohTransport(mesh), author="r2", timeout=2.0) as wm:
            await wm.register_robot(
                RobotRegistration(agent="r2", robot_type="Robot", robot_label="r2")
            )
            (agent_r1,) = [e for e in wm.resolve_element(label="r1") if e.type == "RobotAgent"]
            with pytest.raises(ForbiddenError, match="belongs to agent r1"):
                await wm.remove_element(agent_r1.id)
            raw = encode(Transact(ops=[RemoveElement(id=agent_r1.id)], author="r1"))
            with pytest.raises(NoReplyError, match="ACL"):
                await mesh.request(mesh.keys.wm_write("r1"), raw, timeout=1.0)
            await wm.unregister_robot("r2")
