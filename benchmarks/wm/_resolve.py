"""The world-model benchmark's ``resolve`` on 10k elements against the same questions in
SPARQL."""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Sequence
from typing import Any

import msgspec

from benchmarks.common import (
    Stats,
    summarize,
)
from benchmarks.wm._bench import EXTRA_PART_CLASSES, PART_CLASSES, Bench
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    ClassDef,
    DefineClass,
    Op,
    PropertyFilter,
    Query,
    Relation,
    Transact,
)
from wm_store.rdf import SparqlEngine
from wm_store.server import WmService, WmStore


class ResolveCase(msgspec.Struct):
    """One question asked of the replica (``resolve``) and of SPARQL, over rotating values."""

    name: str
    queries: list[Query]
    sparql: str
    bindings: list[dict[str, str]]


class ResolveResult(msgspec.Struct):
    name: str
    results: int  # matches of the first question
    agree: bool  # resolve and SPARQL gave the same ids for every question checked
    resolve: Stats  # µs, wall
    resolve_cpu: Stats  # µs, CPU time of the thread
    sparql: Stats  # µs, SparqlEngine.query (graph cached)
    rdflib: Stats  # µs, plain Graph.query with the prepared query


async def build_scene(ontology: Ontology) -> tuple[WmStore, list[str], list[str]]:
    """10,000 elements: 10 shelves contain 90 part boxes, each box contains 110 parts of one
    of 10 part classes (990 per class; 6 classes are taught at run time). Parts carry a mass
    and a part number. Returns the store (memory only), the part labels and the box ids."""
    rng = random.Random(7)
    store = await WmStore.open(ontology)
    define: list[Op] = [
        DefineClass(cls=ClassDef(name=n, parent="Part")) for n in EXTRA_PART_CLASSES
    ]
    await store.transact(Transact(ops=define))
    shelves: list[Op] = [
        AddElement(type="Shelf", label=f"shelf-{s}", ref=f"$s{s}") for s in range(10)
    ]
    shelf_ids = list((await store.transact(Transact(ops=shelves))).ids.values())
    labels: list[str] = []
    boxes: list[str] = []
    for c, cls in enumerate(PART_CLASSES + EXTRA_PART_CLASSES):
        for b in range(9):
            shelf = shelf_ids[(c * 9 + b) % len(shelf_ids)]
            ops: list[Op] = [
                AddElement(
                    type="PartBox",
                    label=f"box-{cls.lower()}-{b}",
                    ref="$box",
                    relations=[Relation(shelf, "contain", "$")],
                )
            ]
            for j in range(b * 110, (b + 1) * 110):
                label = f"{cls.lower()}-{j:04d}"
                labels.append(label)
                ops.append(
                    AddElement(
                        type=cls,
                        label=label,
                        properties={
                            "mass": round(rng.uniform(0.01, 0.5), 4),
                            "partNumber": f"PN-{cls}-{j % 50:02d}",
                        },
                        relations=[Relation("$box", "contain", "$")],
                    )
                )
            boxes.append((await store.transact(Transact(ops=ops))).ids["$box"])
    return store, labels, boxes


def resolve_cases(labels: Sequence[str], boxes: Sequence[str], rotate: int) -> list[ResolveCase]:
    rng = random.Random(11)
    classes = PART_CLASSES + EXTRA_PART_CLASSES
    picked_labels = rng.sample(list(labels), rotate)
    picked_boxes = [boxes[i % len(boxes)] for i in rng.sample(range(len(boxes)), min(rotate, 90))]
    light = PropertyFilter(property="mass", op="lt", value=0.06)
    return [
        ResolveCase(
            "type (leaf, ~1k) + filter mass < 0.06",
            [Query(type=c, filters=[light]) for c in classes],
            # skm:rev: scene elements only (the ontology's template individuals have types too);
            # 6e-2 is an xsd:double like the masses (rdflib compares a double with the
            # decimal 0.06 exactly, so a mass of 0.06 would pass "< 0.06")
            "SELECT ?e WHERE { ?e a ?type ; skm:rev ?rev ; skm:mass ?m . FILTER(?m < 6e-2) }",
            [{"type": f"skm:{c}"} for c in classes],
        ),
        ResolveCase(
            "label (unique)",
            [Query(label=label) for label in picked_labels],
            "SELECT ?e WHERE { ?e rdfs:label ?label }",
            [{"label": label} for label in picked_labels],
        ),
        ResolveCase(
            "type Part (subclasses) contained in a box",
            [Query(type="Part", related=[Relation(b, "contain", "?")]) for b in picked_boxes],
            "SELECT ?e WHERE { ?box skm:contain ?e . ?e a/rdfs:subClassOf* skm:Part }",
            [{"box": b} for b in picked_boxes],
        ),
    ]


def time_calls(
    call: Callable[[int], object], calls: int, budget: float, warmup: int
) -> tuple[list[int], list[int]]:
    """ns per ``call(i)``, wall (perf_counter) and this thread's CPU time: ``warmup`` untimed
    calls, then up to ``calls`` timed ones or until ``budget`` seconds have passed (at
    least 5). CPU time leaves out the time the process was descheduled by other load."""
    for i in range(warmup):
        call(i)
    wall: list[int] = []
    cpu: list[int] = []
    deadline = time.perf_counter() + budget
    for i in range(calls):
        start, start_cpu = time.perf_counter_ns(), time.thread_time_ns()
        call(i)
        cpu.append(time.thread_time_ns() - start_cpu)
        wall.append(time.perf_counter_ns() - start)
        if i >= 4 and time.perf_counter() > deadline:
            break
    return wall, cpu


async def resolve_bench(bench: Bench) -> tuple[list[ResolveResult], float, int, int]:
    """Returns the per-question results, the graph build time (s), triples, elements.

    ``resolve`` is timed first, while no rdflib graph exists in the process (as in an agent,
    whose replica never builds one): the graph's ~10^6 objects would lengthen every garbage
    collection pass and so the resolve tail."""
    plan = bench.plan
    store, labels, boxes = await build_scene(bench.ontology)
    async with WmClient.connect(InMemoryTransport(WmService(store))) as wm:
        state, ontology = wm.replica.state, wm.ontology
        cases = resolve_cases(labels, boxes, rotate=50)
        resolve_ns: list[tuple[list[int], list[int]]] = []
        for case in cases:

            def run_resolve(i: int, queries: list[Query] = case.queries) -> object:
                return wm.resolve_element(queries[i % len(queries)])

            resolve_ns.append(time_calls(run_resolve, plan.resolve_calls, 30.0, 50))

        engine = SparqlEngine()
        start = time.perf_counter()
        graph = engine.graph(state, ontology)
        build = time.perf_counter() - start
        results = []
        for case, resolve_samples in zip(cases, resolve_ns, strict=True):
            agree = True
            for q, b in zip(case.queries[:10], case.bindings[:10], strict=True):
                mine = sorted(e.id for e in wm.resolve_element(q))
                reply = engine.query(state, ontology, case.sparql, b)
                agree = agree and mine == sorted(str(row[0]) for row in reply.rows)

            def run_sparql(i: int, case: ResolveCase = case) -> object:
                bindings = case.bindings[i % len(case.bindings)]
                return engine.query(state, ontology, case.sparql, bindings)

            prepared = engine.prepare(case.sparql, ontology)
            inits = [_rdflib_bindings(ontology, b) for b in case.bindings]

            def run_rdflib(i: int, prepared: Any = prepared, inits: Any = inits) -> object:
                return list(graph.query(prepared, initBindings=inits[i % len(inits)]))

            sparql_ns, _ = time_calls(run_sparql, plan.sparql_calls, plan.sparql_seconds, 2)
            rdflib_ns, _ = time_calls(run_rdflib, plan.sparql_calls, plan.sparql_seconds, 2)
            results.append(
                ResolveResult(
                    case.name,
                    len(wm.resolve_element(case.queries[0])),
                    agree,
                    summarize(resolve_samples[0], 1e-3),
                    summarize(resolve_samples[1], 1e-3),
                    summarize(sparql_ns, 1e-3),
                    summarize(rdflib_ns, 1e-3),
                )
            )
        return results, build, len(graph), len(state.elements)


def _rdflib_bindings(ontology: Ontology, bindings: dict[str, str]) -> dict[str, Any]:
    from rdflib import Literal

    from wm_store.rdf import SCENE

    out: dict[str, Any] = {}
    for name, value in bindings.items():
        if value.startswith("skm:"):
            out[name] = ontology.namespace[value[4:]]
        elif name == "box":
            out[name] = SCENE[value]
        else:
            out[name] = Literal(value)
    return out
