"""Read-only SPARQL: typed results, parameter bindings that cannot inject, refusals with clear
messages, and the per-revision graph cache (sync and in a worker thread)."""

from __future__ import annotations

import anyio
import pytest

from wm_store import ValidationError
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, ClassDef, Relation, UpdateElement
from wm_store.rdf import SparqlEngine
from wm_store.scene import SceneState, apply_transaction

Kitting = tuple[SceneState, dict[str, str]]

PARTS = """
SELECT ?part ?type WHERE {
    ?part a ?type .
    ?type rdfs:subClassOf* skm:Part .
    FILTER(STRSTARTS(STR(?part), STR(skms:)))
} ORDER BY ?part
"""


def commit(state: SceneState, ontology: Ontology, *ops: AddElement | UpdateElement) -> None:
    apply_transaction(state, ontology, list(ops), revision=state.revision + 1, now=5.0)
    state.revision += 1


def test_select_by_type_includes_subclasses(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    reply = SparqlEngine().query(state, ontology, PARTS)
    assert reply.revision == 1
    assert reply.variables == ["part", "type"]
    assert reply.rows == [["Gear-1", "skm:Gear"], ["Gear-2", "skm:Gear"]]


def test_rows_render_ids_prefixed_names_literals_and_unbound(
    kitting: Kitting, ontology: Ontology
) -> None:
    state, _ = kitting
    query = """
        SELECT ?e ?mass ?size ?label WHERE {
            ?e a skm:Box ; rdfs:label ?label .
            OPTIONAL { ?e skm:mass ?mass }
            OPTIONAL { ?e skm:size ?size }
        } ORDER BY ?e
    """
    engine = SparqlEngine()
    # exactly Box (no subClassOf path): not the KitBox; Box-1 has no mass (unbound: None)
    assert engine.query(state, ontology, query).rows == [
        ["Box-1", None, "0.3 0.2 0.1", "box-gears"]
    ]
    # templates are individuals of the ontology: they come back as prefixed names
    kit = engine.query(state, ontology, query.replace("skm:Box", "skm:KitBox")).rows
    assert kit == [  # ORDER BY sorts IRIs: the ontology's before the scene's
        ["skm:DefaultKitBox", "0.8", "0.4 0.3 0.12", "kit box"],
        ["KitBox-1", None, None, "kit-1"],
    ]


def test_ask_and_construct(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    engine = SparqlEngine()
    heavy = "ASK { ?g a skm:Gear ; skm:mass ?m FILTER(?m > 0.24) }"
    assert engine.query(state, ontology, heavy).rows == [["true"]]
    assert engine.query(state, ontology, heavy.replace("0.24", "0.3")).rows == [["false"]]
    reply = engine.query(
        state,
        ontology,
        "CONSTRUCT { ?b skm:contain ?g } WHERE { ?b skm:contain ?g . ?g a skm:Gear }",
    )
    assert reply.variables == ["subject", "predicate", "object"]
    assert reply.rows == [["Box-1", "skm:contain", "Gear-1"], ["Box-1", "skm:contain", "Gear-2"]]


# --------------------------------------------------------------------------- bindings


def test_bindings_bind_elements_terms_and_literals(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    engine = SparqlEngine()
    children = "SELECT ?c WHERE { ?parent skm:contain ?c } ORDER BY ?c"
    assert engine.query(state, ontology, children, {"parent": "Box-1"}).rows == [
        ["Gear-1"],
        ["Gear-2"],
    ]
    assert engine.query(state, ontology, children, {"?parent": "Box-99"}).rows == []
    by_label = "SELECT ?e WHERE { ?e rdfs:label ?l } ORDER BY ?e"
    assert engine.query(state, ontology, by_label, {"l": "gear"}).rows == [["Gear-1"]]
    typed = "SELECT ?e WHERE { ?e a ?cls FILTER(STRSTARTS(STR(?e), STR(skms:))) }"
    assert engine.query(state, ontology, typed, {"cls": "skm:KitBox"}).rows == [["KitBox-1"]]
    assert engine.query(state, ontology, typed, {"cls": "skm:NoSuchClass"}).rows == []


def test_injection_attempts_stay_literal_values(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    evil = 'x" } DROP ALL ; SELECT * WHERE { ?s ?p ?o } #'
    engine = SparqlEngine()
    by_label = "SELECT ?e WHERE { ?e rdfs:label ?l }"
    before = len(engine.graph(state, ontology))
    assert engine.query(state, ontology, by_label, {"l": evil}).rows == []
    assert engine.query(state, ontology, by_label, {"l": "Gear-1> ?p ?o . #"}).rows == []
    assert len(engine.graph(state, ontology)) == before
    # the same text stored as a label is found again: it was matched as a value, nothing more
    commit(state, ontology, AddElement(type="Bolt", label=evil))
    assert engine.query(state, ontology, by_label, {"l": evil}).rows == [["Bolt-1"]]


def test_binding_names_are_checked(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    engine = SparqlEngine()
    query = "SELECT ?e WHERE { ?e a skm:Gear }"
    with pytest.raises(ValidationError, match=r"\?y does not occur in the query; .* are \?e"):
        engine.query(state, ontology, query, {"y": "1"})
    with pytest.raises(ValidationError, match="not a SPARQL variable name"):
        engine.query(state, ontology, query, {"e }": "1"})


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(
    "update",
    [
        "DELETE WHERE { ?s ?p ?o }",
        "INSERT DATA { skms:Gear-1 skm:mass 1.0 }",
        "DROP ALL",
        "LOAD <http://example.org/evil.ttl>",
        "PREFIX ex: <http://example.org/> CLEAR DEFAULT",
    ],
)
def test_updates_are_refused(kitting: Kitting, ontology: Ontology, update: str) -> None:
    state, _ = kitting
    engine = SparqlEngine()
    size = len(engine.graph(state, ontology))
    with pytest.raises(ValidationError, match=r"updates are not allowed.*transaction"):
        engine.query(state, ontology, update)
    assert len(engine.graph(state, ontology)) == size


def test_parse_errors_quote_rdflib_with_position(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    with pytest.raises(ValidationError) as info:
        SparqlEngine().query(
            state, ontology, "SELECT ?x WHERE {\n  ?x a skm:Gear\n  FILTER(?x >\n}"
        )
    message = str(info.value)
    assert "SPARQL syntax error at line" in message and "column" in message
    assert "Expected" in message  # rdflib's own words
    assert "^" in message
    with pytest.raises(ValidationError, match=r"Unknown namespace prefix : ex.*predeclared"):
        SparqlEngine().query(state, ontology, "SELECT ?x WHERE { ?x a ex:Gear }")


@pytest.mark.parametrize(
    ("query", "match"),
    [
        ("SELECT * WHERE { SERVICE <http://example.org/sparql> { ?s ?p ?o } }", "SERVICE"),
        ("SELECT ?s FROM <file:///etc/passwd> WHERE { ?s ?p ?o }", "FROM"),
        ("SELECT ?s FROM NAMED <http://example.org/g> WHERE { ?s ?p ?o }", "FROM"),
        ("SELECT ?s WHERE { GRAPH ?g { ?s ?p ?o } }", "evaluation failed"),
    ],
)
def test_unsafe_or_failing_queries_are_refused(
    kitting: Kitting, ontology: Ontology, query: str, match: str
) -> None:
    state, _ = kitting
    with pytest.raises(ValidationError, match=match):
        SparqlEngine().query(state, ontology, query)


def test_row_limit(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    engine = SparqlEngine(max_rows=3)
    with pytest.raises(ValidationError, match="more than 3 rows; add LIMIT"):
        engine.query(state, ontology, "SELECT ?s WHERE { ?s ?p ?o }")
    assert len(engine.query(state, ontology, "SELECT ?s WHERE { ?s ?p ?o } LIMIT 3").rows) == 3


# --------------------------------------------------------------------------- cache


def test_graph_is_cached_per_revision_and_ontology(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    engine = SparqlEngine()
    gears = "SELECT ?g WHERE { ?g a skm:Gear FILTER(STRSTARTS(STR(?g), STR(skms:))) } ORDER BY ?g"
    assert engine.query(state, ontology, gears).rows == [["Gear-1"], ["Gear-2"]]
    engine.query(state, ontology, PARTS)
    assert engine.builds == 1
    commit(state, ontology, AddElement(type="Gear", relations=[Relation("Box-1", "contain", "$")]))
    reply = engine.query(state, ontology, gears)
    assert reply.revision == 2 and reply.rows == [["Gear-1"], ["Gear-2"], ["Gear-3"]]
    assert engine.builds == 2
    extended = ontology.extend(classes=[ClassDef(name="Pulley", parent="Part")])
    engine.query(state, extended, gears)
    assert engine.builds == 3
    other = state.copy()
    engine.query(other, extended, gears)
    assert engine.builds == 4


def test_query_async_matches_and_shares_one_build(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    engine = SparqlEngine()
    replies: list[object] = []

    async def ask() -> None:
        replies.append(await engine.query_async(state, ontology, PARTS))

    async def main() -> None:
        async with anyio.create_task_group() as tg:
            for _ in range(3):
                tg.start_soon(ask)

    anyio.run(main)
    assert engine.builds == 1
    expected = SparqlEngine().query(state, ontology, PARTS)
    assert replies == [expected] * 3


def test_query_async_answers_for_the_revision_it_started_at(
    kitting: Kitting, ontology: Ontology
) -> None:
    state, _ = kitting
    engine = SparqlEngine()

    async def main() -> list[list[str | None]]:
        async with anyio.create_task_group() as tg:
            result: list[list[str | None]] = []

            async def ask() -> None:
                reply = await engine.query_async(state, ontology, PARTS)
                assert reply.revision == 1
                result.extend(reply.rows)

            tg.start_soon(ask)
            await anyio.lowlevel.checkpoint()  # the query is now building in its thread
            commit(state, ontology, AddElement(type="Bolt"))
        return result

    rows = anyio.run(main)
    assert rows == [["Gear-1", "skm:Gear"], ["Gear-2", "skm:Gear"]]
    assert engine.builds == 0  # a graph for a revision that is gone is not cached
    assert ["Bolt-1", "skm:Bolt"] in engine.query(state, ontology, PARTS).rows
