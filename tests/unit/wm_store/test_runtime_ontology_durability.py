"""Classes and templates taught at run time (``DefineClass`` / ``DefineTemplate``) are durable:
a store reopened from its data directory, after a crash (log replay) or a clean stop (snapshot),
knows them, serves them to a new replica, and keeps enforcing them."""

from __future__ import annotations

import shutil
from pathlib import Path

import anyio
import pytest

from tests.unit.wm_store.stores import running
from wm_store import InMemoryTransport, OntologyError, PropertyValueError, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    ClassDef,
    DefineClass,
    DefineTemplate,
    Op,
    Relation,
    SnapshotReply,
    TemplateDef,
    Transact,
)
from wm_store.server import StoreConfig, WmService, WmStore

pytestmark = pytest.mark.anyio


def template(mass: float) -> DefineTemplate:
    return DefineTemplate(
        template=TemplateDef(name="small-sprocket", type="Sprocket", properties={"mass": mass})
    )


async def teach_and_use(store: WmStore) -> SnapshotReply:
    """Teach a class, a subclass and a template (then replace it), and use them in the scene."""
    sprocket = ClassDef(name="Sprocket", parent="Gear", label="sprocket", comment="chain gear")
    steps: list[list[Op]] = [
        [DefineClass(cls=sprocket)],
        [template(0.05)],
        [
            DefineClass(cls=ClassDef(name="TinySprocket", parent="Sprocket")),
            AddElement(type="Box", label="bin", ref="$bin"),
            AddElement(
                type="TinySprocket",
                label="s1",
                properties={"mass": 0.01},
                relations=[Relation("$bin", "contain", "$")],
            ),
        ],
        [template(0.07)],  # a run-time template may be replaced; the newest one counts
    ]
    for ops in steps:
        await store.transact(Transact(ops=ops))
    return store.snapshot()


async def check_taught(store: WmStore, before: SnapshotReply) -> None:
    """``store`` (just reopened) holds what :func:`teach_and_use` taught, and acts on it."""
    assert store.snapshot() == before
    onto = store.ontology
    assert onto.is_a("TinySprocket", "Sprocket") and onto.is_a("Sprocket", "Part")
    assert onto.class_info("Sprocket").comment == "chain gear"
    assert onto.template("small-sprocket").properties == {"mass": 0.07}
    async with running(store) as s:
        # A new replica gets the taught ontology from the restarted store's snapshot.
        async with WmClient.connect(InMemoryTransport(WmService(s)), Ontology.default()) as wm:
            assert wm.ontology.is_a("TinySprocket", "Gear")
            assert wm.get_default_element("small-sprocket").properties == {"mass": 0.07}
            assert [e.id for e in wm.resolve_element(type="Sprocket")] == ["TinySprocket-1"]
            added = await wm.add_element("Sprocket", "s2")
            assert added == "Sprocket-1" and wm.get_element(added).type == "Sprocket"
        # The store validates against what it recovered: names stay taken, values checked.
        again = DefineClass(cls=ClassDef(name="Sprocket", parent="Part"))
        with pytest.raises(OntologyError, match="already defined"):
            await s.transact(Transact(ops=[again]))
        bad = AddElement(type="TinySprocket", properties={"mass": "x"})
        with pytest.raises(PropertyValueError, match="mass"):
            await s.transact(Transact(ops=[bad]))


async def copy_as_a_crash_leaves_it(store: WmStore, live: Path, crash: Path) -> None:
    """Copy the data directory at one point in time: holding the snapshot and log I/O limiters
    keeps a periodic snapshot write and the log compaction after it out of the copy."""
    durability = store._durability
    assert durability is not None
    async with durability._snapshot_io, durability._wal_io:
        await anyio.to_thread.run_sync(shutil.copytree, live, crash)


@pytest.mark.parametrize("snapshot_every", [10_000, 2], ids=["log-only", "snapshots-and-log"])
async def test_taught_classes_and_templates_survive_a_crash(
    ontology: Ontology, tmp_path: Path, snapshot_every: int
) -> None:
    config = StoreConfig(data_dir=str(tmp_path / "live"), snapshot_every=snapshot_every)
    store = await WmStore.open(ontology, config)
    async with running(store) as s:
        before = await teach_and_use(s)
        # What a crash right now leaves on disk: every acknowledged commit, no final snapshot.
        await copy_as_a_crash_leaves_it(s, tmp_path / "live", tmp_path / "crash")
    if snapshot_every == 10_000:
        assert not list((tmp_path / "crash" / "snapshots").glob("*.snap")), "log replay only"
    crashed = await WmStore.open(ontology, StoreConfig(data_dir=str(tmp_path / "crash")))
    assert crashed.recovery_detail.startswith("clean"), crashed.recovery_detail
    await check_taught(crashed, before)


async def test_taught_classes_and_templates_survive_a_clean_restart(
    ontology: Ontology, tmp_path: Path
) -> None:
    config = StoreConfig(data_dir=str(tmp_path))
    store = await WmStore.open(ontology, config)
    async with running(store) as s:
        before = await teach_and_use(s)
    assert list((tmp_path / "snapshots").glob("*.snap")), "a clean stop writes a snapshot"
    await check_taught(await WmStore.open(ontology, config), before)
