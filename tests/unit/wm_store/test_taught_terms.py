"""Terms taught as Turtle (``DefineTerms``, :meth:`WmClient.teach`): one ontology for the mesh.

The store is the source of truth for the ontology it serves: what it is taught (classes,
relations, data properties, templates) is checked, persisted, replayed after a restart, sent
to every replica (at connect and as it changes), exported by ``export_turtle`` and taught back
by ``import_turtle``. Teaching what the ontology already has commits nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.unit.wm_store.stores import running
from wm_store import (
    InMemoryTransport,
    OntologyError,
    UnknownPropertyError,
    ValidationError,
    WmClient,
)
from wm_store.ontology import Ontology, core_ontology_path, property_turtle, relation_turtle
from wm_store.protocol import (
    DefineTerms,
    Element,
    ElementPut,
    GetOntology,
    OntologyReply,
    Snapshot,
    SnapshotReply,
    TemplateDef,
    TermsDef,
    TermsDefined,
    Transact,
    Value,
)
from wm_store.rdf import export_turtle, import_turtle
from wm_store.scene import SceneState
from wm_store.server import StoreConfig, WmService, WmStore

pytestmark = pytest.mark.anyio

BEARING = """\
@prefix skm: <https://skimesh.dev/ontology#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix xsd: <http://www.w3.org/2001/XMLSchema#> .

skm:Bearing a owl:Class ; rdfs:subClassOf skm:Part ; rdfs:label "bearing"@en .
skm:boreDiameter a owl:DatatypeProperty ;
    rdfs:domain skm:Bearing ; rdfs:range xsd:double ; skm:valueKind "float" .
"""


async def test_a_replica_gets_taught_terms_at_connect_and_as_they_change() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s:
        service = WmService(s)
        async with WmClient.connect(InMemoryTransport(service), author="a") as first:
            rev = await first.teach(BEARING, source="bearing.ttl")
            assert first.ontology.is_a("Bearing", "Part"), "the writer's replica has it"
            b = await first.add_element("Bearing", "b1", properties={"boreDiameter": 0.02})
            async with WmClient.connect(InMemoryTransport(service)) as late:
                assert late.ontology.data_property("boreDiameter").kinds == {"float"}
                assert late.get_element(b).type == "Bearing"
                # Taught while `late` follows: it arrives with the change.
                text = relation_turtle("inspectedBy", domain=["Part"], range=["Agent"])
                rev2 = await first.teach(text, source="cli")
                await late.wait_for_revision(rev2, timeout=5)
                assert late.ontology.relation("inspectedBy").range == "Agent"
            assert rev2 > rev


async def test_teaching_known_terms_commits_nothing() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s, WmClient.connect(InMemoryTransport(WmService(s))) as wm:
        rev = await wm.teach(BEARING, source="bearing.ttl")
        assert await wm.teach(BEARING, source="again.ttl") == rev
        assert s.revision == rev and len(s.state.ontology_log) == 1
        # The core's own terms are known too.
        assert await wm.teach(core_ontology_path().read_text(), source="core") == rev


async def test_bad_terms_are_refused_with_their_source() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s, WmClient.connect(InMemoryTransport(WmService(s))) as wm:
        with pytest.raises(OntologyError, match=r"ext\.ttl.*Turtle"):
            await wm.teach("skm:Broken a", source="ext.ttl")
        wrong = BEARING.replace("skm:Part", "skm:Nothing")
        with pytest.raises(OntologyError, match=r"ext\.ttl.*Nothing"):
            await wm.teach(wrong, source="ext.ttl")
        with pytest.raises(OntologyError, match="lower-case"):
            property_turtle("Inspected", kind="bool")
        assert s.revision == 0 and wm.ontology.same_terms(Ontology.default())
        with pytest.raises(UnknownPropertyError):
            await wm.add_element("Gear", "g", properties={"boreDiameter": 1.0})


async def test_a_taught_spatial_relation_keeps_the_tree() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s, WmClient.connect(InMemoryTransport(WmService(s))) as wm:
        text = relation_turtle("holds", parent="spatialRelation", domain=["PhysicalObject"])
        await wm.teach(text, source="cli")
        tray = await wm.add_element("Box", "tray")
        cup = await wm.add_element("Gear", "cup")
        await wm.set_relation(tray, "holds", cup)
        assert s.state.parent(cup) is not None and wm.replica.state.parent(cup) is not None


@pytest.mark.parametrize("snapshot_every", [10_000, 2], ids=["log-only", "snapshots"])
async def test_taught_terms_survive_a_restart(tmp_path: Path, snapshot_every: int) -> None:
    config = StoreConfig(data_dir=str(tmp_path), snapshot_every=snapshot_every)
    store = await WmStore.open(Ontology.default(), config)
    async with running(store) as s:
        async with WmClient.connect(InMemoryTransport(WmService(s))) as wm:
            await wm.define_class("Pulley", "Part")
            await wm.teach(BEARING, source="bearing.ttl")
            await wm.define_property("inspected", kind="bool", domain=["Part"])
            await wm.add_element("Bearing", "b1", properties={"inspected": True})
        before = s.snapshot()
    again = await WmStore.open(Ontology.default(), config)
    assert again.snapshot() == before
    assert again.ontology.same_terms(store.ontology)
    assert again.ontology.is_a("Pulley", "Part") and again.ontology.is_a("Bearing", "Part")


async def test_the_store_serves_its_core_and_what_was_taught() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s:
        service = WmService(s)
        async with WmClient.connect(InMemoryTransport(service)) as wm:
            await wm.teach(BEARING, source="bearing.ttl")
        reply = await service.handle(GetOntology())
        assert isinstance(reply, OntologyReply)
        assert reply.core_digest == Ontology.default().digest
        assert Ontology.load(reply.core).same_terms(Ontology.default())
        assert [d.terms.source for d in reply.taught if isinstance(d, TermsDefined)] == [
            "bearing.ttl"
        ]
        snap = await service.handle(Snapshot())
        assert isinstance(snap, SnapshotReply) and snap.core_digest == reply.core_digest


async def test_a_replica_takes_the_stores_core_when_its_own_differs() -> None:
    """A store run with another core (another release, or a site's own core file): a client
    without an explicit ontology fetches the store's core instead of using its own file."""
    other_core = Ontology.load(
        core_ontology_path().read_text() + "\nskm:Sprocket a owl:Class ; "
        "rdfs:subClassOf skm:Gear .\n"
    )
    store = WmStore(other_core)
    async with running(store) as s, WmClient.connect(InMemoryTransport(WmService(s))) as wm:
        assert wm.ontology.is_a("Sprocket", "Gear")


def test_export_carries_the_taught_terms_and_import_teaches_them_back() -> None:
    onto = (
        Ontology.default()
        .teach(BEARING, source="bearing.ttl")
        .teach(property_turtle("inspected", kind="bool", domain=["Part"]))
    )
    state = SceneState()
    props: dict[str, Value] = {"boreDiameter": 0.02, "inspected": True}
    state.apply(ElementPut(Element(id="Bearing-1", type="Bearing", label="b1", properties=props)))
    text = export_turtle(state, onto)
    assert "boreDiameter" in text and "owl:DatatypeProperty" in text
    ops = import_turtle(text, Ontology.default())
    first, *rest = ops
    assert isinstance(first, DefineTerms)
    again = Ontology.default().teach(first.terms.turtle)
    assert again.same_terms(onto)
    assert [type(o).__name__ for o in rest] == ["AddElement"]


async def test_an_empty_transaction_is_refused_and_a_no_op_commits_nothing() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s:
        with pytest.raises(ValidationError, match="empty transaction"):
            await s.transact(Transact(ops=[]))
        await s.teach(BEARING, "bearing.ttl")
        revision = s.revision
        again = await s.transact(Transact(ops=[DefineTerms(terms=TermsDef(turtle=BEARING))]))
        assert again.revision == revision == s.revision, "known terms: no new revision"


async def test_known_terms_change_nothing_after_run_time_classes_and_templates() -> None:
    """Classes and templates taught one by one (define_class, define_template) beside Turtle
    terms: teaching the same file again is still a no-op."""
    store = WmStore(Ontology.default())
    async with running(store) as s, WmClient.connect(InMemoryTransport(WmService(s))) as wm:
        await wm.teach(BEARING, source="bearing.ttl")
        await wm.define_class("Pulley", "Part")
        await wm.define_template(
            TemplateDef(name="big-pulley", type="Pulley", properties={"mass": 0.4})
        )
        rev = s.revision
        assert await wm.teach(BEARING, source="bearing.ttl") == rev
        # Terms that name a class taught with define_class are accepted too.
        text = relation_turtle("heldBy", domain=["Pulley"], range=["Bearing"])
        assert await wm.teach(text, source="cli") == rev + 1
        assert wm.ontology.relation("heldBy").domain == "Pulley"
        assert wm.ontology.template("big-pulley").properties == {"mass": 0.4}
