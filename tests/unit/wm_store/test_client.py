"""WmClient over the in-memory transport: read-your-writes, replica convergence, gaps, watch."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import pytest

from meshlink.rpc import ErrorReply
from wm_store import (
    ConflictError,
    DeviceSpec,
    ElementNotFoundError,
    InMemoryTransport,
    ProtocolError,
    RemoteError,
    RevisionTimeoutError,
    RobotRegistration,
    SkillSpec,
    TransportError,
    WmClient,
)
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    Change,
    Info,
    Relation,
    Reply,
    Request,
    TemplateDef,
    Transact,
)
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio


class LossyTransport(InMemoryTransport):
    """Drops the changes whose revision is in ``drop`` (as a lossy network would)."""

    def __init__(self, service: WmService, drop: set[int]) -> None:
        super().__init__(service)
        self.drop = drop
        self.requests: list[str] = []

    async def request(self, request: Request, *, timeout: float) -> Reply:
        self.requests.append(type(request).__name__)
        return await super().request(request, timeout=timeout)

    @asynccontextmanager
    async def changes(self) -> AsyncIterator[AsyncIterator[Change]]:
        async with super().changes() as stream:

            async def filtered() -> AsyncIterator[Change]:
                async for change in stream:
                    if change.revision not in self.drop:
                        yield change

            yield filtered()


@asynccontextmanager
async def store_service(ontology: Ontology) -> AsyncIterator[WmService]:
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        yield WmService(store)
        tg.cancel_scope.cancel()


async def test_read_your_writes_and_api(ontology: Ontology) -> None:
    async with (
        store_service(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology, author="t") as wm,
    ):
        box = await wm.add_element("Box", label="box")
        gear = await wm.add_branch(box, "contain", "Gear", properties={"mass": 0.2})
        assert wm.get_element(gear).properties["mass"] == 0.2
        assert wm.get_parent(gear) is not None and wm.get_parent(gear).id == box  # type: ignore[union-attr]
        assert [e.id for e in wm.get_children(box)] == [gear]
        assert [e.id for e in wm.get_children(box, type="Part")] == [gear]
        assert wm.query_relation(box, "contain") == [Relation(box, "contain", gear)]
        rev = wm.get_element(gear).rev
        await wm.update_element(gear, {"mass": 0.3}, expect_rev=rev)
        with pytest.raises(ConflictError):
            await wm.update_element(gear, {"mass": 0.4}, expect_rev=rev)
        await wm.remove_branch(box)
        with pytest.raises(ElementNotFoundError):
            wm.get_element(gear)
        await wm.define_class("Sprocket", "Gear")
        assert wm.ontology.is_a("Sprocket", "Part")
        await wm.define_template(
            TemplateDef(name="small-sprocket", type="Sprocket", properties={"mass": 0.05})
        )
        default = wm.get_default_element("small-sprocket")
        assert default.type == "Sprocket" and default.properties == {"mass": 0.05}


async def test_two_replicas_converge(ontology: Ontology) -> None:
    async with (
        store_service(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology) as a,
        WmClient.connect(InMemoryTransport(service), ontology) as b,
    ):
        async with anyio.create_task_group() as tg:
            for i in range(30):
                tg.start_soon(a.add_element, "Gear", f"a{i}")
                tg.start_soon(b.add_element, "Shaft", f"b{i}")
        await a.wait_for_revision(60)
        await b.wait_for_revision(60)
        assert (
            a.replica.state.to_snapshot()
            == b.replica.state.to_snapshot()
            == service.store.snapshot()
        )


async def test_gap_is_detected_and_resynced(ontology: Ontology) -> None:
    async with store_service(ontology) as service:
        lossy = LossyTransport(service, drop={3, 4, 9})
        async with (
            WmClient.connect(lossy, ontology) as watcher,
            WmClient.connect(InMemoryTransport(service), ontology) as writer,
        ):
            for i in range(10):
                await writer.add_element("Gear", f"g{i}")
            await watcher.wait_for_revision(10)
            assert watcher.replica.state.to_snapshot() == service.store.snapshot()
            stats = watcher.replica.statistics()
            assert stats.gaps >= 1
            assert "ChangesSince" in lossy.requests


async def test_gap_at_the_end_is_pulled_by_waiter(ontology: Ontology) -> None:
    async with store_service(ontology) as service:
        lossy = LossyTransport(service, drop={2})
        async with (
            WmClient.connect(lossy, ontology) as watcher,
            WmClient.connect(InMemoryTransport(service), ontology) as writer,
        ):
            await writer.add_element("Gear")
            await writer.add_element("Gear")  # revision 2 never reaches the watcher's stream
            await watcher.wait_for_revision(2, timeout=3)
            assert "Gear-2" in watcher.replica.state.elements


class RacedTransport(InMemoryTransport):
    """Before the first conditional transaction goes to the store, another client writes, and
    the writing replica applies that change first: the conflict reply then reaches a replica
    that is already up to date (as over a network, where the change can beat the reply)."""

    def __init__(self, service: WmService) -> None:
        super().__init__(service)
        self.replica: WmClient | None = None
        self.raced = False

    async def request(self, request: Request, *, timeout: float) -> Reply:
        conditional = isinstance(request, Transact) and request.expect_revision is not None
        if conditional and not self.raced and self.replica is not None:
            self.raced = True
            async with WmClient.connect(InMemoryTransport(self.service)) as other:
                revision = (await other.transact([AddElement(type="Gear")])).revision
            await self.replica.wait_for_revision(revision)
        return await super().request(request, timeout=timeout)


async def test_a_registration_that_lost_a_race_is_made_again_at_once(
    ontology: Ontology,
) -> None:
    """The replica already shows the write that made the registration conflict: it is made
    again at once, not after waiting for a revision nobody writes (which timed out)."""
    reg = RobotRegistration(agent="r2-agent", address="a", robot_type="Robot", robot_label="r2")
    async with store_service(ontology) as service:
        transport = RacedTransport(service)
        async with WmClient.connect(transport, ontology, timeout=2.0) as wm:
            transport.replica = wm
            ids = await wm.register_robot(reg)
            assert transport.raced and wm.revision == 2
            assert wm.get_element(ids["$robot"]).label == "r2"
            assert [e.id for e in wm.resolve_element(type="Gear")] == ["Gear-1"]


async def test_a_revision_that_never_comes_times_out_with_a_message(ontology: Ontology) -> None:
    """Waiting for a revision the store has not reached fails as a typed, worded error that is
    also a ``TimeoutError`` (a bare one printed as an empty line in the CLI)."""
    async with (
        store_service(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology) as wm,
    ):
        await wm.add_element("Gear")
        with pytest.raises(RevisionTimeoutError) as caught:
            await wm.wait_for_revision(5, timeout=0.6)
        assert isinstance(caught.value, TimeoutError) and isinstance(caught.value, TransportError)
        assert "revision 5" in str(caught.value) and "at revision 1" in str(caught.value)


async def test_watch_and_callbacks(ontology: Ontology) -> None:
    async with (
        store_service(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology) as wm,
    ):
        called: list[int] = []
        unsubscribe = wm.on_change(lambda c: called.append(c.revision))
        async with wm.watch() as changes:
            await wm.add_element("Gear")
            await wm.add_element("Gear")
            seen = [(await changes.__anext__()).revision, (await changes.__anext__()).revision]
        unsubscribe()
        await wm.add_element("Gear")
        assert seen == [1, 2]
        assert called == [1, 2]


async def test_register_and_unregister_robot(ontology: Ontology) -> None:
    reg = RobotRegistration(
        agent="r1-agent",
        address="skimesh/default/agents/r1-agent",
        robot_type="MobileManipulator",
        robot_label="r1",
        devices=[
            DeviceSpec(type="Arm", label="r1-arm"),
            DeviceSpec(type="Gripper", label="r1-gripper"),
        ],
        skills=[SkillSpec(name="pick"), SkillSpec(name="place")],
    )
    async with (
        store_service(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology) as wm,
    ):
        ids = await wm.register_robot(reg)
        agent, robot = ids["$agent"], ids["$robot"]
        assert wm.get_element(agent).properties["available"] is True
        assert wm.query_relation(agent, "controls") == [Relation(agent, "controls", robot)]
        assert sorted(e.label for e in wm.get_children(robot, "hasA")) == ["r1-arm", "r1-gripper"]
        assert sorted(e.label for e in wm.get_children(agent, "hasSkill")) == ["pick", "place"]
        # re-registering reuses robot and devices, replaces skills
        again = await wm.register_robot(reg)
        assert "$robot" not in again and "$agent" not in again
        assert len(wm.resolve_element(type="Skill")) == 2
        assert len(wm.resolve_element(type="Gripper")) == 1
        await wm.unregister_robot("r1-agent")
        assert wm.resolve_element(type="Skill") == []
        assert wm.resolve_element(type="Agent") == []
        assert wm.get_element(robot).label == "r1"


async def test_no_store_gives_transport_error(ontology: Ontology) -> None:
    class Dead(InMemoryTransport):
        async def request(self, request: Request, *, timeout: float) -> Reply:
            raise TransportError("store unreachable")

    store = await WmStore.open(ontology)
    with pytest.raises(TransportError):
        async with WmClient.connect(Dead(WmService(store)), ontology):
            pass


@pytest.mark.parametrize(
    ("code", "raised", "words"),
    [
        ("bad_request", ProtocolError, "malformed"),
        ("too_large", ProtocolError, "split the transaction"),
        ("protocol_error", ProtocolError, "malformed"),
        ("conflict", ConflictError, "malformed"),
        ("internal", RemoteError, "[internal] malformed"),
        ("from_a_newer_store", RemoteError, "[from_a_newer_store]"),
    ],
)
async def test_error_replies_raise_by_code(
    ontology: Ontology, code: str, raised: type[Exception], words: str
) -> None:
    """meshlink's standard codes ``bad_request`` and ``too_large`` raise :class:`ProtocolError`
    (``except ProtocolError`` catches a malformed or oversized request); the store's own codes
    their class; any other code a :class:`RemoteError` that keeps it."""

    class Refusing(InMemoryTransport):
        async def request(self, request: Request, *, timeout: float) -> Reply:
            if isinstance(request, Info):
                return ErrorReply(code=code, message="malformed request")
            return await super().request(request, timeout=timeout)

    store = await WmStore.open(ontology)
    async with WmClient.connect(Refusing(WmService(store)), ontology) as wm:
        with pytest.raises(raised) as caught:
            await wm.info()
    assert words in str(caught.value)
    if isinstance(caught.value, RemoteError):
        assert caught.value.remote_code == code


async def test_reasoners_through_the_client(ontology: Ontology) -> None:
    from wm_store.protocol import Element, Pose, Position, SizeCylinder

    async with (
        store_service(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology) as wm,
    ):
        box = await wm.add_element("Box", properties={"pose": Pose(Position(1.0, 0.0, 0.0))})
        gear = await wm.add_branch(
            box,
            "contain",
            "Gear",
            properties={
                "pose": Pose(Position(0.1, 0.0, 0.0), frame=box),
                "size": SizeCylinder(0.03, 0.02),
                "mass": 0.12,
            },
        )
        world = wm.spatial.world_position(gear)
        assert world.x == pytest.approx(1.1)
        known = wm.get_element(gear)
        seen = Element(id="", type="Gear", properties=dict(known.properties))  # as a camera reports
        assert wm.identify(seen, 0.5)[0][0] == gear
        ranked = wm.classify(seen, "Part", 0.0)
        assert ranked, "the default individuals of Part are candidates"
        assert ranked == sorted(ranked, key=lambda r: -r[1])
