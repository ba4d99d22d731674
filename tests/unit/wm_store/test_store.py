"""WmStore: revisions, durability across restarts, history, snapshots at past revisions."""

from __future__ import annotations

from pathlib import Path

import anyio
import pytest

from tests.unit.wm_store.stores import running
from wm_store import ConflictError, HistoryCompactedError, ValidationError
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Change, Relation, Transact, UpdateElement
from wm_store.server import StoreConfig, WmStore

pytestmark = pytest.mark.anyio


def add_gear(label: str) -> Transact:
    return Transact(ops=[AddElement(type="Gear", label=label, properties={"mass": 0.1})])


async def test_revisions_and_listener_order(ontology: Ontology) -> None:
    store = await WmStore.open(ontology)
    seen: list[int] = []
    store.add_listener(lambda change, _payload: seen.append(change.revision))
    async with running(store) as s:
        async with anyio.create_task_group() as tg:
            for i in range(20):
                tg.start_soon(s.transact, add_gear(f"g{i}"))
        assert s.revision == 20
    assert seen == list(range(1, 21))


@pytest.mark.parametrize("mode", ["group", "fsync"])
async def test_restart_recovers_every_acknowledged_transaction(
    ontology: Ontology, tmp_path: Path, mode: str
) -> None:
    config = StoreConfig(data_dir=str(tmp_path), durability=mode, snapshot_every=7)  # type: ignore[arg-type]
    store = await WmStore.open(ontology, config)
    async with running(store) as s:
        for i in range(25):
            await s.transact(add_gear(f"g{i}"))
        await s.transact(Transact(ops=[UpdateElement(id="Gear-3", properties={"mass": 0.5})]))
        before = s.snapshot()
    again = await WmStore.open(ontology, config)
    assert again.revision == 26
    assert again.snapshot() == before
    async with running(again) as s:
        reply = await s.transact(add_gear("after-restart"))
        assert reply.ids["#0"] == "Gear-26"


async def test_transaction_id_is_idempotent(ontology: Ontology, tmp_path: Path) -> None:
    config = StoreConfig(data_dir=str(tmp_path))
    store = await WmStore.open(ontology, config)
    async with running(store) as s:
        request = Transact(ops=[AddElement(type="Gear")], txn_id="abc")
        first = await s.transact(request)
        second = await s.transact(request)
        assert second.revision == first.revision
        assert second.duplicate and not first.duplicate
        assert s.revision == 1
    again = await WmStore.open(ontology, config)
    async with running(again) as s:
        third = await s.transact(Transact(ops=[AddElement(type="Gear")], txn_id="abc"))
        assert third.duplicate and third.revision == 1
        assert len(s.state.elements) == 1


async def test_expect_revision_conflict(ontology: Ontology) -> None:
    store = await WmStore.open(ontology)
    async with running(store) as s:
        await s.transact(add_gear("a"))
        with pytest.raises(ConflictError, match="revision 1"):
            await s.transact(Transact(ops=[AddElement(type="Gear")], expect_revision=0))
        await s.transact(Transact(ops=[AddElement(type="Gear")], expect_revision=1))
        assert s.revision == 2


async def test_rejected_transaction_takes_no_revision(ontology: Ontology) -> None:
    store = await WmStore.open(ontology)
    async with running(store) as s:
        with pytest.raises(ValidationError):
            await s.transact(
                Transact(ops=[AddElement(type="Gear"), AddElement(type="Gear", id="Gear-1")])
            )
        assert s.revision == 0
        assert s.state.elements == {}


async def test_changes_since_and_history_bound(ontology: Ontology) -> None:
    store = await WmStore.open(ontology, StoreConfig(history=5))
    async with running(store) as s:
        for i in range(8):
            await s.transact(add_gear(f"g{i}"))
        reply = s.changes_since(5)
        assert [c.revision for c in reply.changes] == [6, 7, 8]
        assert [c.revision for c in s.changes_since(3, limit=2).changes] == [4, 5]
        with pytest.raises(HistoryCompactedError, match="snapshot"):
            s.changes_since(2)


async def test_snapshot_at_past_revision(ontology: Ontology) -> None:
    store = await WmStore.open(ontology)
    async with running(store) as s:
        await s.transact(
            Transact(
                ops=[
                    AddElement(type="Box", ref="$b"),
                    AddElement(type="Gear", ref="$g", relations=[Relation("$b", "contain", "$")]),
                ]
            )
        )
        at_one = s.snapshot()
        await s.transact(Transact(ops=[UpdateElement(id="Gear-1", properties={"mass": 1.0})]))
        await s.transact(add_gear("extra"))
        past = s.snapshot(1)
        assert past.revision == 1
        assert sorted(e.id for e in past.elements) == sorted(e.id for e in at_one.elements)
        assert {e.id: e.properties for e in past.elements} == {
            e.id: e.properties for e in at_one.elements
        }
        assert s.snapshot().revision == 3


async def test_change_carries_refs(ontology: Ontology) -> None:
    store = await WmStore.open(ontology)
    changes: list[Change] = []
    store.add_listener(lambda change, _payload: changes.append(change))
    async with running(store) as s:
        await s.transact(Transact(ops=[AddElement(type="Gear", ref="$g")], author="me"))
    assert changes[0].ids == {"$g": "Gear-1"}
    assert changes[0].author == "me"
