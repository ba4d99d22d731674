"""The compiled ontology: what the OWL files say, in a form that decodes without rdflib.

The store parses the files (rdflib) and serves the compiled form on its read-only key
(``GetCompiledOntology``); a replica follows it, fetching it again when terms are taught, and
parses the files itself only when the store is of an older version. The decoded ontology answers
every query as the parsed one does."""

from __future__ import annotations

import logging
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import msgspec
import pytest
from rdflib.compare import isomorphic

from meshlink.rpc import BAD_REQUEST, ErrorReply, encode
from tests.unit.wm_store.stores import running
from wm_store import (
    InMemoryTransport,
    OntologyError,
    TransportError,
    UnknownClassError,
    ValidationError,
    WmClient,
)
from wm_store.ontology import Ontology, core_ontology_path, relation_turtle, replay
from wm_store.protocol import (
    ClassDef,
    ClassDefined,
    CompiledOntologyReply,
    DefineClass,
    GetCompiledOntology,
    OntologyDelta,
    Reply,
    Request,
    TemplateDef,
    TermsDef,
    TermsDefined,
    Transact,
    decode_reply,
)
from wm_store.rdf import export_turtle
from wm_store.server import WmService, WmStore

ROOT = Path(__file__).resolve().parents[3]
ONTOLOGIES = sorted(p for p in (ROOT / "ontologies").iterdir() if p.suffix in (".ttl", ".owl"))
PROTEGE = ROOT / "tests" / "assets" / "protege_extension.ttl"
BEARING = relation_turtle("inspectedBy", domain=["Part"], range=["Agent"])


def _sources() -> Iterator[tuple[Path, ...]]:
    yield from ((p,) for p in ONTOLOGIES)
    yield (core_ontology_path(), PROTEGE)  # a site's extension, written by Protégé


def assert_equivalent(decoded: Ontology, parsed: Ontology) -> None:
    """Every query of the checks answers alike: taxonomy, relations, values, templates."""
    assert decoded.same_terms(parsed)
    assert decoded.classes == parsed.classes
    for cls in sorted(parsed.classes):
        assert decoded.subclasses(cls) == parsed.subclasses(cls)
        assert decoded.superclasses(cls) == parsed.superclasses(cls)
        assert decoded.restrictions(cls) == parsed.restrictions(cls)
        for other in sorted(parsed.classes):
            assert decoded.is_a(cls, other) == parsed.is_a(cls, other)
    assert dict(decoded.relations) == dict(parsed.relations)
    for rel in sorted(parsed.relations):
        assert decoded.subproperties(rel) == parsed.subproperties(rel)
        assert decoded.superproperties(rel) == parsed.superproperties(rel)
    assert dict(decoded.data_properties) == dict(parsed.data_properties)
    assert dict(decoded.templates) == dict(parsed.templates)
    assert decoded.extended_classes == parsed.extended_classes
    assert decoded.extended_templates == parsed.extended_templates


@pytest.mark.parametrize("sources", list(_sources()), ids=lambda s: "+".join(p.name for p in s))
def test_every_ontology_decodes_to_what_its_files_say(sources: tuple[Path, ...]) -> None:
    parsed = Ontology.load(*sources)
    decoded = Ontology.from_compiled(parsed.compiled_bytes())
    assert decoded.compiled and not parsed.compiled and decoded.digest == parsed.digest
    assert_equivalent(decoded, parsed)


def test_the_checks_answer_alike() -> None:
    parsed = Ontology.default()
    decoded = Ontology.from_compiled(parsed.compiled_bytes())
    for onto in (parsed, decoded):
        onto.check_relation("Gripper", "contain", "Gear")
        onto.check_value("graspWidth", 0.204)  # within the tolerance
        with pytest.raises(ValidationError, match="graspWidth"):
            onto.check_value("graspWidth", 0.5)
        with pytest.raises(UnknownClassError, match="did you mean 'Gear'"):
            onto.check_class("Gaer")
        assert onto.template("DefaultKitBox") == parsed.template("DefaultKitBox")


def test_taught_terms_and_extensions_survive_compiling() -> None:
    """What the store serves: the core, taught Turtle, classes and templates added at run
    time; the decoded one extends further without rdflib, and refuses Turtle clearly."""
    store_onto = (
        Ontology.default()
        .teach(BEARING, source="cli")
        .extend(
            classes=[ClassDef(name="Pulley", parent="Part")],
            templates=[TemplateDef(name="big-pulley", type="Pulley", properties={"mass": 1.5})],
        )
    )
    decoded = Ontology.from_compiled(store_onto.compiled_bytes(Ontology.default().digest))
    assert_equivalent(decoded, store_onto)
    assert decoded.digest == Ontology.default().digest  # the core it was built on
    assert decoded.relation("inspectedBy").domains == frozenset({"Part"})
    more = decoded.extend(classes=[ClassDef(name="VBelt", parent="Pulley")])
    assert more.is_a("VBelt", "Part") and more.compiled
    with pytest.raises(OntologyError, match=r"without its sources.*Ontology\.load"):
        decoded.teach(relation_turtle("checkedBy"))
    with pytest.raises(OntologyError, match="without its sources"):
        _ = decoded.graph


def test_with_its_sources_a_compiled_ontology_rebuilds_its_graph() -> None:
    """What the store serves carries its core's Turtle and log: the graph (for SPARQL, Turtle
    export and import) is rebuilt on demand, equal to the store's, extensions included."""
    core = core_ontology_path().read_text()
    log: list[OntologyDelta] = [
        TermsDefined(terms=TermsDef(turtle=BEARING, source="cli")),
        ClassDefined(cls=ClassDef(name="Pulley", parent="Part")),
    ]
    store_onto = replay(Ontology.load(core), log)
    decoded = Ontology.from_compiled(store_onto.compiled_bytes(core=core, taught=log))
    assert_equivalent(decoded, store_onto)
    more = decoded.extend(classes=[ClassDef(name="VBelt", parent="Pulley")])
    expected = store_onto.extend(classes=[ClassDef(name="VBelt", parent="Pulley")])
    assert isomorphic(more.graph, expected.graph)
    assert isomorphic(more.extension_graph(), expected.extension_graph())
    assert more.core_turtle() == expected.core_turtle()
    taught = more.teach(relation_turtle("checkedBy", domain=["Part"]))
    assert not taught.compiled and taught.is_a("VBelt", "Part") and "checkedBy" in taught.relations


def test_another_format_or_garbage_is_refused_by_name() -> None:
    data = msgspec.msgpack.decode(Ontology.default().compiled_bytes())
    data["format"] = 999
    with pytest.raises(OntologyError, match=r"format 999.*same skimesh version"):
        Ontology.from_compiled(msgspec.msgpack.encode(data))
    with pytest.raises(OntologyError, match="not a compiled ontology"):
        Ontology.from_compiled(b"\x01\x02")


def test_decoding_imports_no_rdflib(tmp_path: Path) -> None:
    path = tmp_path / "onto.msgpack"
    path.write_bytes(Ontology.default().compiled_bytes())
    probe = (
        "import sys\n"
        "from wm_store.ontology import Ontology, replay\n"
        "from wm_store.protocol import ClassDef, ClassDefined\n"
        f"onto = Ontology.from_compiled(open({str(path)!r}, 'rb').read())\n"
        "onto = replay(onto, [ClassDefined(cls=ClassDef(name='Pulley', parent='Part'))])\n"
        "onto.check_relation('Gripper', 'contain', 'Pulley')\n"
        "onto.check_value('graspWidth', 0.1)\n"
        "print(onto.is_a('Pulley', 'PhysicalObject'), 'rdflib' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=60, cwd=ROOT
    )
    assert done.stdout.split() == ["True", "False"], done.stderr


# ---------------------------------------------------------------------------- replicas


class OlderStore(InMemoryTransport):
    """A store of a version before ``GetCompiledOntology``: its decoder refuses the tag."""

    async def request(self, request: Request, *, timeout: float) -> Reply:
        if isinstance(request, GetCompiledOntology):
            return ErrorReply(code=BAD_REQUEST, message="Invalid value 'GetCompiledOntology'")
        return await super().request(request, timeout=timeout)


class TeachesInBetween(InMemoryTransport):
    """Commits taught terms and a class right after serving the compiled ontology the first
    time: the snapshot that follows holds more than the compiled ontology."""

    taught = False

    async def request(self, request: Request, *, timeout: float) -> Reply:
        reply = await super().request(request, timeout=timeout)
        if isinstance(request, GetCompiledOntology) and not self.taught:
            self.taught = True
            store = self.service.store
            await store.teach(BEARING, "between")
            pulley = DefineClass(cls=ClassDef(name="Pulley", parent="Part"))
            await store.transact(Transact(ops=[pulley], author="wm"))
        return reply


class Unreachable(InMemoryTransport):
    async def request(self, request: Request, *, timeout: float) -> Reply:
        raise TransportError("the world-model store did not answer within 1 s")


@pytest.mark.anyio
async def test_a_replica_follows_the_stores_compiled_ontology() -> None:
    store = await WmStore.open(Ontology.default())
    async with running(store) as s, WmClient.connect(InMemoryTransport(WmService(s))) as wm:
        assert wm.ontology.compiled and wm.ontology.same_terms(s.ontology)
        await wm.teach(BEARING, source="cli")  # Turtle: the replica fetches the store's again
        assert wm.ontology.compiled and wm.ontology.relation("inspectedBy").ranges == {"Agent"}
        await wm.define_class("Pulley", "Part")  # a class: extended here
        pulley = await wm.add_element("Pulley", "p")
        assert wm.ontology.is_a("Pulley", "Part") and wm.ontology.same_terms(s.ontology)
        assert pulley in wm.replica.state
        # Turtle export (wm export) needs the graph: rebuilt from what the store sent
        exported = export_turtle(wm.replica.state, wm.ontology)
        assert exported == export_turtle(s.state, s.ontology)


@pytest.mark.anyio
async def test_terms_taught_between_the_compiled_ontology_and_the_snapshot() -> None:
    store = await WmStore.open(Ontology.default())
    async with running(store) as s:
        transport = TeachesInBetween(WmService(s))
        async with WmClient.connect(transport) as wm:
            assert transport.taught
            assert wm.ontology.compiled and wm.ontology.same_terms(s.ontology)
            assert wm.ontology.is_a("Pulley", "Part") and "inspectedBy" in wm.ontology.relations
            await wm.define_class("VBelt", "Pulley")
            assert wm.ontology.same_terms(s.ontology)


@pytest.mark.anyio
async def test_an_older_store_makes_the_replica_parse_the_files(
    caplog: pytest.LogCaptureFixture,
) -> None:
    store = await WmStore.open(Ontology.default())
    await store.teach(BEARING, "cli")
    async with running(store) as s:
        with caplog.at_level(logging.WARNING, logger="wm_store"):
            async with WmClient.connect(OlderStore(WmService(s))) as wm:
                assert not wm.ontology.compiled and wm.ontology.same_terms(s.ontology)
                await wm.teach(relation_turtle("checkedBy", domain=["Part"]), source="cli")
                assert "checkedBy" in wm.ontology.relations
    assert "serves no compiled ontology" in caplog.text and "rdflib" in caplog.text


@pytest.mark.anyio
async def test_an_unreachable_store_says_so() -> None:
    store = await WmStore.open(Ontology.default())
    async with running(store) as s:
        with pytest.raises(TransportError, match="did not answer"):
            async with WmClient.connect(Unreachable(WmService(s))):
                pass


@pytest.mark.anyio
async def test_the_store_serves_what_it_checks_against_on_its_read_only_key() -> None:
    store = await WmStore.open(Ontology.default())
    async with running(store) as s:
        await s.teach(BEARING, "cli")
        service = WmService(s)
        data, ok = await service.handle_bytes(encode(GetCompiledOntology()), read_only=True)
        reply = decode_reply(data)
        assert ok and isinstance(reply, CompiledOntologyReply)
        assert (reply.revision, reply.taught) == (s.revision, len(s.state.ontology_log)) == (1, 1)
        assert reply.core_digest == Ontology.default().digest
        assert_equivalent(Ontology.from_compiled(reply.compiled), s.ontology)
