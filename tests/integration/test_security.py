"""Security of a site over real Zenoh on loopback, with the shipped configs of configs/zenoh/.

A router process (``skimesh router --config router-acl.json5``: user/password + ACL) serves a
world-model store logged in as ``wm`` and an agent ``r1`` logged in as ``agent-r1``; the test
connects as ``operator`` (a permitted writer) and as ``viewer`` (read-only). A second router
(``router-tls.json5``, mTLS) checks certificates from ``scripts/make-test-certs``.

Covers: the operator's transaction commits; every way the viewer could write the world model
(the client, a raw ``wm/rpc`` transact, a transact on a wildcard key, impersonating the store's
queryable) fails with an error naming the ACL or reaches nobody, and the store is unchanged
(revision and content, checked by the operator), while the viewer can still read elements,
follow ``wm/changes``, list agents and skills; the viewer cannot start a skill; a wrong password
fails at open within a second (client mode) while peer mode opens with no router (the caveat);
a TLS client with a certificate of the site CA connects and reads, one without a certificate,
with another CA's or over plain TCP is refused at open.
"""

from __future__ import annotations

import hashlib
import json
import secrets
import socket
import subprocess
import sys
import time
import uuid
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path

import anyio
import msgspec
import pytest

from meshlink import Answer, IncomingQuery, Mesh, MeshConfig, NoReplyError, SessionError, open_mesh
from meshlink.rpc import encode
from meshlink.testing import free_port
from skill_agent import AgentTransportError
from skill_agent.client import AgentClient, find_skills, list_agents
from wm_store import ForbiddenError, RobotRegistration, TransportError, WmClient, ZenohTransport
from wm_store.protocol import AddElement, RemoveElement, Transact, UnsetRelation, UpdateElement

from .procs import ROOT, Child, noop_agent

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.anyio]

CONFIGS = ROOT / "configs" / "zenoh"
MAKE_CERTS = ROOT / "scripts" / "make-test-certs"
USERS = ("wm", "agent-r1", "agent-r2", "operator", "viewer")


def from_template(name: str, out: Path, replace: dict[str, str]) -> Path:
    """Write ``configs/zenoh/<name>`` to ``out`` with each text replaced (each must occur, so
    a changed shipped config fails here, not silently)."""
    text = (CONFIGS / name).read_text()
    for old, new in replace.items():
        assert old in text, f"{name} no longer contains {old!r}"
        text = text.replace(old, new)
    out.write_text(text)
    return out


def start_router(config: Path, endpoint: str) -> Child:
    """``skimesh router --config FILE --listen ENDPOINT``, returned once the port accepts."""
    router = Child(
        ["-m", "skimesh", "router", "--config", str(config), "--listen", endpoint], name="router"
    )
    port = int(endpoint.rsplit(":", 1)[1])
    deadline = time.monotonic() + 20
    while True:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return router
        except OSError:
            if router.proc.poll() is not None or time.monotonic() > deadline:
                router.stop()
                raise AssertionError(f"no router on {endpoint}:\n{router.log()}") from None
            time.sleep(0.05)


@dataclass
class AclSite:
    endpoint: str
    mesh: str
    folder: Path
    passwords: dict[str, str] = field(default_factory=dict)

    def client_config(self, user: str, password: str | None = None) -> Path:
        return from_template(
            "client-auth.json5",
            self.folder / f"{user}-{uuid.uuid4().hex[:6]}.json5",
            {
                '"operator", //': f'"{user}", //',
                '"CHANGE-ME"': f'"{password or self.passwords[user]}"',
            },
        )

    def flags(self, user: str) -> list[str]:
        """Mesh flags of a ``skimesh`` command logged in as ``user``."""
        config = str(self.client_config(user))
        return ["--connect", self.endpoint, "--mesh", self.mesh, "--config", config]

    @asynccontextmanager
    async def session(self, user: str) -> AsyncIterator[Mesh]:
        config = MeshConfig(
            connect=(self.endpoint,), mesh=self.mesh, config_file=str(self.client_config(user))
        )
        async with open_mesh(config) as mesh:
            yield mesh


@pytest.fixture(scope="module")
def acl_site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[AclSite]:
    folder = tmp_path_factory.mktemp("acl")
    site = AclSite(f"tcp/127.0.0.1:{free_port()}", f"sec-{uuid.uuid4().hex[:8]}", folder)
    site.passwords = {user: secrets.token_hex(12) for user in USERS}
    users = folder / "users.txt"
    users.write_text("".join(f"{u}:{p}\n" for u, p in site.passwords.items()))
    config = from_template(
        "router-acl.json5", folder / "router.json5", {"/etc/skimesh/zenoh/users.txt": str(users)}
    )
    agent_toml = noop_agent(folder / "r1.toml", "r1")
    router = start_router(config, site.endpoint)
    children: list[Child] = []
    try:
        store_flags = ["--data", str(folder / "wm"), *site.flags("wm")]
        children.append(Child(["-m", "skimesh", "wm", *store_flags], name="store"))
        children[-1].wait_stderr("world model ready")
        agent = ["-m", "skimesh", "agent", "--agent-config", str(agent_toml)]
        children.append(Child([*agent, *site.flags("agent-r1")], name="agent r1"))
        children[-1].wait_stderr("agent r1 ready")
        yield site
    finally:
        for child in reversed(children):
            child.stop()
        router.stop()


def digest(wm: WmClient) -> str:
    snap = wm.replica.state.to_snapshot()
    snap.elements.sort(key=lambda e: e.id)
    snap.relations.sort(key=lambda r: (r.subject, r.predicate, r.object))
    snap.counters = dict(sorted(snap.counters.items()))  # their order carries no meaning
    return hashlib.sha256(msgspec.msgpack.encode(snap)).hexdigest()


async def store_state(site: AclSite) -> tuple[int, str]:
    """(revision, content digest) of the store, read afresh by the operator."""
    async with (
        site.session("operator") as mesh,
        WmClient.connect(ZenohTransport(mesh), author="operator") as wm,
    ):
        return wm.revision, digest(wm)


# --------------------------------------------------------------------------- user/password + ACL


async def test_the_writer_commits_and_the_read_only_user_changes_nothing(acl_site: AclSite) -> None:
    site = acl_site
    async with (
        site.session("operator") as op,
        WmClient.connect(ZenohTransport(op), author="operator") as wm,
    ):
        before = wm.revision
        kit = await wm.add_element("KitBox", "kit-1")
        assert wm.revision == before + 1 and wm.get_element(kit).label == "kit-1"
    revision, content = await store_state(site)

    served: list[IncomingQuery] = []

    async def impostor(query: IncomingQuery) -> list[Answer]:
        served.append(query)
        return [Answer(query.key_expr, b"forged")]

    transact = encode(Transact(ops=[AddElement(type="Gear", label="forged")], author="viewer"))
    async with site.session("viewer") as viewer, anyio.create_task_group() as tg:
        rpc = viewer.keys.wm_rpc()
        # The world-model client loads and reads through the read-only wm/query; its writes
        # go to wm/rpc: denied, and the error says why.
        async with WmClient.connect(ZenohTransport(viewer), timeout=1.0) as wm:
            assert wm.revision == revision
            with pytest.raises(TransportError, match="ACL"):
                await wm.add_element("Gear", label="forged")
        # A raw transact: no reply (the router drops it silently); meshlink names the ACL.
        t0 = time.monotonic()
        with pytest.raises(NoReplyError, match="ACL"):
            await viewer.request(rpc, transact, timeout=2.0)
        assert time.monotonic() - t0 < 2.5
        # A transact on a wildcard that matches wm/rpc: denied too (deny-by-default policy).
        assert await viewer.get(f"{viewer.keys.prefix}/**", transact, timeout=1.0) == []
        assert await viewer.get(f"{viewer.keys.prefix}/wm/*", transact, timeout=1.0) == []
        # Impersonating the store: the viewer's queryable on wm/rpc is never reached.
        await tg.start(viewer.serve, rpc, impostor)
        # What the viewer may still do: read elements, follow changes, list agents and skills.
        (element,) = await viewer.get(viewer.keys.wm_element(kit))
        assert element.ok and msgspec.json.decode(element.payload)["label"] == "kit-1"
        assert "r1" in await list_agents(viewer)
        assert [d.name for d in (await find_skills(viewer))["r1"].skills] == ["noop"]
        async with viewer.subscribe(viewer.keys.wm_changes()) as changes:
            assert await store_state(site) == (revision, content)  # unchanged, operator's view
            async with (
                site.session("operator") as op,
                WmClient.connect(ZenohTransport(op), author="operator") as wm,
            ):
                await wm.add_element("Gear", "gear-1")
                assert wm.revision == revision + 1
            with anyio.fail_after(5):
                sample = await changes.receive()
            assert sample.key == viewer.keys.wm_changes()
        tg.cancel_scope.cancel()
    assert served == [], "the viewer's impostor queryable received queries"


async def test_a_robot_agent_cannot_rewrite_or_unregister_another_robot(acl_site: AclSite) -> None:
    """Logged in as agent-r2: it registers itself, but the store refuses (by its identity,
    which the ACL fixes to the key it writes on) every change to r1's registration, it cannot
    write as r1 (wm/write/r1 is r1's) nor through wm/rpc, and nothing changes."""
    site = acl_site
    reg = RobotRegistration(agent="r2", robot_type="Robot", robot_label="r2")
    async with (
        site.session("agent-r2") as mesh,
        WmClient.connect(ZenohTransport(mesh), author="r2", timeout=2.0) as wm,
    ):
        await wm.register_robot(reg)
        (agent_r1,) = [e for e in wm.resolve_element(label="r1") if e.type == "RobotAgent"]
        (robot_r1,) = [e for e in wm.resolve_element(label="r1") if e.type == "Robot"]
        before = await store_state(site)
        for ops in (
            [UpdateElement(id=robot_r1.id, properties={"available": False})],
            [RemoveElement(id=agent_r1.id)],
            [UnsetRelation(subject=agent_r1.id, predicate="controls", object=robot_r1.id)],
        ):
            with pytest.raises(ForbiddenError, match=r"'r2' may not .* agent r1"):
                await wm.transact(ops)
        raw = encode(Transact(ops=[RemoveElement(id=agent_r1.id)], author="r1"))
        with pytest.raises(NoReplyError, match="ACL"):  # writing as r1: not its key
            await mesh.request(mesh.keys.wm_write("r1"), raw, timeout=1.0)
        with pytest.raises(NoReplyError, match="ACL"):  # the general write key: not for agents
            await mesh.request(mesh.keys.wm_rpc(), raw, timeout=1.0)
        assert await store_state(site) == before
        assert "r1" in await list_agents(mesh)
        await wm.unregister_robot("r2")  # its own: allowed (and the other tests see r1 alone)


async def test_the_read_only_user_cannot_start_a_skill(acl_site: AclSite) -> None:
    async with acl_site.session("operator") as op:
        operator_agent = AgentClient(op, "r1", timeout=5.0)
        result = await operator_agent.run("noop", deadline=10)
        assert result.success, result
        runs_before = {r.run_id for r in await operator_agent.runs(active_only=False)}
        async with acl_site.session("viewer") as viewer:
            with pytest.raises(AgentTransportError):
                await AgentClient(viewer, "r1", timeout=1.0).start("noop", run_id="viewer-run")
            with pytest.raises(NoReplyError, match="ACL"):
                await viewer.request(viewer.keys.agent_rpc("r1"), b"", timeout=1.0)
        runs_after = {r.run_id for r in await operator_agent.runs(active_only=False)}
        assert runs_after == runs_before and "viewer-run" not in runs_after


async def test_a_wrong_password_fails_at_open(acl_site: AclSite) -> None:
    for user, password in (("operator", "wrong"), ("nobody", "secret")):
        config = MeshConfig(
            connect=(acl_site.endpoint,),
            mesh=acl_site.mesh,
            config_file=str(acl_site.client_config(user, password)),
        )
        t0 = time.monotonic()
        with pytest.raises(SessionError, match="cannot open a Zenoh session") as error:
            async with open_mesh(config):
                pass
        assert time.monotonic() - t0 < 1.0
        assert error.value.endpoints == (acl_site.endpoint,)


async def test_peer_mode_with_a_wrong_password_opens_without_a_router(acl_site: AclSite) -> None:
    """The caveat of the guide: a peer opens although the router refused it. Use client mode."""
    config = MeshConfig(
        mode="peer",
        connect=(acl_site.endpoint,),
        mesh=acl_site.mesh,
        config_file=str(acl_site.client_config("operator", "wrong")),
    )
    async with open_mesh(config) as mesh:
        assert list(mesh.session.info.routers_zid()) == []


# --------------------------------------------------------------------------- TLS (mTLS)


@dataclass
class TlsSite:
    endpoint: str
    mesh: str
    folder: Path

    def client_config(self, certs: Path, name: str, *, mtls: bool = True) -> str:
        replace = {
            "/etc/skimesh/tls/ca.pem": str(certs / "ca.pem"),
            "/etc/skimesh/tls/client.pem": str(certs / f"{name}.pem"),
            "/etc/skimesh/tls/client-key.pem": str(certs / f"{name}-key.pem"),
        }
        if not mtls:
            replace["enable_mtls: true"] = "enable_mtls: false"
        out = self.folder / f"client-{name}-{uuid.uuid4().hex[:6]}.json5"
        return str(from_template("client-tls.json5", out, replace))


def make_certs(folder: Path, *clients: str) -> Path:
    args = [str(folder)] + [a for c in clients for a in ("--client", c)]
    subprocess.run([str(MAKE_CERTS), *args], check=True, capture_output=True, timeout=60)
    return folder


@pytest.fixture(scope="module")
def tls_site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TlsSite]:
    folder = tmp_path_factory.mktemp("tls")
    certs = make_certs(folder / "certs", "wm", "ops")
    make_certs(folder / "other-ca", "ops")  # a valid certificate of another CA
    site = TlsSite(f"tls/127.0.0.1:{free_port()}", f"tls-{uuid.uuid4().hex[:8]}", folder)
    config = from_template(
        "router-tls.json5", folder / "router.json5", {"/etc/skimesh/tls": str(certs)}
    )
    router = start_router(config, site.endpoint)
    store: Child | None = None
    try:
        wm_config = site.client_config(certs, "wm")
        flags = ["--connect", site.endpoint, "--mesh", site.mesh, "--config", wm_config]
        store = Child(["-m", "skimesh", "wm", *flags], name="store")
        store.wait_stderr("world model ready")
        yield site
    finally:
        if store is not None:
            store.stop()
        router.stop()


async def test_a_tls_client_with_a_site_certificate_connects_and_reads(tls_site: TlsSite) -> None:
    config = MeshConfig(
        connect=(tls_site.endpoint,),
        mesh=tls_site.mesh,
        config_file=tls_site.client_config(tls_site.folder / "certs", "ops"),
    )
    async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        box = await wm.add_element("KitBox", "kit-tls")
        (reply,) = await mesh.get(mesh.keys.wm_element(box))
        assert msgspec.json.decode(reply.payload)["label"] == "kit-tls"


@pytest.mark.parametrize("client", ["no-certificate", "other-ca", "plain-tcp"])
async def test_a_client_without_a_site_certificate_is_refused(
    tls_site: TlsSite, client: str
) -> None:
    endpoint, certs, mtls = tls_site.endpoint, tls_site.folder / "certs", True
    if client == "no-certificate":
        mtls = False
    elif client == "other-ca":
        certs = tls_site.folder / "other-ca"
    config_file: str | None = tls_site.client_config(certs, "ops", mtls=mtls)
    if client == "plain-tcp":
        endpoint, config_file = endpoint.replace("tls/", "tcp/"), None
    config = MeshConfig(connect=(endpoint,), mesh=tls_site.mesh, config_file=config_file)
    t0 = time.monotonic()
    with pytest.raises(SessionError, match="cannot open a Zenoh session"):
        async with open_mesh(config):
            pass
    assert time.monotonic() - t0 < 2.0


def test_the_read_only_user_on_the_command_line(acl_site: AclSite) -> None:
    def skimesh(*args: str) -> subprocess.CompletedProcess[str]:
        flags = acl_site.flags("viewer")  # after the command (before a `wm` sub-command)
        command = [sys.executable, "-m", "skimesh", args[0], *flags, *args[1:]]
        return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=60)

    agents = skimesh("agents", "--json", "--timeout", "1")
    assert agents.returncode == 0, agents.stderr
    listed = json.loads(agents.stdout)
    assert [(a["agent"], a["available"]) for a in listed] == [("r1", True)], "read from the WM"
    skills = skimesh("skills", "r1", "--json")
    assert skills.returncode == 0 and "noop" in skills.stdout, skills.stderr
    listing = skimesh("wm", "--timeout", "1", "ls", "Robot")
    assert listing.returncode == 0, listing.stderr  # reads go to the read-only wm/query
    assert "Robot-1" in listing.stdout
    scene = ROOT / "configs" / "scenes" / "sample.ttl"
    write = skimesh("wm", "--timeout", "1", "import", str(scene))
    assert write.returncode != 0 and "ACL" in write.stderr, write.stderr
    run = skimesh("run", "r1", "noop", "--timeout", "1")
    assert run.returncode == 3, run.stderr  # the agent "cannot be reached"
